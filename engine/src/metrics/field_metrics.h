// Iris View engine — metrics: field-of-view timing and the figures the API reads.
//
//   isNewField()   (API threads, with the view change) whether a move leaves no pixel of the
//                  old field on screen: such a move starts a timed field (Snapshot::fieldId,
//                  fieldStart, fieldTilesAtStart);
//   MetricsBoard   (render thread) follows each frame's progress on the current field —
//                  TeFOV-LR when every visible LR tile is resident, TeFOV-HR and TPT when the
//                  frame is complete; a field whose first frame is already complete with
//                  tiles that were all uploaded before the move was resident (a revisit) and
//                  is not timed — and publishes the frame's stats and
//                  the finished fields for the API threads (metrics(), resetMetrics()).
//
//   frameFinished  (render thread) the frame's stats (interval, GPU and CPU time, bytes
//                  buffered since the last frame) made and published with the fields finished.
//
// Publication takes no lock: each frame publishes an immutable board by pointer swap
// (core/published.h); the list of finished fields is shared between boards and copied only
// when a field finishes. resetFields() does not write the board: it records how many fields
// had been finished, and read() leaves those out.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/published.h"
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
    uint64_t newestUpload = 0; // the highest upload sequence number of the LR and HR tiles drawn
    uint32_t newlyShown = 0;   // tiles this frame draws that no frame drew before (TileStage::Shown)
};

class MetricsBoard {
public:
    // `stages` (may be null: no stage times) is summarised into each finished field.
    explicit MetricsBoard(const UploadCounters& counters, const StageLog* stages = nullptr)
        : counters_(counters), stages_(stages) {}

    // --- render thread -------------------------------------------------------------------
    // A frame of `snap` was drawn and showed `p` of its field.
    void frameDrawn(const Snapshot& snap, const FieldProgress& p);
    // Frame `serial` of `snap` was submitted (and presented or read back): makes its stats
    // (`gpuMs`: the GPU time of the last frame whose timestamps have come back, -1 when none)
    // and publishes them with the fields finished since the last frame.
    FrameStats frameFinished(const Snapshot& snap, uint64_t serial, bool complete, uint32_t tilesDrawn, double cpuMs,
                             double gpuMs, uint32_t tilesCopied = 0);

    // --- API threads ---------------------------------------------------------------------
    EngineMetrics read() const;
    void resetFields();

private:
    void finishField(bool superseded);

    const UploadCounters& counters_;
    const StageLog* stages_;
    // Render thread only.
    struct Field {
        bool active = false, lrDone = false, firstFrame = false;
        uint64_t id = 0, tilesAtStart = 0;
        std::chrono::steady_clock::time_point start{};
        FieldStats stats;
    } field_;
    std::chrono::steady_clock::time_point lastFrameTime_{};
    uint64_t lastBytes_ = 0;
    // The fields finished so far (the last kKeepFields), shared by the boards that list them;
    // fieldsTotal_ counts every field ever finished. Render thread only.
    static constexpr size_t kKeepFields = 4096;
    std::shared_ptr<const std::vector<FieldStats>> fields_ = std::make_shared<const std::vector<FieldStats>>();
    uint64_t fieldsTotal_ = 0;

    // What the API threads read: one immutable board per frame.
    struct Board {
        EngineMetrics figures; // all but the fields
        std::shared_ptr<const std::vector<FieldStats>> fields;
        uint64_t fieldsTotal = 0; // fields ever finished when this board was made
    };
    Published<Board> board_;
    // resetFields(): fields numbered below this (counting from 0 in finishing order) are left out.
    std::atomic<uint64_t> fieldsReset_{0};
};

} // namespace iris::metrics
