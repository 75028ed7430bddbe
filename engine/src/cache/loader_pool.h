// The loader pool: N threads that decode tiles into the RAM cache. Pull-style: each time a
// loader picks a tile it takes the newest published view, and works through the buffer
// region of that view in priority order, taking the first tile that is neither cached nor
// being decoded. The region is computed once per view (a Plan, shared by the loaders) and
// handed out by an atomic cursor, so picking a tile costs one claim, not a scan of the region
// under the cache's mutex; a plan of an older view is replaced before the next pick, so a
// stale work list is never followed. When the cursor has passed the end, a loader scans the
// region again only if the cache has given a tile back since (TileCache::releaseEpoch).
// Loaders never touch Vulkan.
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "cache/tile_cache.h"
#include "core/log.h"
#include "core/shared_state.h"

namespace iris {

class LoaderPool {
public:
    LoaderPool(SharedState& shared, TileCache& cache, const Log& log, unsigned threads, int perimeter);
    ~LoaderPool(); // joins (shared.stopping must be set and bumped first, or the pool does it)
    void stop();

private:
    struct Plan {
        const OpenSlide* slide = nullptr; // identity only (the snapshot keeps it alive)
        uint64_t viewSerial = 0;
        std::vector<TileRef> tiles;       // the buffer region, in priority order
        std::atomic<size_t> next{0};      // the first tile no loader has tried yet
        // The cache's release epoch the last scan of this plan saw; kScanAgain forces the next
        // loader past the cursor's end to scan (no epoch ever has that value, 0 included).
        std::atomic<uint64_t> scannedEpoch{0};
        static constexpr uint64_t kScanAgain = ~uint64_t(0);
    };
    void run();
    bool loadOne();
    std::shared_ptr<Plan> planFor(const Snapshot& snap);
    void decode(const Snapshot& snap, const TileRef& t);
    // Claims tile t for this loader and decodes it; false when someone else has it, or when it
    // is a synthetic level's tile and syntheticCap_ loaders are already on one (it is then
    // left for later: plan.scannedEpoch is reset so that a loader scans for it again).
    bool tryLoad(const Snapshot& snap, Plan& plan, const TileRef& t);

    SharedState& shared_;
    TileCache& cache_;
    const Log& log_;
    const int perimeter_;
    std::vector<std::thread> threads_;
    // A synthetic level's tile reads 4^k stored tiles (seconds on a large slide without reduced
    // levels). At most syntheticCap_ loaders (all but one, when there are several) work on such
    // tiles at once, so one is always free to take a new view's tiles at once.
    unsigned syntheticCap_ = 1;
    std::atomic<unsigned> syntheticBusy_{0};
    std::mutex planMutex_;         // guards plan_ (held to copy or replace a pointer)
    std::shared_ptr<Plan> plan_;
};

} // namespace iris
