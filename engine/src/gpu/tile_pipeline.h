// The instanced tile pipelines: one quad per tile instance, sampled from the atlas, blended
// premultiplied over what is below (base level, then LR, then HR); and the seam pass, which
// draws the half-texel bands along the sides of tiles drawn at LOD 0 where a neighbour is
// resident, filtering across the seam (shaders/tile_bands.glsl). Dynamic rendering, so one
// pipeline of each per colour-attachment format (offscreen RGBA8, swapchain BGRA8 …).
#pragma once

#include <unordered_map>

#include "gpu/device.h"
#include "gpu/tile_atlas.h"
#include "gpu/tile_instance.h"

namespace iris::gpu {

struct TilePush {
    float targetSize[2];
    int32_t edge = 0; // the seam pass's band: 1 left, 2 right, 3 top, 4 bottom
};

class TilePipeline {
public:
    TilePipeline(Device& device, TileAtlas& atlas) : device_(device), atlas_(atlas) {}
    ~TilePipeline();
    Result init();
    // The tile pass's and the seam pass's pipelines for a colour format, created on first use
    // (render thread only). Both use layout() and descriptorSet().
    Expected<VkPipeline> pipelineFor(VkFormat format);
    Expected<VkPipeline> seamPipelineFor(VkFormat format);
    VkPipelineLayout layout() const { return layout_; }
    VkDescriptorSet descriptorSet() const { return set_; }

private:
    Expected<VkPipeline> pipelineFor(VkFormat format, bool seams);

    Device& device_;
    TileAtlas& atlas_;
    VkShaderModule vert_ = VK_NULL_HANDLE;
    VkShaderModule frag_ = VK_NULL_HANDLE;
    VkShaderModule seamVert_ = VK_NULL_HANDLE;
    VkShaderModule seamFrag_ = VK_NULL_HANDLE;
    VkDescriptorSetLayout setLayout_ = VK_NULL_HANDLE;
    VkPipelineLayout layout_ = VK_NULL_HANDLE;
    VkDescriptorPool pool_ = VK_NULL_HANDLE;
    VkDescriptorSet set_ = VK_NULL_HANDLE;
    std::unordered_map<int, VkPipeline> pipelines_;
    std::unordered_map<int, VkPipeline> seamPipelines_;
};

} // namespace iris::gpu
