#include "cache/loader_pool.h"
#include "core/thread_name.h"

namespace iris {

namespace {
// The parts of this loader thread's pass that decode() times, counted with the pass's whole time
// when it ends (run; StageLog::addDecodedPass keeps the sums consistent while it is counted).
struct PassParts {
    StageLog::Clock::duration acquire{}, decode{};
};
thread_local PassParts passParts;
} // namespace

LoaderPool::LoaderPool(SharedState& shared, TileCache& cache, const Log& log, unsigned threads, int perimeter,
                       Decoded decoded, bool coefficients)
    : shared_(shared), decoded_(std::move(decoded)), coefficients_(coefficients), cache_(cache), log_(log),
      perimeter_(perimeter) {
    if (threads == 0) threads = defaultThreads(std::thread::hardware_concurrency());
    syntheticCap_ = std::max(1u, threads - 1);
    for (unsigned i = 0; i < threads; ++i)
        threads_.emplace_back([this] {
            nameThisThread("iris-loader");
            run();
        });
}

LoaderPool::~LoaderPool() {
    stop();
    if (plan_) retire(*plan_);
}

void LoaderPool::stop() {
    if (threads_.empty()) return;
    shared_.stopping.store(true, std::memory_order_release);
    shared_.bump();
    for (auto& t : threads_) t.join();
    threads_.clear();
}

void LoaderPool::run() {
    while (!shared_.stopping.load(std::memory_order_acquire)) {
        const uint64_t seen = shared_.wakeValue();
        // With nothing to decode, buffers for the next field's tiles first (TileCache::replenish:
        // a few at a time, so that a new view waits at most ~0.3 ms for this loader).
        using Kind = StageLog::LoaderTime;
        StageLog& log = shared_.tileStages;
        auto t0 = StageLog::Clock::now();
        const bool loaded = loadOne();
        auto t1 = StageLog::Clock::now();
        if (loaded) { // a pass that decoded a tile (LoaderPool::decode): counted whole with its parts
            log.addDecodedPass(t1 - t0, passParts.acquire, passParts.decode);
            passParts = {};
            continue;
        }
        log.addLoaderTime(Kind::Search, t1 - t0);
        const bool made = cache_.replenish(4);
        t0 = StageLog::Clock::now();
        log.addLoaderTime(Kind::Replenish, t0 - t1);
        if (made) continue;
        shared_.waitChange(seen);
        log.addLoaderTime(Kind::Asleep, StageLog::Clock::now() - t0);
    }
}

std::shared_ptr<LoaderPool::Plan> LoaderPool::planFor(const Snapshot& snap) {
    {
        std::lock_guard lock(planMutex_);
        // A plan of this view, or of a newer one (this loader's snapshot may be older), serves.
        if (plan_ && plan_->slide == snap.slide.get() && plan_->viewSerial >= snap.viewSerial) return plan_;
    }
    auto plan = std::make_shared<Plan>();
    plan->slide = snap.slide.get();
    plan->viewSerial = snap.viewSerial;
    plan->scannedEpoch.store(cache_.releaseEpoch(), std::memory_order_relaxed);
    plan->tiles = bufferRegion(snap.slide->info, snap.slide->generation, snap.viewport, perimeter_);
    std::shared_ptr<Plan> replaced, current;
    {
        std::lock_guard lock(planMutex_);
        if (!plan_ || plan_->slide != plan->slide || plan_->viewSerial < plan->viewSerial) {
            replaced = std::move(plan_);
            plan_ = plan;
        }
        current = plan_;
    }
    if (current != plan) return current;
    if (replaced) retire(*replaced);
    SlideSource& source = *snap.slide->source;
    if (source.readsOverNetwork()) {
        // The whole region in one batch, in the plan's order (base, LR, HR, perimeters; each
        // centre out), less what is decoded already.
        std::vector<TileAddress> wanted;
        wanted.reserve(plan->tiles.size());
        for (const TileRef& t : plan->tiles)
            if (!cache_.isReady(t.key)) wanted.push_back({t.level, t.tx, t.ty});
        source.prefetch(wanted, [this] {
            arrivals_.fetch_add(1, std::memory_order_release);
            shared_.bump();
        });
    }
    return plan;
}

void LoaderPool::retire(Plan& plan) {
    std::vector<TileRef> back;
    {
        std::lock_guard lock(plan.heldMutex);
        if (plan.retired) return;
        plan.retired = true;
        back = std::move(plan.waiting);
        back.insert(back.end(), plan.ready.begin(), plan.ready.end());
        back.insert(back.end(), plan.failed.begin(), plan.failed.end());
        plan.ready.clear();
        plan.failed.clear();
    }
    // Claimable again (the cache bumps its release epoch): the new plan asks for those it needs.
    for (const TileRef& t : back) cache_.abandon(t.key, nullptr);
}

void LoaderPool::hold(Plan& plan, const TileRef& t, std::vector<TileRef> Plan::*list) {
    {
        std::lock_guard lock(plan.heldMutex);
        if (!plan.retired) {
            (plan.*list).push_back(t);
            return;
        }
    }
    cache_.abandon(t.key, nullptr);
}

void LoaderPool::decode(const Snapshot& snap, Plan& plan, const TileRef& t) {
    SlideSource& source = *snap.slide->source;
    const auto asked = StageLog::Clock::now();
    std::unique_ptr<uint8_t[]> buf = cache_.acquireBuffer();
    const auto started = StageLog::Clock::now();
    passParts.acquire = started - asked;
    reads_.fetch_add(1, std::memory_order_relaxed);
    shared_.tileStages.stamp(TileStage::DecodeStart, 1, started);
    // The GPU finishes the decode where it can (EngineTuning::JpegDecode::Gpu); a tile it does
    // not take, or one that fails so, is read whole, which also says what is wrong with it.
    bool coefficients = false;
    Result r;
    if (coefficients_ && source.readsCoefficients(t.level))
        coefficients = source.readTileCoefficients(t.level, t.tx, t.ty, buf.get()).ok();
    if (!coefficients) r = source.readTile(t.level, t.tx, t.ty, buf.get());
    passParts.decode = StageLog::Clock::now() - started;
    reads_.fetch_sub(1, std::memory_order_relaxed);
    const bool failed = !r.ok();
    if (r.status() == Status::Cancelled) {
        // The slide was let go of (SlideSource::abandon) while this tile was being read: no
        // error to report, and nobody wants the tile. Its claim ends without a result.
        cache_.abandon(t.key, std::move(buf));
        shared_.bump();
        return;
    }
    if (failed) {
        shared_.setSlideError(snap.slide->generation, r);
        log_.error(r.message());
        if (source.readsOverNetwork() && (r.status() == Status::IoError || r.status() == Status::Timeout)) {
            // Perhaps only for now (no connection, a timeout, a server error): the tile is not
            // published, so it is read again, and the claim stays with the plan; meanwhile the
            // render thread draws the placeholder where it lies (core/failing_tiles.h). The view
            // still needs the tile, so it is asked for again at once: the source sends the
            // request when its back-off of the server ends, and the tile waits for it like any
            // other (a view that stays put recovers when the server is back). Only a source
            // that still has the failure at hand leaves it failed until a later view asks again.
            shared_.failingTiles.add(t.key);
            hold(plan, t, source.requestTile(t.level, t.tx, t.ty) ? &Plan::failed : &Plan::waiting);
            shared_.bump(); // the buffer thread uploads the placeholder, the render thread draws it
            return;
        }
        if (!source.keepsPartialTiles(t.level)) fillFailedTilePlaceholder(buf.get());
    }
    shared_.failingTiles.remove(t.key); // read (or failed for good: its own placeholder)
    // Into staging while the tile is still in this core's cache, and beside the other loaders,
    // rather than by the buffer thread alone later (BufferThread::prestage).
    if (decoded_ && !failed) decoded_(t.key, buf.get(), coefficients);
    cache_.publish(t.key, std::move(buf), failed, coefficients);
    shared_.tileStages.stamp(TileStage::Decoded);
    shared_.bump(); // the buffer thread may now upload it
}

bool LoaderPool::loadOne() {
    const Snapshot snap = shared_.snapshot();
    if (!snap.slide) return false;
    const std::shared_ptr<Plan> plan = planFor(snap);
    for (;;) {
        const size_t i = plan->next.fetch_add(1, std::memory_order_relaxed);
        if (i >= plan->tiles.size()) break;
        if (tryLoad(snap, *plan, plan->tiles[i])) return true;
    }
    if (snap.slide->source->readsOverNetwork() && loadArrived(snap, *plan)) return true;
    // Every tile of the plan has been tried. One the cache gave back since (evicted before it
    // was uploaded, dropped), or a synthetic tile left for later, is claimable again: scan the
    // region in priority order for it.
    const uint64_t epoch = cache_.releaseEpoch();
    if (plan->scannedEpoch.exchange(epoch, std::memory_order_acq_rel) == epoch) return false;
    for (const TileRef& t : plan->tiles) {
        if (!tryLoad(snap, *plan, t)) continue;
        plan->scannedEpoch.store(Plan::kScanAgain, std::memory_order_relaxed); // look again after this one
        return true;
    }
    return false;
}

bool LoaderPool::loadArrived(const Snapshot& snap, Plan& plan) {
    TileRef t;
    {
        std::lock_guard lock(plan.heldMutex);
        if (plan.retired) return false;
        if (plan.ready.empty()) {
            // acquire: pairs with the arrival callback's release (see arrivals_).
            const uint64_t arrivals = arrivals_.load(std::memory_order_acquire);
            if (arrivals == plan.arrivalsSeen) return false;
            plan.arrivalsSeen = arrivals;
            std::vector<TileRef> still;
            for (const TileRef& w : plan.waiting) {
                if (snap.slide->source->requestTile(w.level, w.tx, w.ty))
                    plan.ready.push_back(w);
                else
                    still.push_back(w);
            }
            plan.waiting.swap(still);
            if (plan.ready.empty()) return false;
        }
        t = plan.ready.front();
        plan.ready.pop_front();
    }
    decode(snap, plan, t);
    return true;
}

bool LoaderPool::tryLoad(const Snapshot& snap, Plan& plan, const TileRef& t) {
    const bool synthetic = snap.slide->info.levels[size_t(t.level)].synthetic;
    if (synthetic && syntheticBusy_.fetch_add(1, std::memory_order_relaxed) >= syntheticCap_) {
        syntheticBusy_.fetch_sub(1, std::memory_order_relaxed);
        // Left for later: the loader that finishes its synthetic tile bumps `wake`, and the
        // next loader past the cursor's end scans the plan again for this one.
        plan.scannedEpoch.store(Plan::kScanAgain, std::memory_order_relaxed);
        return false;
    }
    bool claimed = cache_.tryClaim(t.key);
    if (claimed) {
        SlideSource& source = *snap.slide->source;
        if (source.readsOverNetwork() && !source.requestTile(t.level, t.tx, t.ty)) {
            hold(plan, t, &Plan::waiting); // read once it lands (loadArrived)
            claimed = false;               // nothing decoded: the caller goes on to the next tile
        } else {
            decode(snap, plan, t);
        }
    }
    if (synthetic) syntheticBusy_.fetch_sub(1, std::memory_order_relaxed);
    return claimed;
}

} // namespace iris

namespace iris {
static_assert(LoaderPool::defaultThreads(0) == 1 && LoaderPool::defaultThreads(2) == 2 &&
              LoaderPool::defaultThreads(4) == 4 && LoaderPool::defaultThreads(5) == 3 &&
              LoaderPool::defaultThreads(16) == 14);
} // namespace iris
