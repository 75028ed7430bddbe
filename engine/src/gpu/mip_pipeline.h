// The mip compute pipeline (shaders/mip_reduce.comp): all mip levels of up to 8 tiles in one
// dispatch of 16 workgroups per tile (one per 64×64 region; the last region of a tile to
// finish also makes levels 5–8), each level computed from the base level only: the exact area
// average, or with enhance the sharpened kernel of gpu/mip_kernel.h (docs/ENHANCEMENT.md).
//
// Owned by the engine, used only by the buffer thread (record() is not thread-safe).
#pragma once

#include "gpu/device.h"
#include "gpu/tile_atlas.h"

namespace iris::gpu {

class MipPipeline {
public:
    static constexpr uint32_t kMaxTiles = 8;
    static constexpr uint32_t kRegionsPerTile = 16;     // workgroups per tile
    static constexpr uint32_t kSharedBytes = 27876;     // the shader's shared memory (checked at init)
    MipPipeline(Device& device, TileAtlas& atlas) : device_(device), atlas_(atlas) {}
    ~MipPipeline();
    Result init();
    // Records the dispatch for `count` atlas layers (count ≤ kMaxTiles); enhance selects the
    // sharpened kernel, else the exact area average.
    // The first call also zeroes the per-slot arrival counters (in the same command buffer).
    void record(VkCommandBuffer cmd, const int* layers, uint32_t count, bool enhance);

private:
    Device& device_;
    TileAtlas& atlas_;
    VkShaderModule module_ = VK_NULL_HANDLE;
    VkDescriptorSetLayout setLayout_ = VK_NULL_HANDLE;
    VkPipelineLayout layout_ = VK_NULL_HANDLE;
    VkPipeline pipeline_ = VK_NULL_HANDLE;
    VkDescriptorPool pool_ = VK_NULL_HANDLE;
    VkDescriptorSet set_ = VK_NULL_HANDLE;
    // Per atlas slot: 256 level-4 sums (uvec2) the regions hand to the last one, then one
    // arrival counter (uint) per slot.
    VkBuffer scratch_ = VK_NULL_HANDLE;
    VkDeviceMemory scratchMemory_ = VK_NULL_HANDLE;
    VkDeviceSize sumsBytes_ = 0;
    VkDeviceSize countersOffset_ = 0;
    VkDeviceSize countersBytes_ = 0;
    bool countersZeroed_ = false;
};

} // namespace iris::gpu
