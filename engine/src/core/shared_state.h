// State shared by the API and the engine threads. API calls publish a new immutable Snapshot
// (slide, view, target size, settings) by pointer swap; engine threads load the current one
// without a lock and work on that.
//
// Wake-ups: every change that another thread may care about (new view, new slide, tile
// decoded, upload completed, target changed) bumps `wake` and notifies. Engine threads read
// `wake` before taking a snapshot and sleep with wake.wait(seen) when they found nothing to
// do, so a change published between snapshot and sleep is never missed.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>

#include "color/color_lut.h"
#include "core/failing_tiles.h"
#include "core/published.h"
#include "core/stage_log.h"
#include "iris/annotations.h"
#include "iris/engine.h"
#include "iris/types.h"
#include "overlay/overlay_settings.h"
#include "slide/slide_source.h"
#include "view/view_model.h"

namespace iris {

struct OpenSlide {
    std::shared_ptr<SlideSource> source;
    SlideInfo info;
    uint32_t generation = 0; // packed into every TileKey of this slide
};

struct Snapshot {
    std::shared_ptr<const OpenSlide> slide;
    Viewport viewport;
    uint64_t viewSerial = 0; // bumped by every view, slide or target change
    bool visible = true;
    std::array<float, 3> background = EngineConfig{}.background; // until create() sets the host's
    bool enhance = true;
    // The colour transform of the open slide (its ICC profile → the display's), baked by the API
    // call that opened the slide or changed the colour settings; null: none (no profile, colour
    // management off, or a profile that could not be used).
    std::shared_ptr<const color::Lut3D> colorLut;
    overlay::OverlaySettings overlays; // which overlays are on, where, the device pixel ratio, the font
    // Annotations drawn over the slide, under the HUD (render/annotation_pass.h): the host's
    // store (each frame takes its newest snapshot), whether they are shown, and the object drawn
    // selected with its vertex handles (0: none).
    std::shared_ptr<const AnnotationStore> annotations;
    bool annotationsVisible = true;
    uint64_t selectedAnnotation = 0;
    // Raster layers (render/layer_pass.h), bottom first; never null. Each change makes a new
    // vector: the render thread keeps the one it drew with while it uploads.
    std::shared_ptr<const std::vector<Engine::LayerEntry>> layers = std::make_shared<const std::vector<Engine::LayerEntry>>();
    // The newest move to an entirely new field of view (0: none being timed). Set by the API
    // call that made the move; the render thread times the field from fieldStart.
    uint64_t fieldId = 0;
    std::chrono::steady_clock::time_point fieldStart{};
    uint64_t fieldTilesAtStart = 0; // uploads completed before the move
};

// Counters the buffer thread bumps as uploads complete (relaxed: statistics only).
struct UploadCounters {
    std::atomic<uint64_t> tiles{0};
    std::atomic<uint64_t> bytes{0};
    std::atomic<uint64_t> mipNs{0};    // GPU time of the mip dispatches (timestamps), or host time (host schedule), summed
    std::atomic<uint64_t> mipTiles{0}; // tiles those dispatches covered
    // Tiles a loader copied into staging (BufferThread::prestage): the time from that copy to
    // the buffer thread taking the tile into a transaction, summed, and the tiles.
    std::atomic<uint64_t> pickupNs{0};
    std::atomic<uint64_t> pickupTiles{0};
    std::atomic<uint64_t> prestageNs{0}; // the loaders' copies into staging, summed, and the tiles copied
    std::atomic<uint64_t> prestageTiles{0};
    // Queue transactions: the time from their submission to the buffer thread seeing them
    // complete, summed, and the transactions.
    std::atomic<uint64_t> uploadNs{0};
    std::atomic<uint64_t> uploadTransactions{0};
};

class SharedState {
public:
    // The current snapshot, copied. The published Snapshot is never written again, and the
    // pointer load()ed keeps it alive while it is copied (core/published.h: readers hold its
    // spin lock only for that pointer's copy, never for the Snapshot's).
    Snapshot snapshot() const { return *current_.load(); }
    // Applies f to a copy of the current snapshot and publishes the copy. Writers (API calls)
    // are serialised by updateMutex_, so no update is lost; f runs under it (keep it short).
    template <class F>
    void update(F&& f) {
        {
            std::lock_guard lock(updateMutex_);
            auto next = std::make_shared<Snapshot>(*current_.load());
            f(*next);
            ++next->viewSerial;
            current_.store(std::move(next));
        }
        bump();
    }
    // release: pairs with the acquire load in waitSeen()/load() of the engine threads, so
    // that whatever was published before the bump is visible to a thread that sees it.
    void bump() {
        wake_.fetch_add(1, std::memory_order_release);
        wake_.notify_all();
    }
    uint64_t wakeValue() const { return wake_.load(std::memory_order_acquire); }
    void waitChange(uint64_t seen) const { wake_.wait(seen, std::memory_order_acquire); }

    std::atomic<bool> stopping{false};

    // The view serial whose whole buffer region (visible tiles and perimeter) the buffer thread
    // has made resident, or as much of it as the atlas can hold: nothing is left to load for
    // that view. The buffer thread stores it (release) and then bumps `wake`; the render thread
    // loads it (acquire) before it drains the hand-over, so a frame of that view drawn after the
    // load shows every tile (Engine::waitForSettled).
    std::atomic<uint64_t> bufferedView{0};

    // When tiles pass each stage of their way to the screen (the loaders, the buffer thread and
    // the render thread stamp it; the metrics summarise it per field). Wait-free, statistics only.
    StageLog tileStages;
    // Tiles of a network slide whose read failed for now (core/failing_tiles.h): listed by the
    // loaders, drawn as the placeholder by the render thread, which the buffer thread uploads.
    FailingTiles failingTiles;

    // First error wins and sticks (until cleared).
    void setError(const Result& r) {
        std::lock_guard lock(errorMutex_);
        if (error_.ok() && !r.ok()) error_ = r;
    }
    // An error that belongs to one slide (a tile that failed to decode): dropped when that
    // slide has been replaced meanwhile, so a loader still finishing a tile of the previous
    // slide cannot stick its error on the new one.
    void setSlideError(uint32_t generation, const Result& r) {
        std::lock_guard lock(errorMutex_);
        if (generation == errorGeneration_ && error_.ok() && !r.ok()) error_ = r;
    }
    Result error() const {
        std::lock_guard lock(errorMutex_);
        return error_;
    }
    void clearError() {
        std::lock_guard lock(errorMutex_);
        error_ = {};
    }
    // The open slide got a new generation (same file, e.g. after an enhancement change): its
    // tile errors keep counting; the error already recorded stays.
    void renumberSlide(uint32_t generation) {
        std::lock_guard lock(errorMutex_);
        errorGeneration_ = generation;
    }
    // Clears the error and makes `generation` the slide whose tile errors count.
    void clearErrorForSlide(uint32_t generation) {
        std::lock_guard lock(errorMutex_);
        error_ = {};
        errorGeneration_ = generation;
    }

private:
    std::mutex updateMutex_; // API writers only; engine threads never take it
    Published<Snapshot> current_{std::make_shared<const Snapshot>()};
    std::atomic<uint64_t> wake_{0};
    mutable std::mutex errorMutex_;
    Result error_;
    uint32_t errorGeneration_ = 0; // the open slide's generation (guarded by errorMutex_)
};

} // namespace iris
