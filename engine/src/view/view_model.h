// The view model: pure functions from (slide levels, view, target size) to the tiles that
// matter and where they go on screen. Every engine thread runs it on the newest published
// view (pull-style), so nobody holds a work list that can go stale.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "iris/types.h"

namespace iris {

// A tile of the engine's 256×256 grid, with the slide generation it belongs to packed in so
// that a key of a closed slide can never be mistaken for one of the next slide.
struct TileKey {
    static constexpr int kLevelBits = 6, kCoordBits = 21, kGenBits = 16;
    static uint64_t make(uint32_t generation, int level, int64_t tx, int64_t ty) {
        return (uint64_t(generation & 0xFFFF) << 48) | (uint64_t(level & 0x3F) << 42) |
               (uint64_t(ty & 0x1FFFFF) << 21) | uint64_t(tx & 0x1FFFFF);
    }
    static uint32_t generation(uint64_t k) { return uint32_t(k >> 48); }
    static int level(uint64_t k) { return int((k >> 42) & 0x3F); }
    static int64_t ty(uint64_t k) { return int64_t((k >> 21) & 0x1FFFFF); }
    static int64_t tx(uint64_t k) { return int64_t(k & 0x1FFFFF); }
};
inline constexpr int64_t kMaxTilesPerAxis = int64_t(1) << TileKey::kCoordBits;

enum class TileRole : uint8_t { Base, LRVisible, HRVisible, LRPerimeter, HRPerimeter };

struct TileRef {
    uint64_t key;
    int level;
    int64_t tx, ty;
    TileRole role;
};

struct Viewport {
    View view;
    uint32_t width = 0;
    uint32_t height = 0;
};

// The two layers drawn for a view (see docs/ARCHITECTURE.md): HR is the finest level whose
// downsample does not exceed the view's (drawn at ≤ 1:1 through mips; level 0 when zoomed in
// past 1:1), LR is the next coarser one (drawn enlarged), and base is the slide's coarsest
// level, kept resident so the screen is never empty.
struct LevelChoice {
    int hr = 0;
    int lr = -1;   // -1: none (HR is the coarsest level)
    int base = 0;
};
LevelChoice chooseLevels(const SlideInfo& info, double downsample);

struct TileRange {
    int64_t x0 = 0, y0 = 0, x1 = -1, y1 = -1; // inclusive; empty when x1 < x0
    bool empty() const { return x1 < x0 || y1 < y0; }
    int64_t count() const { return empty() ? 0 : (x1 - x0 + 1) * (y1 - y0 + 1); }
    bool contains(int64_t x, int64_t y) const { return x >= x0 && x <= x1 && y >= y0 && y <= y1; }
};
// What a viewport shows of a level (docs/ARCHITECTURE.md, "Rotation"): the target's rectangle
// mapped into the level, turned by the view's rotation, grown by `margin` tiles along its own
// sides. `range` bounds it; when the view is turned by other than a multiple of 90°, tiles of
// the range near its corners lie outside it, and `contains` tells.
struct Footprint {
    TileRange range;
    bool turned = false;          // not a multiple of 90°: test tiles with contains()
    double cx = 0, cy = 0;        // centre, level pixels
    double ux = 1, uy = 0;        // the target's x axis in the level (unit); its y axis is (-uy, ux) or mirrored
    double vx = 0, vy = 1;        // the target's y axis in the level (unit)
    double hu = 0, hv = 0;        // half extents along them, level pixels, margin included
    double reach = 0;             // turned: the filter's reach past pixel centres, level pixels
    // Whether tile (tx, ty) overlaps the footprint (by any area).
    bool contains(int64_t tx, int64_t ty) const;
};
Footprint footprint(const LevelInfo& level, const Viewport& vp, int64_t margin);

// Tiles of `level` that intersect the viewport, grown by `margin` tiles on each side: the
// bounding range of footprint(level, vp, margin).
TileRange visibleTiles(const LevelInfo& level, const Viewport& vp, int64_t margin);

// The view's field in level-0 pixels: the bounding box of the target's footprint (x0, y0, x1, y1).
std::array<double, 4> fieldBounds(const Viewport& vp);

// Moves v's centre so that level-0 point `slide` lies under target position (x, y) (v's
// downsample, rotation and flips as they are).
void keepUnder(View& v, const std::array<double, 2>& slide, double x, double y, const Viewport& vp);

// The base level is kept whole when it has at most this many tiles (else only its visible part).
inline constexpr int64_t kMaxResidentBaseTiles = 256;

// The buffer region in priority order: base, LR visible, HR visible, LR perimeter,
// HR perimeter; within each group nearest the view centre first. No duplicates.
std::vector<TileRef> bufferRegion(const SlideInfo& info, uint32_t generation, const Viewport& vp, int perimeter);

// Where a tile lands: its valid area in the view's unturned frame (target pixels before the
// view's rotation and flips, which the tile shaders apply about the target's centre) and the
// texel scale.
struct TilePlacement {
    double x0, y0, x1, y1; // target pixels, unturned
    double texelsPerPixel; // level pixels per target pixel
    int validW, validH;    // texels of the tile inside the level
};
TilePlacement placeTile(const LevelInfo& level, const Viewport& vp, int64_t tx, int64_t ty);

// The view that fits the whole slide into the target, centred, turned and mirrored as
// `orientation` (its rotation and flips; unturned when not given).
View fitView(const SlideInfo& info, uint32_t width, uint32_t height, const View& orientation = {});
// Clamps a downsample into the range the engine supports for this slide and target.
double clampDownsample(const SlideInfo& info, uint32_t width, uint32_t height, double downsample);

} // namespace iris
