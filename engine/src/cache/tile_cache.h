// RAM cache of decoded tiles, bounded by a byte budget, in recycled buffers.
// One mutex, held for map operations only: loaders take each tile of their work list with one
// tryClaim (LoaderPool), not a scan of the region per tile.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <unordered_map>
#include <vector>

namespace iris {

class TileCache {
public:
    explicit TileCache(uint64_t budgetBytes);

    // Claims `key` for decoding: true when it was neither cached nor being decoded.
    bool tryClaim(uint64_t key);
    // Returns a buffer (kTileBytes) to decode into; recycled, or from the reserve, allocated
    // only while the pool grows.
    std::unique_ptr<uint8_t[]> acquireBuffer();
    // For a loader with nothing to decode: while the cache is filling, makes up to `batch` new
    // buffers ahead of need (zeroed, so their pages are resident: a first write to fresh
    // memory costs more than decoding a tile on some virtual machines, core/prefault.h), keeping at most reserveTarget() of them
    // free, and never more buffers in all than the budget holds; any number of loaders at
    // once. False when none was made (the reserve is full, counting the buffers other loaders
    // are making, or the budget spoken for): the loader may sleep.
    bool replenish(size_t batch);
    size_t reserveTarget() const { return reserveTarget_; }
    // Publishes a decoded (or failed, with placeholder pixels) tile and drops the claim.
    // `coefficients`: the buffer holds the tile as a coefficient record (jpegrecord,
    // EngineTuning::JpegDecode::Gpu), which the buffer thread finishes on the GPU.
    void publish(uint64_t key, std::unique_ptr<uint8_t[]> pixels, bool failed, bool coefficients = false);
    // Drops a claim without a result (the tile left the buffer region before it was decoded).
    void abandon(uint64_t key, std::unique_ptr<uint8_t[]> buffer);
    // Copies a ready tile into dst (of a coefficient record, the bytes in use); false when not
    // ready. `failed` tells a placeholder. The copy runs without the cache's lock; any number
    // of threads may copy at once.
    // `coefficients` (optional) tells a coefficient record.
    bool copyOut(uint64_t key, uint8_t* dst, bool* failed, bool* coefficients = nullptr);
    // Calls use(pixels) with a ready tile's kTileBytes, which stay as they are during the call;
    // false (and no call) when not ready. Runs `use` without the cache's lock, like copyOut.
    bool readOut(uint64_t key, const std::function<void(const uint8_t*)>& use, bool* failed,
                 bool* coefficients = nullptr);
    bool isReady(uint64_t key) const;
    // Forgets every tile whose generation differs from `generation`.
    void dropOtherGenerations(uint32_t generation);

    // Counts the times a tile that was claimed or decoded became claimable again (evicted,
    // abandoned, dropped with its generation). Loaders that passed a tile in their work list
    // scan the region again only when this changed (see LoaderPool).
    uint64_t releaseEpoch() const { return releaseEpoch_.load(std::memory_order_acquire); }

    uint64_t bytesUsed() const;
    uint64_t budgetBytes() const { return budget_; }

private:
    struct Entry {
        std::unique_ptr<uint8_t[]> pixels; // null while loading
        bool failed = false;
        bool coefficients = false; // a coefficient record, not pixels
        std::list<uint64_t>::iterator lru;
    };
    void evictOverBudgetLocked();
    void recycleLocked(std::unique_ptr<uint8_t[]> buf);

    const uint64_t budget_;
    // Free buffers kept ready while the cache fills: a new field's first decodes then write
    // memory already resident. 1/8 of the budget, at most 64 MiB.
    const size_t reserveTarget_;
    mutable std::mutex mutex_;
    std::unordered_map<uint64_t, Entry> entries_;
    std::list<uint64_t> lru_; // ready entries, most recent at the front
    std::vector<std::unique_ptr<uint8_t[]>> freeBuffers_;
    // copyOut copies without the lock (a tile is 256 KiB: the loaders would wait on every copy):
    // the buffers being copied from, and those an eviction or a drop let go of meanwhile, kept
    // here, neither freed nor handed to a loader, until their copies end.
    std::vector<const uint8_t*> copying_;
    std::vector<std::unique_ptr<uint8_t[]>> orphans_;
    uint64_t readyCount_ = 0;
    size_t reserving_ = 0; // buffers replenish() is making, outside the lock
    std::atomic<uint64_t> releaseEpoch_{0}; // written under mutex_, read without it
};

} // namespace iris
