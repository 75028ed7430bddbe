#include "cache/loader_pool.h"

namespace iris {

LoaderPool::LoaderPool(SharedState& shared, TileCache& cache, const Log& log, unsigned threads, int perimeter)
    : shared_(shared), cache_(cache), log_(log), perimeter_(perimeter) {
    if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
    syntheticCap_ = std::max(1u, threads - 1);
    for (unsigned i = 0; i < threads; ++i) threads_.emplace_back([this] { run(); });
}

LoaderPool::~LoaderPool() { stop(); }

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
        if (!loadOne()) shared_.waitChange(seen);
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
    std::lock_guard lock(planMutex_);
    if (!plan_ || plan_->slide != plan->slide || plan_->viewSerial < plan->viewSerial) plan_ = plan;
    return plan_;
}

void LoaderPool::decode(const Snapshot& snap, const TileRef& t) {
    std::unique_ptr<uint8_t[]> buf = cache_.acquireBuffer();
    const Result r = snap.slide->source->readTile(t.level, t.tx, t.ty, buf.get());
    const bool failed = !r.ok();
    if (r.status() == Status::Cancelled) {
        // The slide was let go of (SlideSource::abandon) while this tile was being read: no
        // error to report, and nobody wants the tile. It is published as failed so that its
        // claim ends; its generation is no longer drawn.
        fillFailedTilePlaceholder(buf.get());
    } else if (failed) {
        shared_.setSlideError(snap.slide->generation, r);
        log_.error(r.message());
        if (!snap.slide->source->keepsPartialTiles(t.level)) fillFailedTilePlaceholder(buf.get());
    }
    cache_.publish(t.key, std::move(buf), failed);
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

bool LoaderPool::tryLoad(const Snapshot& snap, Plan& plan, const TileRef& t) {
    const bool synthetic = snap.slide->info.levels[size_t(t.level)].synthetic;
    if (synthetic && syntheticBusy_.fetch_add(1, std::memory_order_relaxed) >= syntheticCap_) {
        syntheticBusy_.fetch_sub(1, std::memory_order_relaxed);
        // Left for later: the loader that finishes its synthetic tile bumps `wake`, and the
        // next loader past the cursor's end scans the plan again for this one.
        plan.scannedEpoch.store(Plan::kScanAgain, std::memory_order_relaxed);
        return false;
    }
    const bool claimed = cache_.tryClaim(t.key);
    if (claimed) decode(snap, t);
    if (synthetic) syntheticBusy_.fetch_sub(1, std::memory_order_relaxed);
    return claimed;
}

} // namespace iris
