#include "render/host_resolve.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <type_traits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "core/thread_name.h"
#include "gpu/vk_util.h"
#include "slide/slide_source.h"

namespace iris::render {

namespace {

constexpr int64_t kTile = kTileSize; // the engine's tile grid (slide/slide_source.h)

// The weight of a filter's second tap for fraction f in [0, 1): f in 1/256ths, rounded.
inline uint32_t weightOf(float f) { return std::min(uint32_t(f * 256.0f + 0.5f), 256u); }

// A level position along one axis, as tile_resolve.comp filters it in mip m: the filter's two
// taps in mip-m texels and the second's weight. Shrunk (LOD > 0), the position is first clamped
// into the level's valid texels and the taps into its tiles' mips (the edge tiles' padding
// included, as their own mips hold it); at LOD 0 the taps are clamped into the level.
struct Taps {
    int64_t t0, t1;
    uint32_t weight;
};
inline Taps tapsOf(float q, const HostLayer& l, uint32_t m, int32_t extent, int64_t tiles) {
    int64_t last = extent - 1;
    if (l.shrunk) {
        q = std::clamp(q, 0.5f, float(extent) - 0.5f) / float(1u << m);
        last = tiles * (kTile >> m) - 1;
    }
    q -= 0.5f;
    const float i = std::floor(q);
    return {std::clamp<int64_t>(int64_t(i), 0, last), std::clamp<int64_t>(int64_t(i) + 1, 0, last), weightOf(q - i)};
}

// The slot of tile (tx, ty) of the layer's grid, or -1 (absent, outside the grid or the level).
inline int32_t slotAt(const HostLayer& l, int64_t tx, int64_t ty) {
    if (tx < l.grid.x0 || ty < l.grid.y0 || tx > l.grid.x1 || ty > l.grid.y1) return -1;
    return l.slots[size_t((ty - l.grid.y0) * (l.grid.x1 - l.grid.x0 + 1) + (tx - l.grid.x0))];
}

inline const uint8_t* texel(const gpu::TileAtlas& atlas, int32_t slot, uint32_t m, int64_t x, int64_t y) {
    return atlas.hostLevel(slot, m) + size_t(y) * atlas.hostRowPitch(m) + size_t(x) * 4;
}

// Bilinear from four texels, 8-bit weights: texel × 256.
inline void bilinear16(const uint8_t* a, const uint8_t* b, const uint8_t* c, const uint8_t* d, uint32_t wx, uint32_t wy,
                       uint32_t out[4]) {
    for (int ch = 0; ch < 4; ++ch) {
        const uint32_t top = a[ch] * (256 - wx) + b[ch] * wx, bottom = c[ch] * (256 - wx) + d[ch] * wx;
        out[ch] = (top * (256 - wy) + bottom * wy + 128) >> 8;
    }
}

// Target pixel (x, y) of layer l where a tap's tile is absent: tile_resolve.comp's fallback,
// the pixel's own tile (resident: the layer was chosen for it) sampled as its quad samples it —
// the position clamped into the tile's valid texels, clamp-to-edge within the tile, trilinear
// between its own mips when shrunk.
void fallbackPixel(const gpu::TileAtlas& atlas, const HostLayer& l, uint32_t x, uint32_t y, uint8_t* out) {
    const float qx = l.x0 + (float(x) + 0.5f) * l.scale, qy = l.y0 + (float(y) + 0.5f) * l.scale;
    const int64_t tx = int64_t(qx) / kTile, ty = int64_t(qy) / kTile;
    const int32_t slot = slotAt(l, tx, ty);
    const float validW = float(std::min<int64_t>(kTile, l.levelWidth - tx * kTile));
    const float validH = float(std::min<int64_t>(kTile, l.levelHeight - ty * kTile));
    const float u = std::clamp(qx - float(tx * kTile), 0.5f, validW - 0.5f);
    const float v = std::clamp(qy - float(ty * kTile), 0.5f, validH - 0.5f);
    uint32_t c[2][4] = {};
    for (int k = 0; k < l.mipCount; ++k) {
        const uint32_t m = l.mips[k].level;
        const int64_t size = kTile >> m;
        const float cu = u / float(kTile) * float(size) - 0.5f, cv = v / float(kTile) * float(size) - 0.5f;
        const float iu = std::floor(cu), iv = std::floor(cv);
        const int64_t u0 = std::clamp<int64_t>(int64_t(iu), 0, size - 1),
                      u1 = std::clamp<int64_t>(int64_t(iu) + 1, 0, size - 1);
        const int64_t v0 = std::clamp<int64_t>(int64_t(iv), 0, size - 1),
                      v1 = std::clamp<int64_t>(int64_t(iv) + 1, 0, size - 1);
        bilinear16(texel(atlas, slot, m, u0, v0), texel(atlas, slot, m, u1, v0), texel(atlas, slot, m, u0, v1),
                   texel(atlas, slot, m, u1, v1), weightOf(cu - iu), weightOf(cv - iv), c[k]);
    }
    const uint32_t wb = l.mipCount > 1 ? l.mipWeight : 0, wa = 256 - wb;
    for (int ch = 0; ch < 4; ++ch) out[ch] = uint8_t((c[0][ch] * wa + c[1][ch] * wb + 32768) >> 16);
}

// Plans one drawn level as a layer of the frame; false where the host cannot resolve it.
bool planLayer(const FrameContext& frame, const LevelDraw& d, uint32_t width, HostLayer& l) {
    const Viewport& vp = frame.viewport;
    const LevelInfo& level = frame.snap.slide->info.levels[size_t(d.level)];
    // The target's geometry in the level, in float as the shaders compute it.
    l.x0 = float((vp.view.centerX - vp.width * 0.5 * vp.view.downsample) / level.downsample);
    l.y0 = float((vp.view.centerY - vp.height * 0.5 * vp.view.downsample) / level.downsample);
    l.scale = float(vp.view.downsample / level.downsample);
    l.levelWidth = int32_t(level.width);
    l.levelHeight = int32_t(level.height);
    l.tilesX = level.tilesX;
    l.tilesY = level.tilesY;
    if (!(l.scale > 0.0f)) return false;
    // The drawn range and the ring around it (the filter's neighbours, which linkNeighbours
    // looked up and pinned; -2 where it did not): resident tiles opaque (no "over" to compute);
    // where a tile is absent, the pixels whose filter reaches it are redone from their own tile.
    const int64_t w = d.range.x1 - d.range.x0 + 1, h = d.range.y1 - d.range.y0 + 1;
    const bool ring = d.linked && d.around.size() == size_t((w + 2) * (h + 2));
    l.grid = TileRange{d.range.x0 - 1, d.range.y0 - 1, d.range.x1 + 1, d.range.y1 + 1};
    l.slots.assign(size_t((w + 2) * (h + 2)), -1);
    l.gaps = false;
    for (int64_t ty = l.grid.y0; ty <= l.grid.y1; ++ty) {
        for (int64_t tx = l.grid.x0; tx <= l.grid.x1; ++tx) {
            if (tx < 0 || ty < 0 || tx >= level.tilesX || ty >= level.tilesY) continue; // never read
            const size_t i = size_t((ty - l.grid.y0) * (w + 2) + (tx - l.grid.x0));
            const int32_t slot = d.range.contains(tx, ty) ? d.layers[size_t((ty - d.range.y0) * w + (tx - d.range.x0))]
                                 : ring                   ? std::max(d.around[i], -1)
                                                          : -1;
            if (slot >= 0 && !frame.tiles.opaque(slot)) return false;
            if (slot < 0) l.gaps = true;
            l.slots[i] = slot;
        }
    }
    // The mips: the draw list's LOD (tile_resolve.comp: trilinear between floor(lod) and the next).
    const float lod = d.exact ? 0.0f : std::min(d.instances.front().texel[3], float(gpu::kTileMipLevels - 1));
    l.shrunk = lod > 0.0f;
    l.mips[0].level = uint32_t(lod);
    l.mipWeight = l.shrunk ? weightOf(lod - float(l.mips[0].level)) : 0;
    l.mipCount = l.mipWeight > 0 ? 2 : 1;
    l.mips[1].level = l.mips[0].level + 1;
    // The columns of each mip: each tap from the tile that holds it.
    for (int k = 0; k < l.mipCount; ++k) {
        HostLayer::Mip& mip = l.mips[k];
        const int64_t size = kTile >> mip.level;
        const auto taps = [&](uint32_t x) {
            return tapsOf(l.x0 + (float(x) + 0.5f) * l.scale, l, mip.level, l.levelWidth, l.tilesX);
        };
        // The line: the texels the columns read. Positions grow with x (the view is unturned),
        // and so do both taps.
        mip.lo = taps(0).t0;
        mip.hi = taps(width - 1).t1;
        mip.columns.resize(width);
        mip.at.resize(width);
        mip.weights.resize(width);
        for (uint32_t x = 0; x < width; ++x) {
            const Taps t = taps(x);
            mip.columns[x] = HostLayer::Column{int32_t(t.t0 / size - l.grid.x0), int32_t(t.t1 / size - l.grid.x0)};
            mip.at[x] = uint32_t(t.t0 - mip.lo) * 4;
            const uint16_t wb = t.t1 == t.t0 ? 0 : uint16_t(t.weight), wa = uint16_t(256 - wb);
            mip.weights[x] = {wa, wa, wa, wa, wb, wb, wb, wb};
        }
        // Runs of at least 8 columns a texel apart with one weight; the rest a pixel at a time.
        std::vector<uint32_t> runs(width);
        for (uint32_t x = width; x-- > 0;) {
            const bool next = x + 1 < width && mip.at[x + 1] == mip.at[x] + 4 && mip.weights[x + 1] == mip.weights[x];
            runs[x] = next ? runs[x + 1] + 1 : 1;
        }
        mip.spans.clear();
        for (uint32_t x = 0; x < width;) {
            if (runs[x] >= 8) {
                mip.spans.push_back({x, x + runs[x], true});
                x += runs[x];
            } else {
                if (mip.spans.empty() || mip.spans.back().run) mip.spans.push_back({x, x, false});
                mip.spans.back().x1 = ++x;
            }
        }
    }
    // Each column's own tile: where the pixel's centre lies, inside the level.
    l.own.resize(width);
    for (uint32_t x = 0; x < width; ++x) {
        const float q = l.x0 + (float(x) + 0.5f) * l.scale;
        l.own[x] = q >= 0.0f && q < float(l.levelWidth) ? int32_t(int64_t(q) / kTile - l.grid.x0) : -1;
    }
    l.ownAll = std::all_of(l.own.begin(), l.own.end(), [](int32_t c) { return c >= 0; });
    l.crosses.assign(width, 0);
    for (int k = 0; k < l.mipCount; ++k)
        for (uint32_t x = 0; x < width; ++x)
            l.crosses[x] |= l.mips[k].columns[x].tile0 != l.own[x] || l.mips[k].columns[x].tile1 != l.own[x];
    return true;
}

// The frame's segments (HostSegment): cut where any layer's own column changes.
void planSegments(HostFrame& f) {
    f.segments.clear();
    const uint32_t width = f.width;
    for (uint32_t x0 = 0, x = 1; x <= width; ++x) {
        bool cut = x == width;
        for (int li = 0; li < f.layerCount && !cut; ++li) cut = f.layers[li].own[x] != f.layers[li].own[x - 1];
        if (!cut) continue;
        HostSegment seg{x0, x, {-1, -1, -1}, {x0, x0, x0}, {x0, x0, x0}};
        for (int li = 0; li < f.layerCount; ++li) {
            const HostLayer& l = f.layers[li];
            seg.own[li] = l.own[x0];
            // Taps grow with x, so those leaving the own tile are a run at each end; the inner
            // range is kept only where every column of it stays inside (else all are looked at).
            uint32_t a = x0, b = x;
            while (a < b && l.crosses[a]) ++a;
            while (b > a && l.crosses[b - 1]) --b;
            if (std::none_of(l.crosses.begin() + a, l.crosses.begin() + b, [](uint8_t c) { return c != 0; })) {
                seg.inner0[li] = a;
                seg.inner1[li] = b;
            }
        }
        f.segments.push_back(seg);
        x0 = x;
    }
}

} // namespace

bool planHostFrame(const FrameContext& frame, const DrawList& list, const gpu::TileAtlas& atlas,
                   const std::array<float, 4>& background, HostFrame& f) {
    // Frames of a field still loading too (HR in part over LR and base): resolved here they
    // cost the loaders' cores less than llvmpipe's quads of three layers (BENCHMARKS.md,
    // "Settled filtered frames on the host").
    if (!atlas.hostWritten() || !frame.snap.slide || frame.snap.colorLut || list.placeholders > 0) return false;
    const Viewport& vp = frame.viewport;
    if (!ViewTransform::of(vp.view, vp.width, vp.height).identity()) return false;
    // An HR level drawn exactly is the tile pass's (its copy, or its texel fetches) once the
    // field is whole. While it loads, the LR and base levels under it are llvmpipe's slowest
    // quads (enlarged over most of the target), so the host resolves the frame, drawing that
    // level at its own scale (every weight 0 or 256: its texels exactly), and the tile pass's
    // copy, recorded after, writes the same texels over its tiles.
    const bool hrExact = list.levels[2].level >= 0 && list.levels[2].exact;
    if (hrExact && list.hrComplete) return false;
    f.width = frame.extent.width;
    f.height = frame.extent.height;
    if (f.width == 0 || f.height == 0) return false;
    f.atlas = &atlas;
    f.layerCount = 0;
    for (int i = 2; i >= 0; --i) { // HR, LR, base: finest first
        const LevelDraw& d = list.levels[size_t(i)];
        // (An exact level's copied tiles are out of its instances, but in its layers.)
        const bool drawn = !d.instances.empty() ||
                           (d.exact && std::any_of(d.layers.begin(), d.layers.end(), [](int32_t s) { return s >= 0; }));
        if (d.level < 0 || d.range.empty() || !drawn) continue;
        if ((d.exact && i != 2) || !planLayer(frame, d, f.width, f.layers[f.layerCount])) return false;
        ++f.layerCount;
    }
    planSegments(f);
    const bool targetBgra = frame.format == VK_FORMAT_B8G8R8A8_UNORM || frame.format == VK_FORMAT_B8G8R8A8_SRGB;
    f.swap = atlas.swapped() != targetBgra;
    const auto byte = [](float v) { return uint8_t(std::clamp(v, 0.0f, 1.0f) * 255.0f + 0.5f); };
    f.background[0] = byte(background[targetBgra ? 2 : 0]);
    f.background[1] = byte(background[1]);
    f.background[2] = byte(background[targetBgra ? 0 : 2]);
    f.background[3] = 255;
    return true;
}

namespace {

// (a × b) >> 16: the high half of a 16-bit product, which the compiler vectorises (pmulhuw).
inline uint16_t mulHigh(uint16_t a, uint16_t b) { return uint16_t((uint32_t(a) * b) >> 16); }

// Horizontal filter of `n` columns a pixel at a time: out = texel(at) × wa + texel(at + 1) × wb
// per channel (texel × 256). `line` holds a texel past the last one any column reads.
void filterColumns(const uint8_t* line, const uint32_t* at, const std::array<uint16_t, 8>* w, size_t n,
                   uint16_t* out) {
    size_t i = 0;
#if defined(__SSE2__)
    // Two columns a step: each one's two taps are 8 consecutive bytes of the line, widened to
    // 16 bits and multiplied by its weights (no product exceeds 255 × 256), then the two taps'
    // halves added.
    const __m128i zero = _mm_setzero_si128();
    for (; i + 2 <= n; i += 2) {
        __m128i a = _mm_unpacklo_epi8(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(line + at[i])), zero);
        __m128i b = _mm_unpacklo_epi8(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(line + at[i + 1])), zero);
        a = _mm_mullo_epi16(a, _mm_loadu_si128(reinterpret_cast<const __m128i*>(w[i].data())));
        b = _mm_mullo_epi16(b, _mm_loadu_si128(reinterpret_cast<const __m128i*>(w[i + 1].data())));
        _mm_storeu_si128(reinterpret_cast<__m128i*>(out + 4 * i),
                         _mm_add_epi16(_mm_unpacklo_epi64(a, b), _mm_unpackhi_epi64(a, b)));
    }
#endif
    for (; i < n; ++i) {
        const uint8_t* t = line + at[i];
        for (int ch = 0; ch < 4; ++ch) out[4 * i + ch] = uint16_t(t[ch] * w[i][0] + t[ch + 4] * w[i][4]);
    }
}

// Two rows of texel × 256 values blended, weight wb (0..256) on the second, into `out` as
// texel × 256 (16 bits) or as bytes, rounded. Each weight is the same along a row: the ends
// (one row alone, every view on a level's pixel grid along y) are taken exactly.
template <typename Out>
void blendRows(const uint16_t* first, const uint16_t* second, uint32_t wb, size_t n, Out* out) {
    constexpr bool bytes = std::is_same_v<Out, uint8_t>;
    const auto put = [](uint32_t v) { return bytes ? Out((v + 128) >> 8) : Out(v); };
    if (wb == 0) {
        for (size_t i = 0; i < n; ++i) out[i] = put(first[i]);
    } else if (wb >= 256) {
        for (size_t i = 0; i < n; ++i) out[i] = put(second[i]);
    } else {
        const uint16_t a = uint16_t((256 - wb) << 8), b = uint16_t(wb << 8);
        for (size_t i = 0; i < n; ++i) out[i] = put(uint16_t(mulHigh(first[i], a) + mulHigh(second[i], b)));
    }
}

} // namespace

void resolveRows(const HostFrame& f, uint32_t row0, uint32_t row1, uint8_t* dst, size_t stride) {
    const gpu::TileAtlas& atlas = *f.atlas;
    const size_t width = f.width, channels = width * 4;
    // Per layer and mip, two of its rows filtered horizontally (4 channels × 16 bits a pixel:
    // texel × 256), each over the columns [x0, x1) that rows asked for.
    struct MipRows {
        std::vector<uint16_t> held[2];
        int64_t heldRow[2] = {-1, -1};
        uint32_t x0[2] = {}, x1[2] = {};
    };
    MipRows rows[3][2];
    size_t lineBytes = 0;
    for (int li = 0; li < f.layerCount; ++li)
        for (int k = 0; k < f.layers[li].mipCount; ++k) {
            rows[li][k].held[0].resize(channels);
            rows[li][k].held[1].resize(channels);
            const HostLayer::Mip& mip = f.layers[li].mips[k];
            lineBytes = std::max(lineBytes, size_t(mip.hi - mip.lo + 2) * 4);
        }
    std::vector<uint8_t> line(lineBytes + 16); // a level row's texels [lo, hi + 1]
    std::vector<uint16_t> mipRow[2];           // shrunk between two mips: each one's blend
    for (std::vector<uint16_t>& r : mipRow) r.resize(channels);
    // Per segment of the row (HostFrame::segments): the layer shown, -1: the background. And
    // the row as runs of segments showing one layer.
    std::vector<int8_t> chosen(f.segments.size());
    struct Run {
        uint32_t x0, x1;
        int li;
    };
    std::vector<Run> runs;
    runs.reserve(f.segments.size());
    // Level row r of a layer's mip, filtered horizontally into `out`, columns [x0, x1).
    const auto horizontal = [&](const HostLayer::Mip& mip, const HostLayer& l, int64_t r, uint32_t x0, uint32_t x1,
                                uint16_t* out) {
        const int64_t size = kTile >> mip.level;
        const int64_t ty = r / size;
        const size_t offset = size_t(r - ty * size) * atlas.hostRowPitch(mip.level);
        // The texels those columns read, [lo, hi] of the line, gathered from their tiles; zero
        // where a tile is absent (the pixels whose filter reaches it are redone by
        // fallbackPixel where they show this layer), and past hi (read with weight 0).
        const int64_t lo = mip.lo + mip.at[x0] / 4, hi = std::min(mip.hi, mip.lo + mip.at[x1 - 1] / 4 + 1);
        for (int64_t tx = lo / size; tx <= hi / size; ++tx) {
            const int64_t a = std::max(lo, tx * size), b = std::min(hi, tx * size + size - 1);
            uint8_t* to = line.data() + size_t(a - mip.lo) * 4;
            if (const int32_t slot = slotAt(l, tx, ty); slot >= 0)
                std::memcpy(to, atlas.hostLevel(slot, mip.level) + offset + size_t(a - tx * size) * 4,
                            size_t(b - a + 1) * 4);
            else
                std::memset(to, 0, size_t(b - a + 1) * 4);
        }
        std::memset(line.data() + size_t(mip.hi - mip.lo + 1) * 4, 0, 4);
        for (const HostLayer::Mip::Span& span : mip.spans) {
            const uint32_t s0 = std::max(span.x0, x0), s1 = std::min(span.x1, x1);
            if (s0 >= s1) continue;
            uint16_t* o = out + size_t(s0) * 4;
            if (span.run) { // one weight, consecutive texels: tap b is the texel after tap a
                const uint8_t* src = line.data() + mip.at[s0];
                const uint32_t wa = mip.weights[s0][0], wb = mip.weights[s0][4];
                for (size_t i = 0; i < size_t(s1 - s0) * 4; ++i) o[i] = uint16_t(src[i] * wa + src[i + 4] * wb);
            } else {
                filterColumns(line.data(), mip.at.data() + s0, mip.weights.data() + s0, s1 - s0, o);
            }
        }
    };
    // Layer li's mip k row r over columns [x0, x1), filtered into the slot not holding `keep`
    // when it is not held (or held over fewer columns: then over both's).
    const auto rowFor = [&](int li, int k, int64_t r, int64_t keep, uint32_t x0, uint32_t x1) -> const uint16_t* {
        MipRows& m = rows[li][k];
        const HostLayer& l = f.layers[li];
        for (int i = 0; i < 2; ++i) {
            if (m.heldRow[i] != r) continue;
            if (m.x0[i] > x0 || m.x1[i] < x1) {
                // Only the columns not filtered yet.
                if (x0 < m.x0[i]) horizontal(l.mips[k], l, r, x0, m.x0[i], m.held[i].data());
                if (x1 > m.x1[i]) horizontal(l.mips[k], l, r, m.x1[i], x1, m.held[i].data());
                m.x0[i] = std::min(m.x0[i], x0);
                m.x1[i] = std::max(m.x1[i], x1);
            }
            return m.held[i].data();
        }
        const int i = m.heldRow[0] == keep ? 1 : 0;
        horizontal(l.mips[k], l, r, x0, x1, m.held[i].data());
        m.heldRow[i] = r;
        m.x0[i] = x0;
        m.x1[i] = x1;
        return m.held[i].data();
    };
    // The row of the layer's tiles holding target row y's centre, or -1 (outside the level or the grid).
    const auto tileRowOf = [](const HostLayer& l, uint32_t y) -> int64_t {
        const float qy = l.y0 + (float(y) + 0.5f) * l.scale;
        if (!(qy >= 0.0f && qy < float(l.levelHeight))) return -1;
        const int64_t ty = int64_t(qy) / kTile;
        return ty < l.grid.y0 || ty > l.grid.y1 ? -1 : ty;
    };
    for (uint32_t y = row0; y < row1; ++y) {
        uint8_t* out = dst + size_t(y - row0) * stride;
        // Which layer each segment shows: the finest whose own tile there is resident.
        runs.clear();
        bool rowWhole = false; // most rows of a settled view: the finest layer's tiles along the row all resident
        if (const HostLayer& l = f.layers[0]; f.layerCount > 0 && l.ownAll) {
            if (const int64_t ty = tileRowOf(l, y); ty >= 0) {
                const int32_t* slots = l.slots.data() + size_t((ty - l.grid.y0) * (l.grid.x1 - l.grid.x0 + 1));
                rowWhole = std::all_of(slots + l.own.front(), slots + l.own.back() + 1, [](int32_t s) { return s >= 0; });
            }
        }
        if (rowWhole) {
            std::fill(chosen.begin(), chosen.end(), int8_t(0));
            runs.push_back({0, uint32_t(width), 0});
        } else {
            std::fill(chosen.begin(), chosen.end(), int8_t(-1));
            for (int li = f.layerCount - 1; li >= 0; --li) {
                const HostLayer& l = f.layers[li];
                const int64_t ty = tileRowOf(l, y);
                if (ty < 0) continue;
                const int32_t* slots = l.slots.data() + size_t((ty - l.grid.y0) * (l.grid.x1 - l.grid.x0 + 1));
                for (size_t s = 0; s < f.segments.size(); ++s)
                    if (const int32_t c = f.segments[s].own[li]; c >= 0 && slots[c] >= 0)
                        chosen[s] = int8_t(li); // finer layers, later in this loop, take over
            }
            for (size_t s = 0; s < f.segments.size(); ++s) {
                const HostSegment& seg = f.segments[s];
                if (!runs.empty() && runs.back().li == chosen[s])
                    runs.back().x1 = seg.x1;
                else
                    runs.push_back({seg.x0, seg.x1, chosen[s]});
            }
        }
        for (const Run& run : runs) {
            if (run.li >= 0) continue;
            for (uint32_t x = run.x0; x < run.x1; ++x) std::memcpy(out + 4 * x, f.background, 4);
        }
        for (int li = f.layerCount - 1; li >= 0; --li) {
            // The columns this layer shows along the row: its runs, within [x0, x1).
            uint32_t x0 = uint32_t(width), x1 = 0;
            for (const Run& run : runs)
                if (run.li == li) {
                    x0 = std::min(x0, run.x0);
                    x1 = std::max(x1, run.x1);
                }
            if (x0 >= x1) continue;
            const HostLayer& l = f.layers[li];
            const float qy = l.y0 + (float(y) + 0.5f) * l.scale;
            int64_t tapRows[2][2];
            const uint16_t* top[2];
            const uint16_t* bottom[2];
            uint32_t wb[2];
            for (int k = 0; k < l.mipCount; ++k) {
                const Taps t = tapsOf(qy, l, l.mips[k].level, l.levelHeight, l.tilesY);
                const int64_t size = kTile >> l.mips[k].level;
                tapRows[k][0] = t.t0 / size;
                tapRows[k][1] = t.t1 / size;
                wb[k] = t.weight;
                top[k] = rowFor(li, k, t.t0, t.t1, x0, x1);
                bottom[k] = rowFor(li, k, t.t1, t.t0, x0, x1);
            }
            for (const Run& run : runs) {
                if (run.li != li) continue;
                const size_t at = size_t(run.x0) * 4, n = size_t(run.x1 - run.x0) * 4;
                if (l.mipCount == 1) {
                    blendRows(top[0] + at, bottom[0] + at, wb[0], n, out + at);
                } else {
                    blendRows(top[0] + at, bottom[0] + at, wb[0], n, mipRow[0].data() + at);
                    blendRows(top[1] + at, bottom[1] + at, wb[1], n, mipRow[1].data() + at);
                    blendRows(mipRow[0].data() + at, mipRow[1].data() + at, l.mipWeight, n, out + at);
                }
            }
            // The pixels whose filter reads an absent tile, in any mip read: tile_resolve.comp
            // takes the whole sample from the pixel's own tile then.
            if (!l.gaps) continue;
            // Only a tap outside the pixel's own tile (resident) can find its tile absent: along
            // x, at a segment's ends; along y, in rows near a tile row's edge.
            const int64_t ownRow = int64_t(qy) / kTile;
            bool rowCrosses = false;
            for (int k = 0; k < l.mipCount; ++k)
                rowCrosses = rowCrosses || tapRows[k][0] != ownRow || tapRows[k][1] != ownRow;
            const auto check = [&](uint32_t x) {
                bool whole = true;
                for (int k = 0; k < l.mipCount && whole; ++k) {
                    const HostLayer::Column& col = l.mips[k].columns[x];
                    for (const int64_t ty : tapRows[k])
                        for (const int32_t c : {col.tile0, col.tile1})
                            if (slotAt(l, l.grid.x0 + c, ty) < 0) whole = false;
                }
                if (!whole) fallbackPixel(atlas, l, x, y, out + 4 * size_t(x));
            };
            for (size_t s = 0; s < f.segments.size(); ++s) {
                if (chosen[s] != li) continue;
                const HostSegment& seg = f.segments[s];
                if (rowCrosses) {
                    for (uint32_t x = seg.x0; x < seg.x1; ++x) check(x);
                } else {
                    for (uint32_t x = seg.x0; x < seg.inner0[li]; ++x) check(x);
                    for (uint32_t x = std::max(seg.inner1[li], seg.inner0[li]); x < seg.x1; ++x) check(x);
                }
            }
        }
        if (f.swap)
            for (const Run& run : runs)
                if (run.li >= 0)
                    for (uint32_t x = run.x0; x < run.x1; ++x) std::swap(out[4 * x], out[4 * x + 2]);
    }
}

HostResolvePass::~HostResolvePass() {
    if (helper_.joinable()) {
        {
            std::lock_guard lock(mutex_);
            stopping_ = true;
        }
        cv_.notify_all();
        helper_.join();
    }
}

Result HostResolvePass::init(uint32_t frameSlots) {
    slots_.clear();
    slots_.resize(frameSlots);
    if (!helper_.joinable()) helper_ = std::thread([this] { helperLoop(); });
    return {};
}

void HostResolvePass::helperLoop() {
    nameThisThread("iris-resolve");
    uint64_t seen = 0;
    std::unique_lock lock(mutex_);
    for (;;) {
        cv_.wait(lock, [&] { return stopping_ || posted_ != seen; });
        if (stopping_) return;
        seen = posted_;
        uint8_t* dst = jobDst_;
        const size_t stride = jobStride_;
        const uint32_t r0 = jobRow0_, r1 = jobRow1_;
        lock.unlock();
        resolveRows(frame_, r0, r1, dst, stride);
        lock.lock();
        done_ = seen;
        cv_.notify_all();
    }
}

Expected<bool> HostResolvePass::prepare(const FrameContext& frame, const DrawList& list,
                                        const std::array<float, 4>& background, bool targetTakesCopies) {
    const bool serves = targetTakesCopies && planHostFrame(frame, list, atlas_, background, frame_);
    if (serves != serving_) {
        serving_ = serves;
        log_.debug("tile resolve: frame " + std::to_string(frame.serial) + (serves ? " on the host" : " as quads"));
    }
    if (!serves) return false;
    vk::MappedBuffer& buf = slots_[frame.slot];
    const VkDeviceSize bytes = VkDeviceSize(frame_.width) * frame_.height * 4;
    if (buf.size < bytes) {
        if (Result r = vk::createMappedBuffer(device_.physical(), device_.device(), bytes,
                                              VK_BUFFER_USAGE_TRANSFER_SRC_BIT, false, buf);
            !r.ok())
            return r;
    }
    auto* dst = static_cast<uint8_t*>(buf.mapped);
    const size_t stride = size_t(frame_.width) * 4;
    const uint32_t half = frame_.height / 2;
    {
        std::lock_guard lock(mutex_);
        jobDst_ = dst + size_t(half) * stride;
        jobStride_ = stride;
        jobRow0_ = half;
        jobRow1_ = frame_.height;
        ++posted_;
    }
    cv_.notify_all();
    resolveRows(frame_, 0, half, dst, stride);
    {
        std::unique_lock lock(mutex_);
        cv_.wait(lock, [&] { return done_ == posted_; });
    }
    if (Result r = vk::flush(device_.device(), buf); !r.ok()) return r;
    return true;
}

void HostResolvePass::record(VkCommandBuffer cmd, const FrameContext& frame, VkImage target) const {
    // Previous contents are discarded; the wait on the previous frame's use of the target (its
    // read-back copy, or the acquire semaphore) is covered by the source stages.
    const VkImageMemoryBarrier2 toCopy =
        vk::imageBarrier(target, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_2_COPY_BIT,
                         VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                         VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, vk::colorRange(0, 1, 0, 1));
    vk::pipelineBarrier(cmd, &toCopy, 1);
    const VkBufferImageCopy region = vk::wholeImageCopy({frame.extent.width, frame.extent.height, 1});
    vkCmdCopyBufferToImage(cmd, slots_[frame.slot].buffer, target, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    const VkImageMemoryBarrier2 toColor = vk::imageBarrier(
        target, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
        VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
        VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
        VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, vk::colorRange(0, 1, 0, 1));
    vk::pipelineBarrier(cmd, &toColor, 1);
}

} // namespace iris::render
