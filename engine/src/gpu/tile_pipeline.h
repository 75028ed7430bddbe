// The instanced tile pipeline: one quad per tile instance, sampled from the atlas, blended
// premultiplied over what is below (base level, then LR, then HR). Dynamic rendering, so
// one pipeline per colour-attachment format (offscreen RGBA8, swapchain BGRA8 …).
#pragma once

#include <unordered_map>

#include "gpu/device.h"
#include "gpu/tile_atlas.h"
#include "gpu/tile_instance.h"

namespace iris::gpu {

struct TilePush {
    float targetSize[2];
};

class TilePipeline {
public:
    TilePipeline(Device& device, TileAtlas& atlas) : device_(device), atlas_(atlas) {}
    ~TilePipeline();
    Result init();
    // The pipeline for a colour format, created on first use (render thread only).
    Expected<VkPipeline> pipelineFor(VkFormat format);
    VkPipelineLayout layout() const { return layout_; }
    VkDescriptorSet descriptorSet() const { return set_; }

private:
    Device& device_;
    TileAtlas& atlas_;
    VkShaderModule vert_ = VK_NULL_HANDLE;
    VkShaderModule frag_ = VK_NULL_HANDLE;
    VkDescriptorSetLayout setLayout_ = VK_NULL_HANDLE;
    VkPipelineLayout layout_ = VK_NULL_HANDLE;
    VkDescriptorPool pool_ = VK_NULL_HANDLE;
    VkDescriptorSet set_ = VK_NULL_HANDLE;
    std::unordered_map<int, VkPipeline> pipelines_;
};

} // namespace iris::gpu
