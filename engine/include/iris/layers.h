// Iris View engine — raster layers (issue 19): AI heat maps, probability maps and label maps
// drawn over the slide. This header is the data side: the map model, its placement on the
// slide, colour maps, the style, the file loaders, and the CPU reference of the shading that
// the GPU layer pass implements and is tested against. Qt-free and Vulkan-free;
// docs/LAYERS.md describes the placement rule, the formats and limits and the exact math.
//
// Threads: everything here is a value or a pure function. RasterMap, ColorMap and LayerStyle are
// plain values (copy them to hand them to another thread); loadRasterMap and the fromHostMemory
// helpers keep no shared state and may run on any thread at once.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "iris/annotations.h" // Rgba8
#include "iris/export.h"
#include "iris/types.h"

namespace iris {

// ---- The map -----------------------------------------------------------------------------------

enum class RasterKind : uint8_t {
    Scalar, // float32 values (a probability, a score); NaN means "no data" and is never drawn
    Label,  // uint16 class ids (a segmentation); drawn through LayerStyle::classes
    Rgba,   // 8-bit sRGB RGBA, straight (not premultiplied) alpha: a map that is already coloured
};
IRIS_API const char* rasterKindName(RasterKind k) noexcept;

// The pixels of a level that is not held in memory but read when needed: a large map streamed
// from its file (loadRasterMap streams TIFF levels over RasterLoadOptions::streamAbove), or a
// coarser level made from a finer one on demand. The engine reads it on a worker thread, never
// on the render thread; the CPU reference reads it too. Implementations are thread-safe.
class IRIS_API RasterPixelSource {
public:
    virtual ~RasterPixelSource();
    // The rectangle [x, x + w) × [y, y + h) of the level (the caller keeps it inside the level)
    // into `out`: w·h pixels of the map's kind, rows tightly packed, top row first (float for
    // Scalar, uint16_t for Label, 4 bytes R G B A for Rgba). An error (the file changed or went
    // away since it was opened, a tile that no longer decodes) names the file and the place.
    virtual Result read(int32_t x, int32_t y, int32_t w, int32_t h, void* out) const = 0;
};

// One resolution of a map: width × height pixels, row-major, top row first. Held in memory:
// only the vector of the map's kind is filled, `scalar` (width·height), `label` (width·height)
// or `rgba` (4·width·height, R G B A per pixel). Streamed: `source` is set and every vector is
// empty.
struct RasterLevel {
    int32_t width = 0;
    int32_t height = 0;
    std::vector<float> scalar;
    std::vector<uint16_t> label;
    std::vector<uint8_t> rgba;
    std::shared_ptr<const RasterPixelSource> source;

    bool streamed() const noexcept { return source != nullptr; }
};

// Hard limits of a map, whatever the source (file or host memory): a side over kMaxRasterSide
// pixels, or more than kMaxRasterBytes of decoded pixels held in memory over all levels (4 bytes
// a Scalar or Rgba pixel, 2 a Label pixel), is refused before anything that large is
// allocated. Streamed levels are not held: all levels together, streamed or not, may need up
// to kMaxStreamedRasterBytes decoded (a load reads each streamed level once, to check it).
inline constexpr int32_t kMaxRasterSide = 131072;
inline constexpr uint64_t kMaxRasterBytes = uint64_t(1) << 30;
inline constexpr uint64_t kMaxStreamedRasterBytes = uint64_t(32) << 30;

// A map: one or more levels, finest first. Each level stores its own size, any ratio to the
// one before (a pyramid of ≈ /2 levels, or levels a writer rounded differently); each level
// covers the same extent as level 0, so level k's pixel (i, j) covers level-0 map coordinates
// [i·W0/Wk, (i+1)·W0/Wk) × [j·H0/Hk, (j+1)·H0/Hk). Every level is no larger than the one
// before on both sides and smaller on at least one.
struct IRIS_API RasterMap {
    RasterKind kind = RasterKind::Scalar;
    std::vector<RasterLevel> levels;
    // The range found in the data: Scalar, over every level's values, NaN ignored (both NaN
    // when the map holds no value at all); Label, the smallest and largest id; Rgba, 0 and 255.
    double minValue = std::numeric_limits<double>::quiet_NaN();
    double maxValue = std::numeric_limits<double>::quiet_NaN();
    std::string title; // the legend's title; loaders set the file's name unless told otherwise

    int32_t width() const { return levels.empty() ? 0 : levels.front().width; }
    int32_t height() const { return levels.empty() ? 0 : levels.front().height; }
    uint64_t decodedBytes() const noexcept;  // every level's pixels, streamed or held
    uint64_t residentBytes() const noexcept; // the held levels' pixels
    bool streamed() const noexcept;          // any level is streamed
};

// Reads the rectangle [x, x + w) × [y, y + h) of `level` (held or streamed) into `out`, as
// RasterPixelSource::read does; InvalidArgument for a rectangle outside the level.
IRIS_API Result readRasterRegion(const RasterMap& map, int level, int32_t x, int32_t y, int32_t w, int32_t h,
                                 void* out);

// Why `map` is not a usable map ("" when it is): no level, a level of zero or negative size or
// over kMaxRasterSide, a level not smaller than the one before, pixel vectors of the wrong
// length or of another kind (none for a streamed level), an infinite Scalar value held, more
// than kMaxRasterBytes held or kMaxStreamedRasterBytes in all. Streamed levels are not read.
IRIS_API std::string rasterMapProblem(const RasterMap& map);

// ---- From host memory (a model streaming results through the API) -------------------------------
//
// Each copies tightly packed rows (row-major, top row first), checks the map as
// rasterMapProblem does (InvalidArgument naming the problem), computes minValue/maxValue and
// returns a one-level map. The last takes whole levels (moved in, no copy) for a pyramid.
IRIS_API Expected<RasterMap> fromHostMemory(std::span<const float> values, int32_t width, int32_t height,
                                            std::string title = {});
IRIS_API Expected<RasterMap> fromHostMemory(std::span<const uint16_t> labels, int32_t width, int32_t height,
                                            std::string title = {});
IRIS_API Expected<RasterMap> fromHostMemoryRgba(std::span<const uint8_t> rgba, int32_t width, int32_t height,
                                                std::string title = {});
IRIS_API Expected<RasterMap> fromHostMemory(RasterKind kind, std::vector<RasterLevel> levels, std::string title = {});

// ---- Loading from files --------------------------------------------------------------------------

// A copy of `map` with coarser levels added below its last one, each half the previous (sides
// rounded up) until both sides are at most `coarsest`, while the whole map stays within
// kMaxRasterBytes: what the engine draws a large single-level map from at low magnification
// (Engine::addLayer adds them to maps of one level over 1024 pixels a side). A map that already
// has more than one level is returned as it is. Each new pixel comes from the 2 × 2 it covers
// (fewer at an odd edge): Scalar, the mean of its values that are not NaN (NaN when all are);
// Label, the most frequent id (the smallest among equals); Rgba, the mean of premultiplied
// colours, unpremultiplied and rounded. When the last level is streamed, the new levels of
// over 32 MiB are streamed too (each pixel made from the finer level when it is read, by the same
// rule) and the first one within it is made here, reading the finer levels once.
IRIS_API RasterMap withRasterPyramid(RasterMap map, int32_t coarsest = 512);

struct RasterLoadOptions {
    bool asLabels = false; // a single-channel integer file is a Label map (class ids), not Scalar
    std::string title;     // "" = the file's name without its folder
    // Limits below the hard ones (never above: larger values are clamped to kMaxRaster*).
    int32_t maxSide = kMaxRasterSide;
    uint64_t maxBytes = kMaxRasterBytes;
    // A tiled or stripped TIFF whose levels need more than this decoded (all levels together)
    // is streamed, not read into memory: its levels over streamAbove / 8 (at most 32 MiB) stay
    // in the file and are read a region at a time when a view needs them; the smaller ones,
    // and the coarser levels made down to 512 pixels a side when the file has none, are held.
    // The load still reads every pixel once, to check the values and find the range.
    uint64_t streamAbove = uint64_t(256) << 20;
};

// Reads a map, choosing the reader by the file's first bytes (never its extension):
//   PNG (libpng): 1–16-bit grey → Scalar (0..255 or 0..65535) or Label (asLabels); palette →
//     Rgba, or its indices as Label (asLabels); grey+alpha, RGB, RGBA → Rgba (16-bit channels
//     scaled to 8 with rounding). Interlaced files are read too.
//   TIFF (libtiff): strips or tiles, any compression libtiff decodes; one sample of 8/16/32-bit
//     unsigned or signed integers or 32/64-bit float → Scalar (integers: Label with asLabels);
//     RGB/RGBA 8-bit contiguous, or a palette → Rgba. A pyramid: the first image, then every
//     SubIFD and further IFD, in file order, that is smaller than the last level taken and of
//     the same kind becomes a level; others (a mask, a thumbnail of another kind) are skipped.
//     Over options.streamAbove decoded, the file is streamed (see there): the map's large
//     levels read from the file, which stays open, when a view needs them.
//   NumPy .npy (versions 1.0, 2.0, 3.0): a 2-D array of <f4 >f4 <f8 >f8 (and f2), b1, i1 i2 i4
//     i8, u1 u2 u4 u8 in either byte order, C or Fortran order → Scalar (Label with asLabels:
//     integers 0..65535 only).
// Refused with a message naming the file and the problem (never a crash, never an allocation
// sized by the file beyond the limits): an unknown format (UnsupportedFormat), a layout this
// reader does not take (UnsupportedFormat: 3-D arrays, planar RGB, 12-bit samples…), a size
// over the limits (UnsupportedFormat), truncated or inconsistent data (CorruptData), an
// infinite value (CorruptData; NaN is "no data" and fine), a Label value outside 0..65535.
IRIS_API Expected<RasterMap> loadRasterMap(const std::string& path, const RasterLoadOptions& options = {});
// The same over bytes already in memory (never streamed); `name` stands for the file in messages.
IRIS_API Expected<RasterMap> loadRasterMapFromMemory(std::span<const uint8_t> bytes, const std::string& name,
                                                     const RasterLoadOptions& options = {});

// ---- Placement ------------------------------------------------------------------------------------
//
// Where the map lies on the slide: an affine map from map coordinates of the finest level to
// level-0 slide pixels,
//     slideX = m[0]·x + m[1]·y + m[2]
//     slideY = m[3]·x + m[4]·y + m[5]
// Map coordinates are continuous: map pixel i covers [i, i+1), so its centre is i + 0.5, and the
// map covers [0, W) × [0, H). Slide coordinates follow the same rule (level-0 pixel i covers
// [i, i+1)). Rotation and shear are allowed; a singular or non-finite matrix places nothing.
// The layer's placed rectangle is the image of [0, W) × [0, H); nothing of the layer is drawn
// outside it.
struct IRIS_API Placement {
    std::array<double, 6> m{1, 0, 0, 0, 1, 0}; // identity: one map pixel per level-0 pixel

    // The default placement of a loaded map: the map spans the slide's whole level-0 extent,
    // each of its W × H pixels covering slideW/W × slideH/H level-0 pixels (the usual layout
    // of a patch-level model's output), no offset.
    static Placement spanning(int64_t mapWidth, int64_t mapHeight, int64_t slideWidth, int64_t slideHeight) noexcept;
    // Scale, then rotate by `degrees` (clockwise on screen, y down) about map point (0, 0),
    // then translate by (offsetX, offsetY).
    static Placement scaleRotateOffset(double scaleX, double scaleY, double degrees, double offsetX,
                                       double offsetY) noexcept;

    // Level-0 point → finest-level map coordinates; none when the matrix is singular.
    std::optional<std::array<double, 2>> toMap(double slideX, double slideY) const noexcept;
    std::array<double, 2> toSlide(double mapX, double mapY) const noexcept;
    // The axis-aligned level-0 bounds of the placed rectangle of a W × H map.
    Box2 bounds(int64_t mapWidth, int64_t mapHeight) const noexcept;
};

// ---- Colour maps ----------------------------------------------------------------------------------

// 256 sRGB RGBA8 entries, straight alpha; entry 0 colours the window's low end, 255 its high end.
struct IRIS_API ColorMap {
    std::string name;
    std::array<Rgba8, 256> entries{};

    // The map at t (clamped to [0, 1]; NaN: 0): p = 255·t, linear between entries floor(p) and the next
    // (R, G, B, A as codes 0..255, reals), as the layer pass and the legend colour with it.
    std::array<double, 4> at(double t) const noexcept;

    // matplotlib's viridis and magma (CC0): the published float tables, each value v as the
    // code round(255·v) (viridis[0] = #440154, [128] = #21918c, [255] = #fde725).
    static ColorMap viridis();
    static ColorMap magma();
    // matplotlib's jet: its piecewise-linear segments evaluated at i/255, rounded the same way.
    static ColorMap jet();
    // Grey ramp: entry i = (i, i, i, 255).
    static ColorMap gray();
    // By name ("viridis", "magma", "jet", "gray"/"grey"); none for another name.
    static std::optional<ColorMap> builtin(std::string_view name);

    // A user LUT from a file, by content: a PNG strip of 256×1 or 1×256 pixels (any PNG colour
    // type; alpha taken when present), or text: exactly 256 entries "r g b" or "r g b a" of
    // integers 0..255, one a line; blank lines and lines starting with '#' are ignored.
    static Expected<ColorMap> fromFile(const std::string& path);
    // The same over bytes in memory; `name` names them in messages and becomes the map's name.
    static Expected<ColorMap> fromMemory(std::span<const uint8_t> bytes, const std::string& name);
};

// ---- Style ----------------------------------------------------------------------------------------

enum class LayerSampling : uint8_t { Bilinear, Nearest };

// One class of a label map: its colour (alpha counts: opacity × alpha/255) and whether it is drawn.
struct LabelClass {
    std::string name;
    Rgba8 color;
    bool visible = true;
};

struct LayerStyle {
    bool visible = true;
    double opacity = 0.5;                   // 0..1 (clamped)
    ColorMap colorMap = ColorMap::viridis(); // Scalar maps
    // The window: values from `low` to `high` go linearly to the colour map's 0..1, clamped
    // outside. NaN (the default): the map's minValue / maxValue.
    double low = std::numeric_limits<double>::quiet_NaN();
    double high = std::numeric_limits<double>::quiet_NaN();
    // Scalar values below it are transparent (tested on the interpolated value, before the window).
    double threshold = -std::numeric_limits<double>::infinity();
    LayerSampling sampling = LayerSampling::Bilinear; // Scalar and Rgba maps; Label maps: always nearest
    // Label maps: classes[id] colours id; an id beyond the table is transparent.
    std::vector<LabelClass> classes;
};

// A class table of `count` ids: id 0 "background", invisible; ids 1.. in a fixed palette of 20
// distinct colours (repeating), alpha 255, named "class <id>".
IRIS_API std::vector<LabelClass> defaultLabelClasses(int count);

// ---- The CPU reference of the layer pass ----------------------------------------------------------
//
// Level choice (also the GPU pass's): the map pixel of level k measures, in level-0 pixels,
// sx·W0/Wk along the map's x axis and sy·H0/Hk along y, where sx = hypot(m[0], m[3]) and
// sy = hypot(m[1], m[4]); divided by `downsample` (level-0 pixels per screen pixel) that is its
// size on screen. The level drawn is the finest whose pixel is at least one screen pixel along
// both axes (min(...) ≥ 1 − 1e−9, so that an exact 1:1 is not lost to rounding), or the
// coarsest level when none is: like a mip pick, a map pixel is never smaller than a screen
// pixel unless the map has no coarser level. A `downsample` that is not > 0 picks level 0.
IRIS_API int chooseRasterLevel(const RasterMap& map, const Placement& placement, double downsample) noexcept;

// What the layer contributes at level-0 point (slideX, slideY) (the GPU pass evaluates it at
// each screen pixel's centre) viewed at `downsample`: STRAIGHT (not premultiplied) sRGB RGBA8;
// {0, 0, 0, 0} for nothing. In order:
//  1. Invisible style, opacity 0, a singular placement, or no level: nothing.
//  2. (x, y) = placement.toMap(slideX, slideY). Outside [0, W0) × [0, H0): nothing.
//  3. k = chooseRasterLevel; u = x·Wk/W0, v = y·Hk/H0 (level-k coordinates).
//  4. Sampling. Nearest (always for Label maps): the pixel (floor(u), floor(v)), clamped into the
//     level. Bilinear: s = u − 0.5, t = v − 0.5, i = floor(s), j = floor(t), fx = s − i,
//     fy = t − j; taps (i, j), (i+1, j), (i, j+1), (i+1, j+1), each clamped into the level
//     (clamp-to-edge); value = (1−fy)((1−fx)·v00 + fx·v10) + fy((1−fx)·v01 + fx·v11).
//  5. Scalar: a NaN in any tap used (1 or 4, whatever its weight): nothing. value < threshold:
//     nothing. t = clamp((value − low)/(high − low), 0, 1), low/high resolved from the map
//     when NaN; when high ≤ low, t = (value ≥ high ? 1 : 0). p = 255·t, i0 = floor(p),
//     i1 = min(i0 + 1, 255), f = p − i0; colour = (1−f)·entry[i0] + f·entry[i1] per channel
//     (R, G, B and A, codes 0..255 as reals).
//     Label: id = the tap; id ≥ classes.size() or the class invisible: nothing; colour = its colour.
//     Rgba: bilinear on premultiplied values (each tap's RGB × A/255, then the weighted sum, then
//     RGB divided by the summed A, nothing when it is 0); nearest takes the tap as it is.
//  6. alpha = clamp(opacity, 0, 1) × colour.A / 255.
//  7. Result: R, G, B = floor(colour + 0.5) (clamped to 0..255), A = floor(255·alpha + 0.5).
// Everything is computed in double; the GPU computes in float32, which moves a result by less
// than one code except where a value sits on the threshold or a window edge. Frames are
// compared to this function within ±2 codes.
IRIS_API std::array<uint8_t, 4> shadeLayerAt(const RasterMap& map, const Placement& placement,
                                              const LayerStyle& style, double slideX, double slideY,
                                              double downsample) noexcept;

// The layer (straight RGBA8, as shadeLayerAt returns) over an opaque sRGB RGB8 pixel, on the
// encoded 8-bit values (the engine's UNORM targets blend so):
//     out = (src·A + dst·(255 − A) + 127) / 255   (integer division, each channel)
// which is round-to-nearest of src·A/255 + dst·(1 − A/255) (no tie can occur). Several
// layers stack by applying it in their order, bottom first.
IRIS_API std::array<uint8_t, 3> blendOver(std::array<uint8_t, 3> dst, std::array<uint8_t, 4> layer) noexcept;

} // namespace iris
