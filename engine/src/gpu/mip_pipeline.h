// The mip compute pipeline (shaders/mip_reduce.comp): all mip levels of up to 8 tiles in one
// dispatch, one workgroup per tile, each level computed from the base level only: the exact
// area average, or with enhance the sharpened kernel of gpu/mip_kernel.h (docs/ENHANCEMENT.md).
#pragma once

#include "gpu/device.h"
#include "gpu/tile_atlas.h"

namespace iris::gpu {

class MipPipeline {
public:
    static constexpr uint32_t kMaxTiles = 8;
    MipPipeline(Device& device, TileAtlas& atlas) : device_(device), atlas_(atlas) {}
    ~MipPipeline();
    Result init();
    // Records the dispatch for `count` atlas layers (count ≤ kMaxTiles); enhance selects the
    // sharpened kernel, else the exact area average.
    void record(VkCommandBuffer cmd, const int* layers, uint32_t count, bool enhance) const;

private:
    Device& device_;
    TileAtlas& atlas_;
    VkShaderModule module_ = VK_NULL_HANDLE;
    VkDescriptorSetLayout setLayout_ = VK_NULL_HANDLE;
    VkPipelineLayout layout_ = VK_NULL_HANDLE;
    VkPipeline pipeline_ = VK_NULL_HANDLE;
    VkDescriptorPool pool_ = VK_NULL_HANDLE;
    VkDescriptorSet set_ = VK_NULL_HANDLE;
};

} // namespace iris::gpu
