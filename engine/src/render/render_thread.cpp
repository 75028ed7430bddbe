#include "render/render_thread.h"

#include <cmath>
#include <algorithm>
#include <cstring>
#include <vector>

#include "core/pixels.h"
#include "core/thread_name.h"

namespace iris {

using Clock = std::chrono::steady_clock;

namespace {
// A clear value that lands on the intended byte whether the device rounds or truncates when it
// converts float to UNORM8 (lavapipe rounds, other drivers may not): k/255 plus a quarter step.
float clearUnorm(float v) {
    const float k = std::round(std::clamp(v, 0.0f, 1.0f) * 255.0f);
    return std::min(1.0f, (k + 0.25f) / 255.0f);
}

// The draw list's view of the GPU tile map: a pin holds the slot for frame `serial` and is
// recorded in the frame slot's list, released after the frame's fence.
class FramePins final : public render::TileResidency {
public:
    FramePins(TileMap& map, uint64_t serial, std::vector<int>* pinned)
        : map_(map), serial_(serial), pinned_(pinned) {}
    int pin(uint64_t key) override {
        const int slot = pinned_ ? map_.pin(key, serial_) : -1;
        if (slot >= 0) pinned_->push_back(slot);
        return slot;
    }
    bool isActive(uint64_t key) const override { return map_.statusOf(key) == TileMap::Status::Active; }
    uint64_t uploadSeq(int layer) const override { return map_.uploadSeqOf(layer); }
    bool opaque(int layer) const override { return map_.opaqueOf(layer); }
    bool mipsReady(int layer) const override { return map_.mipsReadyOf(layer); }

private:
    TileMap& map_;
    uint64_t serial_;
    std::vector<int>* pinned_; // null: lookups only
};
} // namespace

RenderThread::RenderThread(SharedState& shared, gpu::Device& device, gpu::TileAtlas& atlas, gpu::TilePipeline& pipeline,
                           Handover& handover, const UploadCounters& counters, const Log& log,
                           const EngineTuning& tuning)
    : shared_(shared), device_(device), atlas_(atlas), pipeline_(pipeline), handover_(handover), counters_(counters),
      log_(log), metrics_(counters, &shared.tileStages), tuning_(tuning) {
    if (tuning_.drawCovered) log_.info("draw covered: coarse tiles are drawn also under resident finer tiles");
}

RenderThread::~RenderThread() {
    stop();
    releaseGpu();
}

// The GPU finishes every frame before anything it uses goes: the targets, the frame slots'
// objects, the passes and the timestamp queries. Pins are dropped with the frames (the atlas's
// tile map is still the one they were taken in: releaseGpu() runs before the atlas goes).
void RenderThread::releaseGpu() {
    if (!device_.device()) return;
    if (Result r = device_.waitIdle(); !r.ok() && !device_.lost()) log_.error(r.message()); // going away regardless
    swapchain_.reset();
    offscreen_.reset();
    if (atlas_.slotCount()) {
        for (FrameSlot& f : frames_)
            for (int s : f.pinned) atlas_.map().unpin(s);
    }
    for (FrameSlot& f : frames_) f = FrameSlot{};
    resolvePass_.reset();
    hostResolve_.reset();
    passes_.reset();
    timestamps_ = {};
}

VkFormat RenderThread::offscreenFormat() const {
    // The atlas's, so that the exact copy can go into it; RGBA where a compute shader writes it
    // (the per-pixel resolve's rgba8 image).
    return resolvePass_ ? VK_FORMAT_R8G8B8A8_UNORM : atlas_.format();
}

Result RenderThread::init() {
    switch (tuning_.pacing) {
    case EngineTuning::Pacing::Auto:
        // On a GPU, only frames that cost enough to hold back uploads and mips (BENCHMARKS.md,
        // "Frame pacing on GPUs for large targets").
        paceFrames_ = true;
        paceMinGpuMs_ = device_.properties().deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU ? 0.0 : kPaceGpuFrameMs;
        break;
    case EngineTuning::Pacing::On: paceFrames_ = true; break;
    case EngineTuning::Pacing::Off: paceFrames_ = false; break;
    }
    log_.info(std::string("frame pacing: ") +
              (!paceFrames_ ? "off" : paceMinGpuMs_ > 0 ? "frames of 0.25 ms of GPU time or more" : "on"));
    copyExact_ = copiesExact(tuning_.exactCopy, device_.properties().deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU);
    log_.info(std::string("exact copy: ") + (copyExact_ ? "on" : "off"));
    if (Result r = initGpu(); !r.ok()) return r;
    log_.info(resolvePass_   ? "tile resolve: compute (offscreen targets; a swapchain draws quads)"
              : hostResolve_ ? "tile resolve: quads, and filtered views on the host"
                             : "tile resolve: quads");
    return {};
}

Result RenderThread::initGpu() {
    VkDevice dev = device_.device();
    passes_.emplace(device_, pipeline_, log_, tuning_.drawCovered, [this] { shared_.bump(); });
    if (Result r = passes_->layers.init(kFramesInFlight); !r.ok()) return r;
    if (Result r = passes_->annotation.init(kFramesInFlight); !r.ok()) return r;
    if (Result r = passes_->hud.init(kFramesInFlight); !r.ok()) return r;
    const bool cpuDevice = device_.properties().deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
    if (tuning_.tileResolve == EngineTuning::TileResolve::Compute ||
        (tuning_.tileResolve == EngineTuning::TileResolve::Auto && !cpuDevice)) {
        resolvePass_ = std::make_unique<render::ResolvePass>(device_, atlas_, pipeline_);
        if (Result r = resolvePass_->init(kFramesInFlight); !r.ok()) return r;
    } else if (tuning_.tileResolve == EngineTuning::TileResolve::Auto && cpuDevice && atlas_.hostWritten()) {
        // The atlas's texels are in mapped memory: filtered views, settled or loading, are
        // resolved on the host (render/host_resolve.h), which llvmpipe's fragment path is slower at.
        hostResolve_ = std::make_unique<render::HostResolvePass>(device_, atlas_, log_);
        if (Result r = hostResolve_->init(kFramesInFlight); !r.ok()) return r;
    }
    if (Result r = vk::createTimestampPool(device_.physical(), dev, device_.queueFamily(), 2 * kFramesInFlight,
                                           *timestamps_.replace(dev), timestampPeriodNs_);
        !r.ok())
        return r;
    for (FrameSlot& f : frames_) {
        const VkCommandPoolCreateInfo pci{.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
                                          .pNext = nullptr,
                                          .flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT,
                                          .queueFamilyIndex = device_.queueFamily()};
        IRIS_VK_TRY(vkCreateCommandPool(dev, &pci, nullptr, f.pool.replace(dev)));
        const VkCommandBufferAllocateInfo cai{.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
                                              .pNext = nullptr,
                                              .commandPool = f.pool.get(),
                                              .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
                                              .commandBufferCount = 1};
        IRIS_VK_TRY(vkAllocateCommandBuffers(dev, &cai, &f.cmd));
        const VkFenceCreateInfo fci{.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO, .pNext = nullptr, .flags = VK_FENCE_CREATE_SIGNALED_BIT};
        IRIS_VK_TRY(vkCreateFence(dev, &fci, nullptr, f.fence.replace(dev)));
        const VkSemaphoreCreateInfo sci{.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO, .pNext = nullptr, .flags = 0};
        IRIS_VK_TRY(vkCreateSemaphore(dev, &sci, nullptr, f.acquired.replace(dev)));
        if (Result r = vk::createMappedBuffer(device_.physical(), dev, sizeof(gpu::TileInstance) * kMaxInstances,
                                              VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, false, f.instances);
            !r.ok())
            return r;
    }
    return {};
}

void RenderThread::start() {
    thread_ = std::thread([this] {
        nameThisThread("iris-render");
        run();
    });
}

void RenderThread::stop() {
    if (thread_.joinable()) thread_.join();
    std::lock_guard lock(mutex_);
    unbindDone_ = true;
    cv_.notify_all();
}

void RenderThread::requestOffscreen(uint32_t width, uint32_t height, bool readback) {
    {
        std::lock_guard lock(mutex_);
        request_ = TargetRequest{true, TargetKind::Offscreen, VK_NULL_HANDLE, width, height, false, readback};
        requestPending_.store(true, std::memory_order_release);
        lastFrame_.store(nullptr);
    }
    shared_.bump();
}

void RenderThread::requestSurface(VkSurfaceKHR surface, uint32_t width, uint32_t height) {
    {
        std::lock_guard lock(mutex_);
        request_ = TargetRequest{true, TargetKind::Surface, surface, width, height, false};
        requestPending_.store(true, std::memory_order_release);
        lastFrame_.store(nullptr);
    }
    shared_.bump();
}

void RenderThread::requestResize(uint32_t width, uint32_t height) {
    {
        std::lock_guard lock(mutex_);
        if (request_.pending && !request_.resizeOnly) {
            request_.width = width; // a bind not yet applied takes the new size
            request_.height = height;
        } else {
            request_ = TargetRequest{true, TargetKind::None, VK_NULL_HANDLE, width, height, true};
        }
        requestPending_.store(true, std::memory_order_release);
    }
    shared_.bump();
}

void RenderThread::unbindSurface() {
    std::unique_lock lock(mutex_);
    if (!thread_.joinable()) return;
    request_ = TargetRequest{true, TargetKind::None, VK_NULL_HANDLE, 0, 0, false};
    requestPending_.store(true, std::memory_order_release);
    unbindDone_ = false;
    lock.unlock();
    shared_.bump();
    lock.lock();
    // Bounded: a render thread stuck in the driver must not hang the host's window teardown.
    if (!cv_.wait_for(lock, std::chrono::seconds(10), [&] { return unbindDone_; })) {
        log_.error("unbindSurface: the render thread did not release the swapchain within 10 s");
    }
}

void RenderThread::setFrameCallback(std::function<void(const FrameStats&)> cb) {
    callback_.store(cb ? std::make_shared<const std::function<void(const FrameStats&)>>(std::move(cb)) : nullptr);
}

Expected<Frame> RenderThread::lastFrame() const {
    const std::shared_ptr<const Frame> frame = lastFrame_.load();
    if (!frame) return Result(Status::NotBound, "No frame has been rendered into an offscreen target yet");
    return *frame; // copied outside any lock; the render thread has moved on to a new Frame
}

Result RenderThread::waitForFrame(uint64_t viewSerial, std::chrono::milliseconds timeout) {
    return waitForSerial(completeViewSerial_, viewSerial, timeout, "complete frame");
}

Result RenderThread::waitForSettled(uint64_t viewSerial, std::chrono::milliseconds timeout) {
    return waitForSerial(settledViewSerial_, viewSerial, timeout, "settled frame (every tile of the buffer region resident)");
}

Result RenderThread::waitForSerial(const std::atomic<uint64_t>& serial, uint64_t viewSerial,
                                   std::chrono::milliseconds timeout, const char* what) {
    std::unique_lock lock(mutex_);
    frameWaiters_.fetch_add(1, std::memory_order_seq_cst);
    const bool ok = cv_.wait_for(lock, timeout, [&] {
        return serial.load(std::memory_order_seq_cst) >= viewSerial || shared_.stopping.load(std::memory_order_acquire);
    });
    frameWaiters_.fetch_sub(1, std::memory_order_relaxed);
    if (!ok)
        return Result(Status::Timeout,
                      std::string("No ") + what + " of the current view within " + std::to_string(timeout.count()) + " ms");
    return {};
}

void RenderThread::applyTargetRequest() {
    if (!requestPending_.load(std::memory_order_acquire)) return; // no lock unless there is a request
    TargetRequest req;
    {
        std::lock_guard lock(mutex_);
        if (!request_.pending) return;
        req = request_;
        request_.pending = false;
        requestPending_.store(false, std::memory_order_relaxed);
    }
    windowGiveUp_.reset(); // a new size: its own patience
    if (!req.resizeOnly && req.kind == TargetKind::Offscreen) readback_ = req.readback;
    if (req.resizeOnly) {
        reqWidth_ = req.width;
        reqHeight_ = req.height;
        if (kind_ == TargetKind::Offscreen) {
            req.kind = TargetKind::Offscreen;
        } else if (kind_ == TargetKind::Surface) {
            if (surfacePhase_ != SurfacePhase::Lost) surfacePhase_ = SurfacePhase::Stale;
            return;
        } else {
            return;
        }
    }
    // Whatever the request, the old target goes first (after the GPU is done with it).
    if (Result r = device_.waitIdle(); !r.ok()) shared_.setError(r);
    for (FrameSlot& f : frames_)
        if (Result r = waitSlot(f); !r.ok()) shared_.setError(r); // a lost device: the first error sticks
    offscreen_.reset();
    if (req.kind != TargetKind::Surface || req.surface != surface_) swapchain_.reset();
    kind_ = req.kind;
    reqWidth_ = req.width;
    reqHeight_ = req.height;
    if (kind_ == TargetKind::Offscreen) {
        offscreen_ = std::make_unique<gpu::OffscreenTarget>(device_, offscreenFormat());
        if (Result r = offscreen_->init(req.width, req.height, resolvePass_ != nullptr); !r.ok()) {
            shared_.setError(r);
            log_.error("offscreen target: " + r.message());
            offscreen_.reset();
            kind_ = TargetKind::None;
        }
    } else if (kind_ == TargetKind::Surface) {
        surface_ = req.surface;
        if (!swapchain_) swapchain_ = std::make_unique<gpu::Swapchain>(device_, surface_);
        surfacePhase_ = SurfacePhase::Stale;
    } else {
        surface_ = VK_NULL_HANDLE;
        std::lock_guard lock(mutex_);
        unbindDone_ = true;
        cv_.notify_all();
    }
}

RenderThread::TargetStep RenderThread::handleSurfaceChanges() {
    applyTargetRequest();
    TargetStep step;
    if (kind_ == TargetKind::Surface && swapchain_) {
        if (surfacePhase_ == SurfacePhase::WaitingForWindow) {
            const VkExtent2D e = swapchain_->surfaceExtent();
            if (e.width == reqWidth_ && e.height == reqHeight_) {
                surfacePhase_ = SurfacePhase::Stale; // the window has its new size now
            } else if (windowGiveUp_ && Clock::now() >= *windowGiveUp_) {
                const VkExtent2D s = swapchain_->extent();
                log_.warn("the window is " + std::to_string(s.width) + "x" + std::to_string(s.height) + " pixels, not the " +
                          std::to_string(reqWidth_) + "x" + std::to_string(reqHeight_) +
                          " the host asked for; drawing at its size");
                surfacePhase_ = SurfacePhase::Current;
                step.redraw = true; // a frame at this size is complete now
            } else {
                step.poll = true;
            }
        }
        if (surfacePhase_ == SurfacePhase::Stale) {
            step.redraw = true; // a new swapchain needs a frame, and that frame is not paced
            if (Result r = swapchain_->recreate(reqWidth_, reqHeight_); !r.ok()) {
                shared_.setError(r);
                log_.error("swapchain: " + r.message());
            }
            surfacePhase_ = SurfacePhase::Current;
            // Made at another size than the host asked for: the window system has not applied
            // the window's resize yet (X11 reports the window's size at that moment, and a
            // software WSI may never say that the swapchain went stale). Frames are drawn but
            // none is complete until the surface reports the asked-for size (polled, then
            // recreated) or kWindowPatience has passed.
            const VkExtent2D e = swapchain_->extent();
            if (swapchain_->valid() && reqWidth_ && reqHeight_ && (e.width != reqWidth_ || e.height != reqHeight_)) {
                if (!windowGiveUp_) {
                    windowGiveUp_ = Clock::now() + kWindowPatience;
                    log_.info("swapchain made at " + std::to_string(e.width) + "x" + std::to_string(e.height) +
                              ", the host asked for " + std::to_string(reqWidth_) + "x" + std::to_string(reqHeight_) +
                              ": waiting for the window to follow");
                }
                if (Clock::now() < *windowGiveUp_) {
                    surfacePhase_ = SurfacePhase::WaitingForWindow;
                    step.poll = true;
                } else {
                    log_.warn("the window is " + std::to_string(e.width) + "x" + std::to_string(e.height) +
                              " pixels, not the " + std::to_string(reqWidth_) + "x" + std::to_string(reqHeight_) +
                              " the host asked for; drawing at its size");
                }
            }
        }
        if (surfacePhase_ == SurfacePhase::Lost) {
            // The window system took the surface away (its window is gone or was re-created):
            // nothing can be drawn until the host binds a new one (the widget does when it
            // next shows its window).
            const Result r(Status::SurfaceLost, "the window's Vulkan surface was lost; drawing stops until a new one is bound");
            shared_.setError(r);
            log_.error(r.message());
            reportFault(r);
            if (Result w = device_.waitIdle(); !w.ok()) shared_.setError(w);
            swapchain_.reset();
        }
    }
    step.drawable = (kind_ == TargetKind::Offscreen && offscreen_) ||
                    (kind_ == TargetKind::Surface && swapchain_ && swapchain_->valid());
    return step;
}

void RenderThread::run() {
    uint64_t renderedWake = 0;
    bool rendered = false; // renderedWake is the wake value of the last frame drawn
    while (!shared_.stopping.load(std::memory_order_acquire)) {
        if (device_.lost()) {
            recover();
            rendered = false; // the recreated target needs a frame
            drawnViewSerial_ = UINT64_MAX;
            continue;
        }
        const uint64_t seen = shared_.wakeValue();
        const TargetStep step = handleSurfaceChanges();
        if (step.redraw) {
            rendered = false;                 // a new or resized target needs a frame
            drawnViewSerial_ = UINT64_MAX;    // which is not paced
        }
        const Snapshot snap = shared_.snapshot();
        if (!step.drawable || !snap.visible || (rendered && seen == renderedWake)) {
            if (step.poll) {
                std::this_thread::sleep_for(kWindowPoll); // the window system tells no one: look again
            } else {
                shared_.waitChange(seen);
            }
            continue;
        }
        // Tiles arrive faster than frames are worth drawing. On a CPU device every frame
        // rasterises on the cores the loaders decode on, and drawing each arrival took more of
        // the CPU than the decoding; on a GPU, frames of a large target drawn back to back took
        // the GPU from the mip pass of the very tiles they waited for. A frame that would only
        // add some tiles to the view already on screen waits for its turn (a new view, target
        // or setting is drawn at once, as is the frame that shows a layer whole). Meanwhile
        // it looks again whenever something happened (a tile arrived: perhaps the one that
        // makes a layer whole), at most every paceStep_.
        if (paceFrames_ && snap.viewSerial == drawnViewSerial_ && Clock::now() < paceUntil_ && !showsLayerWhole(snap)) {
            const auto until = std::min(paceUntil_, Clock::now() + std::chrono::milliseconds(4));
            while (Clock::now() < until && shared_.wakeValue() == seen &&
                   !shared_.stopping.load(std::memory_order_acquire))
                std::this_thread::sleep_for(std::min<Clock::duration>(paceStep_, until - Clock::now()));
            continue;
        }
        if (Result r = renderFrame(snap); !r.ok()) {
            if (r.status() == Status::DeviceLost) {
                device_.reportLost(r.message().c_str()); // a wait or an acquire saw it: the loop recovers
                continue;
            }
            shared_.setError(r);
            log_.error("render: " + r.message());
        }
        renderedWake = seen;
        rendered = true;
        drawnViewSerial_ = snap.viewSerial;
        if (paceFrames_ && lastGpuMs_ > 0 && lastGpuMs_ >= paceMinGpuMs_) {
            const auto turn = std::chrono::duration_cast<Clock::duration>(
                std::chrono::duration<double, std::milli>(kPaceFactor * lastGpuMs_));
            paceUntil_ = Clock::now() + turn;
            paceStep_ = std::max<Clock::duration>(turn / 16, kPaceStepMin);
        }
    }
}

void RenderThread::reportFault(const Result& r) {
    if (const auto cb = faultCallback_.load(); cb && *cb) (*cb)(r);
}

void RenderThread::setFaultCallback(std::function<void(const Result&)> cb) {
    faultCallback_.store(cb ? std::make_shared<const std::function<void(const Result&)>>(std::move(cb)) : nullptr);
}

void RenderThread::recover() {
    recovering_.store(true, std::memory_order_relaxed);
    const Result lost(Status::DeviceLost, "The GPU device was lost; the engine is recreating it and will draw the view again");
    shared_.setError(lost);
    log_.error(lost.message());
    reportFault(lost);
    const auto t0 = Clock::now();
    auto pause = std::chrono::milliseconds(50);
    for (int attempt = 1; !shared_.stopping.load(std::memory_order_acquire); ++attempt) {
        releaseGpu();
        Result r = rebuild_ ? rebuild_() : Result(Status::DeviceLost, "no way to rebuild the device");
        if (r.ok()) r = initGpu();
        if (r.ok()) {
            // The target it had, on the new device: the same offscreen size, or a new swapchain
            // on the same surface (one the window system took away stays lost).
            if (kind_ == TargetKind::Offscreen) {
                offscreen_ = std::make_unique<gpu::OffscreenTarget>(device_, offscreenFormat());
                r = offscreen_->init(reqWidth_, reqHeight_, resolvePass_ != nullptr);
                if (!r.ok()) offscreen_.reset();
            } else if (kind_ == TargetKind::Surface && surfacePhase_ != SurfacePhase::Lost) {
                swapchain_ = std::make_unique<gpu::Swapchain>(device_, surface_);
                surfacePhase_ = SurfacePhase::Stale;
            }
        }
        if (r.ok() && !device_.lost()) {
            serial_ = 0;
            lastGpuMs_ = -1;
            lrWholeViewSerial_ = UINT64_MAX;
            const uint32_t n = recoveries_.fetch_add(1, std::memory_order_relaxed) + 1;
            const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
            const Result back(Status::Ok, "The GPU device was recreated after a loss (" + std::to_string(n) +
                                               (n == 1 ? " recovery" : " recoveries") + " so far, this one took " +
                                               std::to_string(int(std::lround(ms))) + " ms); the view is being re-buffered");
            log_.warn(back.message());
            recovering_.store(false, std::memory_order_relaxed);
            reportFault(back);
            shared_.bump();
            return;
        }
        log_.error("device recovery, attempt " + std::to_string(attempt) + ": " +
                   (r.ok() ? std::string("the new device was lost too") : r.message()) + "; trying again in " +
                   std::to_string(pause.count()) + " ms");
        // Polled: nothing announces that a device has come back.
        for (const auto until = Clock::now() + pause;
             Clock::now() < until && !shared_.stopping.load(std::memory_order_acquire);)
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        pause = std::min(pause * 2, std::chrono::milliseconds(5000));
    }
    recovering_.store(false, std::memory_order_relaxed);
}

bool RenderThread::showsLayerWhole(const Snapshot& snap) const {
    if (!snap.slide) return true;
    const LevelChoice c = chooseLevels(snap.slide->info, snap.viewport.view.downsample);
    // completeViewSerial_ is written only by this thread (under mutex_, for the API's readers).
    const FramePins lookup(atlas_.map(), 0, nullptr);
    const auto whole = [&](int level) {
        return render::allResident(snap.slide->info, snap.slide->generation, level, snap.viewport, lookup);
    };
    return (completeViewSerial_ < snap.viewSerial && whole(c.hr)) ||
           (c.lr >= 0 && lrWholeViewSerial_ != snap.viewSerial && whole(c.lr));
}

Result RenderThread::waitSlot(FrameSlot& f) {
    if (!f.fence) return Result(Status::DeviceLost, "frame slot without a fence (a submit failed and so did its replacement)");
    IRIS_VK_TRY(device_.waitFence(f.fence.get()));
    if (f.timed) {
        uint64_t t[2] = {0, 0};
        const size_t idx = size_t(&f - frames_.data());
        if (vkGetQueryPoolResults(device_.device(), timestamps_.get(), uint32_t(idx * 2), 2, sizeof(t), t,
                                  sizeof(uint64_t), VK_QUERY_RESULT_64_BIT) == VK_SUCCESS &&
            t[1] >= t[0]) {
            lastGpuMs_ = double(t[1] - t[0]) * timestampPeriodNs_ / 1e6;
        }
        f.timed = false;
    }
    // The GPU is done with this frame: its slots may be reclaimed.
    TileMap& map = atlas_.map();
    for (int s : f.pinned) map.unpin(s);
    f.pinned.clear();
    return {};
}

Expected<RenderThread::TargetImage> RenderThread::acquireTarget(FrameSlot& f) {
    if (kind_ == TargetKind::Offscreen)
        return TargetImage{offscreen_->image(), offscreen_->view(), offscreen_->format(), offscreen_->extent(), 0, true};
    uint32_t index = 0;
    const VkResult ar = vkAcquireNextImageKHR(device_.device(), swapchain_->handle(), 100'000'000, f.acquired.get(),
                                              VK_NULL_HANDLE, &index);
    switch (ar) {
    case VK_SUCCESS: break;
    case VK_SUBOPTIMAL_KHR: surfacePhase_ = SurfacePhase::Stale; break; // draw this one, recreate after
    case VK_ERROR_OUT_OF_DATE_KHR:
        surfacePhase_ = SurfacePhase::Stale;
        shared_.bump();
        return TargetImage{};
    case VK_ERROR_SURFACE_LOST_KHR:
        surfacePhase_ = SurfacePhase::Lost;
        shared_.bump();
        return TargetImage{};
    case VK_TIMEOUT:
    case VK_NOT_READY:
        shared_.bump(); // try again on the next pass
        return TargetImage{};
    default: return vk::check(ar, "vkAcquireNextImageKHR");
    }
    return TargetImage{swapchain_->image(index), swapchain_->view(index), swapchain_->format(), swapchain_->extent(), index,
                       swapchain_->transferDst()};
}

Result RenderThread::renderFrame(const Snapshot& snap) {
    const auto t0 = Clock::now();
    FrameSlot& f = frames_[serial_ % kFramesInFlight];
    if (Result r = waitSlot(f); !r.ok()) return r;
    Expected<TargetImage> acquired = acquireTarget(f);
    if (!acquired) return acquired.error();
    const TargetImage target = *acquired;
    if (!target.image) return {}; // nothing to draw into now (handleSurfaceChanges follows up)

    const uint64_t serial = ++serial_;
    f.serial = serial;
    // Before the hand-over is drained: every tile of a view the buffer thread has finished is
    // then either activated already or drained below.
    const uint64_t buffered = shared_.bufferedView.load(std::memory_order_acquire);

    // Tiles whose mips were made on another queue family: record the acquire half of their
    // compute → graphics ownership transfer (the buffer thread recorded the release), wait on
    // the upload timeline value that covered the release, and only then let them be drawn.
    // The per-pixel resolve samples the atlas in a compute shader, the quads in fragment shaders.
    const bool resolve = resolvePass_ && kind_ == TargetKind::Offscreen;
    const VkPipelineStageFlags2 sampleStages =
        VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | (resolve ? VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT : VkPipelineStageFlags2(0)) |
        (copyExact_ ? VK_PIPELINE_STAGE_2_COPY_BIT : VkPipelineStageFlags2(0));
    std::vector<VkImageMemoryBarrier2> acquires;
    uint64_t uploadWait = 0;
    if (handover_.needed) {
        handover_.drain([&](const HandoverItem& h) {
            VkImageMemoryBarrier2 b = vk::imageBarrier(
                atlas_.image(), VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE, sampleStages,
                VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_GENERAL,
                vk::colorRange(0, gpu::kTileMipLevels, uint32_t(h.slot), 1));
            b.srcQueueFamilyIndex = handover_.srcFamily;
            b.dstQueueFamilyIndex = device_.queueFamily();
            acquires.push_back(b);
            uploadWait = std::max(uploadWait, h.uploadValue);
            atlas_.map().activatePinned(h.slot, serial, h.uploadSeq, h.opaque);
            f.pinned.push_back(h.slot); // held until this frame's fence
        });
        if (!acquires.empty()) shared_.tileStages.stamp(TileStage::Drawable, uint32_t(acquires.size()));
    }

    // The passes prepare on the CPU: what each draws, in the frame slot's own buffers.
    FramePins pins(atlas_.map(), serial, &f.pinned);
    // Tiles failing for now, drawn as the placeholder (held for this frame's preparation).
    const std::shared_ptr<const FailingTiles::Set> failing = shared_.failingTiles.load();
    render::InstanceArena instances{static_cast<gpu::TileInstance*>(f.instances.mapped), f.instances.buffer,
                                    kMaxInstances, 0};
    render::FrameContext frame{.snap = snap,
                               .viewport = snap.viewport,
                               .extent = target.extent,
                               .format = target.format,
                               .slot = uint32_t(&f - frames_.data()),
                               .serial = serial,
                               // A frame drawn into a target whose size is not the published one
                               // (a rebind or resize not yet applied; a swapchain made before
                               // the window system resized the window) shows the right view at
                               // the wrong size: it is never complete.
                               .sizeMatches = kind_ == TargetKind::Offscreen
                                                  ? target.extent.width == snap.viewport.width &&
                                                        target.extent.height == snap.viewport.height
                                                  : surfacePhase_ != SurfacePhase::WaitingForWindow,
                               .copyTarget = copyExact_ && !resolve && target.transferDst &&
                                             target.format == atlas_.format(),
                               .tiles = pins,
                               .instances = instances,
                               .failing = failing.get()};
    frame.viewport.width = target.extent.width;
    frame.viewport.height = target.extent.height;
    const auto passFailed = [&](render::FramePass& pass, const Result& r) {
        shared_.setError(r);
        log_.error(std::string(pass.name()) + ": " + r.message());
    };
    // The clear colour: the resolves' background and the render pass's clear value.
    const std::array<float, 4> bg{clearUnorm(snap.background[0]), clearUnorm(snap.background[1]),
                                  clearUnorm(snap.background[2]), 1.0f};
    passes_->tile.setDrawLevels(!resolve);
    for (render::FramePass* pass : passes_->list)
        if (Result r = pass->prepare(frame); !r.ok()) passFailed(*pass, r); // the frame goes on without it
    if (resolve) {
        if (Result r = resolvePass_->prepare(frame, passes_->tile.drawList(), bg, target.view); !r.ok()) return r;
    }
    if (passes_->tile.progress().lrComplete) lrWholeViewSerial_ = snap.viewSerial;
    if (const uint32_t n = passes_->tile.progress().newlyShown) shared_.tileStages.stamp(TileStage::Shown, n);
    metrics_.frameDrawn(snap, passes_->tile.progress());
    // A frame the host resolves (render/host_resolve.h): the tile pass's draw list, which the
    // metrics above read (tiles drawable as this frame saw them, as for the quads, whose
    // drawing follows on the GPU), resolved on the host instead of drawn.
    bool hostResolved = false;
    if (hostResolve_ && !resolve) {
        Expected<bool> h = hostResolve_->prepare(frame, passes_->tile.drawList(), bg, target.transferDst);
        if (!h) log_.warn("tile resolve on the host: " + h.error().message() + "; drawing quads"); // (no buffer)
        hostResolved = h && *h;
        if (hostResolved) passes_->tile.setDrawLevels(false);
    }

    // Recording: uploads, then one render pass with every pass's draws in order.
    VkCommandBuffer cmd = f.cmd;
    IRIS_VK_TRY(vkResetCommandBuffer(cmd, 0));
    const VkCommandBufferBeginInfo bi{.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                      .pNext = nullptr,
                                      .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT,
                                      .pInheritanceInfo = nullptr};
    IRIS_VK_TRY(vkBeginCommandBuffer(cmd, &bi));
    // The frame slot's own pair: waitSlot(f) reads exactly these once f's fence has passed.
    const uint32_t query = uint32_t(&f - frames_.data()) * 2;
    if (timestamps_) {
        vkCmdResetQueryPool(cmd, timestamps_.get(), query, 2);
        vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_TOP_OF_PIPE_BIT, timestamps_.get(), query);
    }
    if (!acquires.empty()) vk::pipelineBarrier(cmd, acquires.data(), uint32_t(acquires.size()));
    for (render::FramePass* pass : passes_->list) pass->recordUploads(cmd, frame);
    if (resolve) {
        // The atlas's tiles (and a new colour table) were written by earlier submissions and
        // commands; the quads' fragment reads are covered by their barriers, a compute read is not.
        vk::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
                          VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                          VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
        resolvePass_->record(cmd, frame, target.image);
    } else if (hostResolved) {
        hostResolve_->record(cmd, frame, target.image);
    } else {
        // Previous contents are discarded (UNDEFINED); the wait on the previous frame's copy
        // (offscreen) or on the acquire semaphore (swapchain) is covered by the source stages.
        const VkImageMemoryBarrier2 toColor = vk::imageBarrier(
            target.image, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_NONE,
            VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
            VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, vk::colorRange(0, 1, 0, 1));
        vk::pipelineBarrier(cmd, &toColor, 1);
    }
    const VkRenderingAttachmentInfo color{
        .sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO,
        .pNext = nullptr,
        .imageView = target.view,
        .imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
        .resolveMode = VK_RESOLVE_MODE_NONE,
        .resolveImageView = VK_NULL_HANDLE,
        .resolveImageLayout = VK_IMAGE_LAYOUT_UNDEFINED,
        .loadOp = resolve || hostResolved ? VK_ATTACHMENT_LOAD_OP_LOAD : VK_ATTACHMENT_LOAD_OP_CLEAR,
        .storeOp = VK_ATTACHMENT_STORE_OP_STORE,
        .clearValue = {.color = {{bg[0], bg[1], bg[2], bg[3]}}},
    };
    const VkRenderingInfo ri{
        .sType = VK_STRUCTURE_TYPE_RENDERING_INFO,
        .pNext = nullptr,
        .flags = 0,
        .renderArea = {{0, 0}, target.extent},
        .layerCount = 1,
        .viewMask = 0,
        .colorAttachmentCount = 1,
        .pColorAttachments = &color,
        .pDepthAttachment = nullptr,
        .pStencilAttachment = nullptr,
    };
    vkCmdBeginRendering(cmd, &ri);
    if (passes_->tile.tilesCopied() > 0) {
        // The exact copy (render/tile_pass.h): the levels still drawn, then the copied tiles
        // over them, then the other passes over both in a second render pass that keeps them.
        if (Result r = passes_->tile.recordDraws(cmd, frame); !r.ok()) passFailed(passes_->tile, r);
        vkCmdEndRendering(cmd);
        recordExactCopies(cmd, target);
        VkRenderingAttachmentInfo keep = color;
        keep.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
        VkRenderingInfo again = ri;
        again.pColorAttachments = &keep;
        vkCmdBeginRendering(cmd, &again);
        for (render::FramePass* pass : passes_->list)
            if (pass != &passes_->tile)
                if (Result r = pass->recordDraws(cmd, frame); !r.ok()) passFailed(*pass, r);
    } else {
        for (render::FramePass* pass : passes_->list)
            if (Result r = pass->recordDraws(cmd, frame); !r.ok()) passFailed(*pass, r);
    }
    vkCmdEndRendering(cmd);
    recordTargetFinish(cmd, target);
    if (timestamps_) vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, timestamps_.get(), query + 1);
    IRIS_VK_TRY(vkEndCommandBuffer(cmd));
    f.timed = bool(timestamps_);

    if (Result r = submitFrame(f, target, uploadWait); !r.ok()) return r;
    if (Result r = deliverFrame(f, target, frame); !r.ok()) return r;
    publishFrame(snap, frame.complete, buffered, passes_->tile.tilesDrawn(),
                 std::chrono::duration<double, std::milli>(Clock::now() - t0).count(), passes_->hud.layout());
    if (frame.redraw) shared_.bump();
    return {};
}

void RenderThread::recordExactCopies(VkCommandBuffer cmd, const TargetImage& target) {
    // The target from drawing to a copy destination; the atlas's tiles, written by earlier
    // uploads (their barriers cover fragment reads, not transfers), to transfer reads.
    const VkImageMemoryBarrier2 toCopy = vk::imageBarrier(
        target.image, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
        VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
        VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, vk::colorRange(0, 1, 0, 1));
    vk::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT,
                      VK_ACCESS_2_TRANSFER_READ_BIT, &toCopy, 1);
    passes_->tile.recordCopies(cmd, atlas_.image(), target.image);
    const VkImageMemoryBarrier2 toColor = vk::imageBarrier(
        target.image, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
        VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
        VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
        VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, vk::colorRange(0, 1, 0, 1));
    vk::pipelineBarrier(cmd, &toColor, 1);
}

void RenderThread::recordTargetFinish(VkCommandBuffer cmd, const TargetImage& target) {
    if (kind_ == TargetKind::Offscreen && readback_) {
        const VkImageMemoryBarrier2 toCopy = vk::imageBarrier(
            target.image, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
            VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
            VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, vk::colorRange(0, 1, 0, 1));
        vk::pipelineBarrier(cmd, &toCopy, 1);
        const VkBufferImageCopy region = vk::wholeImageCopy({target.extent.width, target.extent.height, 1});
        vkCmdCopyImageToBuffer(cmd, target.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, offscreen_->readback().buffer, 1,
                               &region);
        const VkBufferMemoryBarrier2 toHost{
            .sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2,
            .pNext = nullptr,
            .srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT,
            .srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT,
            .dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT,
            .dstAccessMask = VK_ACCESS_2_HOST_READ_BIT,
            .srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
            .dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
            .buffer = offscreen_->readback().buffer,
            .offset = 0,
            .size = VK_WHOLE_SIZE,
        };
        vk::pipelineBarrier(cmd, toHost);
    } else if (kind_ == TargetKind::Surface) {
        const VkImageMemoryBarrier2 toPresent = vk::imageBarrier(
            target.image, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
            VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
            VK_IMAGE_LAYOUT_PRESENT_SRC_KHR, vk::colorRange(0, 1, 0, 1));
        vk::pipelineBarrier(cmd, &toPresent, 1);
    }
}

Result RenderThread::submitFrame(FrameSlot& f, const TargetImage& target, uint64_t uploadWait) {
    VkDevice dev = device_.device();
    const VkFence fence = f.fence.get();
    IRIS_VK_TRY(vkResetFences(dev, 1, &fence));
    const VkCommandBufferSubmitInfo cbi = vk::commandInfo(f.cmd);
    const bool surface = kind_ == TargetKind::Surface;
    VkSemaphoreSubmitInfo waits[2];
    uint32_t waitCount = 0;
    if (surface)
        waits[waitCount++] = vk::semaphoreInfo(f.acquired.get(), 0, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT);
    if (uploadWait)
        waits[waitCount++] = vk::semaphoreInfo(handover_.uploadTimeline, uploadWait,
                                               VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT |
                                                   (resolvePass_ && kind_ == TargetKind::Offscreen
                                                        ? VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT
                                                        : VkPipelineStageFlags2(0)));
    const VkSemaphoreSubmitInfo sigDone = vk::semaphoreInfo(
        surface ? swapchain_->renderDone(target.index) : VK_NULL_HANDLE, 0, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT);
    const VkSubmitInfo2 si = vk::submitInfo(&cbi, waits, waitCount, &sigDone, surface ? 1u : 0u);
    const VkResult sr = device_.submit(si, fence);
    if (sr == VK_SUCCESS) return {};
    // The fence was reset but nothing will signal it: replace it with a signalled one so the
    // next use of this frame slot does not wait forever. Should even that fail (the device is
    // gone), the slot has no fence and waitSlot reports the loss instead.
    f.fence.reset();
    const VkFenceCreateInfo fci{.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO, .pNext = nullptr, .flags = VK_FENCE_CREATE_SIGNALED_BIT};
    VkFence replacement = VK_NULL_HANDLE;
    if (const VkResult fr = vkCreateFence(dev, &fci, nullptr, &replacement); fr == VK_SUCCESS)
        f.fence = vk::Fence(dev, replacement);
    else
        log_.error("vkCreateFence after a failed frame submit: " + vk::check(fr, "vkCreateFence").message());
    return vk::check(sr, "vkQueueSubmit2 (frame)");
}

Result RenderThread::deliverFrame(FrameSlot& f, const TargetImage& target, const render::FrameContext& frame) {
    if (kind_ == TargetKind::Surface) {
        VkSwapchainKHR sc = swapchain_->handle();
        VkSemaphore done = swapchain_->renderDone(target.index);
        const VkPresentInfoKHR pi{.sType = VK_STRUCTURE_TYPE_PRESENT_INFO_KHR,
                                  .pNext = nullptr,
                                  .waitSemaphoreCount = 1,
                                  .pWaitSemaphores = &done,
                                  .swapchainCount = 1,
                                  .pSwapchains = &sc,
                                  .pImageIndices = &target.index,
                                  .pResults = nullptr};
        switch (const VkResult pr = device_.present(pi)) {
        case VK_SUCCESS: return {};
        case VK_SUBOPTIMAL_KHR:
        case VK_ERROR_OUT_OF_DATE_KHR:
            surfacePhase_ = SurfacePhase::Stale;
            shared_.bump();
            return {};
        case VK_ERROR_SURFACE_LOST_KHR:
            surfacePhase_ = SurfacePhase::Lost;
            shared_.bump();
            return {};
        default: return vk::check(pr, "vkQueuePresentKHR");
        }
    }
    if (!readback_) return {};
    // Offscreen: the frame is read back right away (that is what an offscreen target is for).
    if (Result r = waitSlot(f); !r.ok()) return r;
    if (Result r = vk::invalidate(device_.device(), offscreen_->readback()); !r.ok()) return r;
    // A new Frame each time: readers may still be copying the previous one.
    auto out = std::make_shared<Frame>();
    out->image.width = target.extent.width;
    out->image.height = target.extent.height;
    out->image.rgba.resize(size_t(target.extent.width) * target.extent.height * 4);
    if (offscreen_->format() == VK_FORMAT_B8G8R8A8_UNORM)
        swapRedBlue(static_cast<const uint8_t*>(offscreen_->readback().mapped), out->image.rgba.data(),
                    size_t(target.extent.width) * target.extent.height);
    else
        std::memcpy(out->image.rgba.data(), offscreen_->readback().mapped, out->image.rgba.size());
    out->view = frame.viewport.view;
    out->serial = frame.serial;
    out->complete = frame.complete;
    out->overlays = passes_->hud.layout();
    lastFrame_.store(std::move(out));
    return {};
}

void RenderThread::publishFrame(const Snapshot& snap, bool complete, uint64_t buffered, uint32_t tiles, double cpuMs,
                                const OverlayLayout& overlays) {
    shown_.store(std::make_shared<const Shown>(
        Shown{overlays, snap.slide ? std::weak_ptr<const SlideSource>(snap.slide->source) : std::weak_ptr<const SlideSource>()}));
    const bool newlyComplete = complete && snap.viewSerial > completeViewSerial_.load(std::memory_order_relaxed);
    if (newlyComplete) completeViewSerial_.store(snap.viewSerial, std::memory_order_seq_cst);
    const bool newlySettled = complete && buffered == snap.viewSerial &&
                              snap.viewSerial > settledViewSerial_.load(std::memory_order_relaxed);
    if (newlySettled) settledViewSerial_.store(snap.viewSerial, std::memory_order_seq_cst);
    const FrameStats stats =
        metrics_.frameFinished(snap, serial_, complete, tiles, cpuMs, lastGpuMs_, passes_->tile.tilesCopied());
    // After the metrics, so that a waiter that wakes sees this frame's figures. The lock is
    // taken only when a thread sleeps in waitForFrame (see frameWaiters_).
    if ((newlyComplete || newlySettled) && frameWaiters_.load(std::memory_order_seq_cst) > 0) {
        { std::lock_guard lock(mutex_); }
        cv_.notify_all();
    }
    if (const auto cb = callback_.load(); cb) (*cb)(stats);
}

OverlayLayout RenderThread::overlayLayout(std::shared_ptr<const SlideSource>* source) const {
    const std::shared_ptr<const Shown> shown = shown_.load();
    if (!shown) {
        if (source) source->reset();
        return {};
    }
    if (source) *source = shown->slide.lock();
    return shown->overlays;
}

EngineMetrics RenderThread::metrics() const { return metrics_.read(); }

void RenderThread::resetMetrics() { metrics_.resetFields(); }

} // namespace iris
