// The tiles of a network slide whose last read failed for a reason that may pass (no
// connection, a timeout, HTTP 408/429/5xx): the loaders list a tile when its read fails so
// and take it off once it is read. Such a tile stays wanted (the loaders ask for it again), and
// until it arrives the render thread draws the failed-tile placeholder where it lies
// (render/draw_list.h: DrawOptions::failing), as for a tile that cannot be read at all, rather
// than letting the coarser level beneath show through: a pathologist must not take an
// enlarged coarse level for the slide's own pixels. The buffer thread uploads the placeholder
// into one atlas slot (placeholderKey) once a tile is listed.
//
// Threads: add/remove from the loaders (serialised by a mutex, copy on write; failures are
// rare and the set small), load from the render thread without waiting (core/published.h).
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <unordered_set>

#include "core/published.h"
#include "view/view_model.h"

namespace iris {

// The atlas key of the placeholder tile of slide `generation`: level 63 and the last tile
// coordinates, which no slide's tile has (a slide has fewer levels).
inline uint64_t placeholderKey(uint32_t generation) {
    return TileKey::make(generation, (1 << TileKey::kLevelBits) - 1, kMaxTilesPerAxis - 1, kMaxTilesPerAxis - 1);
}

class FailingTiles {
public:
    using Set = std::unordered_set<uint64_t>;
    // At most this many are listed; a tile past it shows what lies beneath, as before.
    static constexpr size_t kMaxTiles = 1 << 16;

    // Lists `key` (a loader, after its read failed for a reason that may pass). Keys of another
    // slide generation are dropped: their slide is no longer open.
    void add(uint64_t key) {
        std::lock_guard lock(mutex_);
        const std::shared_ptr<const Set> cur = set_.load();
        if (cur && cur->count(key)) return;
        auto next = std::make_shared<Set>();
        if (cur) {
            next->reserve(cur->size() + 1);
            const uint32_t gen = TileKey::generation(key);
            for (uint64_t k : *cur)
                if (TileKey::generation(k) == gen) next->insert(k);
        }
        if (next->size() >= kMaxTiles) return;
        next->insert(key);
        count_.store(next->size(), std::memory_order_release);
        set_.store(std::move(next));
    }
    // Takes `key` off the list (a loader, after it read the tile); cheap when it is not listed.
    void remove(uint64_t key) {
        if (count_.load(std::memory_order_acquire) == 0) return;
        {
            const std::shared_ptr<const Set> cur = set_.load();
            if (!cur || !cur->count(key)) return;
        }
        std::lock_guard lock(mutex_);
        const std::shared_ptr<const Set> cur = set_.load();
        if (!cur || !cur->count(key)) return;
        std::shared_ptr<Set> next;
        if (cur->size() > 1) {
            next = std::make_shared<Set>(*cur);
            next->erase(key);
        }
        count_.store(next ? next->size() : 0, std::memory_order_release);
        set_.store(std::move(next));
    }
    // Forgets every tile (a slide closed or replaced).
    void clear() {
        std::lock_guard lock(mutex_);
        count_.store(0, std::memory_order_release);
        set_.store(nullptr);
    }
    // The listed tiles; null when none.
    std::shared_ptr<const Set> load() const {
        if (count_.load(std::memory_order_acquire) == 0) return nullptr;
        return set_.load();
    }
    bool empty() const { return count_.load(std::memory_order_acquire) == 0; }

private:
    std::mutex mutex_; // writers
    Published<Set> set_;
    std::atomic<size_t> count_{0};
};

} // namespace iris
