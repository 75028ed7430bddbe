#include "metrics/field_metrics.h"

#include "view/view_model.h"

#include <algorithm>
#include <utility>

namespace iris {

const char* tileStageName(TileStage stage) noexcept {
    switch (stage) {
    case TileStage::DecodeStart: return "decode_start";
    case TileStage::Decoded: return "decoded";
    case TileStage::Staged: return "staged";
    case TileStage::Submitted: return "submitted";
    case TileStage::GpuDone: return "gpu_done";
    case TileStage::Drawable: return "drawable";
    case TileStage::Shown: return "shown";
    }
    return "?";
}

} // namespace iris

namespace iris::metrics {

bool isNewField(const View& a, const View& b, double w, double h) {
    // The fields' bounding boxes in level-0 pixels (a turned view's is larger than its field).
    const auto [ax0, ay0, ax1, ay1] = fieldBounds(Viewport{a, uint32_t(w), uint32_t(h)});
    const auto [bx0, by0, bx1, by1] = fieldBounds(Viewport{b, uint32_t(w), uint32_t(h)});
    const double eps = 1e-3 * std::max(a.downsample, b.downsample);
    const bool overlap = ax0 + eps < bx1 && bx0 + eps < ax1 && ay0 + eps < by1 && by0 + eps < ay1;
    return !overlap;
}

void MetricsBoard::finishField(bool superseded) {
    if (!field_.active) return;
    if (superseded) field_.stats.hrTeFovMs = -1;
    if (stages_) {
        const auto now = std::chrono::steady_clock::now();
        for (int s = 0; s < kTileStageCount; ++s)
            field_.stats.stages[size_t(s)] = stages_->summarise(TileStage(s), field_.start, now);
        field_.stats.decodesInFlight = stages_->meanBetween(TileStage::DecodeStart, TileStage::Decoded, field_.start, now);
    }
    // A new list (boards already published keep theirs); a field finishes at most once a frame.
    auto next = std::make_shared<std::vector<FieldStats>>();
    const std::vector<FieldStats>& prev = *fields_;
    const size_t keep = std::min(prev.size(), kKeepFields - 1);
    next->reserve(keep + 1);
    next->insert(next->end(), prev.end() - long(keep), prev.end());
    next->push_back(field_.stats);
    fields_ = std::move(next);
    ++fieldsTotal_;
    field_.active = false;
}

void MetricsBoard::frameDrawn(const Snapshot& snap, const FieldProgress& p) {
    if (snap.fieldId != field_.id) {
        finishField(/*superseded=*/true);
        field_ = Field{};
        field_.id = snap.fieldId;
        if (snap.fieldId != 0) {
            field_.active = true;
            field_.firstFrame = true;
            field_.start = snap.fieldStart;
            field_.tilesAtStart = snap.fieldTilesAtStart;
            field_.stats.id = snap.fieldId;
            field_.stats.view = snap.viewport.view;
        }
    }
    if (!field_.active) return;
    // The first frame of a new field already whole, every tile of it uploaded before the view
    // moved there: it was resident (a revisit), so there is nothing to time. (Whole with a
    // tile uploaded since: a field that loaded before the render thread's first frame of it,
    // which a fast GPU on one queue does for a few tiles; that is timed.)
    const bool whole = p.hrComplete && (!p.hasLr || p.lrComplete);
    if (std::exchange(field_.firstFrame, false) && whole && p.newestUpload <= field_.tilesAtStart) {
        field_.active = false;
        return;
    }
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - field_.start).count();
    const uint64_t tiles = counters_.tiles.load(std::memory_order_relaxed) - field_.tilesAtStart;
    field_.stats.lrTiles = p.lrTiles;
    field_.stats.hrTiles = p.hrTiles;
    if (p.hasLr && !field_.lrDone && p.lrComplete) {
        field_.lrDone = true;
        field_.stats.lrTeFovMs = ms;
        field_.stats.lrTptUs = tiles ? ms * 1000.0 / double(tiles) : -1;
    }
    if (p.hrComplete) {
        field_.stats.hrTeFovMs = ms;
        field_.stats.tilesBuffered = uint32_t(tiles);
        field_.stats.hrTptUs = tiles ? ms * 1000.0 / double(tiles) : -1;
        finishField(/*superseded=*/false);
    }
}

FrameStats MetricsBoard::frameFinished(const Snapshot& snap, uint64_t serial, bool complete, uint32_t tilesDrawn,
                                       double cpuMs, double gpuMs, uint32_t tilesCopied) {
    FrameStats stats;
    const auto now = std::chrono::steady_clock::now();
    stats.serial = serial;
    stats.intervalMs = lastFrameTime_.time_since_epoch().count()
                           ? std::chrono::duration<double, std::milli>(now - lastFrameTime_).count()
                           : 0;
    lastFrameTime_ = now;
    stats.cpuMs = cpuMs;
    stats.gpuMs = gpuMs;
    const uint64_t bytes = counters_.bytes.load(std::memory_order_relaxed);
    stats.bytesBuffered = bytes - lastBytes_;
    lastBytes_ = bytes;
    stats.bufferRateGBps = stats.intervalMs > 0 ? double(stats.bytesBuffered) / (stats.intervalMs * 1e6) : 0;
    stats.tilesDrawn = tilesDrawn;
    stats.tilesCopied = tilesCopied;
    stats.complete = complete;
    stats.view = snap.viewport.view;

    auto board = std::make_shared<Board>();
    EngineMetrics& m = board->figures;
    m.frames = serial;
    m.lastFrame = stats;
    m.tilesBuffered = counters_.tiles.load(std::memory_order_relaxed);
    m.bytesBuffered = bytes;
    m.mipGpuMs = double(counters_.mipNs.load(std::memory_order_relaxed)) / 1e6;
    m.mipTiles = counters_.mipTiles.load(std::memory_order_relaxed);
    // The pickups first (acquire; the buffer thread adds a pickup's tile with release after its
    // time, and after the loader's copy counted it): the sums read have every picked-up tile's
    // copy and wait in them.
    m.stagedPickupTiles = counters_.pickupTiles.load(std::memory_order_acquire);
    m.stagedPickupMs = double(counters_.pickupNs.load(std::memory_order_relaxed)) / 1e6;
    m.prestageTiles = counters_.prestageTiles.load(std::memory_order_relaxed);
    m.prestageCopyMs = double(counters_.prestageNs.load(std::memory_order_relaxed)) / 1e6;
    if (stages_) {
        // The parts of the passes that decoded before their whole (StageLog::addDecodedPass).
        using Kind = StageLog::LoaderTime;
        const auto ms = [&](Kind k) { return double(stages_->loaderNs(k)) / 1e6; };
        m.decodeMs = double(stages_->decodeNs()) / 1e6;
        m.decodeTiles = stages_->decodeTiles();
        m.loaderAcquireMs = ms(Kind::Acquire);
        m.loaderWorkMs = ms(Kind::Work);
        m.loaderSearchMs = ms(Kind::Search);
        m.loaderReplenishMs = ms(Kind::Replenish);
        m.loaderAsleepMs = ms(Kind::Asleep);
    }
    m.uploadTransactions = counters_.uploadTransactions.load(std::memory_order_acquire); // before its time
    m.uploadMs = double(counters_.uploadNs.load(std::memory_order_relaxed)) / 1e6;
    board->fields = fields_;
    board->fieldsTotal = fieldsTotal_;
    board_.store(std::move(board));
    return stats;
}

EngineMetrics MetricsBoard::read() const {
    const std::shared_ptr<const Board> board = board_.load();
    if (!board) return {};
    EngineMetrics m = board->figures;
    // The board lists fields [fieldsTotal - size, fieldsTotal); those below fieldsReset_ were
    // finished before the last resetFields().
    const std::vector<FieldStats>& all = *board->fields;
    const uint64_t firstListed = board->fieldsTotal - all.size();
    const uint64_t reset = fieldsReset_.load(std::memory_order_acquire);
    const size_t skip = reset > firstListed ? size_t(std::min<uint64_t>(reset - firstListed, all.size())) : 0;
    m.fields.assign(all.begin() + long(skip), all.end());
    return m;
}

void MetricsBoard::resetFields() {
    // Everything the newest board lists is dropped; a field finished after it (not yet on a
    // board) is kept. Monotonic, so concurrent resets keep the later mark.
    const std::shared_ptr<const Board> board = board_.load();
    const uint64_t mark = board ? board->fieldsTotal : 0;
    uint64_t cur = fieldsReset_.load(std::memory_order_relaxed);
    while (cur < mark && !fieldsReset_.compare_exchange_weak(cur, mark, std::memory_order_release)) {
    }
}

} // namespace iris::metrics
