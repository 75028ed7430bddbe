#include "metrics/field_metrics.h"

#include <algorithm>
#include <utility>

namespace iris::metrics {

bool isNewField(const View& a, const View& b, double w, double h) {
    const double ax0 = a.centerX - w / 2 * a.downsample, ax1 = a.centerX + w / 2 * a.downsample;
    const double ay0 = a.centerY - h / 2 * a.downsample, ay1 = a.centerY + h / 2 * a.downsample;
    const double bx0 = b.centerX - w / 2 * b.downsample, bx1 = b.centerX + w / 2 * b.downsample;
    const double by0 = b.centerY - h / 2 * b.downsample, by1 = b.centerY + h / 2 * b.downsample;
    const double eps = 1e-3 * std::max(a.downsample, b.downsample);
    const bool overlap = ax0 + eps < bx1 && bx0 + eps < ax1 && ay0 + eps < by1 && by0 + eps < ay1;
    return !overlap;
}

void MetricsBoard::finishField(bool superseded) {
    if (!field_.active) return;
    if (superseded) field_.stats.hrTeFovMs = -1;
    unpublished_.push_back(field_.stats);
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
    // The first frame of a new field already whole: every tile of it was resident when the
    // view moved there (a revisit), so there is nothing to time.
    const bool whole = p.hrComplete && (!p.hasLr || p.lrComplete);
    if (std::exchange(field_.firstFrame, false) && whole) {
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

void MetricsBoard::publish(const FrameStats& stats) {
    // Never wait for a reader: a busy lock leaves the figures (and the finished fields, kept in
    // unpublished_) for the next frame.
    std::unique_lock lock(mutex_, std::try_to_lock);
    if (!lock.owns_lock()) return;
    published_.frames = stats.serial;
    published_.lastFrame = stats;
    published_.tilesBuffered = counters_.tiles.load(std::memory_order_relaxed);
    published_.bytesBuffered = counters_.bytes.load(std::memory_order_relaxed);
    published_.mipGpuMs = double(counters_.mipNs.load(std::memory_order_relaxed)) / 1e6;
    published_.mipTiles = counters_.mipTiles.load(std::memory_order_relaxed);
    for (FieldStats& fs : unpublished_) published_.fields.push_back(fs);
    unpublished_.clear();
    constexpr size_t kKeep = 4096;
    if (published_.fields.size() > kKeep)
        published_.fields.erase(published_.fields.begin(), published_.fields.end() - long(kKeep));
}

EngineMetrics MetricsBoard::read() const {
    std::lock_guard lock(mutex_);
    return published_;
}

void MetricsBoard::resetFields() {
    std::lock_guard lock(mutex_);
    published_.fields.clear();
}

} // namespace iris::metrics
