// The GPU tile map: a fixed array of slots, each one layer of a single 2D-array image of
// 256×256 RGBA8 tiles with a full mip chain, sized from the VRAM budget at startup (no Vulkan
// allocation after startup), plus the index (tile key → slot).
//
// Slot life: FREE → FILLING (buffer thread recorded an upload) → ACTIVE (upload completed,
// read from a timeline semaphore) → reclaimed (status flip back to FILLING for another key)
// once no frame in flight still samples it (lastUsedFrame ≤ the render thread's completed frame).
//
// Issue-2 slice: one mutex guards the index and the slot states; the render thread holds it
// only to look up its draw list. The lock-free map replaces it in the engine-core issue.
//
// The image stays in VK_IMAGE_LAYOUT_GENERAL for its whole life: uploads (copy, blit) and
// sampling are ordered by memory barriers alone, so no per-layer layout tracking can go wrong.
#pragma once

#include <cstdint>
#include <mutex>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "gpu/device.h"

namespace iris::gpu {

inline constexpr uint32_t kTileMipLevels = 9; // 256 → 1

class TileAtlas {
public:
    explicit TileAtlas(Device& device) : device_(device) {}
    ~TileAtlas();
    Result init(uint64_t vramBudgetBytes);

    static uint64_t bytesPerSlot();
    VkImage image() const { return image_; }
    VkImageView view() const { return view_; }
    VkSampler sampler() const { return sampler_; }
    uint32_t slotCount() const { return uint32_t(slots_.size()); }

    // Render thread: the layer of an ACTIVE tile, or -1. Marks the slot used by `frame`.
    int acquireForFrame(uint64_t key, uint64_t frame);
    // Buffer thread: is the key ACTIVE or FILLING (nothing to do)?
    bool present(uint64_t key) const;
    // Buffer thread: a slot for `key` (state FILLING), or -1 when none can be reclaimed.
    // Reclaims FREE slots first, then the least recently drawn ACTIVE slot whose key is not
    // in `keep` and that no unfinished frame uses.
    int allocate(uint64_t key, const std::unordered_set<uint64_t>& keep, uint64_t completedFrame);
    // Buffer thread: the upload into `slot` completed.
    void activate(int slot);
    // Buffer thread: the upload was abandoned; the slot becomes FREE.
    void release(int slot);
    uint32_t activeCount() const;

private:
    enum class State : uint8_t { Free, Filling, Active };
    struct Slot {
        uint64_t key = 0;
        State state = State::Free;
        uint64_t lastUsedFrame = 0;
    };

    Device& device_;
    VkImage image_ = VK_NULL_HANDLE;
    VkDeviceMemory memory_ = VK_NULL_HANDLE;
    VkImageView view_ = VK_NULL_HANDLE;
    VkSampler sampler_ = VK_NULL_HANDLE;

    mutable std::mutex mutex_;
    std::vector<Slot> slots_;
    std::unordered_map<uint64_t, int> index_;
};

} // namespace iris::gpu
