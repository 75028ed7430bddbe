// Engine: the public facade. It owns the device, the atlas, the caches and the three kinds of
// engine thread, and turns API calls into published state (SharedState::update) that the
// threads pull. See docs/ARCHITECTURE.md.
#include "iris/engine.h"
#include "iris/annotations.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <mutex>
#include <shared_mutex>

#include "buffer/buffer_thread.h"
#include "cache/loader_pool.h"
#include "cache/tile_cache.h"
#include "core/log.h"
#include "core/shared_state.h"
#include "buffer/handover.h"
#include "gpu/device.h"
#include "gpu/mip_pipeline.h"
#include "gpu/tile_atlas.h"
#include "gpu/tile_pipeline.h"
#include "overlay/font.h"
#include "metrics/field_metrics.h"
#include "render/render_thread.h"
#include "slide/dicomweb_source.h"
#include "slide/pyramid_source.h"
#include "view/view_model.h"

namespace iris {

struct Engine::Impl {
    explicit Impl(const EngineConfig& c)
        : config(c), log(c.log), device(log), atlas(device), pipeline(device, atlas), mips(device, atlas),
          cache(c.ramBudgetBytes) {
        color = c.color;
    }

    ~Impl() {
        // A loader computing a synthetic tile stops at its next stored tile instead of
        // finishing (it can take seconds on a large slide without reduced levels).
        if (const Snapshot s = shared.snapshot(); s.slide) s.slide->source->abandon();
        shared.stopping.store(true, std::memory_order_release);
        shared.bump();
        loaders.reset();
        if (render) render->stop();
        if (buffer) buffer->stop();
        render.reset();
        buffer.reset();
    }

    Result init() {
        if (Result r = device.init(config); !r.ok()) return r;
        // BGRA where the exact copy is on and the mips are made on the host (CPU devices): X11's
        // swapchains are BGRA, and a copy cannot swap channels (a converting blit costs what
        // drawing does on lavapipe). Tiles stay RGBA in RAM; the buffer thread swaps them as it
        // stages them. The compute mip passes write rgba8 images, so they keep RGBA.
        const bool cpuDevice = device.properties().deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
        const bool hostMips = gpu::MipPipeline::resolve(config.tuning.mipSchedule, device.properties()) ==
                              gpu::MipPipeline::Schedule::Host;
        const VkFormat atlasFormat = RenderThread::copiesExact(config.tuning.exactCopy, cpuDevice) && hostMips
                                         ? gpu::TileAtlas::kSwappedFormat
                                         : gpu::TileAtlas::kFormat;
        // Tiles written into the atlas from the host (EngineTuning::tileUpload): only where the
        // buffer thread makes the levels itself, since the compute mip pass writes after an upload.
        const EngineTuning::TileUpload upload = config.tuning.tileUpload;
        const bool wantHostWrites =
            upload == EngineTuning::TileUpload::Host || (upload == EngineTuning::TileUpload::Auto && cpuDevice);
        if (upload == EngineTuning::TileUpload::Host && !hostMips)
            log.warn("tile upload: host writes need the host mip schedule; uploading by queue copies");
        if (Result r = atlas.init(config.vramBudgetBytes, config.tuning.deviceAllocationLimit, atlasFormat,
                                  wantHostWrites && hostMips);
            !r.ok())
            return r;
        if (!atlas.hostFallback().empty())
            log.warn("tile upload: no host-written atlas (" + atlas.hostFallback() + "); uploading by queue copies");
        log.info(std::string("tile upload: ") +
                 (atlas.hostWritten() ? "host writes into a linear atlas" : "queue copies"));
        if (atlas.slotCount() < atlas.requestedSlots()) {
            const auto mib = [](uint64_t slots) { return std::to_string(slots * gpu::TileAtlas::bytesPerSlot() >> 20); };
            log.warn("VRAM: the device could not allocate a tile atlas of " + std::to_string(atlas.requestedSlots()) +
                     " slots (" + mib(atlas.requestedSlots()) + " MiB, from the VRAM budget); using " +
                     std::to_string(atlas.slotCount()) + " slots (" + mib(atlas.slotCount()) +
                     " MiB): fewer tiles stay resident, views are drawn as before");
        }
        if (Result r = pipeline.init(RenderThread::kFramesInFlight, config.tuning.colorLookup); !r.ok()) return r;
        log.info(std::string("colour lookup: ") + (pipeline.lutSampled() ? "sampler" : "8 nodes in float"));
        if (Result r = mips.init(config.tuning.mipSchedule); !r.ok()) return r;
        log.info(std::string("mip pass: ") + gpu::MipPipeline::scheduleName(mips.schedule()) + " schedule");
        handover = std::make_unique<Handover>(atlas.slotCount());
        render = std::make_unique<RenderThread>(shared, device, atlas, pipeline, *handover, counters, log, config.tuning);
        if (Result r = render->init(); !r.ok()) return r;
        buffer = std::make_unique<BufferThread>(shared, cache, device, atlas, mips, *handover, counters, log,
                                                int(config.perimeterTiles), render->copiesExact(), config.tuning.jpegDecode);
        if (Result r = buffer->init(); !r.ok()) return r;
        shared.update([&](Snapshot& s) { s.background = config.background; });
        (void)bakeColor(nullptr, color, colorStatus); // the display profile's description
        // Whichever thread sees the device lost wakes the render thread, which recovers.
        device.setLostCallback([this] { shared.bump(); });
        render->setRebuild([this] { return rebuildGpu(); });
        buffer->start();
        render->start();
        // Each decoded tile into staging by its loader (BufferThread::prestage); the loaders go
        // before the buffer thread (the destructor, and no rebuild replaces it).
        // Where the buffer thread finishes JPEG tiles on the GPU, the loaders hand it their
        // coefficients (EngineTuning::jpegDecode).
        log.info(std::string("JPEG decode: ") + (buffer->reconstructsJpeg() ? "entropy on the CPU, the rest on the GPU" : "CPU"));
        loaders = std::make_unique<LoaderPool>(
            shared, cache, log, config.loaderThreads, int(config.perimeterTiles),
            [b = buffer.get()](uint64_t key, const uint8_t* pixels, bool coefficients) {
                b->prestage(key, pixels, coefficients);
            },
            buffer->reconstructsJpeg());
        log.info("engine ready: " + std::to_string(atlas.slotCount()) + " atlas slots, RAM budget " +
                 std::to_string(cache.budgetBytes() >> 20) + " MiB");
        return {};
    }

    // Device loss, called by the render thread's recovery (RenderThread::recover) once its own
    // GPU objects are gone: parks the buffer thread (which drops its own), destroys the mip and
    // tile pipelines and the atlas, makes a new logical device, and builds them again in place
    // (the threads hold references to them). The atlas asks for no more slots than it had, so
    // that the hand-over ring, sized for them, still holds every slot. The RAM cache, the slide,
    // the view and the loaders are untouched: the view is re-buffered from RAM.
    Result rebuildGpu() {
        buffer->park();
        if (shared.stopping.load(std::memory_order_acquire)) return Result(Status::Cancelled, "the engine is stopping");
        {
            std::unique_lock lock(gpuMutex); // memoryStats() and device() read the atlas
            if (atlas.slotCount()) atlasSlots = atlas.slotCount();
            const VkFormat atlasFormat = atlas.format(); // as init chose them
            const bool hostWritten = atlas.hostWritten();
            std::destroy_at(&mips);
            std::destroy_at(&pipeline);
            std::destroy_at(&atlas);
            std::construct_at(&atlas, device);
            std::construct_at(&pipeline, device, atlas);
            std::construct_at(&mips, device, atlas);
            handover->reset();
            if (Result r = device.recreate(); !r.ok()) return r;
            const uint64_t budget = std::min<uint64_t>(config.vramBudgetBytes, uint64_t(atlasSlots) * gpu::TileAtlas::bytesPerSlot());
            if (Result r = atlas.init(budget, config.tuning.deviceAllocationLimit, atlasFormat, hostWritten); !r.ok())
                return r;
            if (Result r = pipeline.init(RenderThread::kFramesInFlight, config.tuning.colorLookup); !r.ok()) return r;
            if (Result r = mips.init(config.tuning.mipSchedule); !r.ok()) return r;
        }
        if (Result r = buffer->init(); !r.ok()) return r;
        buffer->resume();
        return {};
    }

    // A move whose new field shares no pixel with the old one starts a TeFOV measurement
    // (metrics/field_metrics.h; the render thread leaves a revisit, whose tiles are all
    // resident already, untimed).
    void noteFieldMove(Snapshot& s, const View& before) {
        if (!s.slide || s.viewport.width == 0) return;
        if (!metrics::isNewField(before, s.viewport.view, s.viewport.width, s.viewport.height)) return;
        s.fieldId = ++fieldCounter;
        s.fieldStart = std::chrono::steady_clock::now();
        s.fieldTilesAtStart = counters.tiles.load(std::memory_order_relaxed);
    }

    // The colour transform of `info`'s embedded profile under `settings` (null: none), and what
    // is applied in `status`. Runs on the calling API thread outside the snapshot lock
    // (LittleCMS takes milliseconds for the table); a profile that cannot be used is logged
    // and leaves the slide untransformed.
    std::shared_ptr<const color::Lut3D> bakeColor(const SlideInfo* info, const ColorSettings& settings,
                                                  ColorStatus& status) const {
        status = {};
        if (settings.displayProfile.empty()) {
            status.displayProfile = "sRGB (built-in)";
        } else {
            status.displayProfile = color::profileDescription(settings.displayProfile);
            if (status.displayProfile.empty()) status.displayProfile = "display profile without a description";
        }
        if (!info || info->iccProfile.empty()) return nullptr;
        status.slideProfile = color::profileDescription(info->iccProfile);
        if (status.slideProfile.empty()) status.slideProfile = "embedded profile without a description";
        if (!settings.managed) return nullptr;
        Expected<color::Lut3D> lut = color::bakeLut(info->iccProfile, settings.displayProfile, settings.intent);
        if (!lut) {
            status.error = lut.error();
            log.warn("colour management: " + lut.error().message() + "; the slide is drawn without its profile");
            return nullptr;
        }
        status.applied = true;
        return std::make_shared<const color::Lut3D>(std::move(lut.value()));
    }

    // Applies a view change with the downsample clamped and the numbers sanitised.
    void setViewLocked(Snapshot& s, View v) {
        if (!std::isfinite(v.centerX) || !std::isfinite(v.centerY)) return;
        v.rotation = normalizedRotation(v.rotation);
        if (s.slide) {
            v.downsample = clampDownsample(s.slide->info, s.viewport.width, s.viewport.height, v.downsample);
        } else if (!(v.downsample > 0) || !std::isfinite(v.downsample)) {
            return;
        }
        const View before = s.viewport.view;
        s.viewport.view = v;
        noteFieldMove(s, before);
    }

    EngineConfig config;
    Log log;
    SharedState shared;
    gpu::Device device;
    gpu::TileAtlas atlas;
    gpu::TilePipeline pipeline;
    gpu::MipPipeline mips;
    std::unique_ptr<Handover> handover;
    // Held exclusively while rebuildGpu() replaces the atlas and the pipelines, shared by the API
    // calls that read them (the threads that use them are parked then).
    mutable std::shared_mutex gpuMutex;
    uint32_t atlasSlots = 0; // the atlas's slots before a rebuild
    UploadCounters counters;
    uint64_t fieldCounter = 0; // guarded by SharedState's update lock
    uint64_t layerCounter = 0; // the last layer id given; guarded by SharedState's update lock
    // Colour settings and what they give for the open slide; written under openMutex too.
    mutable std::mutex colorMutex;
    ColorSettings color;
    ColorStatus colorStatus;
    TileCache cache;
    std::unique_ptr<RenderThread> render;
    std::unique_ptr<BufferThread> buffer;
    std::unique_ptr<LoaderPool> loaders;
    std::mutex openMutex; // serialises open/close (the disk work of open happens outside it)
    std::mutex fontMutex; // serialises font choices (file and fontconfig work happen under it)
    bool fontChosen = false; // guarded by fontMutex: a font was set, or the default was looked up
    // What open() gives a DICOMweb source: EngineConfig::network until setNetworkOptions().
    // Its own lock, not openMutex, so that setting credentials never waits for an open() that
    // is talking to a slow server (open() copies the options before its network work).
    mutable std::mutex networkMutex;
    NetworkOptions network = config.network; // guarded by networkMutex
    uint32_t generation = 0;
    bool surfaceBound = false;
    bool offscreenBound = false;
    // The annotations shown (setAnnotations) and the registration that wakes the render
    // thread after each change the store publishes. Declared after `shared`, which the
    // registration's function bumps: it is destroyed (and waits out a call) first.
    mutable std::mutex annotationMutex;
    std::shared_ptr<AnnotationStore> annotationStore; // guarded by annotationMutex
    AnnotationSubscription annotationWake;            // guarded by annotationMutex
};

Expected<std::unique_ptr<Engine>> Engine::create(const EngineConfig& config) {
    auto impl = std::make_unique<Impl>(config);
    if (Result r = impl->init(); !r.ok()) return r;
    return std::unique_ptr<Engine>(new Engine(std::move(impl)));
}

Engine::Engine(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Engine::~Engine() = default;

namespace {
Result checkSize(uint32_t w, uint32_t h, uint32_t maxDim) {
    if (w == 0 || h == 0) return Result(Status::InvalidArgument, "The target size must not be zero");
    if (w > maxDim || h > maxDim) {
        return Result(Status::InvalidArgument, "Target " + std::to_string(w) + "x" + std::to_string(h) +
                                                   " exceeds the device's limit of " + std::to_string(maxDim));
    }
    return {};
}
} // namespace

Result Engine::bindOffscreen(uint32_t width, uint32_t height, bool readback) {
    if (Result r = checkSize(width, height, impl_->device.properties().limits.maxImageDimension2D); !r.ok()) return r;
    {
        std::lock_guard lock(impl_->openMutex);
        if (impl_->surfaceBound) impl_->render->unbindSurface();
        impl_->surfaceBound = false;
        impl_->offscreenBound = true;
    }
    impl_->shared.update([&](Snapshot& s) {
        s.viewport.width = width;
        s.viewport.height = height;
    });
    impl_->render->requestOffscreen(width, height, readback);
    return {};
}

Result Engine::bindSurface(VkInstance instance, VkSurfaceKHR surface, uint32_t width, uint32_t height) {
    if (!surface) return Result(Status::InvalidArgument, "bindSurface: no surface given");
    if (instance != impl_->device.instance()) {
        return Result(Status::InvalidArgument,
                      "bindSurface: the surface's VkInstance is not the engine's (pass it as EngineConfig::instance)");
    }
    if (!impl_->device.hasSwapchain()) return Result(Status::Vulkan, "The Vulkan device has no VK_KHR_swapchain");
    if (width == 0 || height == 0) width = height = 1;
    {
        std::lock_guard lock(impl_->openMutex);
        impl_->surfaceBound = true;
        impl_->offscreenBound = false;
    }
    impl_->shared.update([&](Snapshot& s) {
        s.viewport.width = width;
        s.viewport.height = height;
    });
    impl_->render->requestSurface(surface, width, height);
    return {};
}

void Engine::unbindSurface() {
    {
        std::lock_guard lock(impl_->openMutex);
        if (!impl_->surfaceBound) return;
        impl_->surfaceBound = false;
    }
    impl_->render->unbindSurface();
}

void Engine::resize(uint32_t width, uint32_t height) {
    if (width == 0 || height == 0) return; // minimised: keep the last size
    if (!checkSize(width, height, impl_->device.properties().limits.maxImageDimension2D).ok()) return;
    impl_->shared.update([&](Snapshot& s) {
        s.viewport.width = width;
        s.viewport.height = height;
    });
    impl_->render->requestResize(width, height);
}

void Engine::setVisible(bool visible) {
    impl_->shared.update([&](Snapshot& s) { s.visible = visible; });
}

// The render thread draws whenever `wake` moved since its last frame (RenderThread::run).
void Engine::redraw() { impl_->shared.bump(); }

void Engine::setNetworkOptions(const NetworkOptions& options) {
    std::lock_guard lock(impl_->networkMutex);
    impl_->network = options;
}

Result Engine::open(const std::string& path) {
    NetworkOptions network;
    {
        std::lock_guard lock(impl_->networkMutex);
        network = impl_->network;
    }
    // The disk work (header parse) runs without holding any engine lock.
    Expected<std::unique_ptr<SlideSource>> src = openSlideSource(path, impl_->config.source, network);
    // A network slide keeps compressed frames besides the decoded tiles: a share of the budget.
    if (src)
        if (auto* web = dynamic_cast<DicomWebSource*>(src->get()))
            web->setFrameStoreBytes(DicomWebSource::frameStoreBytesFor(impl_->config.ramBudgetBytes));
    std::lock_guard lock(impl_->openMutex);
    if (!src) {
        close();
        impl_->shared.setError(src.error());
        impl_->log.warn(src.error().message());
        return src.error();
    }
    auto slide = std::make_shared<OpenSlide>();
    // Levels the file lacks (a coarsest level too large to keep resident) are computed.
    slide->source = std::shared_ptr<SlideSource>(PyramidSource::complete(std::move(src.value())));
    slide->info = slide->source->info();
    impl_->generation = (impl_->generation + 1) & 0xFFFF;
    if (impl_->generation == 0) impl_->generation = 1;
    slide->generation = impl_->generation;
    impl_->cache.dropOtherGenerations(slide->generation);
    impl_->shared.failingTiles.clear();
    impl_->shared.clearErrorForSlide(slide->generation);
    ColorStatus colorStatus;
    const std::shared_ptr<const color::Lut3D> lut = impl_->bakeColor(&slide->info, colorSettings(), colorStatus);
    std::shared_ptr<const OpenSlide> previous;
    impl_->shared.update([&](Snapshot& s) {
        previous = std::move(s.slide);
        s.slide = slide;
        s.colorLut = lut;
        s.fieldId = 0;
        s.viewport.view = iris::fitView(slide->info, s.viewport.width, s.viewport.height);
    });
    if (previous) previous->source->abandon();
    {
        std::lock_guard colorLock(impl_->colorMutex);
        impl_->colorStatus = std::move(colorStatus);
    }
    impl_->log.info("opened " + path + " (" + slide->info.vendor + ", " + std::to_string(slide->info.width) + "x" +
                    std::to_string(slide->info.height) + ", " + std::to_string(slide->info.levels.size()) + " levels)");
    return {};
}

void Engine::close() {
    std::shared_ptr<const OpenSlide> previous;
    impl_->shared.update([&](Snapshot& s) {
        previous = std::move(s.slide);
        s.fieldId = 0;
        s.colorLut.reset();
    });
    {
        std::lock_guard colorLock(impl_->colorMutex);
        impl_->colorStatus.applied = false;
        impl_->colorStatus.slideProfile.clear();
        impl_->colorStatus.error = {};
    }
    if (previous) previous->source->abandon();
}

std::optional<SlideInfo> Engine::slideInfo() const {
    const Snapshot s = impl_->shared.snapshot();
    if (!s.slide) return std::nullopt;
    return s.slide->info;
}

Expected<Image> Engine::readAssociatedImage(const std::string& name, ImageColors colors) const {
    const Snapshot s = impl_->shared.snapshot();
    if (!s.slide) return Result(Status::NoSlide, "No slide is open");
    Expected<Image> image = s.slide->source->readAssociatedImage(name);
    // The snapshot's table is the transform the tiles go through: none, none for the image.
    if (!image || colors == ImageColors::AsStored || !s.colorLut) return image;
    const ColorSettings settings = colorSettings();
    if (Result r =
            color::transformImage(s.slide->info.iccProfile, settings.displayProfile, settings.intent, image.value());
        !r) {
        return Result(r.status(), "Cannot convert the associated image '" + name + "' for display: " + r.message());
    }
    return image;
}

void Engine::translate(double dx, double dy) {
    if (!std::isfinite(dx) || !std::isfinite(dy)) return;
    impl_->shared.update([&](Snapshot& s) {
        View v = s.viewport.view;
        // The image follows the pointer: the target's centre moves to the slide point that
        // lay at (centre − delta).
        const ViewTransform t = ViewTransform::of(v, s.viewport.width, s.viewport.height);
        const auto to = t.toSlide(t.targetCX - dx, t.targetCY - dy);
        v.centerX = to[0];
        v.centerY = to[1];
        if (s.slide) {
            // Panning never pushes the slide out of the target: the centre may not move past
            // the slide's edge (a centre already outside, set by setView, is not pulled back).
            const View& o = s.viewport.view;
            const double w = double(s.slide->info.width), h = double(s.slide->info.height);
            if (v.centerX < 0 && v.centerX < o.centerX) v.centerX = std::min(o.centerX, 0.0);
            if (v.centerX > w && v.centerX > o.centerX) v.centerX = std::max(o.centerX, w);
            if (v.centerY < 0 && v.centerY < o.centerY) v.centerY = std::min(o.centerY, 0.0);
            if (v.centerY > h && v.centerY > o.centerY) v.centerY = std::max(o.centerY, h);
        }
        impl_->setViewLocked(s, v);
    });
}

void Engine::zoom(double factor, double anchorX, double anchorY) {
    if (!std::isfinite(factor) || factor <= 0 || !std::isfinite(anchorX) || !std::isfinite(anchorY)) return;
    impl_->shared.update([&](Snapshot& s) {
        View v = s.viewport.view;
        // The level-0 point under the anchor before and after must coincide.
        const auto p = ViewTransform::of(v, s.viewport.width, s.viewport.height).toSlide(anchorX, anchorY);
        double ds = v.downsample / factor;
        if (s.slide) ds = clampDownsample(s.slide->info, s.viewport.width, s.viewport.height, ds);
        v.downsample = ds;
        keepUnder(v, p, anchorX, anchorY, s.viewport);
        impl_->setViewLocked(s, v);
    });
}

void Engine::rotate(double degrees, double anchorX, double anchorY) {
    if (!std::isfinite(degrees) || !std::isfinite(anchorX) || !std::isfinite(anchorY)) return;
    impl_->shared.update([&](Snapshot& s) {
        View v = s.viewport.view;
        // The slide turns clockwise on screen about the anchor: the slide point there stays.
        const auto p = ViewTransform::of(v, s.viewport.width, s.viewport.height).toSlide(anchorX, anchorY);
        v.rotation = normalizedRotation(v.rotation + degrees);
        keepUnder(v, p, anchorX, anchorY, s.viewport);
        impl_->setViewLocked(s, v);
    });
}

void Engine::setView(const View& view) {
    impl_->shared.update([&](Snapshot& s) { impl_->setViewLocked(s, view); });
}

View Engine::view() const { return impl_->shared.snapshot().viewport.view; }

View Engine::fitView() const {
    const Snapshot s = impl_->shared.snapshot();
    if (!s.slide) return s.viewport.view;
    return iris::fitView(s.slide->info, s.viewport.width, s.viewport.height, s.viewport.view);
}

std::pair<uint32_t, uint32_t> Engine::targetSize() const {
    const Snapshot s = impl_->shared.snapshot();
    return {s.viewport.width, s.viewport.height};
}

Expected<Frame> Engine::readFrame() const {
    {
        std::lock_guard lock(impl_->openMutex);
        if (!impl_->offscreenBound) return Result(Status::NotBound, "readFrame needs an offscreen target (bindOffscreen)");
    }
    Expected<Frame> frame = impl_->render->lastFrame();
    // Bound, but nothing drawn yet: with no slide open, that is why.
    if (!frame.ok() && !impl_->shared.snapshot().slide)
        return Result(Status::NoSlide, "No slide is open, and no frame has been rendered yet");
    return frame;
}

Result Engine::waitForFrame(std::chrono::milliseconds timeout) {
    const Snapshot s = impl_->shared.snapshot();
    if (!s.slide) return Result(Status::NoSlide, "No slide is open");
    {
        std::lock_guard lock(impl_->openMutex);
        if (!impl_->offscreenBound && !impl_->surfaceBound) return Result(Status::NotBound, "No render target is bound");
    }
    return impl_->render->waitForFrame(s.viewSerial, timeout);
}

Result Engine::waitForSettled(std::chrono::milliseconds timeout) {
    const Snapshot s = impl_->shared.snapshot();
    if (!s.slide) return Result(Status::NoSlide, "No slide is open");
    {
        std::lock_guard lock(impl_->openMutex);
        if (!impl_->offscreenBound && !impl_->surfaceBound) return Result(Status::NotBound, "No render target is bound");
    }
    return impl_->render->waitForSettled(s.viewSerial, timeout);
}

void Engine::setFrameCallback(std::function<void(const FrameStats&)> callback) {
    impl_->render->setFrameCallback(std::move(callback));
}

void Engine::setBackground(float r, float g, float b) {
    auto c = [](float v) { return std::isfinite(v) ? std::clamp(v, 0.0f, 1.0f) : 0.0f; };
    impl_->shared.update([&](Snapshot& s) { s.background = {c(r), c(g), c(b)}; });
}

void Engine::setEnhance(bool on) {
    // Tiles in the atlas keep the mips they were made with: a change gives the open slide a new
    // generation (same source), so that every tile is buffered again with the new kernel. The
    // RAM cache is keyed by generation too, so this re-decodes the visible tiles.
    std::lock_guard lock(impl_->openMutex); // open() cannot replace the slide meanwhile
    const Snapshot cur = impl_->shared.snapshot();
    if (cur.enhance == on) return;
    std::shared_ptr<OpenSlide> slide;
    if (cur.slide) {
        slide = std::make_shared<OpenSlide>(*cur.slide);
        impl_->generation = (impl_->generation + 1) & 0xFFFF;
        if (impl_->generation == 0) impl_->generation = 1;
        slide->generation = impl_->generation;
        impl_->cache.dropOtherGenerations(slide->generation);
        impl_->shared.renumberSlide(slide->generation);
    }
    impl_->shared.update([&](Snapshot& s) {
        s.enhance = on;
        if (slide && s.slide) s.slide = slide;
    });
}

bool Engine::enhance() const { return impl_->shared.snapshot().enhance; }

void Engine::setColorSettings(const ColorSettings& settings) {
    std::lock_guard lock(impl_->openMutex); // open() cannot replace the slide meanwhile
    {
        std::lock_guard colorLock(impl_->colorMutex);
        impl_->color = settings;
    }
    const Snapshot cur = impl_->shared.snapshot();
    ColorStatus status;
    const std::shared_ptr<const color::Lut3D> lut = impl_->bakeColor(cur.slide ? &cur.slide->info : nullptr, settings, status);
    impl_->shared.update([&](Snapshot& s) { s.colorLut = s.slide ? lut : nullptr; });
    std::lock_guard colorLock(impl_->colorMutex);
    impl_->colorStatus = std::move(status);
}

ColorSettings Engine::colorSettings() const {
    std::lock_guard lock(impl_->colorMutex);
    return impl_->color;
}

ColorStatus Engine::colorStatus() const {
    std::lock_guard lock(impl_->colorMutex);
    return impl_->colorStatus;
}

namespace {
bool validOverlay(Overlay o) { return int(o) >= 0 && int(o) < kOverlayCount; }
bool labelled(Overlay o) { return o != Overlay::Overview; }
} // namespace

void Engine::setAnnotations(std::shared_ptr<AnnotationStore> store) {
    std::lock_guard lock(impl_->annotationMutex);
    if (store == impl_->annotationStore) return;
    impl_->annotationWake.reset();
    if (store) {
        SharedState* shared = &impl_->shared;
        impl_->annotationWake = store->onChange([shared] { shared->bump(); });
    }
    impl_->annotationStore = store;
    impl_->shared.update([&](Snapshot& s) { s.annotations = std::move(store); });
}

std::shared_ptr<AnnotationStore> Engine::annotations() const {
    std::lock_guard lock(impl_->annotationMutex);
    return impl_->annotationStore;
}

void Engine::setAnnotationsVisible(bool visible) {
    impl_->shared.update([&](Snapshot& s) { s.annotationsVisible = visible; });
}

bool Engine::annotationsVisible() const { return impl_->shared.snapshot().annotationsVisible; }

void Engine::setSelectedAnnotation(uint64_t id) {
    impl_->shared.update([&](Snapshot& s) { s.selectedAnnotation = id; });
}

uint64_t Engine::selectedAnnotation() const { return impl_->shared.snapshot().selectedAnnotation; }

namespace {
using Layers = std::vector<Engine::LayerEntry>;
// The stack with `edit` applied to a copy (the render thread may be drawing the old one).
template <class F>
Result editLayers(SharedState& shared, uint64_t id, F&& edit) {
    bool found = false;
    shared.update([&](Snapshot& s) {
        auto next = std::make_shared<Layers>(*s.layers);
        auto it = std::find_if(next->begin(), next->end(), [&](const Engine::LayerEntry& e) { return e.id == id; });
        if (it == next->end()) return;
        found = true;
        edit(*next, it);
        s.layers = std::move(next);
    });
    if (!found) return Result(Status::NotFound, "No layer " + std::to_string(id) + " is shown");
    return {};
}
Result checkMap(const std::shared_ptr<const RasterMap>& map) {
    if (!map) return Result(Status::InvalidArgument, "No raster map given");
    if (std::string problem = rasterMapProblem(*map); !problem.empty())
        return Result(Status::InvalidArgument, "The raster map cannot be shown: " + problem);
    return {};
}
// A single-level map larger than this a side gets coarser levels (withRasterPyramid), so that a
// view of the whole slide draws from a small level instead of needing the whole map on the GPU.
constexpr int32_t kPyramidFromSide = 1024;
// The pyramids made so far, by the map they were made from, for as long as both live: a map
// shown twice (in two layers, or in the two engines of a synchronised pair of views) gets one
// copy, not one per layer. The key is the map's identity, which is safe because a RasterMap
// behind a shared_ptr<const> never changes, and the source's weak_ptr tells a live map from a
// new one that reuses a freed address.
struct PyramidCache {
    std::mutex mutex;
    std::vector<std::pair<std::weak_ptr<const RasterMap>, std::weak_ptr<const RasterMap>>> made;

    std::shared_ptr<const RasterMap> find(const std::shared_ptr<const RasterMap>& source) {
        std::lock_guard lock(mutex);
        std::erase_if(made, [](const auto& e) { return e.first.expired() || e.second.expired(); });
        for (const auto& [from, pyramid] : made)
            if (from.lock() == source) return pyramid.lock();
        return nullptr;
    }
    std::shared_ptr<const RasterMap> keep(const std::shared_ptr<const RasterMap>& source,
                                          std::shared_ptr<const RasterMap> pyramid) {
        std::lock_guard lock(mutex);
        for (const auto& [from, other] : made) // another thread made one meanwhile: share it
            if (from.lock() == source)
                if (auto p = other.lock()) return p;
        made.emplace_back(source, pyramid);
        return pyramid;
    }
};
PyramidCache& pyramidCache() {
    static PyramidCache cache; // process-wide: engines share maps
    return cache;
}
std::shared_ptr<const RasterMap> drawable(std::shared_ptr<const RasterMap> map) {
    if (map->levels.size() != 1 || std::max(map->width(), map->height()) <= kPyramidFromSide) return map;
    if (auto made = pyramidCache().find(map)) return made;
    // Made outside the lock: a large map takes a while, and other maps need not wait for it.
    return pyramidCache().keep(map, std::make_shared<const RasterMap>(withRasterPyramid(*map)));
}
} // namespace

Expected<uint64_t> Engine::addLayer(std::shared_ptr<const RasterMap> map, const LayerStyle& style,
                                    std::optional<Placement> placement) {
    if (Result r = checkMap(map); !r.ok()) return r;
    map = drawable(std::move(map));
    uint64_t id = 0;
    impl_->shared.update([&](Snapshot& s) {
        id = ++impl_->layerCounter; // guarded by the update lock
        auto next = std::make_shared<Layers>(*s.layers);
        next->push_back(LayerEntry{id, std::move(map), style, placement});
        s.layers = std::move(next);
    });
    return id;
}

Result Engine::setLayerMap(uint64_t id, std::shared_ptr<const RasterMap> map) {
    if (Result r = checkMap(map); !r.ok()) return r;
    map = drawable(std::move(map));
    return editLayers(impl_->shared, id, [&](Layers&, Layers::iterator it) { it->map = std::move(map); });
}

Result Engine::setLayerStyle(uint64_t id, const LayerStyle& style) {
    return editLayers(impl_->shared, id, [&](Layers&, Layers::iterator it) { it->style = style; });
}

Result Engine::setLayerPlacement(uint64_t id, std::optional<Placement> placement) {
    return editLayers(impl_->shared, id, [&](Layers&, Layers::iterator it) { it->placement = placement; });
}

Result Engine::moveLayer(uint64_t id, size_t index) {
    return editLayers(impl_->shared, id, [&](Layers& l, Layers::iterator it) {
        LayerEntry e = std::move(*it);
        l.erase(it);
        l.insert(l.begin() + std::ptrdiff_t(std::min(index, l.size())), std::move(e));
    });
}

void Engine::removeLayer(uint64_t id) {
    (void)editLayers(impl_->shared, id, [&](Layers& l, Layers::iterator it) { l.erase(it); });
}

void Engine::clearLayers() {
    impl_->shared.update([&](Snapshot& s) { s.layers = std::make_shared<const Layers>(); });
}

std::vector<Engine::LayerEntry> Engine::layers() const { return *impl_->shared.snapshot().layers; }

void Engine::setCrosshair(std::optional<std::array<double, 2>> slidePos) {
    if (slidePos && (!std::isfinite((*slidePos)[0]) || !std::isfinite((*slidePos)[1]))) slidePos.reset();
    impl_->shared.update([&](Snapshot& s) { s.overlays.crosshair = slidePos; });
}

std::optional<std::array<double, 2>> Engine::crosshair() const {
    return impl_->shared.snapshot().overlays.crosshair;
}

void Engine::setOverlayVisible(Overlay overlay, bool visible) {
    if (!validOverlay(overlay)) return;
    if (visible && labelled(overlay)) {
        // The first labelled overlay needs a font: the default one, unless the host chose.
        std::lock_guard lock(impl_->fontMutex);
        if (!impl_->fontChosen) {
            impl_->fontChosen = true;
            Expected<std::string> file = overlay::findDefaultFontFile();
            Expected<std::shared_ptr<const overlay::FontData>> font =
                file ? overlay::loadFontFile(*file) : Expected<std::shared_ptr<const overlay::FontData>>(file.error());
            if (font) {
                impl_->log.info("overlay font: " + (*font)->path);
                impl_->shared.update([&](Snapshot& s) { s.overlays.font = *font; });
            } else {
                impl_->shared.setError(font.error());
                impl_->log.error("overlay labels are not drawn: " + font.error().message());
            }
        }
    }
    impl_->shared.update([&](Snapshot& s) { s.overlays.visible[size_t(overlay)] = visible; });
}

bool Engine::overlayVisible(Overlay overlay) const {
    return validOverlay(overlay) && impl_->shared.snapshot().overlays.visible[size_t(overlay)];
}

void Engine::setOverlayCorner(Overlay overlay, Corner corner) {
    if (!validOverlay(overlay) || int(corner) < 0 || int(corner) > 3) return;
    impl_->shared.update([&](Snapshot& s) { s.overlays.corner[size_t(overlay)] = corner; });
}

Corner Engine::overlayCorner(Overlay overlay) const {
    if (!validOverlay(overlay)) return Corner::TopLeft;
    return impl_->shared.snapshot().overlays.corner[size_t(overlay)];
}

void Engine::setDevicePixelRatio(double ratio) {
    if (!std::isfinite(ratio) || ratio <= 0) return;
    ratio = std::clamp(ratio, 0.25, 8.0);
    impl_->shared.update([&](Snapshot& s) { s.overlays.devicePixelRatio = ratio; });
}

double Engine::devicePixelRatio() const { return impl_->shared.snapshot().overlays.devicePixelRatio; }

Result Engine::setOverlayFont(const std::string& path) {
    std::lock_guard lock(impl_->fontMutex);
    impl_->fontChosen = true;
    Expected<std::string> file = path.empty() ? overlay::findDefaultFontFile() : Expected<std::string>(path);
    Expected<std::shared_ptr<const overlay::FontData>> font =
        file ? overlay::loadFontFile(*file) : Expected<std::shared_ptr<const overlay::FontData>>(file.error());
    // On failure no font is left: labels are not drawn rather than drawn in a font the host did not ask for.
    impl_->shared.update([&](Snapshot& s) { s.overlays.font = font ? *font : nullptr; });
    if (!font) {
        impl_->shared.setError(font.error());
        impl_->log.error("overlay labels are not drawn: " + font.error().message());
        return font.error();
    }
    impl_->log.info("overlay font: " + (*font)->path);
    return {};
}

OverlayLayout Engine::overlayLayout() const { return impl_->render->overlayLayout(); }

bool Engine::overviewHit(double x, double y, View* out) const {
    if (!std::isfinite(x) || !std::isfinite(y)) return false;
    std::shared_ptr<const SlideSource> shown;
    const OverlayLayout layout = impl_->render->overlayLayout(&shown);
    const Snapshot s = impl_->shared.snapshot();
    if (!s.slide || !shown || shown != s.slide->source) return false; // laid out for another slide
    const PixelRect& img = layout.overviewImage;
    if (layout.rect(Overlay::Overview).empty() || !img.contains(x, y) || !(layout.overviewDownsample > 0)) return false;
    if (out) {
        View v = s.viewport.view;
        v.centerX = std::clamp((x - img.x) * layout.overviewDownsample, 0.0, double(s.slide->info.width));
        v.centerY = std::clamp((y - img.y) * layout.overviewDownsample, 0.0, double(s.slide->info.height));
        *out = v;
    }
    return true;
}

Result Engine::error() const { return impl_->shared.error(); }
void Engine::clearError() { impl_->shared.clearError(); }

DeviceInfo Engine::device() const {
    DeviceInfo d;
    d.name = impl_->device.properties().deviceName;
    d.driver = impl_->device.driverName();
    d.graphicsFamily = impl_->device.families().graphics;
    d.computeFamily = impl_->device.families().compute;
    d.transferFamily = impl_->device.families().transfer;
    d.recoveries = impl_->render->recoveries();
    d.lost = impl_->device.lost() || impl_->render->recovering();
    std::shared_lock lock(impl_->gpuMutex);
    d.atlasSlots = impl_->atlas.slotCount();
    d.mipSchedule = gpu::MipPipeline::scheduleName(impl_->mips.schedule());
    d.tileUpload = impl_->atlas.hostWritten() ? "host" : "queue";
    d.jpegDecode = impl_->buffer->reconstructsJpeg() ? "gpu" : "cpu";
    return d;
}

MemoryStats Engine::memoryStats() const {
    MemoryStats m;
    m.ramCacheBytes = impl_->cache.bytesUsed();
    m.ramBudgetBytes = impl_->cache.budgetBytes();
    std::shared_lock lock(impl_->gpuMutex);
    m.vramAtlasBytes = uint64_t(impl_->atlas.slotCount()) * gpu::TileAtlas::bytesPerSlot();
    m.atlasSlots = impl_->atlas.slotCount();
    m.atlasActive = m.atlasSlots ? impl_->atlas.map().countActive() : 0; // none while a rebuild failed
    return m;
}

EngineMetrics Engine::metrics() const {
    EngineMetrics m = impl_->render->metrics();
    m.tileReadsInProgress = impl_->loaders ? impl_->loaders->readsInProgress() : 0;
    return m;
}
void Engine::resetMetrics() { impl_->render->resetMetrics(); }

uint64_t Engine::validationMessageCount() const { return impl_->device.validationMessages(); }

namespace {
const char* faultName(Engine::InjectedFault f) {
    switch (f) {
    case Engine::InjectedFault::DeviceLostAtFrameSubmit: return "device lost at the next frame submission";
    case Engine::InjectedFault::DeviceLostAtUploadSubmit: return "device lost at the next upload submission";
    case Engine::InjectedFault::DeviceLostAtFrameWait: return "device lost at the next frame fence wait";
    case Engine::InjectedFault::DeviceLostAtPresent: return "device lost at the next present";
    case Engine::InjectedFault::SurfaceLostAtPresent: return "surface lost at the next present";
    }
    return "?";
}
} // namespace

void Engine::injectFault(InjectedFault fault) {
    using F = gpu::Device::Fault;
    switch (fault) {
    case InjectedFault::DeviceLostAtFrameSubmit: impl_->device.inject(F::LostAtFrameSubmit); break;
    case InjectedFault::DeviceLostAtUploadSubmit: impl_->device.inject(F::LostAtUploadSubmit); break;
    case InjectedFault::DeviceLostAtFrameWait: impl_->device.inject(F::LostAtFrameWait); break;
    case InjectedFault::DeviceLostAtPresent: impl_->device.inject(F::LostAtPresent); break;
    case InjectedFault::SurfaceLostAtPresent: impl_->device.inject(F::SurfaceLostAtPresent); break;
    default: return;
    }
    impl_->log.warn(std::string("fault injected: ") + faultName(fault));
}

void Engine::setFaultCallback(std::function<void(const Result&)> callback) {
    impl_->render->setFaultCallback(std::move(callback));
}

} // namespace iris
