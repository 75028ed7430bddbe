// The instanced tile pipelines: one quad per tile instance, sampled from the atlas, blended
// premultiplied over what is below (base level, then LR, then HR); and the seam pass, which
// draws the half-texel bands along the sides of tiles drawn at LOD 0 where a neighbour is
// resident, filtering across the seam (shaders/tile_bands.glsl). Dynamic rendering, so one
// pipeline of each per colour-attachment format (offscreen RGBA8, swapchain BGRA8 …), and per
// colour management (on: the fragment shaders apply the colour table, binding 1; off: that
// step is compiled out by a specialization constant), and for the tile pass per exactness
// (a level drawn 1:1 on whole pixels fetches its texels: render/draw_list.h, drawsExact).
#pragma once

#include <unordered_map>

#include "gpu/color_lut_texture.h"
#include "gpu/device.h"
#include "gpu/tile_atlas.h"
#include "gpu/tile_instance.h"
#include "gpu/vk_handle.h"

namespace iris::gpu {

struct TilePush {
    float targetSize[2];
    int32_t edge = 0; // the seam pass's band: 1 left, 2 right, 3 top, 4 bottom; 5-8 corners (fullBands)
    // 1: every tile is cut 3 × 3 into an interior and eight seam-pass pieces, whatever its
    // neighbours (a view turned by other than a right angle; shaders/tile_bands.glsl).
    float fullBands = 0;
    // The view's turn (ViewTransform::m, row-major), applied about the target's centre to the
    // instances' unturned rectangles (shaders/tile_turn.glsl); identity for unturned views and
    // the overview's thumbnail.
    float turn[4] = {1, 0, 0, 1};
    float centre[2] = {0, 0}; // the turn's centre: the view's target centre, target pixels
};

class TilePipeline {
public:
    TilePipeline(Device& device, TileAtlas& atlas) : device_(device), atlas_(atlas), colorLut_(device) {}
    ~TilePipeline() = default;
    // frameSlots: frames in flight (the colour table's staging buffers). lookup: how the
    // colour step interpolates the table (EngineTuning::colorLookup; Auto by device type).
    Result init(uint32_t frameSlots, EngineTuning::ColorLookup lookup);
    // Whether the colour step's table is interpolated by the sampler (else from its 8 nodes).
    bool lutSampled() const { return lutSampled_; }
    // The tile pass's and the seam pass's pipelines for a colour format, with or without the
    // colour transform, created on first use (render thread only); `exact`: the tile pass's
    // for levels drawn exactly. All use layout() and descriptorSet().
    Expected<VkPipeline> pipelineFor(VkFormat format, bool colorManaged = false, bool exact = false);
    Expected<VkPipeline> seamPipelineFor(VkFormat format, bool colorManaged = false);
    // The colour table the pipelines sample (binding 1); the render thread updates it.
    ColorLutTexture& colorLut() { return colorLut_; }
    VkPipelineLayout layout() const { return layout_.get(); }
    VkDescriptorSet descriptorSet() const { return set_; }

private:
    Expected<VkPipeline> create(VkFormat format, bool seams, bool colorManaged, bool exact);

    Device& device_;
    TileAtlas& atlas_;
    ColorLutTexture colorLut_;
    bool lutSampled_ = false;
    vk::ShaderModule vert_, frag_, seamVert_, seamFrag_;
    vk::DescriptorSetLayout setLayout_;
    vk::PipelineLayout layout_;
    vk::DescriptorPool pool_;
    VkDescriptorSet set_ = VK_NULL_HANDLE;           // freed with pool_
    std::unordered_map<uint64_t, vk::Pipeline> pipelines_; // key: format × 8 + exact × 4 + seams × 2 + colour
};

} // namespace iris::gpu
