// The loader pool: N threads that decode tiles into the RAM cache. Pull-style: each time a
// loader picks a tile it takes the newest published view, and works through the buffer
// region of that view in priority order, taking the first tile that is neither cached nor
// being decoded. The region is computed once per view (a Plan, shared by the loaders) and
// handed out by an atomic cursor, so picking a tile costs one claim, not a scan of the region
// under the cache's mutex; a plan of an older view is replaced before the next pick, so a
// stale work list is never followed. When the cursor has passed the end, a loader scans the
// region again only if the cache has given a tile back since (TileCache::releaseEpoch).
// Loaders never touch Vulkan.
//
// A source that reads over a network (SlideSource::readsOverNetwork) gets each new plan's
// tiles as one prefetch batch, and the loaders never wait on it: a claimed tile whose data has
// not arrived is set aside in the plan (`waiting`, claim held) and read once the source says it
// landed (its callback counts `arrivals_` and wakes the loaders). A read that fails for a
// reason that may pass (IoError, Timeout) publishes nothing (`failed`, claim held), so the
// layers below show through; when the plan is replaced every held claim is given back, and a
// later view that needs the tile asks for it again. docs/ARCHITECTURE.md, "The network source".
#pragma once

#include <atomic>
#include <deque>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "cache/tile_cache.h"
#include "core/log.h"
#include "core/shared_state.h"

#include <functional>

namespace iris {

class LoaderPool {
public:
    // Called by a loader with each tile it decoded (not a failed one), before publishing it:
    // the buffer thread's BufferThread::prestage. `coefficients`: the buffer is a coefficient
    // record, not pixels. Must be thread-safe.
    using Decoded = std::function<void(uint64_t key, const uint8_t* pixels, bool coefficients)>;
    // threads 0: defaultThreads(the hardware threads). `coefficients`: read the tiles of levels
    // whose source has coefficient records as records (EngineTuning::JpegDecode::Gpu; the
    // buffer thread finishes them on the GPU), others as pixels.
    LoaderPool(SharedState& shared, TileCache& cache, const Log& log, unsigned threads, int perimeter,
               Decoded decoded = {}, bool coefficients = false);
    // Loaders for `hardware` hardware threads: all of them up to 4, else two fewer, which the
    // buffer thread (staging every tile) and the render thread then have to themselves. On
    // the H100's 16 cores, 14 loaders made a new field whole sooner than 16 in 7 of 9 and 8 of
    // 9 alternated pairs (HR-TeFOV medians 6.25 → 5.65 ms at 2774×1750, 2.86 → 2.69 ms at
    // 1920×1080; BENCHMARKS.md, "Loaders leave two cores").
    static constexpr unsigned defaultThreads(unsigned hardware) {
        return hardware == 0 ? 1 : hardware <= 4 ? hardware : hardware - 2;
    }
    ~LoaderPool(); // joins (shared.stopping must be set and bumped first, or the pool does it)
    void stop();
    // Tile reads (SlideSource::readTile) running now, on all loaders. Relaxed: a count for
    // metrics and tests, which order nothing by it.
    unsigned readsInProgress() const { return reads_.load(std::memory_order_relaxed); }

private:
    struct Plan {
        const OpenSlide* slide = nullptr; // identity only (the snapshot keeps it alive)
        uint64_t viewSerial = 0;
        std::vector<TileRef> tiles;  // the buffer region, in priority order
        std::atomic<size_t> next{0}; // the first tile no loader has tried yet
        // The cache's release epoch the last scan of this plan saw; kScanAgain forces the next
        // loader past the cursor's end to scan (no epoch ever has that value, 0 included).
        std::atomic<uint64_t> scannedEpoch{0};
        static constexpr uint64_t kScanAgain = ~uint64_t(0);

        // Network sources only; guarded by heldMutex. Every tile in these lists is claimed in the
        // cache by this plan, until a loader takes it (ready) or the plan is retired.
        std::mutex heldMutex;
        std::vector<TileRef> waiting; // data still on the way, priority order
        std::deque<TileRef> ready;    // taken from `waiting` once their data landed, priority order
        std::vector<TileRef> failed;  // read failed for a reason that may pass, and not asked for again yet
        bool retired = false;         // replaced: claims handed to it are given back at once
        uint64_t arrivalsSeen = 0;    // arrivals_ when `waiting` was last looked through
    };
    void run();
    bool loadOne();
    std::shared_ptr<Plan> planFor(const Snapshot& snap);
    void decode(const Snapshot& snap, Plan& plan, const TileRef& t);
    // Claims tile t for this loader and decodes it; false when someone else has it, when it
    // is a synthetic level's tile and syntheticCap_ loaders are already on one (it is then
    // left for later: plan.scannedEpoch is reset so that a loader scans for it again), or when
    // it was set aside to wait for the network (plan.waiting).
    bool tryLoad(const Snapshot& snap, Plan& plan, const TileRef& t);
    // Network sources: a claimed tile into one of the plan's held lists (or its claim back, when
    // the plan was retired meanwhile).
    void hold(Plan& plan, const TileRef& t, std::vector<TileRef> Plan::*list);
    // Network sources: decodes the next tile of the plan whose data has landed; false when none has.
    bool loadArrived(const Snapshot& snap, Plan& plan);
    // Gives back the claims a replaced plan holds.
    void retire(Plan& plan);

    SharedState& shared_;
    const Decoded decoded_;
    const bool coefficients_;
    TileCache& cache_;
    const Log& log_;
    const int perimeter_;
    std::vector<std::thread> threads_;
    // A synthetic level's tile reads 4^k stored tiles (seconds on a large slide without reduced
    // levels). At most syntheticCap_ loaders (all but one, when there are several) work on such
    // tiles at once, so one is always free to take a new view's tiles at once.
    unsigned syntheticCap_ = 1;
    std::atomic<unsigned> syntheticBusy_{0};
    std::atomic<unsigned> reads_{0}; // readsInProgress()
    std::mutex planMutex_; // guards plan_ (held to copy or replace a pointer)
    std::shared_ptr<Plan> plan_;
    // Counts the network source's arrival callbacks: fetch_add(release) there, then `wake` is
    // bumped; loaders load(acquire) it before looking through a plan's waiting tiles, so a
    // callback after that look changes the count and makes the next loader look again.
    std::atomic<uint64_t> arrivals_{0};
};

} // namespace iris
