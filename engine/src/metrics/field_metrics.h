// Iris View engine — metrics: field-of-view timing and the figures the API reads.
//
//   isNewField()   (API threads, with the view change) whether a move leaves no pixel of the
//                  old field on screen: such a move starts a timed field (Snapshot::fieldId,
//                  fieldStart, fieldTilesAtStart);
//   MetricsBoard   (render thread) follows each frame's progress on the current field —
//                  TeFOV-LR when every visible LR tile is resident, TeFOV-HR and TPT when the
//                  frame is complete; a field whose first frame is already complete was
//                  resident (a revisit) and is not timed — and publishes the frame's stats and
//                  the finished fields for the API threads (metrics(), resetMetrics()).
//
// Publication never waits on a reader: the render thread try_locks the board and, when a
// reader holds it, keeps its figures for the next frame. Readers hold the lock only to copy.
#pragma once

#include <chrono>
#include <cstdint>
#include <mutex>
#include <vector>

#include "core/shared_state.h"
#include "iris/types.h"

namespace iris::metrics {

// Whether the fields of `before` and `after` (one target of width × height pixels) share no
// pixel. Fields that only touch (a walk of adjacent fields) share none, also when their edges,
// computed from different centres, differ by a rounding error: overlaps below a thousandth of
// a target pixel do not count.
bool isNewField(const View& before, const View& after, double width, double height);

// What a frame showed of its view's field (the draw list's verdict).
struct FieldProgress {
    bool hasLr = false, lrComplete = false, hrComplete = false;
    uint32_t lrTiles = 0, hrTiles = 0;
};

class MetricsBoard {
public:
    explicit MetricsBoard(const UploadCounters& counters) : counters_(counters) {}

    // --- render thread -------------------------------------------------------------------
    // A frame of `snap` was drawn and showed `p` of its field.
    void frameDrawn(const Snapshot& snap, const FieldProgress& p);
    // The frame's stats, with the fields finished since the last publication.
    void publish(const FrameStats& stats);

    // --- API threads ---------------------------------------------------------------------
    EngineMetrics read() const;
    void resetFields();

private:
    void finishField(bool superseded);

    const UploadCounters& counters_;
    // Render thread only.
    struct Field {
        bool active = false, lrDone = false, firstFrame = false;
        uint64_t id = 0, tilesAtStart = 0;
        std::chrono::steady_clock::time_point start{};
        FieldStats stats;
    } field_;
    std::vector<FieldStats> unpublished_;
    // The published figures.
    mutable std::mutex mutex_;
    EngineMetrics published_;
};

} // namespace iris::metrics
