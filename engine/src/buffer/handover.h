// Hand-over of finished tiles from the buffer thread to the render thread when mips are made
// on a compute queue of another family than the graphics queue: the render thread must then
// record the queue-family *acquire* half of the ownership transfer before it samples them.
//
// A single-producer (buffer thread) / single-consumer (render thread) ring. Capacity is at
// least the atlas slot count and a slot is handed over at most once per fill, so it never
// overflows.
#pragma once

#include <atomic>
#include <bit>
#include <cstdint>
#include <vector>

#include <vulkan/vulkan.h>

#include "core/tile_map.h"

namespace iris {

struct HandoverItem {
    int slot;
    uint64_t uploadValue; // upload timeline value whose signal released the slot
    uint64_t uploadSeq;   // UploadCounters::tiles once this tile's upload was counted (TileMap::activate)
    bool opaque = false;  // every pixel's alpha is 255 (TileMap::activate)
};

class Handover {
public:
    explicit Handover(uint32_t slots) : ring_(std::bit_ceil(size_t(slots) + 1)), mask_(ring_.size() - 1) {}

    // Set once at startup, before the threads start.
    bool needed = false;             // compute family != graphics family
    uint32_t srcFamily = 0;          // compute family (releasing)
    VkSemaphore uploadTimeline = VK_NULL_HANDLE;

    void push(HandoverItem item) {
        const size_t h = head_.load(std::memory_order_relaxed);
        ring_[h & mask_] = item;
        head_.store(h + 1, std::memory_order_release); // pairs with pop()'s acquire load
    }
    template <class F>
    void drain(F&& f) {
        const size_t h = head_.load(std::memory_order_acquire); // pairs with push()'s release
        size_t t = tail_.load(std::memory_order_relaxed);
        for (; t != h; ++t) f(ring_[t & mask_]);
        tail_.store(t, std::memory_order_release); // frees entries for the producer
    }

    // Device loss: forgets what was handed over, while neither thread uses the ring.
    void reset() {
        head_.store(0, std::memory_order_relaxed);
        tail_.store(0, std::memory_order_relaxed);
    }

private:
    std::vector<HandoverItem> ring_;
    size_t mask_;
    alignas(kCacheLine) std::atomic<size_t> head_{0};
    alignas(kCacheLine) std::atomic<size_t> tail_{0};
};

} // namespace iris
