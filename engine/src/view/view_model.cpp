#include "view/view_model.h"

#include <algorithm>
#include <cmath>
#include <unordered_set>

#include "slide/slide_source.h"

namespace iris {

LevelChoice chooseLevels(const SlideInfo& info, double downsample) {
    LevelChoice c;
    const int n = int(info.levels.size());
    c.base = n - 1;
    c.hr = info.levelFor(downsample);
    c.lr = c.hr + 1 < n ? c.hr + 1 : -1;
    return c;
}

Footprint footprint(const LevelInfo& level, const Viewport& vp, int64_t margin) {
    Footprint f;
    if (vp.width == 0 || vp.height == 0 || level.tilesX == 0) return f;
    const ViewTransform t = ViewTransform::of(vp.view, vp.width, vp.height);
    const double s = vp.view.downsample / level.downsample; // level px per target px
    // The target's axes in the level (Mᵀ's columns) and the footprint's bounding box, in
    // target pixels along the level's axes. Unturned or turned by a multiple of 90°, the box
    // is the footprint and the expressions reduce exactly to the unturned ones.
    f.ux = t.m[0], f.uy = t.m[1], f.vx = t.m[2], f.vy = t.m[3];
    const double bw = std::abs(t.m[0]) * vp.width + std::abs(t.m[2]) * vp.height;
    const double bh = std::abs(t.m[1]) * vp.width + std::abs(t.m[3]) * vp.height;
    double ox = (vp.view.centerX - bw * 0.5 * vp.view.downsample) / level.downsample;
    double oy = (vp.view.centerY - bh * 0.5 * vp.view.downsample) / level.downsample;
    f.turned = !t.axisAligned();
    double ex = ox + bw * s, ey = oy + bh * s;
    f.cx = vp.view.centerX / level.downsample;
    f.cy = vp.view.centerY / level.downsample;
    f.hu = vp.width * 0.5 * s + double(margin * kTileSize);
    f.hv = vp.height * 0.5 * s + double(margin * kTileSize);
    if (f.turned) {
        // The filter reads texels up to half a texel of the coarsest mip it samples from each
        // pixel centre, along the level's axes: at a turned field's edge that reaches tiles the
        // field itself does not overlap (a tile across the corner of a pixel's tap box). They
        // are part of what the view shows: the footprint is grown by that reach (a box, the
        // tile's own shape) so they are loaded and waited for like the others.
        const double lod = std::max(0.0, std::log2(s));
        f.reach = 0.5 * std::exp2(std::min(std::ceil(lod), 8.0));
    }
    // A tile is visible when it overlaps [o, e) by any amount.
    const auto lo = [](double v) { return int64_t(std::floor(v / kTileSize)); };
    const auto hi = [](double v) { return int64_t(std::ceil(v / kTileSize)) - 1; };
    TileRange& r = f.range;
    ox -= f.reach, oy -= f.reach, ex += f.reach, ey += f.reach;
    // A turned footprint grown along its own sides reaches further along the level's axes.
    const int64_t growX = f.turned ? int64_t(std::ceil(margin * (std::abs(f.ux) + std::abs(f.vx) + 1e-9))) : margin;
    const int64_t growY = f.turned ? int64_t(std::ceil(margin * (std::abs(f.uy) + std::abs(f.vy) + 1e-9))) : margin;
    r.x0 = std::max<int64_t>(0, lo(ox) - growX);
    r.y0 = std::max<int64_t>(0, lo(oy) - growY);
    r.x1 = std::min<int64_t>(level.tilesX - 1, hi(ex) + growX);
    r.y1 = std::min<int64_t>(level.tilesY - 1, hi(ey) + growY);
    if (ex <= 0 || ey <= 0 || ox >= double(level.width) || oy >= double(level.height)) {
        if (margin == 0) r = TileRange{};
    }
    return f;
}

bool Footprint::contains(int64_t tx, int64_t ty) const {
    if (!range.contains(tx, ty)) return false;
    if (!turned) return true;
    // Separating axes: the level's (the range) and the footprint's own two; the tile grown by
    // the filter's reach (the footprint grown by a box of that size).
    const double half = kTileSize * 0.5, h = half + reach;
    const double dx = (double(tx) * kTileSize + half) - cx, dy = (double(ty) * kTileSize + half) - cy;
    const double du = std::abs(dx * ux + dy * uy), rU = h * (std::abs(ux) + std::abs(uy));
    const double dv = std::abs(dx * vx + dy * vy), rV = h * (std::abs(vx) + std::abs(vy));
    return du < hu + rU && dv < hv + rV;
}

TileRange visibleTiles(const LevelInfo& level, const Viewport& vp, int64_t margin) {
    return footprint(level, vp, margin).range;
}

std::array<double, 4> fieldBounds(const Viewport& vp) {
    const ViewTransform t = ViewTransform::of(vp.view, vp.width, vp.height);
    const double bw = std::abs(t.m[0]) * vp.width + std::abs(t.m[2]) * vp.height;
    const double bh = std::abs(t.m[1]) * vp.width + std::abs(t.m[3]) * vp.height;
    const double ds = vp.view.downsample;
    return {vp.view.centerX - bw * 0.5 * ds, vp.view.centerY - bh * 0.5 * ds, vp.view.centerX + bw * 0.5 * ds,
            vp.view.centerY + bh * 0.5 * ds};
}

void keepUnder(View& v, const std::array<double, 2>& slide, double x, double y, const Viewport& vp) {
    const ViewTransform t = ViewTransform::of(v, vp.width, vp.height);
    const double dx = x - t.targetCX, dy = y - t.targetCY;
    v.centerX = slide[0] - (t.m[0] * dx + t.m[2] * dy) * v.downsample;
    v.centerY = slide[1] - (t.m[1] * dx + t.m[3] * dy) * v.downsample;
}

namespace {

void appendRange(std::vector<TileRef>& out, std::unordered_set<uint64_t>& seen, const LevelInfo& level, int li,
                 uint32_t gen, const Footprint& area, const Footprint* exclude, const Viewport& vp, TileRole role) {
    const TileRange& range = area.range;
    if (range.empty()) return;
    const size_t first = out.size();
    // Centre of the view in this level's tile units, to order by distance.
    const double cx = vp.view.centerX / level.downsample / kTileSize - 0.5;
    const double cy = vp.view.centerY / level.downsample / kTileSize - 0.5;
    for (int64_t y = range.y0; y <= range.y1; ++y) {
        for (int64_t x = range.x0; x <= range.x1; ++x) {
            if (!area.contains(x, y) || (exclude && exclude->contains(x, y))) continue;
            const uint64_t k = TileKey::make(gen, li, x, y);
            if (!seen.insert(k).second) continue;
            out.push_back({k, li, x, y, role});
        }
    }
    std::sort(out.begin() + long(first), out.end(), [&](const TileRef& a, const TileRef& b) {
        const double da = (a.tx - cx) * (a.tx - cx) + (a.ty - cy) * (a.ty - cy);
        const double db = (b.tx - cx) * (b.tx - cx) + (b.ty - cy) * (b.ty - cy);
        return da < db;
    });
}

} // namespace

std::vector<TileRef> bufferRegion(const SlideInfo& info, uint32_t gen, const Viewport& vp, int perimeter) {
    std::vector<TileRef> out;
    if (info.levels.empty() || vp.width == 0 || vp.height == 0) return out;
    std::unordered_set<uint64_t> seen;
    const LevelChoice c = chooseLevels(info, vp.view.downsample);
    const LevelInfo& base = info.levels[size_t(c.base)];
    const auto appendBase = [&] {
        if (base.tilesX * base.tilesY <= kMaxResidentBaseTiles) {
            Footprint whole;
            whole.range = TileRange{0, 0, base.tilesX - 1, base.tilesY - 1};
            appendRange(out, seen, base, c.base, gen, whole, nullptr, vp, TileRole::Base);
        } else {
            appendRange(out, seen, base, c.base, gen, footprint(base, vp, 0), nullptr, vp, TileRole::Base);
        }
    };
    // A stored base costs one tile read per tile and comes first: the screen is never empty.
    // A synthetic base (pyramid_source.h) costs 4^k stored tiles per tile — minutes for a very
    // large slide without reduced levels — so while the view draws stored levels, their
    // visible and perimeter tiles come first and the base fills in behind them.
    const bool baseLast = base.synthetic && !info.levels[size_t(c.hr)].synthetic;
    if (!baseLast) appendBase();
    const LevelInfo& hr = info.levels[size_t(c.hr)];
    const Footprint hrVis = footprint(hr, vp, 0);
    Footprint lrVis;
    if (c.lr >= 0) {
        lrVis = footprint(info.levels[size_t(c.lr)], vp, 0);
        appendRange(out, seen, info.levels[size_t(c.lr)], c.lr, gen, lrVis, nullptr, vp, TileRole::LRVisible);
    }
    appendRange(out, seen, hr, c.hr, gen, hrVis, nullptr, vp, TileRole::HRVisible);
    if (perimeter > 0) {
        if (c.lr >= 0) {
            appendRange(out, seen, info.levels[size_t(c.lr)], c.lr, gen,
                        footprint(info.levels[size_t(c.lr)], vp, perimeter), &lrVis, vp, TileRole::LRPerimeter);
        }
        appendRange(out, seen, hr, c.hr, gen, footprint(hr, vp, perimeter), &hrVis, vp, TileRole::HRPerimeter);
    }
    if (baseLast) appendBase();
    return out;
}

TilePlacement placeTile(const LevelInfo& level, const Viewport& vp, int64_t tx, int64_t ty) {
    TilePlacement p{};
    const double s = level.downsample / vp.view.downsample; // target px per level px
    const double ox = (vp.view.centerX - vp.width * 0.5 * vp.view.downsample) / level.downsample;
    const double oy = (vp.view.centerY - vp.height * 0.5 * vp.view.downsample) / level.downsample;
    const int64_t lx0 = tx * kTileSize, ly0 = ty * kTileSize;
    const int64_t lx1 = std::min<int64_t>(lx0 + kTileSize, level.width);
    const int64_t ly1 = std::min<int64_t>(ly0 + kTileSize, level.height);
    // Shared edges are computed by the same expression in both neighbours, so they are
    // bit-identical and the rasteriser's top-left rule leaves no gap and no overlap.
    p.x0 = (double(lx0) - ox) * s;
    p.y0 = (double(ly0) - oy) * s;
    p.x1 = (double(lx1) - ox) * s;
    p.y1 = (double(ly1) - oy) * s;
    p.texelsPerPixel = vp.view.downsample / level.downsample;
    p.validW = int(lx1 - lx0);
    p.validH = int(ly1 - ly0);
    return p;
}

View fitView(const SlideInfo& info, uint32_t width, uint32_t height, const View& orientation) {
    View v;
    v.rotation = normalizedRotation(orientation.rotation);
    v.flipH = orientation.flipH;
    v.flipV = orientation.flipV;
    v.centerX = double(info.width) * 0.5;
    v.centerY = double(info.height) * 0.5;
    if (width == 0 || height == 0 || info.width <= 0 || info.height <= 0) return v;
    // The turned slide's bounding box on screen, per unit of downsample.
    const ViewTransform t = ViewTransform::of(v, width, height);
    const double sw = std::abs(t.m[0]) * double(info.width) + std::abs(t.m[1]) * double(info.height);
    const double sh = std::abs(t.m[2]) * double(info.width) + std::abs(t.m[3]) * double(info.height);
    v.downsample = std::max(sw / width, sh / height);
    return v;
}

double clampDownsample(const SlideInfo& info, uint32_t width, uint32_t height, double ds) {
    if (!std::isfinite(ds) || ds <= 0) ds = 1;
    const double minDs = 1.0 / 64.0; // 64 screen pixels per level-0 pixel
    double maxDs = 1e6;
    if (width > 0 && height > 0 && info.width > 0) {
        // Zooming out stops at a quarter of the fitted size, or at the coarsest level shown
        // 1:1, whichever is further out.
        maxDs = std::max({1.0, 4.0 * fitView(info, width, height).downsample,
                          info.levels.empty() ? 1.0 : info.levels.back().downsample});
    }
    return std::clamp(ds, minDs, maxDs);
}

} // namespace iris
