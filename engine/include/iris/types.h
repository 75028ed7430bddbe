// Iris View engine — public value types.
//
// Everything in engine/include/iris/ is public API: Qt-free, exception-free,
// and safe to use from any thread. Coordinates follow OpenSlide's convention:
// "level-0 pixels" are pixels of the slide's full-resolution level, and a
// downsample is level-0 pixels per screen (or level) pixel.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "iris/export.h"

namespace iris {

// What went wrong, as a category a host can branch on. The message says it in words.
enum class Status : int {
    Ok = 0,
    InvalidArgument,    // a call's arguments make no sense (zero size, NaN, …)
    NotFound,           // the path does not exist
    NotAFile,           // the path is a directory or a device
    UnsupportedFormat,  // the file exists but no reader recognises it
    CorruptData,        // the file is recognised but broken (truncated, bad tiles, …)
    IoError,            // the operating system refused a read
    OutOfMemory,
    Vulkan,             // a Vulkan call failed (VkResult in the message)
    DeviceLost,         // the GPU went away; the engine recreates its device (Engine::injectFault)
    NoSlide,            // the call needs an open slide
    NotBound,           // the call needs a render target (offscreen or surface)
    Timeout,
    Cancelled,          // the caller's cancel flag stopped the operation (encodeIris)
    SurfaceLost,        // the window system took the bound surface away: bind a new one
};

IRIS_API const char* statusName(Status s) noexcept;

// The result of a call that can fail: a status and a human-readable message.
class [[nodiscard]] Result {
public:
    Result() = default;
    Result(Status status, std::string message) : status_(status), message_(std::move(message)) {}
    static Result success() { return {}; }

    bool ok() const noexcept { return status_ == Status::Ok; }
    explicit operator bool() const noexcept { return ok(); }
    Status status() const noexcept { return status_; }
    const std::string& message() const noexcept { return message_; }

private:
    Status status_ = Status::Ok;
    std::string message_;
};

// A value or the Result that explains why there is none (std::expected is C++23).
template <class T>
class [[nodiscard]] Expected {
public:
    Expected(T value) : value_(std::move(value)) {}
    Expected(Result error) : error_(std::move(error)) {
        if (error_.ok()) error_ = Result(Status::InvalidArgument, "Expected constructed from a success Result without a value");
    }
    bool ok() const noexcept { return value_.has_value(); }
    explicit operator bool() const noexcept { return ok(); }
    T& value() & { return *value_; }
    const T& value() const& { return *value_; }
    T&& value() && { return std::move(*value_); }
    T* operator->() { return &*value_; }
    const T* operator->() const { return &*value_; }
    T& operator*() { return *value_; }
    const T& operator*() const { return *value_; }
    const Result& error() const noexcept { return error_; }

private:
    std::optional<T> value_;
    Result error_;
};

// Which reader opens a slide file (EngineConfig::source, EncodeOptions::source). Auto: the
// format table's order (fast paths first, OpenSlide last). OpenSlide: always OpenSlide.
// Iris: only .iris files.
enum class SourcePreference { Auto, OpenSlide, Iris };

struct LevelInfo {
    int64_t width = 0;     // pixels of this level
    int64_t height = 0;
    double downsample = 1; // level-0 pixels per pixel of this level
    int64_t tilesX = 0;    // the engine's own 256×256 grid over this level
    int64_t tilesY = 0;
    double mppX = 0;       // microns per pixel of this level (slide mpp × downsample); 0 when unknown
    double mppY = 0;
    double magnification = 0; // objective power at this level (slide power ÷ downsample); 0 when unknown
    // Not stored in the file: the engine computes it (an area average of the coarsest stored
    // level) because the stored pyramid stops while its coarsest level is still too large to
    // keep resident — a slide without reduced levels, for example. See docs/ARCHITECTURE.md.
    bool synthetic = false;
};

struct SlideInfo {
    std::string path;
    std::string vendor;                // "aperio", "generic-tiff", "iris", …
    int64_t width = 0;                 // level-0 dimensions
    int64_t height = 0;
    std::vector<LevelInfo> levels;     // finest first
    double mppX = 0;                   // microns per level-0 pixel; 0 when the slide does not say
    double mppY = 0;
    double objectivePower = 0;         // scanning objective (for example 20 or 40); 0 when unknown
    std::vector<std::pair<std::string, std::string>> properties; // every property, sorted by name
    std::vector<std::string> associatedImages;                     // "label", "macro", "thumbnail", …
    std::vector<uint8_t> iccProfile;   // the embedded ICC colour profile's bytes; empty when none

    // The finest level whose downsample is at most `downsample`: the level the engine draws
    // sharp (its HR layer) at that view downsample, and the one a viewer reads. 0 for a view
    // finer than level 0 (or no levels). See kLevelTolerance.
    int levelFor(double downsample) const;
    // The objective the magnification readouts use: objectivePower when stated, else
    // 10 µm ÷ mpp (a 0.25 µm/px scan is a 40× scan); 0 when the slide states neither.
    double effectiveObjectivePower() const;
};

// Relative tolerance of "this level's downsample equals the view's": a view set to a level's
// downsample must pick that level, also when one of the two went through float32 metadata
// (.iris scales and mpp). One part per million is far below a pixel across any slide's tile.
inline constexpr double kLevelTolerance = 1e-6;

// The objective-power rule of SlideInfo::effectiveObjectivePower for loose fields. Where both
// axes' mpp are given their mean counts (most scanners have square pixels).
inline double effectiveObjectivePower(double objectivePower, double mppX, double mppY) {
    if (objectivePower > 0 && std::isfinite(objectivePower)) return objectivePower;
    const double mpp = (mppX > 0 && mppY > 0) ? (mppX + mppY) / 2 : std::max(mppX, mppY);
    return mpp > 0 && std::isfinite(mpp) ? 10.0 / mpp : 0;
}

inline int SlideInfo::levelFor(double downsample) const {
    int level = 0;
    for (size_t i = 0; i < levels.size(); ++i)
        if (levels[i].downsample <= downsample * (1.0 + kLevelTolerance)) level = int(i);
    return level;
}

inline double SlideInfo::effectiveObjectivePower() const {
    return iris::effectiveObjectivePower(objectivePower, mppX, mppY);
}

// The view: which level-0 point is at the centre of the target, and how many
// level-0 pixels one target pixel covers. The target's size comes from bind/resize.
struct View {
    double centerX = 0;    // level-0 pixels: the slide point at the target's centre
    double centerY = 0;
    double downsample = 1; // level-0 pixels per target pixel
    // The slide turned clockwise on screen by this many degrees about the target's centre;
    // the engine keeps it in [0, 360).
    double rotation = 0;
    // The slide mirrored before it is turned: flipH swaps its left and right, flipV its top
    // and bottom (as seen at rotation 0).
    bool flipH = false;
    bool flipV = false;

    bool operator==(const View&) const = default;
};

// `degrees` brought into [0, 360); a non-finite angle gives 0. An angle within 1e-9° of a
// multiple of 90° is that multiple (a turn made of animated steps lands on it exactly, and
// such views are drawn exactly).
inline double normalizedRotation(double degrees) {
    if (!std::isfinite(degrees)) return 0;
    double r = std::fmod(degrees, 360.0);
    if (r < 0) r += 360.0;
    const double right = std::round(r / 90.0) * 90.0;
    if (std::abs(r - right) < 1e-9) r = right;
    return r >= 360.0 ? 0.0 : r;
}

// The map between target pixels and level-0 slide pixels under a view (docs/ARCHITECTURE.md,
// "Rotation"): slide = centre + downsample · Mᵀ · (target − target centre), where M = R·F turns
// the slide clockwise by the rotation (R) after mirroring it (F). Multiples of 90° use exact
// sines and cosines, so such a view maps pixel centres onto pixel centres as an unturned one
// does.
struct ViewTransform {
    // M, row-major: a target offset (dx, dy) from the target's centre is M · (slide offset) /
    // downsample.
    std::array<double, 4> m{1, 0, 0, 1};
    double centerX = 0, centerY = 0, downsample = 1; // the view's
    double targetCX = 0, targetCY = 0;               // the target's centre, target pixels

    static ViewTransform of(const View& v, double targetWidth, double targetHeight) {
        constexpr double kPi = 3.14159265358979323846;
        ViewTransform t;
        const double r = normalizedRotation(v.rotation);
        double c, s;
        if (r == 0) c = 1, s = 0;
        else if (r == 90) c = 0, s = 1;
        else if (r == 180) c = -1, s = 0;
        else if (r == 270) c = 0, s = -1;
        else c = std::cos(r * (kPi / 180.0)), s = std::sin(r * (kPi / 180.0));
        const double fx = v.flipH ? -1 : 1, fy = v.flipV ? -1 : 1;
        t.m = {c * fx, -s * fy, s * fx, c * fy};
        t.centerX = v.centerX, t.centerY = v.centerY, t.downsample = v.downsample;
        t.targetCX = targetWidth * 0.5, t.targetCY = targetHeight * 0.5;
        return t;
    }
    // Whether the turn is a multiple of 90°: the slide's axes stay on the target's.
    bool axisAligned() const { return (m[0] == 0 || m[1] == 0) && (m[2] == 0 || m[3] == 0); }
    // Whether the view is neither turned nor mirrored.
    bool identity() const { return m[0] == 1 && m[1] == 0 && m[2] == 0 && m[3] == 1; }
    // Level-0 slide position of target position (x, y).
    std::array<double, 2> toSlide(double x, double y) const {
        const double dx = x - targetCX, dy = y - targetCY;
        return {centerX + (m[0] * dx + m[2] * dy) * downsample, centerY + (m[1] * dx + m[3] * dy) * downsample};
    }
    // Target position of level-0 slide position (sx, sy).
    std::array<double, 2> toTarget(double sx, double sy) const {
        const double dx = (sx - centerX) / downsample, dy = (sy - centerY) / downsample;
        return {targetCX + m[0] * dx + m[1] * dy, targetCY + m[2] * dx + m[3] * dy};
    }
};

// An RGBA8 image, rows top to bottom, 4 bytes a pixel, no padding, straight (not premultiplied) alpha.
struct Image {
    uint32_t width = 0;
    uint32_t height = 0;
    std::vector<uint8_t> rgba;
};

// --- colour management (docs/COLOR.md) -------------------------------------------------

// ICC rendering intent of the slide → display transform.
enum class RenderingIntent {
    Perceptual,           // the default
    RelativeColorimetric, // with black-point compensation
};

struct ColorSettings {
    // Apply the slide's embedded ICC profile (on by default). Off, or for a slide without a
    // profile, the slide's bytes are drawn as they are stored.
    bool managed = true;
    // The display's ICC profile (for example X11's _ICC_PROFILE); empty: sRGB.
    std::vector<uint8_t> displayProfile;
    RenderingIntent intent = RenderingIntent::Perceptual;
};

// Which colours Engine::readAssociatedImage returns: the file's, or those the display shows
// the slide's tiles in (the colour transform, when one is applied).
enum class ImageColors { AsStored, ForDisplay };

// What the engine applies now (Engine::colorStatus).
struct ColorStatus {
    bool applied = false;       // the slide's pixels go through a transform
    std::string slideProfile;   // the slide profile's description ("" when it has no profile)
    std::string displayProfile; // the display profile's description
    Result error;               // why a profile could not be used (the slide is then drawn untransformed)
};

// --- network sources (DICOMweb; docs/DICOM.md) ------------------------------------------

// How the engine talks to a DICOMweb server when open() is given a series URL,
// http(s)://host[:port]/<prefix>/studies/<StudyUID>/series/<SeriesUID> (EngineConfig::network).
// Credentials go only to the URL's own scheme, host and port (redirects are not followed) and
// are never logged; a URL with credentials in it (user:password@host) is refused.
struct NetworkOptions {
    std::string username;    // HTTP basic authentication, when not empty
    std::string password;
    std::string bearerToken; // "Authorization: Bearer <token>", when not empty (instead of basic)
    std::string caFile;      // PEM file of the certificate authorities to trust; empty: the system's
    bool verifyTls = true;   // check the server's certificate and host name (off only to debug a server)
    // Plain http:// is accepted for loopback hosts (localhost, 127.0.0.0/8, ::1) only, unless
    // this is set: pixels and credentials then cross the network unencrypted.
    bool allowPlainHttp = false;
    uint32_t connectTimeoutMs = 10000;
    uint32_t requestTimeoutMs = 30000; // one request, from start to the last byte
    uint32_t maxConnections = 6;       // per server over HTTP/1.1 (HTTP/2 multiplexes over one)
    // A folder where the frames fetched are kept, so that a series opened again (in this session
    // or a later one) draws them without asking the server; empty: none are kept. Created when
    // missing, readable by the user alone (frames are patient data); shared safely by several
    // viewers. The series' metadata is still read from the server at each open, so a user it
    // refuses cannot reach the kept frames. A folder that cannot be used is reported in the
    // slide's properties ("dicomweb.FrameCacheError") and the slide opens without it.
    std::string frameCacheDirectory;
    uint64_t frameCacheBytes = uint64_t(2) << 30; // the most the folder holds (least recently used go first)
};

// --- overlays -------------------------------------------------------------------------
// What the render thread can draw over the slide (Engine::setOverlayVisible).
enum class Overlay : int {
    ScaleBar = 0,      // a bar of a round physical length (1, 2 or 5 × 10^n µm), labelled
    Magnification = 1, // the objective magnification of the view ("20.0×")
    Overview = 2,      // a thumbnail of the whole slide with the current field outlined
    Legend = 3,        // the topmost visible layer's key: a heat map's colour bar and window, or a
                       // label map's classes (swatch and name), under the map's title
};
inline constexpr int kOverlayCount = 4;
enum class Corner : int { TopLeft = 0, TopRight = 1, BottomLeft = 2, BottomRight = 3 };

// Target pixels [x, x + width) × [y, y + height). Empty (width or height 0): nothing there.
struct PixelRect {
    int32_t x = 0;
    int32_t y = 0;
    int32_t width = 0;
    int32_t height = 0;
    bool empty() const { return width <= 0 || height <= 0; }
    bool contains(double px, double py) const {
        return !empty() && px >= x && py >= y && px < double(x) + width && py < double(y) + height;
    }
    friend bool operator==(const PixelRect&, const PixelRect&) = default;
};

// Where a frame's overlays are, in target pixels. Every pixel an overlay changes lies inside
// its rectangle (the render thread clips each overlay's drawing to it).
struct OverlayLayout {
    std::array<PixelRect, kOverlayCount> rects{}; // by Overlay; empty: not drawn
    const PixelRect& rect(Overlay o) const { return rects[size_t(o)]; }
    bool text = false;               // labels were drawn (false while no usable font is loaded)
    // Scale bar: its physical length, that length in target pixels (microns / (mppX ×
    // downsample)) and its label ("100 µm", "1 mm"; UTF-8).
    double scaleBarMicrons = 0;
    double scaleBarPixels = 0;
    std::string scaleBarLabel;
    // Magnification: objective × level-0 downsample / view downsample (the objective is the
    // stated objective power, else 10 µm / mpp), and its label.
    double magnification = 0;
    std::string magnificationLabel;
    // Overview: the thumbnail's pixels (the slide's level-0 origin is at its top-left corner),
    // level-0 pixels per thumbnail pixel, and the view's field in target pixels (not clipped;
    // the outline drawn is this rectangle clipped to the thumbnail).
    PixelRect overviewImage;
    double overviewDownsample = 0;
    // The view's field on the thumbnail, target pixels: its corners (target's top-left,
    // top-right, bottom-right, bottom-left; a turned view's field is turned) and their
    // bounding box (x0, y0, x1, y1).
    std::array<double, 8> overviewFieldCorners{};
    std::array<double, 4> overviewField{};
    // Legend: the layer it describes (0: none) and the map's title. For a Scalar layer, the
    // colour bar's pixels (its columns run from the window's low end to its high end) and the
    // window's ends as written. For a Label layer, one row per class drawn, by id: the swatch's
    // pixels, the class id and its name; legendMoreClasses classes were left out ("+N more").
    uint64_t legendLayer = 0;
    std::string legendTitle;
    PixelRect legendBar;
    std::string legendLowLabel;
    std::string legendHighLabel;
    std::vector<PixelRect> legendSwatches;
    std::vector<uint16_t> legendClassIds;
    std::vector<std::string> legendClassNames;
    int legendMoreClasses = 0;
};

// A rendered frame read back from the offscreen target.
struct Frame {
    Image image;
    View view;              // the view this frame shows
    uint64_t serial = 0;    // increases with every frame rendered
    bool complete = false;  // every visible tile of the finest needed level was resident
                            // (and every tile of the overview's thumbnail, when it is shown)
    OverlayLayout overlays; // where this frame's overlays are
};

// Per-frame figures, delivered to the frame callback and kept in Engine::metrics().
struct FrameStats {
    uint64_t serial = 0;
    double intervalMs = 0;       // since the previous frame
    double cpuMs = 0;            // render thread's time recording and submitting this frame
    double gpuMs = -1;           // GPU time of the frame's commands (timestamp queries); -1 when unknown
    uint64_t bytesBuffered = 0;  // tile bytes whose upload (base level + all mips) completed since the previous frame
    double bufferRateGBps = 0;   // bytesBuffered / intervalMs
    uint32_t tilesDrawn = 0;
    uint32_t tilesCopied = 0;    // of tilesDrawn: copied into the target, not drawn (EngineTuning::exactCopy)
    bool complete = false;
    View view;
};

// One move to an entirely new field of view (no pixel overlapping the previous field), timed
// the way the reference paper defines it: from the move call until every LR (resp. HR) tile
// of the new field is drawable on the GPU, as observed by the render thread. Fields whose
// tiles were already resident when the move was made (revisits) are not recorded.
// The stages of a tile's way from the slide to the screen, in order (FieldStats::stages).
enum class TileStage : uint8_t {
    DecodeStart = 0, // a loader thread started reading and decoding the tile
    Decoded = 1,     // its pixels are in the RAM cache
    Staged = 2,      // the buffer thread copied them into staging memory
    Submitted = 3,   // its upload (copy, then the mip pass) was submitted to the GPU
    GpuDone = 4,     // the buffer thread saw that upload and its mips complete
    Drawable = 5,    // frames may draw it (at GpuDone on one queue family; with several, once
                     // the render thread has taken the compute → graphics ownership transfer)
    Shown = 6,       // a frame drew it for the first time (when that frame was submitted)
};
inline constexpr int kTileStageCount = 7;
IRIS_API const char* tileStageName(TileStage stage) noexcept; // "decode_start", "decoded", …

// When the tiles of one field passed one stage: the events between the move and the field's
// completion (HR, or its being superseded), as offsets from the move. tiles = 0: none (the
// times are then -1). Every tile the engine moved meanwhile counts, the perimeter's included.
struct StageTimes {
    uint32_t tiles = 0;
    double firstMs = -1;
    double medianMs = -1;
    double lastMs = -1;
};

struct FieldStats {
    uint64_t id = 0;
    View view;
    double lrTeFovMs = -1;     // -1: the field has no LR level (HR is the coarsest) or was superseded
    double hrTeFovMs = -1;     // -1: superseded by another move before it completed
    uint32_t lrTiles = 0;      // visible tiles of the new field
    uint32_t hrTiles = 0;
    uint32_t tilesBuffered = 0; // tiles uploaded between the move and HR completion, perimeter included
    double lrTptUs = -1;       // TeFOV / tiles buffered by then
    double hrTptUs = -1;
    std::array<StageTimes, kTileStageCount> stages{}; // by TileStage: where the field's time went
    // Tiles the loaders were reading at once, on average, from the move to the last tile they
    // finished before the field was done (DecodeStart to Decoded); -1 when none was read.
    double decodesInFlight = -1;
};

struct EngineMetrics {
    uint64_t frames = 0;
    uint64_t tilesBuffered = 0;    // since create()
    uint64_t bytesBuffered = 0;
    double mipGpuMs = 0;           // GPU time of the mip (reduction-enhancement) dispatches, summed; under
                                   // the host schedule the buffer thread's time making the levels
    uint64_t mipTiles = 0;         // tiles those covered (0: no timestamps on the compute queue)
    // Tiles that a loader copied into staging as it decoded them (GPUs): the time from that
    // copy to the buffer thread taking the tile into an upload, summed, and the tiles.
    double stagedPickupMs = 0;
    uint64_t stagedPickupTiles = 0;
    double prestageCopyMs = 0;    // loaders' copies into staging, summed, and the tiles copied
    uint64_t prestageTiles = 0;
    double decodeMs = 0;          // the loaders' reads and decodes (SlideSource::readTile), summed
    uint64_t decodeTiles = 0;
    // The loaders' time, summed over them: passes that decoded a tile (all of its work), the
    // part of those spent getting a buffer to decode into, passes that found no tile, making
    // the RAM cache's reserve of buffers, asleep. Each pass counts when it ends: a loader asleep
    // now adds its sleep when it wakes (a board read while all sleep lacks their current naps).
    double loaderWorkMs = 0, loaderAcquireMs = 0, loaderSearchMs = 0, loaderReplenishMs = 0, loaderAsleepMs = 0;
    // Uploads through the device's queues: the time from a transaction's submission to the
    // buffer thread seeing it complete, summed, and the transactions (up to 8 tiles each).
    double uploadMs = 0;
    uint64_t uploadTransactions = 0;
    FrameStats lastFrame;
    std::vector<FieldStats> fields; // completed or superseded field moves, oldest first (last 4096)
    uint32_t tileReadsInProgress = 0; // tiles the loader threads are reading and decoding now
};

struct DeviceInfo {
    std::string name;            // VkPhysicalDeviceProperties::deviceName
    std::string driver;          // driver name and version
    uint32_t graphicsFamily = 0; // queue family indices the engine chose
    uint32_t computeFamily = 0;
    uint32_t transferFamily = 0;
    uint32_t atlasSlots = 0;     // tile slots the VRAM budget bought
    std::string mipSchedule;     // "wide" (16 workgroups per tile, GPUs), "serial" (one) or "host" (the CPU, CPU devices)
    std::string tileUpload; // "host" (written into a linear, host-visible atlas: EngineTuning::tileUpload) or "queue"
    std::string jpegDecode; // "gpu" (JPEG tiles finished by the buffer thread's compute pass: EngineTuning::jpegDecode) or "cpu"
    uint32_t recoveries = 0;     // lost devices the engine recreated since create() (Engine::injectFault)
    bool lost = false;           // the device is lost now and not yet recreated
};

// Memory the engine holds, readable at any time.
struct MemoryStats {
    uint64_t ramCacheBytes = 0;   // decoded tiles in the RAM cache plus its recycled buffers
    uint64_t ramBudgetBytes = 0;  // EngineConfig::ramBudgetBytes as applied
    uint64_t vramAtlasBytes = 0;  // the tile atlas, allocated once at create()
    uint32_t atlasSlots = 0;
    uint32_t atlasActive = 0;     // slots holding a drawable tile
};

enum class LogLevel { Debug, Info, Warning, Error };
using LogCallback = std::function<void(LogLevel, std::string_view)>;

} // namespace iris
