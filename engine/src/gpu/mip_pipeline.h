// The mip compute pipeline: all mip levels of up to 8 tiles in one dispatch, each level
// computed from the base level only: the exact area average, or with enhance the sharpened
// kernel of gpu/mip_kernel.h (docs/ENHANCEMENT.md). Two schedules of the same kernel:
//   wide   (shaders/mip_reduce.comp, GPUs): 16 workgroups per tile, one per 64×64 region; the
//          last region of a tile to finish also makes levels 5–8;
//   serial (shaders/mip_reduce_serial.comp): one workgroup per tile;
//   host   (no pipeline): the buffer thread runs the kernel on the CPU while it stages a tile
//          (mipkernel::reduceChain8) and uploads the levels with the base level. For CPU
//          devices, where a dispatch is the same cores running the kernel far more slowly
//          (lavapipe's serial dispatch: 0.6–2 ms a tile), serialised with the frames.
// The device type picks wide or host; EngineTuning::mipSchedule overrides it (tests run all).
//
// Owned by the engine, used only by the buffer thread (record() is not thread-safe).
#pragma once

#include "gpu/device.h"
#include "gpu/tile_atlas.h"
#include "gpu/vk_handle.h"

namespace iris::gpu {

class MipPipeline {
public:
    static constexpr uint32_t kMaxTiles = 8;
    static constexpr uint32_t kRegionsPerTile = 16;     // workgroups per tile
    static constexpr uint32_t kSharedBytes = 27876;     // the wide shader's shared memory (checked at init)
    enum class Schedule { Wide, Serial, Host };
    MipPipeline(Device& device, TileAtlas& atlas) : device_(device), atlas_(atlas) {}
    // `requested`: EngineConfig::tuning.mipSchedule (Auto picks by device type).
    Result init(EngineTuning::MipSchedule requested);
    // The schedule `requested` comes to on a device of these properties (init's choice, before
    // there is a pipeline: the engine sizes the atlas's format by it).
    static Schedule resolve(EngineTuning::MipSchedule requested, const VkPhysicalDeviceProperties& device);
    Schedule schedule() const { return schedule_; }
    static const char* scheduleName(Schedule s) {
        return s == Schedule::Wide ? "wide" : s == Schedule::Serial ? "serial" : "host";
    }
    // Records the dispatch for `count` atlas layers (count ≤ kMaxTiles); enhance selects the
    // sharpened kernel, else the exact area average.
    // The first call also zeroes the per-slot arrival counters (in the same command buffer).
    void record(VkCommandBuffer cmd, const int* layers, uint32_t count, bool enhance);

private:
    // Wide schedule: zeroes the counters on first use, then orders this dispatch's scratch
    // accesses after the previous dispatch's.
    void recordScratchBarrier(VkCommandBuffer cmd);

    Device& device_;
    TileAtlas& atlas_;
    vk::ShaderModule module_;
    // Per atlas slot: 256 level-4 sums (uvec2) the regions hand to the last one, then one
    // arrival counter (uint) per slot.
    vk::Memory scratchMemory_;
    vk::Buffer scratch_;
    vk::DescriptorSetLayout setLayout_;
    vk::PipelineLayout layout_;
    vk::DescriptorPool pool_;
    VkDescriptorSet set_ = VK_NULL_HANDLE; // freed with pool_
    vk::Pipeline pipeline_;
    VkDeviceSize sumsBytes_ = 0;
    VkDeviceSize countersOffset_ = 0;
    VkDeviceSize countersBytes_ = 0;
    bool countersZeroed_ = false;
    Schedule schedule_ = Schedule::Wide;
};

} // namespace iris::gpu
