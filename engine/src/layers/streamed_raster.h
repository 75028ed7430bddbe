// Not API: streamed map levels (iris::RasterPixelSource), for maps too large to hold — a level
// read a block at a time from its file (tiff_raster.cpp's TIFF levels), or a coarser level made
// from the finer one when a block of it is read (ReducedSource) — and the pyramid rule that
// both the held and the streamed levels are made by (reduceRegion), so that a level made on
// demand equals the one withRasterPyramid would have held, pixel for pixel.
//
// Threads: a source serialises its own reads (one mutex: a libtiff handle is not thread-safe,
// and a block is produced once for everyone who waits on it); a read never takes another
// source's lock while the caller holds one, except down the chain of finer levels, which has
// no cycle.
#pragma once

#include <cstdint>
#include <limits>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "iris/layers.h"

namespace iris::layers_detail {

inline int bytesPerPixelOf(RasterKind k) {
    return k == RasterKind::Label ? 2 : 4;
}

// A coarser pixel from each 2 × 2 of `src` (srcW × srcH pixels, rows srcW apart; fewer at an odd
// edge: an odd last column or row of `src` is the level's edge), written into `dst` (dstW × dstH
// = ceil(srcW/2) × ceil(srcH/2), rows dstW apart). Scalar: the mean of the values that are not
// NaN (NaN when none is); Label: the most frequent id, the smallest among equals; Rgba: the mean
// of premultiplied colours, unpremultiplied and rounded. withRasterPyramid's rule.
void reduceRegion(RasterKind kind, const uint8_t* src, int32_t srcW, int32_t srcH, uint8_t* dst);

// The range a level's values add to a map's: Scalar min/max ignoring NaN, Label min/max id.
struct ValueRange {
    double lo = std::numeric_limits<double>::infinity();
    double hi = -std::numeric_limits<double>::infinity();
    void add(double v) {
        if (v < lo) lo = v;
        if (v > hi) hi = v;
    }
    void add(const ValueRange& o) {
        if (o.lo < lo) lo = o.lo;
        if (o.hi > hi) hi = o.hi;
    }
    bool empty() const { return !(lo <= hi); }
};

// A level read in blocks of blockW × blockH pixels (the last column and row of blocks partial),
// each produced once and kept in an LRU of `cacheBytes` (at least one block).
class BlockedSource : public RasterPixelSource {
public:
    BlockedSource(RasterKind kind, int32_t width, int32_t height, int32_t blockW, int32_t blockH, size_t cacheBytes);
    Result read(int32_t x, int32_t y, int32_t w, int32_t h, void* out) const override;

    // Produces every block no read has produced yet, and forgets them again (a load's check of
    // every value); the first error stops it.
    Result produceAll() const;
    RasterKind kind() const { return kind_; }
    int32_t width() const { return width_; }
    int32_t height() const { return height_; }

protected:
    // Writes block (bx, by) into `out` (blockW × blockH pixels, rows blockW apart; only the part
    // inside the level matters). Called with the source's mutex held.
    virtual Result produce(int32_t bx, int32_t by, uint8_t* out) const = 0;

private:
    struct Block {
        std::vector<uint8_t> pixels;
        std::list<int64_t>::iterator age;
    };
    const std::vector<uint8_t>* block(int64_t index) const; // mutex_ held; null: failed (error in lastError_)

    RasterKind kind_;
    int32_t width_, height_, blockW_, blockH_, blocksX_, blocksY_;
    size_t maxBlocks_;
    mutable std::mutex mutex_;
    mutable std::unordered_map<int64_t, Block> blocks_;
    mutable std::list<int64_t> lru_; // front: the most recently used
    mutable std::vector<bool> produced_; // blocks produced at least once (produceAll skips them)
    mutable Result lastError_;
};

// A level made from the finer level `finer` (streamed) by reduceRegion, a block of 256 × 256 at a
// time, each reading the 512 × 512 of the finer level under it.
class ReducedSource final : public BlockedSource {
public:
    ReducedSource(RasterKind kind, std::shared_ptr<const RasterPixelSource> finer, int32_t finerW, int32_t finerH);

protected:
    Result produce(int32_t bx, int32_t by, uint8_t* out) const override;

private:
    std::shared_ptr<const RasterPixelSource> finer_;
    int32_t finerW_, finerH_;
    mutable std::vector<uint8_t> scratch_;
};

// The held level made from `a` (held) by reduceRegion.
RasterLevel reduceLevel(RasterKind kind, const RasterLevel& a);

// Coarser levels below the map's last one, each half the one before (sides rounded up), until
// both sides are at most `coarsest`: over `heldBytes` a level is streamed (a ReducedSource),
// the others are held, the first of them made by reading the streamed level above it once.
// Stops adding held levels where the held bytes would pass kMaxRasterBytes. A read error of a
// streamed level is returned.
Result extendPyramid(RasterMap& map, int32_t coarsest, uint64_t heldBytes);

// Reads a streamed level whole, a band of rows at a time, into `range` (Scalar: NaN left out;
// Label: the ids); an infinite Scalar value is refused, naming the pixel. Rgba adds nothing.
Result scanLevel(RasterKind kind, const RasterLevel& level, ValueRange& range);

// The held bytes at most of a level that withRasterPyramid adds below a streamed one.
inline constexpr uint64_t kHeldLevelBytes = uint64_t(32) << 20;

// A TIFF file's map, its large levels streamed (tiff_raster.cpp). Chosen by loadRasterMap for a
// TIFF over options.streamAbove; none (an empty optional) when the file is not that large, so
// that the whole-file reader takes it.
std::optional<Expected<RasterMap>> streamTiffRaster(const std::string& path, const RasterLoadOptions& options);

} // namespace iris::layers_detail
