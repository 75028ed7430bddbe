// The render thread: owns the render target (offscreen image or swapchain), the frame
// command buffers and the instance buffers, and the frame's passes (render/frame_pass.h): the
// tiles of the base, LR and HR levels (tiles not yet buffered are simply absent, so coarser
// ones show through), the host's annotations, then the HUD overlays. Per frame: handleSurfaceChanges() (target
// requests, stale swapchains, a window that lags its resize, a lost surface), acquire the
// target image, prepare the passes, record them in one render pass, submit, then present or
// read back, and publish the frame. It renders while something changes and sleeps on the
// shared wake counter otherwise.
#pragma once

#include <array>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "buffer/handover.h"
#include "core/log.h"
#include "core/shared_state.h"
#include "gpu/render_target.h"
#include "gpu/tile_atlas.h"
#include "gpu/tile_pipeline.h"
#include "gpu/vk_handle.h"
#include "metrics/field_metrics.h"
#include "render/annotation_pass.h"
#include "render/frame_pass.h"
#include "render/hud_pass.h"
#include "render/layer_pass.h"
#include "render/host_resolve.h"
#include "render/resolve_pass.h"
#include "render/tile_pass.h"

namespace iris {

class RenderThread {
public:
    RenderThread(SharedState& shared, gpu::Device& device, gpu::TileAtlas& atlas, gpu::TilePipeline& pipeline,
                 Handover& handover, const UploadCounters& counters, const Log& log, const EngineTuning& tuning);
    ~RenderThread();
    Result init();
    // Whether levels drawn exactly are copied where they can be (EngineTuning::exactCopy,
    // resolved against the device by init()): the buffer thread then looks at tiles' opacity.
    bool copiesExact() const { return copyExact_; }
    // The same for a device that is (or is not) a CPU device, before there is a render thread.
    static bool copiesExact(EngineTuning::ExactCopy setting, bool cpuDevice) {
        return setting == EngineTuning::ExactCopy::On || (setting == EngineTuning::ExactCopy::Auto && cpuDevice);
    }
    void start();
    void stop(); // shared.stopping must be set first

    // Target requests from API threads; applied by the render thread on its next pass.
    void requestOffscreen(uint32_t width, uint32_t height, bool readback = true);
    void requestSurface(VkSurfaceKHR surface, uint32_t width, uint32_t height);
    void requestResize(uint32_t width, uint32_t height);
    void unbindSurface(); // waits until the swapchain is gone

    // What a frame leaves for the API threads is published by pointer swap: the render thread
    // never takes a lock to publish it and readers never hold one while they copy it.
    Expected<Frame> lastFrame() const;
    Result waitForFrame(uint64_t viewSerial, std::chrono::milliseconds timeout);
    // Waits for a complete frame of `viewSerial` drawn after the buffer thread finished that
    // view's buffer region (SharedState::bufferedView).
    Result waitForSettled(uint64_t viewSerial, std::chrono::milliseconds timeout);
    void setFrameCallback(std::function<void(const FrameStats&)> cb);
    // Faults the host is told of (Engine::setFaultCallback): a lost device, its recovery, a lost
    // surface. Called on the render thread.
    void setFaultCallback(std::function<void(const Result&)> cb);
    // Device loss: what the engine rebuilds between this thread's release of its own GPU objects
    // and their re-creation (recover()): it parks the buffer thread, recreates the device, the
    // atlas and the shared pipelines, and lets the buffer thread go on. Set before start().
    void setRebuild(std::function<Result()> rebuild) { rebuild_ = std::move(rebuild); }
    uint32_t recoveries() const { return recoveries_.load(std::memory_order_relaxed); }
    bool recovering() const { return recovering_.load(std::memory_order_relaxed); }
    // Metrics: the render thread publishes by pointer swap (metrics/field_metrics.h).
    EngineMetrics metrics() const;
    void resetMetrics();
    // The overlays of the last frame rendered, and the slide source that frame showed (empty
    // when none): a hit test applies the layout only to the slide it was made for.
    OverlayLayout overlayLayout(std::shared_ptr<const SlideSource>* source = nullptr) const;

    static constexpr uint32_t kFramesInFlight = 2;

private:
    static constexpr uint32_t kMaxInstances = 16384;
    struct FrameSlot {
        vk::CommandPool pool;
        VkCommandBuffer cmd = VK_NULL_HANDLE; // freed with pool
        vk::Fence fence;
        vk::Semaphore acquired;
        vk::MappedBuffer instances;
        uint64_t serial = 0;
        std::vector<int> pinned; // atlas slots this frame samples, unpinned after its fence
        bool timed = false;      // timestamps were written for this frame
    };
    enum class TargetKind { None, Offscreen, Surface };
    struct TargetRequest {
        bool pending = false;
        TargetKind kind = TargetKind::None;
        VkSurfaceKHR surface = VK_NULL_HANDLE;
        uint32_t width = 0, height = 0;
        bool resizeOnly = false;
        bool readback = true;
    };

    // The image a frame draws into; image is null when there is none to draw into now (an
    // out-of-date or lost swapchain, an acquire that timed out).
    struct TargetImage {
        VkImage image = VK_NULL_HANDLE;
        VkImageView view = VK_NULL_HANDLE;
        VkFormat format = VK_FORMAT_UNDEFINED;
        VkExtent2D extent{};
        uint32_t index = 0; // swapchain image index
        bool transferDst = false; // can be copied into (the exact copy)
    };
    // What handleSurfaceChanges() leaves the loop to do.
    struct TargetStep {
        bool drawable = false; // a target image can be acquired
        bool redraw = false;   // the target is new or was resized: draw a frame (not paced)
        bool poll = false;     // waiting for the window system, which signals nothing: look again soon
    };

    void run();
    // The GPU objects this thread owns: frame slots, timestamp queries, the passes' buffers and
    // pipelines, the resolve pass. initGpu() makes them on the current device, releaseGpu()
    // waits for the device and destroys them with the target (device loss, then initGpu()).
    Result initGpu();
    void releaseGpu();
    // After a lost device: releases this thread's objects, has the engine rebuild the device
    // and the shared objects (rebuild_), makes its own again and binds the target it had,
    // retrying with a growing pause until it works or the engine stops.
    void recover();
    void reportFault(const Result& r);
    // The one place where the target changes: the host's requests (offscreen, surface, resize,
    // unbind), a stale swapchain (out of date or suboptimal at acquire or present, a resize), a
    // window that has not yet taken the size asked for, and a lost surface.
    TargetStep handleSurfaceChanges();
    void applyTargetRequest();
    Result renderFrame(const Snapshot& snap);
    Expected<TargetImage> acquireTarget(FrameSlot& f);
    // The tile pass's exact copies into `target`, between its two render passes.
    void recordExactCopies(VkCommandBuffer cmd, const TargetImage& target);
    // The offscreen target's format (see the definition).
    VkFormat offscreenFormat() const;
    void recordTargetFinish(VkCommandBuffer cmd, const TargetImage& target); // readback copy or present layout
    Result submitFrame(FrameSlot& f, const TargetImage& target, uint64_t uploadWait);
    Result deliverFrame(FrameSlot& f, const TargetImage& target, const render::FrameContext& frame); // present or read back
    Result waitSlot(FrameSlot& f);
    // `buffered`: SharedState::bufferedView as loaded before the frame drained the hand-over.
    void publishFrame(const Snapshot& snap, bool complete, uint64_t buffered, uint32_t tiles, double cpuMs,
                      const OverlayLayout& overlays);
    Result waitForSerial(const std::atomic<uint64_t>& serial, uint64_t viewSerial, std::chrono::milliseconds timeout,
                         const char* what);
    // Frame pacing (see run()): whether a frame of `snap` drawn now would show
    // the view's HR or LR layer whole for the first time. Such a frame is never delayed.
    bool showsLayerWhole(const Snapshot& snap) const;

    SharedState& shared_;
    gpu::Device& device_;
    gpu::TileAtlas& atlas_;
    gpu::TilePipeline& pipeline_;
    Handover& handover_;
    const UploadCounters& counters_;
    const Log& log_;
    vk::QueryPool timestamps_; // 2 per frame slot; null when the queue has no timestamps
    double timestampPeriodNs_ = 0;
    double lastGpuMs_ = -1;

    // Field-of-view timing and the published figures (metrics/field_metrics.h).
    metrics::MetricsBoard metrics_;

    // EngineConfig::tuning: drawCovered draws coarse tiles even where resident finer tiles
    // cover them (the engine before culling; for A/B measurements and the culling test).
    const EngineTuning tuning_;
    // The frame's passes, in drawing order (render/frame_pass.h): tiles, raster layers (heat
    // maps, label maps), annotations, HUD. Made anew with the device
    // after a loss (initGpu), in place: the HUD pass refers to the tile pass.
    struct Passes {
        Passes(gpu::Device& device, gpu::TilePipeline& pipeline, const Log& log, bool drawCovered,
               std::function<void()> wake)
            : tile(pipeline, drawCovered), layers(device, log, std::move(wake)), annotation(device, log),
              hud(device, log, tile) {}
        render::TilePass tile;
        render::LayerPass layers;
        render::AnnotationPass annotation;
        render::HudPass hud;
        std::array<render::FramePass*, 4> list{&tile, &layers, &annotation, &hud};
    };
    std::optional<Passes> passes_;
    // EngineTuning::TileResolve::Compute: offscreen frames resolve the tiles per pixel in a
    // compute pass instead of the tile pass's quads (null otherwise).
    std::unique_ptr<render::ResolvePass> resolvePass_;
    std::unique_ptr<render::HostResolvePass> hostResolve_; // CPU devices with a host-written atlas
    // Frame pacing: a frame that only adds tiles to the view already drawn waits until
    // kPaceFactor × the last frame's GPU time has passed since the previous one was submitted,
    // unless it shows a layer whole, which it looks at again whenever `wake` moved, at most
    // every paceStep_ (1/16 of the wait, at least kPaceStepMin). On a CPU device drawing takes
    // the cores the loaders decode on: every frame is paced. On a GPU (Pacing::Auto) only a
    // frame of kPaceGpuFrameMs or more (an 8K target: 0.39 ms on an H200) is, as the GPU time
    // it took held back the uploads' mips; cheaper frames drawn back to back measured no
    // such cost. tuning_.pacing overrides (On: every frame, on every device; A/B, tests).
    static constexpr double kPaceFactor = 2.0;
    static constexpr double kPaceGpuFrameMs = 0.25;
    static constexpr std::chrono::microseconds kPaceStepMin{50};
    bool paceFrames_ = true;
    double paceMinGpuMs_ = 0.0; // frames that cost less GPU time than this are not paced
    std::chrono::steady_clock::duration paceStep_ = kPaceStepMin;
    bool copyExact_ = false; // EngineTuning::exactCopy, resolved for this device
    uint64_t drawnViewSerial_ = UINT64_MAX;   // the view of the last frame drawn
    uint64_t lrWholeViewSerial_ = UINT64_MAX; // the view whose LR layer a frame has shown whole
    std::chrono::steady_clock::time_point paceUntil_{};

    std::array<FrameSlot, kFramesInFlight> frames_{};
    uint64_t serial_ = 0;

    // Render-thread-only target state.
    TargetKind kind_ = TargetKind::None;
    std::unique_ptr<gpu::OffscreenTarget> offscreen_;
    std::unique_ptr<gpu::Swapchain> swapchain_;
    VkSurfaceKHR surface_ = VK_NULL_HANDLE;
    enum class SurfacePhase {
        Current,          // the swapchain matches the window
        Stale,            // recreate it before the next frame
        WaitingForWindow, // made at another size than asked for: frames are drawn, none complete
        Lost,             // VK_ERROR_SURFACE_LOST_KHR: nothing is drawn until a new surface is bound
    };
    SurfacePhase surfacePhase_ = SurfacePhase::Current;
    // How long a swapchain of the wrong size waits for the window to follow its resize, and how
    // often the surface's size is looked at meanwhile. Set when the wait starts; a new request
    // clears it.
    static constexpr std::chrono::milliseconds kWindowPatience{2000};
    static constexpr std::chrono::milliseconds kWindowPoll{5};
    std::optional<std::chrono::steady_clock::time_point> windowGiveUp_;
    bool readback_ = true;
    uint32_t reqWidth_ = 0, reqHeight_ = 0;

    // Target requests in, guarded by mutex_. The render thread looks at requestPending_ and
    // takes the lock only when it is set.
    mutable std::mutex mutex_;
    std::condition_variable cv_; // unbindDone_, and completeViewSerial_ for waitForFrame
    TargetRequest request_;
    std::atomic<bool> requestPending_{false};
    bool unbindDone_ = true;

    // Frames out, each published whole by a pointer swap (core/published.h): a reader gets one
    // frame's pixels, view and overlays together, never parts of two, and keeps them alive
    // while it copies them (the swap's spin lock covers one pointer copy, never the frame's).
    struct Shown {
        OverlayLayout overlays;                 // of the last frame, either kind of target
        std::weak_ptr<const SlideSource> slide; // the slide that frame showed
    };
    Published<Frame> lastFrame_; // the last offscreen read-back; null: none
    Published<Shown> shown_;
    Published<std::function<void(const FrameStats&)>> callback_;
    // The newest view serial a complete frame showed. Written by the render thread only;
    // waitForFrame sleeps on cv_. The render thread takes mutex_ (to close the window between
    // a waiter's check and its sleep) only while frameWaiters_ says someone sleeps: the
    // waiter's increment and the render thread's store are seq_cst, so one sees the other.
    std::atomic<uint64_t> completeViewSerial_{0};
    std::atomic<uint64_t> settledViewSerial_{0}; // the same for settled frames (waitForSettled)
    std::atomic<int> frameWaiters_{0};

    // Device loss (recover()).
    std::function<Result()> rebuild_;
    Published<std::function<void(const Result&)>> faultCallback_;
    std::atomic<uint32_t> recoveries_{0};
    std::atomic<bool> recovering_{false};

    std::thread thread_;
};

} // namespace iris
