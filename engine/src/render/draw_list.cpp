#include "render/draw_list.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "slide/slide_source.h" // kTileSize

namespace iris::render {

namespace {

gpu::TileInstance instanceOf(const TilePlacement& p, double originX, double originY, int layer, double lod) {
    return gpu::TileInstance{
        .rect = {float(originX + p.x0), float(originY + p.y0), float(originX + p.x1), float(originY + p.y1)},
        .texel = {float(p.validW), float(p.validH), float(layer), float(lod)},
        .scale = float(p.texelsPerPixel),
    };
}

uint32_t visibleCount(const Footprint& area) {
    if (!area.turned) return uint32_t(area.range.count());
    uint32_t n = 0;
    for (int64_t ty = area.range.y0; ty <= area.range.y1; ++ty)
        for (int64_t tx = area.range.x0; tx <= area.range.x1; ++tx) n += area.contains(tx, ty) ? 1 : 0;
    return n;
}

// The mip LOD a level is sampled at: log2 of target pixels' size in the level's pixels.
double lodOf(const LevelInfo& level, const Viewport& vp) {
    return std::max(0.0, std::log2(vp.view.downsample / level.downsample));
}

} // namespace

uint32_t DrawList::instanceCount() const {
    size_t n = 0;
    for (const LevelDraw& d : levels) n += d.instances.size();
    return uint32_t(n);
}

void DrawList::copyInstances(gpu::TileInstance* out) const {
    for (const LevelDraw& d : levels) {
        if (d.instances.empty()) continue;
        std::memcpy(out, d.instances.data(), d.instances.size() * sizeof(gpu::TileInstance));
        out += d.instances.size();
    }
}

bool coveredBy(const LevelInfo& coarse, int64_t tx, int64_t ty, const LevelInfo& fine, const LevelDraw& drawn,
               const Viewport& vp) {
    // In level-0 units: the coarse tile, clipped to the target's field.
    // (A turned view's field is clipped to its bounding box; fine tiles outside the field
    // count as covering, below.)
    const double ds = vp.view.downsample;
    const std::array<double, 4> field = fieldBounds(vp);
    double x0 = std::max(double(tx * kTileSize) * coarse.downsample, field[0]);
    double y0 = std::max(double(ty * kTileSize) * coarse.downsample, field[1]);
    double x1 = std::min(double(std::min<int64_t>((tx + 1) * kTileSize, coarse.width)) * coarse.downsample, field[2]);
    double y1 = std::min(double(std::min<int64_t>((ty + 1) * kTileSize, coarse.height)) * coarse.downsample, field[3]);
    // One target pixel of margin: the two levels' tile edges are placed by different
    // expressions, so an edge they share in exact arithmetic may round to different pixels.
    // With the margin, coarse tiles along the slide's right and bottom edges (where the levels'
    // extents differ by rounding anyway) are always drawn. Its left and top edges are every
    // level's 0, placed by the same expression: unless the view is turned, the margin stops
    // there. (A turned view's filter reaches past the slide's edge, half a texel of the level
    // it reads, farther for the coarse level: there its tiles stay.)
    x0 -= ds, y0 -= ds, x1 += ds, y1 += ds;
    if (!drawn.area.turned) x0 = std::max(x0, 0.0), y0 = std::max(y0, 0.0);
    if (x0 < 0 || y0 < 0 || x1 > double(fine.width) * fine.downsample || y1 > double(fine.height) * fine.downsample)
        return false;
    // Fine tiles outside the drawn range lie outside the field (the range holds every tile the
    // field overlaps): the margin reaching them at the target's border covers no pixel, so they
    // count as covering, as those outside the field's area do below. (A field whose edge lies
    // on the fine level's tile boundary, as at a level's own scale on whole pixels, otherwise
    // drew every coarse tile along that edge, and the base level's tile across the whole
    // target: two layers of fill under the finer one.)
    const double span = double(kTileSize) * fine.downsample;
    const TileRange& r = drawn.range;
    if (r.empty()) return false;
    const int64_t fx0 = std::max(r.x0, int64_t(std::floor(x0 / span)));
    const int64_t fx1 = std::min(r.x1, int64_t(std::floor(x1 / span)));
    const int64_t fy0 = std::max(r.y0, int64_t(std::floor(y0 / span)));
    const int64_t fy1 = std::min(r.y1, int64_t(std::floor(y1 / span)));
    for (int64_t y = fy0; y <= fy1; ++y)
        for (int64_t x = fx0; x <= fx1; ++x)
            if (!drawn.isDrawn(x, y) && drawn.area.contains(x, y)) return false;
    return true;
}

// The atlas layer of `key` for a draw at `lod`: pinned, or -1 when the tile is not resident,
// or when its mip levels are still to come and the draw would sample them.
static int pinFor(TileResidency& tiles, uint64_t key, double lod) {
    const int layer = tiles.pin(key);
    return layer >= 0 && lod > 0 && !tiles.mipsReady(layer) ? -1 : layer;
}

void linkNeighbours(const LevelInfo& level, int levelIndex, uint32_t generation, TileResidency& tiles, double lod,
                    LevelDraw& d) {
    const TileRange& r = d.range;
    const int64_t w = r.x1 - r.x0 + 1, h = r.y1 - r.y0 + 1;
    constexpr int32_t kUnknown = -2;
    d.around.assign(size_t((w + 2) * (h + 2)), kUnknown);
    // The layer of tile (tx, ty), -1 when it is outside the level or not resident; each tile
    // looked up (and pinned) once per frame.
    const auto layerOf = [&](int64_t tx, int64_t ty) {
        if (tx < 0 || ty < 0 || tx >= level.tilesX || ty >= level.tilesY) return int32_t(-1);
        int32_t& cached = d.around[size_t((ty - r.y0 + 1) * (w + 2) + (tx - r.x0 + 1))];
        if (cached == kUnknown) {
            const int32_t drawn = r.contains(tx, ty) ? d.layers[size_t((ty - r.y0) * w + (tx - r.x0))] : -1;
            cached = drawn >= 0 ? drawn : pinFor(tiles, TileKey::make(generation, levelIndex, tx, ty), lod);
        }
        return cached;
    };
    size_t k = 0; // the instances follow the drawn tiles in row-major order
    for (int64_t ty = r.y0; ty <= r.y1; ++ty) {
        for (int64_t tx = r.x0; tx <= r.x1; ++tx) {
            if (d.layers[size_t((ty - r.y0) * w + (tx - r.x0))] < 0) continue;
            gpu::TileInstance& t = d.instances[k++];
            t.sides[0] = float(layerOf(tx - 1, ty));
            t.sides[1] = float(layerOf(tx + 1, ty));
            t.sides[2] = float(layerOf(tx, ty - 1));
            t.sides[3] = float(layerOf(tx, ty + 1));
            t.corners[0] = float(layerOf(tx - 1, ty - 1));
            t.corners[1] = float(layerOf(tx + 1, ty - 1));
            t.corners[2] = float(layerOf(tx - 1, ty + 1));
            t.corners[3] = float(layerOf(tx + 1, ty + 1));
        }
    }
}

bool drawsExact(const LevelInfo& level, const Viewport& vp) {
    if (vp.width == 0 || vp.height == 0 || !(vp.view.downsample == level.downsample)) return false;
    const ViewTransform t = ViewTransform::of(vp.view, double(vp.width), double(vp.height));
    if (!t.axisAligned()) return false;
    // M is a signed permutation, so whole-pixel steps in the target are whole-texel steps in
    // the level: one pixel centre on a texel centre puts them all there. The fragment shader
    // maps pixel centre p to u = c + Mᵀ (p − c) and reads texel u − (the tile's corner); every
    // value is a small multiple of 1/2, exact in float as in double.
    const double dx = 0.5 - t.targetCX, dy = 0.5 - t.targetCY;
    const double ux = t.targetCX + t.m[0] * dx + t.m[2] * dy, uy = t.targetCY + t.m[1] * dx + t.m[3] * dy;
    const TilePlacement p = placeTile(level, vp, 0, 0); // every tile's corner is this one's plus a multiple of 256
    const auto onCentre = [](double v) { return std::isfinite(v) && v - std::floor(v) == 0.5; };
    return p.texelsPerPixel == 1.0 && onCentre(ux - p.x0) && onCentre(uy - p.y0);
}

bool allResident(const SlideInfo& info, uint32_t generation, int level, const Viewport& vp,
                 const TileResidency& tiles) {
    const Footprint area = footprint(info.levels[size_t(level)], vp, 0);
    const TileRange& range = area.range;
    for (int64_t ty = range.y0; ty <= range.y1; ++ty)
        for (int64_t tx = range.x0; tx <= range.x1; ++tx)
            if (area.contains(tx, ty) && !tiles.isActive(TileKey::make(generation, level, tx, ty))) return false;
    return true;
}

void buildDrawList(const SlideInfo& info, uint32_t generation, const Viewport& vp, const DrawOptions& options,
                   TileResidency& tiles, DrawList& out) {
    for (LevelDraw& d : out.levels) {
        d.level = -1;
        d.range = TileRange{};
        d.area = Footprint{};
        d.layers.clear();
        d.instances.clear();
        d.linked = d.exact = false;
    }
    out.lrTiles = out.hrTiles = 0;
    out.newestUpload = 0;
    out.placeholderLayer = -1;
    out.placeholders = 0;
    bool placeholderLooked = false;
    out.hasLr = out.lrComplete = out.hrComplete = false;
    if (info.levels.empty() || vp.width == 0 || vp.height == 0) return;

    const LevelChoice c = chooseLevels(info, vp.view.downsample);
    // Painter's order. A layer that is the base level is drawn once, as the base.
    int order[3] = {c.base, c.lr, c.hr};
    if (order[1] == order[0]) order[1] = -1;
    if (order[2] == order[0]) order[0] = -1;
    bool hrComplete = options.sizeMatches;
    out.hasLr = c.lr >= 0;
    out.lrComplete = options.sizeMatches;
    // LR left out of the order (it is the base level) is still counted for LR-TeFOV.
    if (c.lr >= 0 && order[1] < 0) {
        out.lrTiles = visibleCount(footprint(info.levels[size_t(c.lr)], vp, 0));
        if (!allResident(info, generation, c.lr, vp, tiles)) out.lrComplete = false;
    }
    // Finest first, so that a coarser tile lying wholly under finer tiles already drawn is
    // left out; the instances still go out coarsest first (copyInstances).
    uint32_t budget = options.maxInstances;
    for (int oi = 2; oi >= 0; --oi) {
        const int li = order[oi];
        if (li < 0) continue;
        LevelDraw& d = out.levels[size_t(oi)];
        const LevelInfo& level = info.levels[size_t(li)];
        d.level = li;
        d.area = footprint(level, vp, 0);
        d.range = d.area.range;
        d.layers.assign(size_t(d.range.count()), -1);
        const bool isHr = li == c.hr, isLr = li == c.lr;
        if (isHr) out.hrTiles = visibleCount(d.area);
        if (isLr) out.lrTiles = visibleCount(d.area);
        const double lod = lodOf(level, vp);
        for (int64_t ty = d.range.y0; ty <= d.range.y1; ++ty) {
            for (int64_t tx = d.range.x0; tx <= d.range.x1; ++tx) {
                if (!d.area.contains(tx, ty)) continue; // a turned view's corner: not visible
                const uint64_t key = TileKey::make(generation, li, tx, ty);
                bool covered = false;
                for (int fi = oi + 1; fi <= 2 && !covered && !options.drawCovered; ++fi) {
                    const LevelDraw& finer = out.levels[size_t(fi)];
                    if (finer.level >= 0) covered = coveredBy(level, tx, ty, info.levels[size_t(finer.level)], finer, vp);
                }
                if (covered) {
                    // Not drawn, but LR-TeFOV still asks whether it is resident.
                    if (isLr && !tiles.isActive(key)) out.lrComplete = false;
                    continue;
                }
                int layer = budget > 0 ? pinFor(tiles, key, lod) : -1;
                if (layer < 0) {
                    if (isHr) hrComplete = false;
                    if (isLr) out.lrComplete = false;
                    if (budget == 0 || !options.failing || !options.failing->count(key)) continue;
                    // Failed for now: the placeholder (pinned once a frame) in its place.
                    if (!placeholderLooked) {
                        placeholderLooked = true;
                        out.placeholderLayer = tiles.pin(options.placeholder);
                    }
                    if (out.placeholderLayer < 0) continue;
                    layer = out.placeholderLayer;
                    ++out.placeholders;
                } else if (isHr || isLr) {
                    out.newestUpload = std::max(out.newestUpload, tiles.uploadSeq(layer));
                }
                --budget;
                d.layers[size_t((ty - d.range.y0) * (d.range.x1 - d.range.x0 + 1) + (tx - d.range.x0))] = layer;
                d.instances.push_back(instanceOf(placeTile(level, vp, tx, ty), 0, 0, layer, lod));
            }
        }
        // Every drawn level filters across its tile seams (the seam pass), enlarged or shrunk;
        // one drawn exactly has nothing to filter.
        d.exact = drawsExact(level, vp);
        if (!d.instances.empty() && !d.exact) {
            linkNeighbours(level, li, generation, tiles, lod, d);
            d.linked = true;
        }
    }
    out.hrComplete = hrComplete;
}

bool appendThumbnail(const SlideInfo& info, uint32_t generation, double viewDownsample, const Viewport& thumbnailView,
                     double originX, double originY, uint32_t budget, TileResidency& tiles,
                     std::vector<gpu::TileInstance>& out) {
    if (info.levels.empty()) return true;
    const int base = chooseLevels(info, viewDownsample).base;
    const LevelInfo& level = info.levels[size_t(base)];
    const bool keptWhole = level.tilesX * level.tilesY <= kMaxResidentBaseTiles;
    const TileRange range = visibleTiles(level, thumbnailView, 0);
    const double lod = lodOf(level, thumbnailView);
    bool complete = true;
    for (int64_t ty = range.y0; ty <= range.y1; ++ty) {
        for (int64_t tx = range.x0; tx <= range.x1; ++tx) {
            const int layer = out.size() < budget ? pinFor(tiles, TileKey::make(generation, base, tx, ty), lod) : -1;
            if (layer < 0) {
                if (keptWhole) complete = false;
                continue;
            }
            out.push_back(instanceOf(placeTile(level, thumbnailView, tx, ty), originX, originY, layer, lod));
        }
    }
    return complete;
}

} // namespace iris::render
