#include "render/host_resolve.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

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
    const float lod = std::min(d.instances.front().texel[3], float(gpu::kTileMipLevels - 1));
    l.shrunk = lod > 0.0f;
    l.mips[0].level = uint32_t(lod);
    l.mipWeight = l.shrunk ? weightOf(lod - float(l.mips[0].level)) : 0;
    l.mipCount = l.mipWeight > 0 ? 2 : 1;
    l.mips[1].level = l.mips[0].level + 1;
    // The columns of each mip: each tap from the tile that holds it.
    for (int k = 0; k < l.mipCount; ++k) {
        HostLayer::Mip& mip = l.mips[k];
        const int64_t size = kTile >> mip.level;
        mip.columns.resize(width);
        for (uint32_t x = 0; x < width; ++x) {
            const Taps t = tapsOf(l.x0 + (float(x) + 0.5f) * l.scale, l, mip.level, l.levelWidth, l.tilesX);
            mip.columns[x] = HostLayer::Column{int32_t(t.t0 / size - l.grid.x0), int32_t(t.t1 / size - l.grid.x0),
                                               uint32_t(t.t0 % size) * 4, uint32_t(t.t1 % size) * 4, t.weight};
        }
        mip.runs.resize(width);
        for (uint32_t x = width; x-- > 0;) {
            const HostLayer::Column& c = mip.columns[x];
            const bool oneTile = c.tile0 == c.tile1 && c.offset1 == c.offset0 + 4;
            const HostLayer::Column* n = x + 1 < width ? &mip.columns[x + 1] : nullptr;
            const bool next = n && oneTile && n->tile0 == c.tile0 && n->tile1 == c.tile0 &&
                              n->offset0 == c.offset0 + 4 && n->offset1 == n->offset0 + 4 && n->weight == c.weight;
            mip.runs[x] = next ? mip.runs[x + 1] + 1 : 1;
        }
    }
    // Each column's own tile: where the pixel's centre lies, inside the level.
    l.own.resize(width);
    for (uint32_t x = 0; x < width; ++x) {
        const float q = l.x0 + (float(x) + 0.5f) * l.scale;
        l.own[x] = q >= 0.0f && q < float(l.levelWidth) ? int32_t(int64_t(q) / kTile - l.grid.x0) : -1;
    }
    for (int k = 0; k < l.mipCount; ++k) {
        HostLayer::Mip& mip = l.mips[k];
        mip.crosses.resize(width);
        for (uint32_t x = 0; x < width; ++x)
            mip.crosses[x] = mip.columns[x].tile0 != l.own[x] || mip.columns[x].tile1 != l.own[x];
    }
    return true;
}

} // namespace

bool planHostFrame(const FrameContext& frame, const DrawList& list, const gpu::TileAtlas& atlas,
                   const std::array<float, 4>& background, HostFrame& f) {
    // Complete frames only: while a field loads, the cores are the loaders', and a frame of
    // three layers (HR in part, LR, base) resolved beside them costs more there than llvmpipe's
    // quads (BENCHMARKS.md, "Settled filtered frames on the host").
    if (!atlas.hostWritten() || !frame.snap.slide || frame.snap.colorLut || list.placeholders > 0 || !list.hrComplete)
        return false;
    const Viewport& vp = frame.viewport;
    if (!ViewTransform::of(vp.view, vp.width, vp.height).identity()) return false;
    // An HR level drawn exactly is the tile pass's (its copy, or its texel fetches), even where
    // the copy took every instance out of the list.
    if (list.levels[2].level >= 0 && list.levels[2].exact) return false;
    f.width = frame.extent.width;
    f.height = frame.extent.height;
    if (f.width == 0 || f.height == 0) return false;
    f.atlas = &atlas;
    f.layerCount = 0;
    for (int i = 2; i >= 0; --i) { // HR, LR, base: finest first
        const LevelDraw& d = list.levels[size_t(i)];
        if (d.level < 0 || d.range.empty() || d.instances.empty()) continue;
        if (d.exact || !planLayer(frame, d, f.width, f.layers[f.layerCount])) return false;
        ++f.layerCount;
    }
    const bool targetBgra = frame.format == VK_FORMAT_B8G8R8A8_UNORM || frame.format == VK_FORMAT_B8G8R8A8_SRGB;
    f.swap = atlas.swapped() != targetBgra;
    const auto byte = [](float v) { return uint8_t(std::clamp(v, 0.0f, 1.0f) * 255.0f + 0.5f); };
    f.background[0] = byte(background[targetBgra ? 2 : 0]);
    f.background[1] = byte(background[1]);
    f.background[2] = byte(background[targetBgra ? 0 : 2]);
    f.background[3] = 255;
    return true;
}

void resolveRows(const HostFrame& f, uint32_t row0, uint32_t row1, uint8_t* dst, size_t stride) {
    const gpu::TileAtlas& atlas = *f.atlas;
    const size_t width = f.width, channels = width * 4;
    // Per layer and mip, two of its rows filtered horizontally (4 channels × 16 bits a pixel:
    // texel × 256), and the vertical blend of a mip's two rows, for the blend of two mips.
    struct MipRows {
        std::vector<uint16_t> held[2];
        int64_t heldRow[2] = {-1, -1};
        std::vector<uint16_t> blended;
    };
    MipRows rows[3][2];
    for (int li = 0; li < f.layerCount; ++li)
        for (int k = 0; k < f.layers[li].mipCount; ++k) {
            rows[li][k].held[0].resize(channels);
            rows[li][k].held[1].resize(channels);
            if (f.layers[li].mipCount > 1) rows[li][k].blended.resize(channels);
        }
    std::vector<const uint8_t*> rowOf;
    std::vector<int8_t> chosen(width); // per pixel of the row: the layer shown, -1: the background
    const auto horizontal = [&](const HostLayer& l, const HostLayer::Mip& mip, int64_t r, uint16_t* out) {
        const int64_t gridW = l.grid.x1 - l.grid.x0 + 1;
        const int64_t size = kTile >> mip.level;
        const int64_t ty = r / size;
        const size_t offset = size_t(r - ty * size) * atlas.hostRowPitch(mip.level);
        rowOf.assign(size_t(gridW), nullptr);
        for (int64_t c = 0; c < gridW; ++c) {
            const int32_t slot = slotAt(l, l.grid.x0 + c, ty);
            if (slot >= 0) rowOf[size_t(c)] = atlas.hostLevel(slot, mip.level) + offset;
        }
        for (size_t x = 0; x < width;) {
            const HostLayer::Column& col = mip.columns[x];
            const uint8_t* a = rowOf[size_t(col.tile0)];
            const uint8_t* b = rowOf[size_t(col.tile1)];
            const uint32_t wb = col.weight, wa = 256 - wb;
            if (const size_t run = mip.runs[x]; run >= 8 && a) {
                // One tile's consecutive texels: tap b is the texel after tap a.
                const uint8_t* src = a + col.offset0;
                for (size_t i = 0; i < run * 4; ++i) out[i] = uint16_t(src[i] * wa + src[i + 4] * wb);
                out += run * 4;
                x += run;
                continue;
            }
            if (!a || !b) { // an absent tile: the pixel is redone by fallbackPixel if it shows this layer
                out[0] = out[1] = out[2] = out[3] = 0;
            } else {
                a += col.offset0;
                b += col.offset1;
                for (int ch = 0; ch < 4; ++ch) out[ch] = uint16_t(a[ch] * wa + b[ch] * wb);
            }
            out += 4;
            ++x;
        }
    };
    // Layer li's mip k row r, filtered into the slot not holding `keep` when it is not held.
    const auto rowFor = [&](int li, int k, int64_t r, int64_t keep) -> const uint16_t* {
        MipRows& m = rows[li][k];
        for (int i = 0; i < 2; ++i)
            if (m.heldRow[i] == r) return m.held[i].data();
        const int i = m.heldRow[0] == keep ? 1 : 0;
        horizontal(f.layers[li], f.layers[li].mips[k], r, m.held[i].data());
        m.heldRow[i] = r;
        return m.held[i].data();
    };
    for (uint32_t y = row0; y < row1; ++y) {
        uint8_t* out = dst + size_t(y - row0) * stride;
        // Which layer each pixel shows: the finest whose own tile there is resident.
        std::fill(chosen.begin(), chosen.end(), int8_t(-1));
        bool any[3] = {};
        size_t shown[3] = {};
        for (int li = f.layerCount - 1; li >= 0; --li) {
            const HostLayer& l = f.layers[li];
            const float qy = l.y0 + (float(y) + 0.5f) * l.scale;
            if (!(qy >= 0.0f && qy < float(l.levelHeight))) continue;
            const int64_t ty = int64_t(qy) / kTile;
            if (ty < l.grid.y0 || ty > l.grid.y1) continue;
            const int32_t* slots = l.slots.data() + size_t((ty - l.grid.y0) * (l.grid.x1 - l.grid.x0 + 1));
            for (size_t x = 0; x < width; ++x)
                if (const int32_t c = l.own[x]; c >= 0 && slots[c] >= 0) {
                    chosen[x] = int8_t(li); // finer layers, later in this loop, take over
                    any[li] = true;
                }
        }
        for (size_t x = 0; x < width; ++x) {
            if (chosen[x] < 0)
                std::memcpy(out + 4 * x, f.background, 4);
            else
                ++shown[size_t(chosen[x])];
        }
        for (int li = f.layerCount - 1; li >= 0; --li) {
            if (!any[li]) continue;
            const HostLayer& l = f.layers[li];
            const float qy = l.y0 + (float(y) + 0.5f) * l.scale;
            const bool only = shown[li] == width; // every pixel of the row is this layer's
            int64_t tapRows[2][2];
            for (int k = 0; k < l.mipCount; ++k) {
                const Taps t = tapsOf(qy, l, l.mips[k].level, l.levelHeight, l.tilesY);
                const int64_t size = kTile >> l.mips[k].level;
                tapRows[k][0] = t.t0 / size;
                tapRows[k][1] = t.t1 / size;
                const uint32_t wb = t.weight, wa = 256 - wb;
                const uint16_t* top = rowFor(li, k, t.t0, t.t1);
                const uint16_t* bottom = rowFor(li, k, t.t1, t.t0);
                if (l.mipCount == 1) {
                    if (only) {
                        for (size_t i = 0; i < channels; ++i)
                            out[i] = uint8_t((uint32_t(top[i]) * wa + uint32_t(bottom[i]) * wb + 32768) >> 16);
                    } else {
                        for (size_t x = 0; x < width; ++x)
                            if (chosen[x] == li)
                                for (size_t i = 4 * x; i < 4 * x + 4; ++i)
                                    out[i] = uint8_t((uint32_t(top[i]) * wa + uint32_t(bottom[i]) * wb + 32768) >> 16);
                    }
                } else {
                    uint16_t* v = rows[li][k].blended.data(); // texel × 256, rounded
                    for (size_t i = 0; i < channels; ++i)
                        v[i] = uint16_t((uint32_t(top[i]) * wa + uint32_t(bottom[i]) * wb + 128) >> 8);
                }
            }
            if (l.mipCount > 1) {
                const uint16_t* a = rows[li][0].blended.data();
                const uint16_t* b = rows[li][1].blended.data();
                const uint32_t wb = l.mipWeight, wa = 256 - wb;
                for (size_t x = 0; x < width; ++x)
                    if (only || chosen[x] == li)
                        for (size_t i = 4 * x; i < 4 * x + 4; ++i)
                            out[i] = uint8_t((uint32_t(a[i]) * wa + uint32_t(b[i]) * wb + 32768) >> 16);
            }
            // The pixels whose filter reads an absent tile, in any mip read: tile_resolve.comp
            // takes the whole sample from the pixel's own tile then.
            if (l.gaps) {
                // Only a tap outside the pixel's own tile (resident) can find its tile absent.
                const int64_t ownRow = int64_t(qy) / kTile;
                bool rowCrosses = false;
                for (int k = 0; k < l.mipCount; ++k)
                    rowCrosses = rowCrosses || tapRows[k][0] != ownRow || tapRows[k][1] != ownRow;
                for (size_t x = 0; x < width; ++x) {
                    if (chosen[x] != li) continue;
                    if (!rowCrosses && !l.mips[0].crosses[x] && (l.mipCount < 2 || !l.mips[1].crosses[x])) continue;
                    bool whole = true;
                    for (int k = 0; k < l.mipCount && whole; ++k) {
                        const HostLayer::Column& col = l.mips[k].columns[x];
                        for (const int64_t ty : tapRows[k])
                            for (const int32_t c : {col.tile0, col.tile1})
                                if (slotAt(l, l.grid.x0 + c, ty) < 0) whole = false;
                    }
                    if (!whole) fallbackPixel(atlas, l, uint32_t(x), y, out + 4 * x);
                }
            }
        }
        if (f.swap)
            for (size_t x = 0; x < width; ++x)
                if (chosen[x] >= 0) std::swap(out[4 * x], out[4 * x + 2]);
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
