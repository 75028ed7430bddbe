// SlideSource over the file's own TIFF tiles, for Aperio SVS and generic tiled TIFF pyramids.
//
// Why: OpenSlide 3.4.1 addresses every level in level-0 coordinates, so on a level whose
// downsample is not an integer (Aperio's 4.0002…, 2.0005…) a tile's level position is
// fractional and read_region resamples it, shifting the engine's tiles by up to ±0.5 px and
// softening them. This reader decodes the tiles of each level's own TIFF directory and copies
// them into the engine's 256×256 grid, so every level's pixels are the level's true pixels.
//
// Metadata (levels, downsamples, properties, associated images) comes from an OpenSlideSource
// opened on the same file, which is kept for readAssociatedImage(); SlideInfo is therefore
// identical to the OpenSlide reader's. Pixels are decoded as OpenSlide 3.4.1 decodes them
// (libtiff's TIFFRGBAImage for libtiff codecs, OpenJPEG plus OpenSlide's YCbCr tables for
// Aperio JPEG 2000), so level 0 equals OpenSlide's read_region byte for byte.
//
// tryOpen() answers UnsupportedFormat to mean "not mine, ask the next reader": the file is not
// a TIFF, OpenSlide says it is not aperio or generic-tiff, a level has no TIFF directory of its
// dimensions, or a level uses a compression or pixel layout this reader does not decode
// (2 samples, alpha, 16-bit, planar, palette, rotated, …). Errors that OpenSlide itself
// raises at open (CorruptData) are passed on unchanged.
//
// Threading: readTile() may be called from any number of threads. libtiff handles are not
// thread-safe, so each call borrows a TIFF handle from a per-level pool (handles read the file
// through one shared descriptor with pread, so a pool costs no file descriptors). Decoded file
// tiles go to a small shared LRU cache (32 MiB), since neighbouring engine tiles share file
// tiles when the file's tile size is not 256.
#pragma once

#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

#include "slide/slide_source.h"

namespace iris {

class TiffTileSource final : public SlideSource {
public:
    // Cheap: true when the file starts with a TIFF or BigTIFF header.
    static bool detect(const std::string& path);
    // UnsupportedFormat: not for this reader (the format table falls through to OpenSlide).
    static Expected<std::unique_ptr<SlideSource>> tryOpen(const std::string& path);
    ~TiffTileSource() override;

    const SlideInfo& info() const override;
    Result readTile(int level, int64_t tx, int64_t ty, uint8_t* dst) override;
    // Levels of 256×256 JPEG tiles, whose file tiles are the engine's.
    bool readsCoefficients(int level) const override;
    Result readTileCoefficients(int level, int64_t tx, int64_t ty, uint8_t* dst) override;
    Expected<Image> readAssociatedImage(const std::string& name) override;

    struct Level;
    struct Handle;
    struct DecodedTile;

private:
    TiffTileSource() = default;

    std::unique_ptr<Handle> acquire(size_t level, Result* error);
    void release(size_t level, std::unique_ptr<Handle> handle);
    Expected<std::shared_ptr<const DecodedTile>> fileTile(size_t level, uint32_t col, uint32_t row);
    // A JPEG level's tile through libjpeg-turbo directly (Decoder::JpegYCbCr/JpegRgb): its
    // top-left w × h pixels (the part inside the level) into dst, rows `pitch` bytes apart;
    // false when it cannot (the caller then reads it through TIFFRGBAImage).
    bool decodeJpegTile(Handle& hd, const Level& level, uint32_t tileIndex, uint32_t w, uint32_t h, uint8_t* dst,
                        size_t pitch);
    // The tile's whole JPEG stream (tables, then the tile), in this thread's buffer.
    bool jpegTileStream(Handle& hd, const Level& level, uint32_t tileIndex, const uint8_t** data, size_t* size);

    std::unique_ptr<SlideSource> meta_; // the OpenSlide reader: associated images
    SlideInfo info_;                    // OpenSlide's, plus the ICC profile OpenSlide 3.4 does not read
    std::string fileName_;              // for messages
    int fd_ = -1;                       // shared by every handle (pread only)
    uint64_t fileSize_ = 0;
    std::vector<Level> levels_;         // parallel to info().levels

    std::mutex poolMutex_;
    std::vector<std::vector<std::unique_ptr<Handle>>> pool_; // idle handles, per level

    std::mutex cacheMutex_;
    std::list<std::pair<uint64_t, std::shared_ptr<const DecodedTile>>> lru_; // most recent first
    std::unordered_map<uint64_t, decltype(lru_)::iterator> cacheIndex_;
    size_t cacheBytes_ = 0;
};

} // namespace iris
