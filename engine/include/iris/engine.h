// Iris View engine — the public entry point.
//
// An Engine owns a Vulkan device, a render thread, a buffer thread and a loader
// pool. Every member function is thread-safe and may be called in any order from
// any thread. None of them waits on an engine thread, with three documented
// exceptions: open() reads the file's header synchronously so that it can return
// a clear error, unbindSurface() waits until the render thread has released the
// swapchain (the surface must outlive it), and waitForFrame() waits by design.
#pragma once

#include <chrono>
#include <memory>
#include <string>

#include <vulkan/vulkan_core.h>

#include "iris/layers.h"
#include "iris/types.h"

namespace iris {

class AnnotationStore; // iris/annotations.h

// Switches for debugging, A/B benchmarks and device choice. The defaults are what a viewer
// wants. The engine never reads the environment, so a host does not inherit behaviour from
// the shell it was started in and two engines in one process can be set up differently; a
// tool or test that wants the IRIS_* variables maps them with tuningFromEnvironment()
// (iris/environment.h).
struct EngineTuning {
    enum class Pacing {
        Auto, // On for CPU devices (lavapipe, llvmpipe); on a GPU only for frames of 0.25 ms or more
        On,   // while tiles arrive for an unchanged view, draw at most once per 2× the last frame's GPU time
        Off,  // draw on every arrival
    };
    Pacing pacing = Pacing::Auto;
    // Draw coarser tiles also where resident finer tiles cover them completely (the frame is
    // the same; it only costs fill). For tests and benchmarks of the culling.
    bool drawCovered = false;
    // Who makes the tiles' mip levels (the same kernel each way: docs/ENHANCEMENT.md).
    enum class MipSchedule {
        Auto,   // Host for CPU devices, Wide otherwise (and Serial where shared memory is short)
        Wide,   // a compute dispatch, 16 workgroups per tile
        Serial, // a compute dispatch, one workgroup per tile
        Host,   // the buffer thread, on the CPU, uploading them with the base level (no dispatch)
    };
    MipSchedule mipSchedule = MipSchedule::Auto;
    // Use only a Vulkan device whose name contains this (empty: the best one by type).
    std::string deviceName;
    // Every role (draw, mips, uploads) on the graphics queue even where the device has separate
    // compute and transfer families: to run the single-queue path on any device.
    bool singleQueue = false;
    // How the slide's tiles become pixels (docs/ARCHITECTURE.md, "Per-tile quads or a
    // per-pixel resolve"). Quads: one instanced quad per tile and layer, then the seam bands
    // (every target). Compute: one compute pass resolves every pixel through a page table of the
    // frame's resident tiles, finest layer first, filtering across tiles by hand (offscreen
    // targets; a swapchain keeps quads). Auto, as measured: compute for offscreen targets on a
    // GPU (an H100 draws a settled 1080p frame 15× faster so, and its colour step costs
    // nothing visible); on a CPU device whose atlas is written from the host, the resolve on
    // the host (docs/ARCHITECTURE.md, "The resolve on the host"), else quads (lavapipe
    // resolves 3× slower per pixel in a compute pass).
    enum class TileResolve { Auto, Quads, Compute };
    TileResolve tileResolve = TileResolve::Auto;
    // How the colour step interpolates its table (docs/COLOR.md, "Cost"). Sampler: one
    // trilinear fetch, weighted by the sampler's filter (at least 8 fractional bits: at most
    // 1/512 of a node step off the exact weights, far under one 8-bit code). Nodes: the eight
    // nodes around the colour fetched and weighted in 32-bit float (8 fetches; the CPU model's
    // exact weights). Auto: Sampler, measured equal to Nodes within the accuracy tests and
    // 2-3× cheaper per frame on the H200 and on lavapipe.
    enum class ColorLookup { Auto, Sampler, Nodes };
    ColorLookup colorLookup = ColorLookup::Auto;
    // Levels drawn exactly (1:1 on whole pixels, unturned, no colour step) whose tiles are
    // opaque are copied from the atlas into the target (vkCmdCopyImage) instead of drawn, where
    // the target's format is the atlas's. The bytes are the same; the copy skips the
    // rasteriser. Auto: on for CPU devices (lavapipe copies a settled 1080p field about 5x
    // faster than it draws it: docs/BENCHMARKS.md), off for GPUs. With the host mip schedule
    // the atlas and offscreen targets are then BGRA, the order of X11's swapchains, so that
    // windows get the copy too (frames read back are RGBA as always).
    enum class ExactCopy { Auto, On, Off };
    ExactCopy exactCopy = ExactCopy::Auto;
    // How decoded tiles reach the atlas. Queue: staged in a host buffer and copied by a
    // transfer on the device's queue (the only way into a GPU's own memory). Host: the atlas is
    // a linear image in host-visible memory and the buffer thread writes each tile and its
    // levels into it directly, with no command and no queue submission; the next frame's
    // submission makes the writes visible. On a CPU device the device's memory is the host's
    // and its one queue runs the frames: an upload submitted there waited behind a frame in
    // flight (docs/BENCHMARKS.md). Auto: Host for CPU devices whose mips are made on the host
    // and that can sample a linear, host-visible atlas; Queue otherwise. Host chosen: Host
    // wherever the device allows it (else Queue, with a log line).
    enum class TileUpload { Auto, Queue, Host };
    TileUpload tileUpload = TileUpload::Auto;
    // Where a JPEG tile's decode ends (issue 20). Cpu: the loaders decode whole tiles. Gpu: for
    // levels of 256×256 JPEG tiles of the direct TIFF reader (Aperio SVS, generic TIFF) and of
    // .iris files, the loaders only entropy-decode each tile, the RAM cache keeps its
    // coefficients (packed), and the buffer thread's compute pass finishes it into the atlas
    // (dequantisation, inverse DCT, upsampling, colour conversion: libjpeg-turbo's bytes,
    // docs/ARCHITECTURE.md); tiles whose coefficients do not fit a tile buffer even packed
    // (near-lossless streams, noise) and all other sources decode as with Cpu. Gpu needs tiles
    // uploaded by queue copies and mips made on the device (else Cpu, with a log line). Auto:
    // Gpu on GPUs where it can, Cpu on CPU devices (docs/BENCHMARKS.md, "The GPU's share of the
    // decode in the engine").
    enum class JpegDecode { Auto, Cpu, Gpu };
    JpegDecode jpegDecode = JpegDecode::Auto;
    // Fault injection for tests: a device allocation of the tile atlas larger than this many
    // bytes fails as VK_ERROR_OUT_OF_DEVICE_MEMORY would (0: no limit), so that the fallback to a
    // smaller atlas can be tested on any device.
    uint64_t deviceAllocationLimit = 0;
};

struct EngineConfig {
    SourcePreference source = SourcePreference::Auto;
    uint64_t ramBudgetBytes = 1ull << 30;   // decoded tiles kept in RAM
    uint64_t vramBudgetBytes = 512ull << 20; // tile atlas size (slots of 256×256 RGBA8 with mips)
    uint32_t loaderThreads = 0;              // 0: one per hardware thread (two fewer above 4)
    uint32_t perimeterTiles = 1;             // tiles buffered beyond the visible field on each side
    bool validation = false;                 // enable VK_LAYER_KHRONOS_validation when installed
    std::array<float, 3> background{0.96f, 0.96f, 0.96f}; // colour outside the slide: RGB 0..1, written as bytes (round(v·255))
    // Optional: a VkInstance created by the host (for example QVulkanInstance::vkInstance()).
    // The engine then creates its device on it, so that a VkSurfaceKHR of that instance
    // can be bound later. The host keeps it alive until the Engine is destroyed.
    VkInstance instance = VK_NULL_HANDLE;
    // Receives log lines from any engine thread; must be thread-safe and quick.
    LogCallback log;
    EngineTuning tuning;
    ColorSettings color; // colour management, on by default (Engine::setColorSettings)
    NetworkOptions network; // credentials, TLS and timeouts for DICOMweb series URLs given to open()
};

class IRIS_API Engine {
public:
    // Creates the Vulkan device and the engine threads. Fails with a clear message when no
    // Vulkan 1.3 device with the needed features exists.
    static Expected<std::unique_ptr<Engine>> create(const EngineConfig& config);
    ~Engine();
    Engine(const Engine&) = delete;
    Engine& operator=(const Engine&) = delete;

    // --- render target -------------------------------------------------------------
    // Render into an offscreen RGBA8 image that readFrame() returns. With readback off the
    // frames are not copied to the host (readFrame() then has nothing), so frames pipeline
    // like a swapchain's: for benchmarks.
    Result bindOffscreen(uint32_t width, uint32_t height, bool readback = true);
    // Present into a surface (the engine makes the swapchain and presents from its render
    // thread). `instance` must be the one given in EngineConfig::instance, since the device
    // was created on it. width/height are in device pixels.
    Result bindSurface(VkInstance instance, VkSurfaceKHR surface, uint32_t width, uint32_t height);
    // Releases the swapchain (waits for the render thread to do so); the surface may be
    // destroyed once this returns.
    void unbindSurface();
    // New target size in (device) pixels; the view's centre and downsample are kept.
    void resize(uint32_t width, uint32_t height);
    // A hidden target renders nothing (a window that is not exposed).
    void setVisible(bool visible);
    // Draws and presents the current view again although nothing changed: for a window
    // system that dropped the window's pixels (an X11 expose without a compositor). The view,
    // its serial and waitForFrame are unaffected.
    void redraw();

    // --- slide ---------------------------------------------------------------------
    // Opens a slide (replacing the current one) and fits it into the target: a slide file, a
    // DICOM series folder (or one of its files), or a DICOMweb series URL
    // (https://host/prefix/studies/<StudyUID>/series/<SeriesUID>; credentials and TLS from
    // EngineConfig::network or setNetworkOptions(); docs/DICOM.md). A path of the form
    // "synthetic:WIDTHxHEIGHT" opens a procedural test slide of that size. Returns a clear error for missing, unreadable,
    // corrupt or unsupported files and unreachable or refusing servers; on error the previous
    // slide is closed and the engine stays usable.
    Result open(const std::string& path);
    // Credentials, TLS and timeouts for the DICOMweb series URLs given to later open() calls
    // (replacing EngineConfig::network): a host that asks the user for a password after the
    // engine exists sets it here. A slide already open keeps the options it was opened with.
    // Thread-safe; never logged.
    void setNetworkOptions(const NetworkOptions& options);
    void close();
    std::optional<SlideInfo> slideInfo() const;
    // An associated image ("label", "macro", "thumbnail", …; SlideInfo::associatedImages).
    // ImageColors::ForDisplay converts it as the slide's tiles are drawn (the current
    // ColorSettings with the slide's ICC profile, when colorStatus().applied), so that a host
    // showing it beside the slide shows the same colours; AsStored gives the file's pixels.
    Expected<Image> readAssociatedImage(const std::string& name, ImageColors colors = ImageColors::AsStored) const;

    // --- view ----------------------------------------------------------------------
    // Moves the view by (dx, dy) target pixels: the image moves with the pointer, so a
    // positive dx shows what lies further left.
    void translate(double dx, double dy);
    // Multiplies the magnification by factor (>1 zooms in), keeping the level-0 point
    // under the target pixel (anchorX, anchorY) where it is.
    void zoom(double factor, double anchorX, double anchorY);
    // Turns the slide clockwise on screen by `degrees` (negative: anticlockwise) about target
    // pixel (anchorX, anchorY), whose level-0 point stays where it is.
    void rotate(double degrees, double anchorX, double anchorY);
    // The view as given (rotation kept in [0, 360), downsample clamped); View's rotation and
    // flips turn and mirror the slide about the target's centre (ViewTransform maps target
    // pixels to level-0 pixels and back).
    void setView(const View& view);
    View view() const;
    // The view that shows the whole slide in the current target, turned and mirrored as the
    // current view is.
    View fitView() const;
    // Target size in pixels as last bound or resized.
    std::pair<uint32_t, uint32_t> targetSize() const;

    // --- output --------------------------------------------------------------------
    // The last frame in the offscreen target (RGBA8); before the first, NoSlide or NotBound.
    Expected<Frame> readFrame() const;
    // Waits until a frame of the current view with every visible tile resident has been
    // rendered (or until timeout). Returns Timeout, NoSlide, NotBound or the engine error.
    Result waitForFrame(std::chrono::milliseconds timeout);
    // Waits until the engine has nothing left to load for the current view: every tile of its
    // buffer region (the visible tiles of every layer and the perimeter around them), or as
    // many as the atlas holds, is resident, and a complete frame drawn after that has been
    // rendered. Later frames of this view are identical until something changes. For
    // snapshots, batch rendering and tests that must compare settled frames. Returns Timeout,
    // NoSlide, NotBound or the engine error.
    Result waitForSettled(std::chrono::milliseconds timeout);
    // Called on the render thread after each frame is submitted (presented); keep it
    // quick and thread-safe (a Qt host posts a queued signal).
    void setFrameCallback(std::function<void(const FrameStats&)> callback);

    // --- settings ------------------------------------------------------------------
    void setBackground(float r, float g, float b);
    // Reduction-enhancement of mip levels (on by default): every mip level is the area
    // average of the 1× tile plus a normalised difference-of-Gaussians sharpening term
    // (docs/ENHANCEMENT.md); off gives the exact area average. A change re-buffers the tiles.
    void setEnhance(bool on);
    bool enhance() const;
    // Colour management (docs/COLOR.md): the open slide's embedded ICC profile is converted to
    // the display profile in the tile shader, through a lookup table baked with LittleCMS, for
    // the slide's tiles and the overview's thumbnail (never the HUD). On by default
    // (EngineConfig::color). A profile that cannot be used is reported in colorStatus() and
    // the slide is drawn untransformed. Takes effect with the next frame.
    void setColorSettings(const ColorSettings& settings);
    ColorSettings colorSettings() const;
    ColorStatus colorStatus() const;

    // --- overlays ------------------------------------------------------------------
    // The render thread draws the scale bar, the magnification readout, the overview map and
    // the legend over the tiles, alpha-blended on a semi-transparent plate, each in a corner of the
    // target (several in one corner stack inwards, in the order of `Overlay`). All are off
    // by default, so frames hold slide pixels only; nothing is drawn while no slide is open,
    // the scale bar is hidden when the slide states no mpp, the readout when it states
    // neither objective power nor mpp (with mpp alone the objective is taken as 10 µm / mpp,
    // as IrisSlideView's magnification() does), and an overlay that does not fit into the
    // target is left out.
    // The legend describes the topmost layer (raster layers, below) that is visible, has an
    // opacity above 0 and something to show, under the map's title: for a Scalar map, its colour
    // map as a bar from the window's low end to its high end and both numbers; for a Label map,
    // a swatch and the name of each class it draws (visible, not transparent, an id within the
    // map's range), at most 12 rows and then "+N more". Rgba maps are passed over; hidden while
    // no layer qualifies.
    // Turning on a labelled overlay (scale bar, magnification, legend) before any font was chosen
    // looks up the default font on the calling thread (fontconfig; see setOverlayFont).
    void setOverlayVisible(Overlay overlay, bool visible);
    bool overlayVisible(Overlay overlay) const;
    // Defaults: scale bar BottomLeft, magnification TopLeft, overview TopRight, legend BottomRight.
    void setOverlayCorner(Overlay overlay, Corner corner);
    Corner overlayCorner(Overlay overlay) const;
    // Device pixels per logical pixel of the host's window (Qt's devicePixelRatio; 1 by
    // default, clamped to 0.25…8). Overlays are laid out in logical pixels and drawn at
    // device resolution: text is rasterised at pixel size = point size × ratio.
    void setDevicePixelRatio(double ratio);
    double devicePixelRatio() const;
    // The font overlay labels use: a font file FreeType reads (TrueType, OpenType, …), read
    // on the calling thread. An empty path picks the system's default sans-serif through
    // fontconfig (DejaVu Sans). On failure (no such file, not a scalable font, fontconfig
    // finds nothing) the error is returned, logged and recorded (error()), and overlays draw
    // no text until a font loads; they keep drawing everything else.
    Result setOverlayFont(const std::string& path);
    // The overlays of the last frame rendered (into either kind of target): for hit-testing.
    OverlayLayout overlayLayout() const;
    // --- annotations (docs/ANNOTATIONS.md) -------------------------------------------
    // The store whose objects the render thread draws over the slide, under the HUD overlays,
    // in level-0 coordinates of the open slide (null: none, the default). The engine keeps the
    // store alive while it shows it and draws a new frame after every change the store
    // publishes, from any thread; several engines may show one store. Nothing is drawn while
    // no slide is open.
    void setAnnotations(std::shared_ptr<AnnotationStore> store);
    std::shared_ptr<AnnotationStore> annotations() const;
    // Shown by default.
    void setAnnotationsVisible(bool visible);
    bool annotationsVisible() const;
    // The object drawn selected (a contrasting outline and its vertex handles); 0: none.
    void setSelectedAnnotation(uint64_t id);
    uint64_t selectedAnnotation() const;

    // --- raster layers: heat maps and label maps (iris/layers.h, docs/LAYERS.md) -----------
    // A map drawn over the tiles and under the annotations, layers in the order added (a later
    // one over an earlier one), each pixel shaded exactly as shadeLayerAt() says and blended as
    // blendOver() says. `placement` std::nullopt: the map spans the open slide's level 0
    // (Placement::spanning, for whichever slide is open). The map is shared, not copied, unless
    // it has one level over 1024 pixels a side: then the engine draws a copy with coarser levels
    // (withRasterPyramid, made on the calling thread; layers() returns that copy), so that a view
    // of the whole slide needs a small level. Pass a pyramid (a pyramidal TIFF loads as one) to
    // avoid the copy. The engine uploads the parts of the level a view needs. Returns the layer's id (never 0);
    // an empty or inconsistent map (rasterMapProblem) is InvalidArgument.
    Expected<uint64_t> addLayer(std::shared_ptr<const RasterMap> map, const LayerStyle& style = {},
                                std::optional<Placement> placement = std::nullopt);
    // Replaces a shown layer's map (a model streaming its results), style or placement; the
    // next frame shows it. NotFound for an id that is not shown.
    Result setLayerMap(uint64_t id, std::shared_ptr<const RasterMap> map);
    Result setLayerStyle(uint64_t id, const LayerStyle& style);
    Result setLayerPlacement(uint64_t id, std::optional<Placement> placement);
    // Moves a layer to position `index` of the stack (0: the bottom; past the end: the top).
    Result moveLayer(uint64_t id, size_t index);
    void removeLayer(uint64_t id);
    void clearLayers();
    struct LayerEntry {
        uint64_t id = 0;
        std::shared_ptr<const RasterMap> map;
        LayerStyle style;
        std::optional<Placement> placement;
    };
    // The stack, bottom first.
    std::vector<LayerEntry> layers() const;

    // A cross-hair marker over the slide at a level-0 position (a linked view's cursor), drawn
    // over the tiles and the other overlays, turned with the view; std::nullopt hides it
    // (the default).
    void setCrosshair(std::optional<std::array<double, 2>> slidePos);
    std::optional<std::array<double, 2>> crosshair() const;
    // Whether target pixel (x, y) lies on the overview map's thumbnail of the last frame
    // shown for the open slide. If it does and `out` is given, *out is the current view
    // moved to be centred on the slide point under (x, y).
    bool overviewHit(double x, double y, View* out = nullptr) const;

    // --- state ---------------------------------------------------------------------
    // First error wins and sticks until clearError() or a successful open().
    Result error() const;
    void clearError();
    DeviceInfo device() const;
    MemoryStats memoryStats() const;
    // Frame and field-of-view metrics; readable at any time from any thread.
    EngineMetrics metrics() const;
    void resetMetrics();
    // Messages the Vulkan validation layers reported (tests require zero).
    uint64_t validationMessageCount() const;

    // --- faults --------------------------------------------------------------------
    // A lost device (VK_ERROR_DEVICE_LOST from any submit, wait or present: a driver reset, a
    // GPU hang, a removed eGPU) is recovered by the engine itself: error() reports it
    // (Status::DeviceLost) and it is logged; the render thread parks the buffer thread,
    // destroys and recreates the logical device, the tile atlas and every pipeline, binds the
    // same target again and re-buffers the current view from the RAM cache. The host does
    // nothing: its calls meanwhile are kept (views, target requests, waitForFrame), and
    // DeviceInfo::recoveries counts the recoveries. docs/RELIABILITY.md "Device loss".
    //
    // Fault injection, for tests (the host's and the engine's): the next operation of the kind
    // named reports the fault as the driver would. DeviceLost* also makes every later
    // submission fail until the engine has recreated the device, as a real loss does.
    enum class InjectedFault {
        DeviceLostAtFrameSubmit,  // the render thread's next frame submission
        DeviceLostAtUploadSubmit, // the buffer thread's next upload (copy or mip) submission; a
                                  // host-written atlas submits none (EngineTuning::tileUpload)
        DeviceLostAtFrameWait,    // the render thread's next wait on a frame's fence
        DeviceLostAtPresent,      // the next vkQueuePresentKHR (a bound surface only)
        SurfaceLostAtPresent,     // the next vkQueuePresentKHR reports VK_ERROR_SURFACE_LOST_KHR
    };
    void injectFault(InjectedFault fault);
    // Told of faults and recoveries, on an engine thread (quick, thread-safe; a Qt host
    // queues to its own thread): Status::DeviceLost when a lost device is noticed,
    // Status::Ok with a message once it has been recreated, Status::SurfaceLost when the
    // window system took the bound surface away (nothing is drawn until the host binds a new
    // one: unbindSurface(), destroy it, make one, bindSurface()). They also set error().
    void setFaultCallback(std::function<void(const Result&)> callback);

    struct Impl;

private:
    explicit Engine(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

} // namespace iris
