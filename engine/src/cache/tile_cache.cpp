#include "cache/tile_cache.h"

#include <algorithm>
#include <cstring>

#include "slide/jpeg_coefficients.h"
#include "slide/slide_source.h"
#include "view/view_model.h"

namespace iris {

TileCache::TileCache(uint64_t budgetBytes)
    : budget_(budgetBytes < uint64_t(kTileBytes) * 16 ? uint64_t(kTileBytes) * 16 : budgetBytes),
      reserveTarget_(size_t(std::min<uint64_t>(256, budget_ / kTileBytes / 8))) {}

bool TileCache::tryClaim(uint64_t key) {
    std::lock_guard lock(mutex_);
    auto [it, inserted] = entries_.try_emplace(key);
    if (inserted) it->second.lru = lru_.end();
    return inserted;
}

std::unique_ptr<uint8_t[]> TileCache::acquireBuffer() {
    {
        std::lock_guard lock(mutex_);
        if (!freeBuffers_.empty()) {
            auto b = std::move(freeBuffers_.back());
            freeBuffers_.pop_back();
            return b;
        }
    }
    return std::make_unique<uint8_t[]>(kTileBytes); // zeroed: its pages written once here
}

bool TileCache::replenish(size_t batch) {
    size_t n = 0;
    {
        std::lock_guard lock(mutex_);
        const uint64_t held = readyCount_ + freeBuffers_.size() + reserving_;
        const uint64_t maxReady = budget_ / kTileBytes;
        const size_t free = freeBuffers_.size() + reserving_;
        // Any number of idle loaders at once. (One at a time until 2026-11-29: many making
        // memory resident at once contend in the kernel, each buffer being a mapping of its
        // own; but with one, a walk of fields back to back left the reserve empty, and every
        // loader then paid 135-270 µs a tile for fresh memory while the cache filled. Every idle
        // loader refilling made new fields whole sooner in 7 of 7 alternated pairs on the H200:
        // BENCHMARKS.md, "Where the loaders' time goes".)
        if (free >= reserveTarget_ || held >= maxReady) return false;
        n = size_t(std::min<uint64_t>({batch, reserveTarget_ - free, maxReady - held}));
        reserving_ += n;
    }
    std::vector<std::unique_ptr<uint8_t[]>> made;
    made.reserve(n);
    for (size_t i = 0; i < n; ++i) made.push_back(std::make_unique<uint8_t[]>(kTileBytes)); // zeroed: resident
    std::lock_guard lock(mutex_);
    for (auto& b : made) freeBuffers_.push_back(std::move(b));
    reserving_ -= n;
    return true;
}

void TileCache::recycleLocked(std::unique_ptr<uint8_t[]> buf) {
    if (!buf) return;
    if (std::find(copying_.begin(), copying_.end(), buf.get()) != copying_.end()) {
        orphans_.push_back(std::move(buf)); // a copy still reads it
        return;
    }
    if (freeBuffers_.size() < std::max<size_t>(64, reserveTarget_)) freeBuffers_.push_back(std::move(buf));
}

void TileCache::publish(uint64_t key, std::unique_ptr<uint8_t[]> pixels, bool failed, bool coefficients) {
    std::lock_guard lock(mutex_);
    auto it = entries_.find(key);
    if (it == entries_.end()) { // dropped meanwhile (slide closed)
        recycleLocked(std::move(pixels));
        return;
    }
    it->second.pixels = std::move(pixels);
    it->second.failed = failed;
    it->second.coefficients = coefficients;
    lru_.push_front(key);
    it->second.lru = lru_.begin();
    ++readyCount_;
    evictOverBudgetLocked();
}

void TileCache::abandon(uint64_t key, std::unique_ptr<uint8_t[]> buffer) {
    std::lock_guard lock(mutex_);
    auto it = entries_.find(key);
    if (it != entries_.end() && !it->second.pixels) {
        entries_.erase(it);
        releaseEpoch_.fetch_add(1, std::memory_order_release);
    }
    recycleLocked(std::move(buffer));
}

bool TileCache::copyOut(uint64_t key, uint8_t* dst, bool* failed, bool* coefficients) {
    bool record = false;
    const bool found = readOut(
        key, [&](const uint8_t* src) { std::memcpy(dst, src, record ? jpegrecord::usedBytes(src) : kTileBytes); }, failed,
        &record);
    if (coefficients) *coefficients = record;
    return found;
}

bool TileCache::readOut(uint64_t key, const std::function<void(const uint8_t*)>& use, bool* failed,
                        bool* coefficients) {
    const uint8_t* src = nullptr;
    {
        std::lock_guard lock(mutex_);
        auto it = entries_.find(key);
        if (it == entries_.end() || !it->second.pixels) return false;
        src = it->second.pixels.get();
        if (failed) *failed = it->second.failed;
        if (coefficients) *coefficients = it->second.coefficients;
        lru_.splice(lru_.begin(), lru_, it->second.lru);
        copying_.push_back(src);
    }
    // The buffer stays as it is while listed in copying_: an eviction or a drop moves it to
    // orphans_ instead of recycling it, and only recycled buffers are written (acquireBuffer).
    use(src);
    std::lock_guard lock(mutex_);
    copying_.erase(std::find(copying_.begin(), copying_.end(), src));
    if (std::find(copying_.begin(), copying_.end(), src) == copying_.end()) {
        auto o = std::find_if(orphans_.begin(), orphans_.end(), [&](const auto& b) { return b.get() == src; });
        if (o != orphans_.end()) {
            std::unique_ptr<uint8_t[]> buf = std::move(*o);
            orphans_.erase(o);
            recycleLocked(std::move(buf));
        }
    }
    return true;
}

bool TileCache::isReady(uint64_t key) const {
    std::lock_guard lock(mutex_);
    auto it = entries_.find(key);
    return it != entries_.end() && it->second.pixels;
}

void TileCache::evictOverBudgetLocked() {
    const uint64_t maxReady = budget_ / kTileBytes;
    while (readyCount_ > maxReady && !lru_.empty()) {
        const uint64_t victim = lru_.back();
        lru_.pop_back();
        auto it = entries_.find(victim);
        recycleLocked(std::move(it->second.pixels));
        entries_.erase(it);
        --readyCount_;
        releaseEpoch_.fetch_add(1, std::memory_order_release);
    }
}

void TileCache::dropOtherGenerations(uint32_t generation) {
    std::lock_guard lock(mutex_);
    for (auto it = entries_.begin(); it != entries_.end();) {
        if (TileKey::generation(it->first) != (generation & 0xFFFF)) {
            if (it->second.pixels) {
                lru_.erase(it->second.lru);
                recycleLocked(std::move(it->second.pixels));
                --readyCount_;
            }
            it = entries_.erase(it);
            releaseEpoch_.fetch_add(1, std::memory_order_release);
        } else {
            ++it;
        }
    }
}

uint64_t TileCache::bytesUsed() const {
    std::lock_guard lock(mutex_);
    return (readyCount_ + freeBuffers_.size() + orphans_.size()) * uint64_t(kTileBytes);
}

} // namespace iris
