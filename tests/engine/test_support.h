// Shared helpers of the engine suites (tests/engine/tst_*.cpp).
//
// Nothing here uses Qt Test macros: helpers return values or messages and the suites
// assert on them, so that a failure is reported in the test function that made it.
//
//   * where the test data is ($IRIS_TESTDATA, else $IRIS_TESTDATA_DEFAULT; a folder holding
//     slides/), the sample slide ($IRIS_TEST_SAMPLE) and the output folder ($IRIS_TEST_OUT);
//   * an Engine made the way every suite makes it (validation layers on, two loader threads,
//     a log callback that keeps Error lines, a background colour no slide pixel is likely to
//     have);
//   * an OpenSlide reader that returns exact level pixels as straight-alpha RGBA (the
//     reference the engine's frames are compared with);
//   * image comparison, PNG output, and failure artefacts written to $IRIS_TEST_OUT.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <iris/engine.h>

struct _openslide; // openslide_t, kept out of the suites' includes

namespace iristest {

namespace fs = std::filesystem;

// ---- locations ------------------------------------------------------------------------

// The test data folder (it contains slides/): $IRIS_TESTDATA, else $IRIS_TESTDATA_DEFAULT.
// nullopt when neither names a folder with slides/ in it (suites then QSKIP what needs it).
std::optional<fs::path> testDataDir();
// testDataDir()/slides/<sub>, or nullopt.
std::optional<fs::path> slidesDir(const std::string& sub = {});
// $IRIS_TEST_SAMPLE when it is set (the file may be missing: the fixture makes it).
std::optional<fs::path> sampleSlidePath();
// $IRIS_TEST_OUT (created when missing), else <temp>/iris-test-out.
fs::path testOutDir();
// Regular files under dir (recursively when asked), sorted by path.
std::vector<fs::path> filesUnder(const fs::path& dir, bool recursive);

// ---- engine ---------------------------------------------------------------------------

// Log lines of one Engine; the callback may run on any engine thread.
class LogSink {
public:
    void add(iris::LogLevel level, std::string_view line);
    std::vector<std::string> errors() const;        // Error-level lines so far
    std::vector<std::string> takeErrors();          // ... and forget them
    std::size_t errorCount() const;
    std::size_t warningsContaining(std::string_view needle) const; // Warning-level lines so far

private:
    mutable std::mutex mutex_;
    std::vector<std::string> errors_;
    std::vector<std::string> warnings_;
};

// The colour the suites ask the engine to draw outside the slide. Not grey, so that it
// cannot be confused with glass (near-white) or with a black/transparent failure.
inline constexpr std::array<float, 3> kBackground{0.2f, 0.4f, 0.6f};
// EngineConfig::background ×255, rounded: what the RGBA8 target must hold outside the slide.
std::array<uint8_t, 3> backgroundBytes(const std::array<float, 3>& bg = kBackground);

// One engine for a whole suite, and the checks every engine suite makes around each test
// function (call them from Qt Test's init(), cleanup() and cleanupTestCase(); each returns
// what went wrong, empty when nothing did, for QVERIFY2):
//   beginTest()  remembers the validation-message count;
//   endTest()    no validation message during the test, and no Error line logged (or, with
//                ErrorLines::Show, the lines printed: suites of bad input expect them);
//   finish()     closes the slide, no validation message in the whole suite, engine destroyed.
struct TestEngine {
    std::shared_ptr<LogSink> log;
    std::unique_ptr<iris::Engine> engine;
    iris::Result error; // why create() failed
    uint64_t validationBefore = 0; // the count when the current test function began
    explicit operator bool() const { return engine != nullptr; }
    iris::Engine* operator->() const { return engine.get(); }

    enum class ErrorLines { Fail, Show };
    void beginTest();
    std::string endTest(ErrorLines errors = ErrorLines::Fail);
    std::string finish();
};
// EngineConfig{validation = true, loaderThreads = 2, background = kBackground, a log callback
// recording Error lines} plus whatever `base` sets otherwise.
iris::EngineConfig testEngineConfig(const std::shared_ptr<LogSink>& log, iris::EngineConfig base = {});
// An engine of testEngineConfig(base), its tuning taken from the IRIS_* environment variables
// over base.tuning (iris::tuningFromEnvironment: how the GPU runs switch every suite to the
// single-queue path). A bad variable is reported as the creation error.
TestEngine createTestEngine(iris::EngineConfig base = {});

// Whether the Khronos validation layer is installed (the engine enables it when it is;
// without it validationMessageCount() proves nothing, so the suites say so).
bool validationLayerInstalled();

// "Status: message", for failure output.
std::string describe(const iris::Result& r);

// setView(view), waitForFrame(timeout), readFrame(); checks that the frame is complete and
// shows `view` at the bound size. On failure returns the error and explains in *why.
std::optional<iris::Frame> renderView(iris::Engine& engine, const iris::View& view, uint32_t width, uint32_t height,
                                      std::chrono::milliseconds timeout, std::string* why);

// renderView, then Engine::waitForSettled (every tile of the buffer region resident and
// drawn) and the frame read again: what two engines are compared on, in the same state. The
// settled frame must be complete and show `view` like renderView's.
std::optional<iris::Frame> renderSettled(iris::Engine& engine, const iris::View& view, uint32_t width, uint32_t height,
                                         std::chrono::milliseconds timeout, std::string* why);

// The view whose frame (width × height at `downsample`) has its top-left corner at the
// level-0 point (x0, y0): centre = (x0, y0) + (width, height)/2 · downsample.
iris::View viewWithOrigin(double x0, double y0, double downsample, uint32_t width, uint32_t height);
// A view turned by `rotation` (a multiple of 90°) and mirrored as given, at `downsample`,
// whose output pixel (0, 0) shows the centre of pixel (kx, ky) of a level with that
// downsample: every output pixel centre then lands on a level pixel centre.
iris::View turnedViewAt(int64_t kx, int64_t ky, double downsample, double rotation, bool flipH, bool flipV,
                        uint32_t width, uint32_t height);

// ---- images ---------------------------------------------------------------------------

iris::Image makeImage(uint32_t width, uint32_t height, std::array<uint8_t, 4> fill = {0, 0, 0, 0});
inline uint8_t* pixel(iris::Image& img, uint32_t x, uint32_t y) {
    return img.rgba.data() + (std::size_t(y) * img.width + x) * 4;
}
inline const uint8_t* pixel(const iris::Image& img, uint32_t x, uint32_t y) {
    return img.rgba.data() + (std::size_t(y) * img.width + x) * 4;
}

bool writePng(const fs::path& path, const iris::Image& img, std::string* error = nullptr);

// Per-pixel mask: 1 = compare this pixel, 0 = skip it.
using Mask = std::vector<uint8_t>;

struct DiffStats {
    uint64_t compared = 0;   // pixels compared
    uint64_t differing = 0;  // pixels with any compared channel different
    int maxAbs = 0;          // largest channel difference
    double meanAbs = 0;      // mean channel difference over compared pixels and channels
    int p99 = 0;             // 99th / 99.5th percentile of the per-pixel largest channel difference
    int p995 = 0;
    int worstX = -1, worstY = -1; // where maxAbs is (first such pixel)
    std::string summary() const;
};
// Compares the first `channels` channels (3: RGB) of a and b where mask says so (all when null).
DiffStats compareImages(const iris::Image& a, const iris::Image& b, const Mask* mask = nullptr, int channels = 3);
// |a − b| × gain per channel, opaque; pixels outside the mask are drawn dark magenta.
iris::Image diffImage(const iris::Image& a, const iris::Image& b, const Mask* mask, int gain);
// Writes <name>.engine.png, <name>.reference.png and <name>.diff.png into testOutDir()/failures
// and returns a line naming them. `name` is made file-system safe.
std::string saveFailureArtefacts(const std::string& name, const iris::Image& frame, const iris::Image& reference,
                                 const Mask* mask);

// Pixels of `img` (over mask) that are not exactly `rgb` with alpha 255.
uint64_t countNotColour(const iris::Image& img, std::array<uint8_t, 3> rgb, const Mask* mask);
// Pixels of `img` whose alpha is not 255.
uint64_t countNotOpaque(const iris::Image& img);

// ---- OpenSlide reference --------------------------------------------------------------

// An OpenSlide handle that reads exact level pixels.
class OpenSlideRef {
public:
    static std::unique_ptr<OpenSlideRef> open(const fs::path& path, std::string* error);
    ~OpenSlideRef();
    OpenSlideRef(const OpenSlideRef&) = delete;
    OpenSlideRef& operator=(const OpenSlideRef&) = delete;

    int levelCount() const;
    int64_t levelWidth(int level) const;
    int64_t levelHeight(int level) const;
    double levelDownsample(int level) const;
    // openslide.level[N].tile-width/-height (0 when the slide does not say).
    int64_t tileWidth(int level) const;
    int64_t tileHeight(int level) const;
    std::string vendor() const;
    std::string property(const std::string& name) const;
    std::string lastError() const; // openslide_get_error, empty when none
    const fs::path& path() const { return path_; }

    // Level pixels [lx, lx + w) × [ly, ly + h) of `level`, in that level's own pixel
    // coordinates, as straight-alpha RGBA; pixels outside the level are transparent black.
    //
    // OpenSlide 3.4.1's read_region takes level-0 (x, y) and starts reading the level at
    // x / downsample, which is fractional unless downsample divides x: it then resamples the
    // tiles with cairo (bilinear), so the result is not the level's pixels. This reads from
    // the nearest level pixel k ≤ lx at which (double)round(k·ds) / ds == k exactly (k = 0
    // always qualifies) and crops, so every pixel returned is an exact level pixel.
    std::optional<iris::Image> readLevelRegion(int level, int64_t lx, int64_t ly, uint32_t w, uint32_t h,
                                               std::string* error);
    // read_region at level 0 (no alignment question there).
    std::optional<iris::Image> readLevel0(int64_t x, int64_t y, uint32_t w, uint32_t h, std::string* error) {
        return readLevelRegion(0, x, y, w, h, error);
    }

    // Whether OpenSlide 3.4.1 returns this level's true pixels. See
    // shared/testdata/slides/SOURCES.md, "Warning about OpenSlide 3.4.1 on Debian 12": on
    // generic TIFF, libtiff 4.5's TIFFRGBAImageGet adapts the raster width when the tile is
    // larger than the level, and OpenSlide then returns scrambled colours and transparent
    // pixels. Every level listed there as wrong is one whose width or height is smaller than
    // its tile's and whose tiles go through TIFFRGBAImage (not RGB JPEG, which OpenSlide
    // decodes itself); the rule below is that condition, plus the list itself by file name.
    bool levelPixelsTrustworthy(int level, std::string* why) const;

private:
    bool jpegColourTiles(int level) const; // the level's TIFF directory holds RGB/YCbCr JPEG tiles
    OpenSlideRef() = default;
    _openslide* osr_ = nullptr;
    fs::path path_;
};

// OpenSlide handles kept open by path for a suite's rows (opening a slide costs more than a
// row's reads): the first get() opens, later ones return the same handle.
class OpenSlideRefs {
public:
    // Null with *error set when OpenSlide cannot open `path`.
    OpenSlideRef* get(const fs::path& path, std::string* error) {
        if (auto it = refs_.find(path.string()); it != refs_.end()) return it->second.get();
        std::unique_ptr<OpenSlideRef> r = OpenSlideRef::open(path, error);
        OpenSlideRef* raw = r.get();
        if (r) refs_.emplace(path.string(), std::move(r));
        return raw;
    }
    void clear() { refs_.clear(); } // closes them

private:
    std::map<std::string, std::unique_ptr<OpenSlideRef>> refs_;
};

// The ICC profile (TIFF tag 34675) of a TIFF's first directory; empty when it has none.
std::vector<uint8_t> tiffIccProfile(const fs::path& path);

// Writes a one-directory tiled TIFF (256×256 tiles, 8-bit RGB, deflate) of width × height
// whose pixel (x, y) is syntheticPixel's RGB. The tiles listed in `broken` (tile column, row)
// hold bytes that do not inflate: a slide whose reads fail on exactly those tiles. A non-empty
// `icc` is embedded as the slide's ICC profile (TIFF tag 34675). A non-empty `software` and
// `description` become the Software and ImageDescription tags (which OpenSlide reads vendors by).
bool writeOneLevelTiff(const fs::path& path, uint32_t width, uint32_t height,
                       const std::vector<std::pair<uint32_t, uint32_t>>& broken, std::string* error,
                       const std::vector<uint8_t>& icc = {}, const std::string& software = {},
                       const std::string& description = {});

// Writes a tiled TIFF pyramid (256×256 tiles, 8-bit RGB, deflate): one directory per level,
// (width / d) × (height / d) pixels with pixel (x, y) syntheticPixel's RGB at (x · d, y · d),
// the directories after the first marked reduced-resolution images, each with the
// ImageDescription and XMLPacket given (none when empty: the tags vendors are told by).
struct TiffLevel {
    uint32_t downsample = 1;
    std::string description;
    std::string xmlPacket;
};
bool writeTiffPyramid(const fs::path& path, uint32_t width, uint32_t height, const std::vector<TiffLevel>& levels,
                      std::string* error);

// Converts OpenSlide's premultiplied ARGB (native-endian uint32) to straight-alpha RGBA.
void argbPremultipliedToRgba(const uint32_t* src, uint8_t* dst, std::size_t n);

// The level-0 pixel (x, y) of a "synthetic:" slide, written independently of the engine's
// SyntheticSource::pixel (engine/src/slide/synthetic_source.cpp) so that tests can compute any
// expected pixel: a colour ramp, a 256-px checker and a fine diagonal pattern, opaque.
inline void syntheticPixel(int64_t x, int64_t y, uint8_t* p) {
    const bool checker = ((x >> 8) + (y >> 8)) & 1;
    p[0] = uint8_t((x * 255) / 4096 % 256);
    p[1] = uint8_t((y * 255) / 4096 % 256);
    p[2] = uint8_t(checker ? 200 : 60) ^ uint8_t(((x + y) & 7) << 2);
    p[3] = 255;
}

} // namespace iristest
