// The overlay pipeline: instanced quads that are either solid (plates, bars, outlines) or
// glyphs sampled texel for pixel from the glyph atlas, blended premultiplied over the tiles.
// It owns the glyph atlas image (8-bit coverage; overlay/glyph_cache decides what goes where)
// and records the copies into it. Used by the render thread only.
#pragma once

#include <unordered_map>

#include "gpu/device.h"
#include "gpu/vk_handle.h"
#include "gpu/vk_util.h"

namespace iris::gpu {

// Per-instance data; the layout matches shaders/overlay.vert.
struct OverlayInstance {
    float rect[4];   // x0, y0, x1, y1 in target pixels
    float colour[4]; // straight RGBA
    float glyph[4];  // atlas texel at the rect's top-left corner (x, y), 1 for a glyph (z), unused (w)
};

struct OverlayPush {
    float targetSize[2];
};

class OverlayPipeline {
public:
    explicit OverlayPipeline(Device& device) : device_(device) {}
    OverlayPipeline(const OverlayPipeline&) = delete;
    OverlayPipeline& operator=(const OverlayPipeline&) = delete;

    // Creates the shaders, the glyph atlas (atlasSize² texels, R8) and its descriptor set.
    Result init(uint32_t atlasSize);
    // The pipeline for a colour format, created on first use.
    Expected<VkPipeline> pipelineFor(VkFormat format);
    VkPipelineLayout layout() const { return layout_.get(); }
    VkDescriptorSet descriptorSet() const { return set_; }

    // Records, outside a render pass, the copies of `regions` of `staging` into the glyph atlas
    // (and, the first time, a clear of the whole atlas, which leaves it in the layout the
    // descriptor names even when nothing is copied). The copies wait for the fragment-shader
    // reads of every earlier frame on this queue, and this frame's reads wait for them.
    void recordUploads(VkCommandBuffer cmd, VkBuffer staging, const VkBufferImageCopy* regions, uint32_t count);
    bool atlasReady() const { return atlasReady_; }

private:
    Device& device_;
    vk::ShaderModule vert_, frag_;
    vk::Memory atlasMemory_;
    vk::Image atlas_;
    vk::ImageView atlasView_;
    vk::Sampler sampler_;
    vk::DescriptorSetLayout setLayout_;
    vk::PipelineLayout layout_;
    vk::DescriptorPool pool_;
    VkDescriptorSet set_ = VK_NULL_HANDLE; // freed with pool_
    bool atlasReady_ = false;              // the first clear has been recorded
    std::unordered_map<int, vk::Pipeline> pipelines_;
};

} // namespace iris::gpu
