// Streamed map levels: the block cache every streamed level reads through, the coarser levels
// made on demand, and the pyramid rule shared with the held levels (streamed_raster.h).
#include "layers/streamed_raster.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace iris {

RasterPixelSource::~RasterPixelSource() = default;

namespace layers_detail {

void reduceRegion(RasterKind kind, const uint8_t* src, int32_t srcW, int32_t srcH, uint8_t* dst) {
    const int32_t dstW = (srcW + 1) / 2, dstH = (srcH + 1) / 2;
    for (int32_t y = 0; y < dstH; ++y)
        for (int32_t x = 0; x < dstW; ++x) {
            size_t at[4];
            int k = 0;
            for (int dy = 0; dy < 2; ++dy)
                for (int dx = 0; dx < 2; ++dx) {
                    const int32_t sx = 2 * x + dx, sy = 2 * y + dy;
                    if (sx < srcW && sy < srcH) at[k++] = size_t(sy) * size_t(srcW) + size_t(sx);
                }
            const size_t out = size_t(y) * size_t(dstW) + size_t(x);
            switch (kind) {
            case RasterKind::Scalar: {
                const auto* a = reinterpret_cast<const float*>(src);
                double sum = 0;
                int m = 0;
                for (int i = 0; i < k; ++i)
                    if (!std::isnan(a[at[i]])) sum += a[at[i]], ++m;
                const float v = m ? float(sum / m) : std::numeric_limits<float>::quiet_NaN();
                std::memcpy(dst + out * 4, &v, 4);
                break;
            }
            case RasterKind::Label: {
                uint16_t ids[4];
                for (int i = 0; i < k; ++i) std::memcpy(&ids[i], src + at[i] * 2, 2);
                uint16_t best = 0;
                int bestCount = 0;
                for (int i = 0; i < k; ++i) {
                    int c = 0;
                    for (int j = 0; j < k; ++j) c += ids[j] == ids[i];
                    if (c > bestCount || (c == bestCount && ids[i] < best)) best = ids[i], bestCount = c;
                }
                std::memcpy(dst + out * 2, &best, 2);
                break;
            }
            case RasterKind::Rgba: {
                double rgb[3] = {0, 0, 0}, alpha = 0;
                for (int i = 0; i < k; ++i) {
                    const uint8_t* p = src + 4 * at[i];
                    for (int c = 0; c < 3; ++c) rgb[c] += p[c] * (p[3] / 255.0);
                    alpha += p[3] / 255.0;
                }
                uint8_t* q = dst + 4 * out;
                for (int c = 0; c < 3; ++c)
                    q[c] = alpha > 0 ? uint8_t(std::clamp(std::floor(rgb[c] / alpha + 0.5), 0.0, 255.0)) : 0;
                q[3] = uint8_t(std::clamp(std::floor(255.0 * alpha / k + 0.5), 0.0, 255.0));
                break;
            }
            }
        }
}

RasterLevel reduceLevel(RasterKind kind, const RasterLevel& a) {
    RasterLevel b;
    b.width = (a.width + 1) / 2, b.height = (a.height + 1) / 2;
    const size_t n = size_t(b.width) * size_t(b.height);
    switch (kind) {
    case RasterKind::Scalar:
        b.scalar.resize(n);
        reduceRegion(kind, reinterpret_cast<const uint8_t*>(a.scalar.data()), a.width, a.height,
                     reinterpret_cast<uint8_t*>(b.scalar.data()));
        break;
    case RasterKind::Label:
        b.label.resize(n);
        reduceRegion(kind, reinterpret_cast<const uint8_t*>(a.label.data()), a.width, a.height,
                     reinterpret_cast<uint8_t*>(b.label.data()));
        break;
    case RasterKind::Rgba:
        b.rgba.resize(4 * n);
        reduceRegion(kind, a.rgba.data(), a.width, a.height, b.rgba.data());
        break;
    }
    return b;
}

// ---- BlockedSource ----------------------------------------------------------------------------

BlockedSource::BlockedSource(RasterKind kind, int32_t width, int32_t height, int32_t blockW, int32_t blockH,
                             size_t cacheBytes)
    : kind_(kind), width_(width), height_(height), blockW_(std::max(blockW, 1)), blockH_(std::max(blockH, 1)) {
    blocksX_ = int32_t((int64_t(width_) + blockW_ - 1) / blockW_);
    blocksY_ = int32_t((int64_t(height_) + blockH_ - 1) / blockH_);
    const size_t blockBytes = size_t(blockW_) * size_t(blockH_) * size_t(bytesPerPixelOf(kind));
    maxBlocks_ = std::max<size_t>(1, cacheBytes / std::max<size_t>(blockBytes, 1));
    produced_.assign(size_t(blocksX_) * size_t(blocksY_), false);
}

const std::vector<uint8_t>* BlockedSource::block(int64_t index) const {
    if (auto it = blocks_.find(index); it != blocks_.end()) {
        lru_.splice(lru_.begin(), lru_, it->second.age);
        return &it->second.pixels;
    }
    std::vector<uint8_t> pixels;
    // The oldest block's buffer is reused when the cache is full.
    if (blocks_.size() >= maxBlocks_) {
        auto old = blocks_.find(lru_.back());
        pixels = std::move(old->second.pixels);
        blocks_.erase(old);
        lru_.pop_back();
    }
    pixels.resize(size_t(blockW_) * size_t(blockH_) * size_t(bytesPerPixelOf(kind_)));
    const int32_t bx = int32_t(index % blocksX_), by = int32_t(index / blocksX_);
    if (Result r = produce(bx, by, pixels.data()); !r.ok()) {
        lastError_ = r;
        return nullptr;
    }
    produced_[size_t(index)] = true;
    lru_.push_front(index);
    auto& b = blocks_[index];
    b.pixels = std::move(pixels);
    b.age = lru_.begin();
    return &b.pixels;
}

Result BlockedSource::read(int32_t x, int32_t y, int32_t w, int32_t h, void* out) const {
    if (x < 0 || y < 0 || w <= 0 || h <= 0 || int64_t(x) + w > width_ || int64_t(y) + h > height_)
        return Result(Status::InvalidArgument, "a read of " + std::to_string(w) + "x" + std::to_string(h) + " at (" +
                                                   std::to_string(x) + ", " + std::to_string(y) + ") outside a level of " +
                                                   std::to_string(width_) + "x" + std::to_string(height_));
    const size_t bpp = size_t(bytesPerPixelOf(kind_));
    auto* dst = static_cast<uint8_t*>(out);
    std::lock_guard lock(mutex_);
    for (int32_t by = y / blockH_; by <= (y + h - 1) / blockH_; ++by)
        for (int32_t bx = x / blockW_; bx <= (x + w - 1) / blockW_; ++bx) {
            const std::vector<uint8_t>* b = block(int64_t(by) * blocksX_ + bx);
            if (!b) return lastError_;
            const int32_t x0 = std::max(x, bx * blockW_), x1 = std::min(x + w, (bx + 1) * blockW_);
            const int32_t y0 = std::max(y, by * blockH_), y1 = std::min(y + h, (by + 1) * blockH_);
            for (int32_t r = y0; r < y1; ++r)
                std::memcpy(dst + (size_t(r - y) * size_t(w) + size_t(x0 - x)) * bpp,
                            b->data() + (size_t(r - by * blockH_) * size_t(blockW_) + size_t(x0 - bx * blockW_)) * bpp,
                            size_t(x1 - x0) * bpp);
        }
    return {};
}

Result BlockedSource::produceAll() const {
    std::lock_guard lock(mutex_);
    std::vector<uint8_t> scratch(size_t(blockW_) * size_t(blockH_) * size_t(bytesPerPixelOf(kind_)));
    for (size_t i = 0; i < produced_.size(); ++i) {
        if (produced_[i]) continue;
        if (Result r = produce(int32_t(i % size_t(blocksX_)), int32_t(i / size_t(blocksX_)), scratch.data()); !r.ok())
            return r;
        produced_[i] = true;
    }
    return {};
}

// ---- ReducedSource ----------------------------------------------------------------------------

namespace {
constexpr int32_t kReducedBlock = 256;
constexpr size_t kReducedCacheBytes = size_t(32) << 20;
} // namespace

ReducedSource::ReducedSource(RasterKind kind, std::shared_ptr<const RasterPixelSource> finer, int32_t finerW,
                             int32_t finerH)
    : BlockedSource(kind, (finerW + 1) / 2, (finerH + 1) / 2, kReducedBlock, kReducedBlock, kReducedCacheBytes),
      finer_(std::move(finer)), finerW_(finerW), finerH_(finerH) {}

Result ReducedSource::produce(int32_t bx, int32_t by, uint8_t* out) const {
    // The finer region under the block: even-aligned, so each 2 × 2 is the one the whole level's
    // reduction groups; it is cut short only at the finer level's edge.
    const int32_t fx = 2 * bx * kReducedBlock, fy = 2 * by * kReducedBlock;
    const int32_t fw = std::min(2 * kReducedBlock, finerW_ - fx), fh = std::min(2 * kReducedBlock, finerH_ - fy);
    const size_t bpp = size_t(bytesPerPixelOf(kind()));
    scratch_.resize(size_t(fw) * size_t(fh) * bpp);
    if (Result r = finer_->read(fx, fy, fw, fh, scratch_.data()); !r.ok()) return r;
    const int32_t w = (fw + 1) / 2, h = (fh + 1) / 2;
    if (w == kReducedBlock) {
        reduceRegion(kind(), scratch_.data(), fw, fh, out);
        return {};
    }
    // A partial block: reduced compactly, then laid out at the block's stride.
    std::vector<uint8_t> tmp(size_t(w) * size_t(h) * bpp);
    reduceRegion(kind(), scratch_.data(), fw, fh, tmp.data());
    for (int32_t r = 0; r < h; ++r)
        std::memcpy(out + size_t(r) * kReducedBlock * bpp, tmp.data() + size_t(r) * size_t(w) * bpp, size_t(w) * bpp);
    return {};
}

// ---- The pyramid ----------------------------------------------------------------------------

Result extendPyramid(RasterMap& map, int32_t coarsest, uint64_t heldBytes) {
    if (map.levels.empty() || coarsest < 1) return {};
    const uint64_t bpp = uint64_t(bytesPerPixelOf(map.kind));
    while (std::max(map.levels.back().width, map.levels.back().height) > coarsest) {
        const RasterLevel& a = map.levels.back();
        const int32_t w = (a.width + 1) / 2, h = (a.height + 1) / 2;
        const uint64_t bytes = uint64_t(w) * uint64_t(h) * bpp;
        if (a.streamed() && bytes > heldBytes) {
            RasterLevel b;
            b.width = w, b.height = h;
            b.source = std::make_shared<ReducedSource>(map.kind, a.source, a.width, a.height);
            map.levels.push_back(std::move(b));
            continue;
        }
        if (map.residentBytes() + bytes > kMaxRasterBytes) break;
        if (!a.streamed()) {
            map.levels.push_back(reduceLevel(map.kind, a));
            continue;
        }
        // The first held level under streamed ones: the finer level read once, in bands of an
        // even number of rows (so that each 2 × 2 lies within one band), reduced band by band.
        RasterLevel b;
        b.width = w, b.height = h;
        const size_t n = size_t(w) * size_t(h);
        uint8_t* dst = nullptr;
        switch (map.kind) {
        case RasterKind::Scalar: b.scalar.resize(n), dst = reinterpret_cast<uint8_t*>(b.scalar.data()); break;
        case RasterKind::Label: b.label.resize(n), dst = reinterpret_cast<uint8_t*>(b.label.data()); break;
        case RasterKind::Rgba: b.rgba.resize(4 * n), dst = b.rgba.data(); break;
        }
        const uint64_t rowBytes = uint64_t(a.width) * bpp;
        const int32_t band = int32_t(std::max<uint64_t>(2, ((uint64_t(16) << 20) / rowBytes) & ~uint64_t(1)));
        std::vector<uint8_t> rows;
        for (int32_t y = 0; y < a.height; y += band) {
            const int32_t bh = std::min(band, a.height - y);
            rows.resize(size_t(rowBytes) * size_t(bh));
            if (Result r = a.source->read(0, y, a.width, bh, rows.data()); !r.ok()) return r;
            reduceRegion(map.kind, rows.data(), a.width, bh, dst + size_t(y / 2) * size_t(w) * bpp);
        }
        map.levels.push_back(std::move(b));
    }
    return {};
}

Result scanLevel(RasterKind kind, const RasterLevel& l, ValueRange& range) {
    if (kind == RasterKind::Rgba || !l.streamed()) return {};
    const uint64_t rowBytes = uint64_t(l.width) * uint64_t(bytesPerPixelOf(kind));
    const int32_t band = int32_t(std::max<uint64_t>(1, (uint64_t(16) << 20) / rowBytes));
    std::vector<uint8_t> rows;
    for (int32_t y = 0; y < l.height; y += band) {
        const int32_t bh = std::min(band, l.height - y);
        rows.resize(size_t(rowBytes) * size_t(bh));
        if (Result r = l.source->read(0, y, l.width, bh, rows.data()); !r.ok()) return r;
        const size_t n = size_t(l.width) * size_t(bh);
        for (size_t i = 0; i < n; ++i) {
            if (kind == RasterKind::Label) {
                uint16_t id;
                std::memcpy(&id, rows.data() + 2 * i, 2);
                range.add(id);
                continue;
            }
            float v;
            std::memcpy(&v, rows.data() + 4 * i, 4);
            if (std::isinf(v))
                return Result(Status::InvalidArgument,
                              "an infinite value at (" + std::to_string(i % size_t(l.width)) + ", " +
                                  std::to_string(size_t(y) + i / size_t(l.width)) +
                                  ") of a streamed level (NaN marks no data; infinity is refused)");
            if (v == v) range.add(v);
        }
    }
    return {};
}

} // namespace layers_detail
} // namespace iris
