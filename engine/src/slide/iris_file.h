// SlideSource for .iris files (the Iris File Extension, version 1.x: 1.0 with the 1.1
// additions, and newer minor versions read through the fields this reader knows). The layout
// is in shared/formats/iris-file-extension.md.
//
// The file is memory-mapped read-only and its whole structure is validated at open (every
// block, array, tile stream and attribute), so that readTile() only has to decode. Tiles are
// 256×256 JPEG (or AVIF, refused per tile in this build) and the engine's grid is 256×256 as
// well, so one engine tile is exactly one .iris tile, decoded straight into the caller's
// buffer.
//
// Levels: .iris layer 0 is the LOWEST resolution; the engine's level 0 is the finest. Engine
// level l is .iris layer (layerCount − 1 − l), with downsample = finest SCALE / layer SCALE.
#pragma once

#include <cstdint>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "slide/slide_source.h"

namespace iris {

// The parsed and validated structure of an .iris file (values as stored unless said).
namespace ife {

// ---- the format's constants (shared/formats/iris-file-extension.md), for the reader and
// the encoder (codec/iris_writer.*) alike ------------------------------------------------

inline constexpr uint32_t kMagic = 0x49726973; // "sirI" on disk
inline constexpr uint16_t kRecoveryBase = 0x5500;
inline constexpr uint64_t kNullOffset = 0xFFFFFFFFFFFFFFFFull;
inline constexpr uint64_t kNullTile = 0xFFFFFFFFFFull; // u40
inline constexpr uint64_t kMaxTileOffset = kNullTile - 1; // the largest u40 offset that is not NULL_TILE
inline constexpr uint32_t kMaxTileSize = 0xFFFFFFu;       // u24
inline constexpr uint32_t kTileLength = 256;              // TILE_LENGTH when absent (1.0) or 0
inline constexpr int kMaxLayers = 64;                   // the engine's tile key holds 6 level bits

// Block types: the RECOVERY tag on disk is kRecoveryBase | Tag.
enum Tag : uint16_t {
    FILE_HEADER = 1,
    TILE_TABLE,
    CIPHER,
    METADATA,
    ATTRIBUTES,
    LAYER_EXTENTS,
    TILE_OFFSETS,
    ATTRIBUTE_SIZES,
    ATTRIBUTE_BYTES,
    IMAGES,
    IMAGE_BYTES,
    ICC_PROFILE,
    ANNOTATIONS,
    ANNOTATION_BYTES,
    ANNOTATION_GROUP_SIZES,
    ANNOTATION_GROUP_BYTES,
    CLINICAL_METADATA,
};

// Fixed sizes: what a reader of this version needs to find inside the file, and what a
// version 1.0 writer writes.
inline constexpr uint64_t kHeaderSize = 38;
inline constexpr uint64_t kTileTableSize10 = 44, kTileTableSize11 = 46; // 1.1 adds TILE_LENGTH
inline constexpr uint64_t kMetadataSize10 = 56, kMetadataSize11 = 68;   // 1.1 adds CLINICAL_OFFSET, MICRONS_PLANE
inline constexpr uint64_t kCipherSize = 10;
inline constexpr uint64_t kAttributesSize = 29;
inline constexpr uint64_t kArrayHeader = 16;       // VALIDATION, RECOVERY, STRIDE, COUNT
inline constexpr uint64_t kAnnotationsHeader = 32; // ... GROUP_SIZES_OFFSET, GROUP_BYTES_OFFSET
inline constexpr uint64_t kByteArrayHeader = 14;   // VALIDATION, RECOVERY, COUNT
inline constexpr uint64_t kClinicalHeader = 15;    // ... ENCODING
inline constexpr uint64_t kImageBytesHeader = 16;  // VALIDATION, RECOVERY, TITLE_SIZE, IMAGE_SIZE
// Entry sizes of version 1.0: the least STRIDE a reader of the fields it knows accepts.
inline constexpr uint16_t kLayerEntry = 12;        // X_TILES, Y_TILES, SCALE (1.1: + Z_PLANES)
inline constexpr uint16_t kTileEntry = 8;          // OFFSET u40, SIZE u24
inline constexpr uint16_t kAttributeSizeEntry = 6; // KEY_SIZE, VALUE_SIZE (later: + KIND)
inline constexpr uint16_t kImageEntry = 20;
inline constexpr uint16_t kAnnotationEntry = 39;
inline constexpr uint16_t kGroupSizeEntry = 6;

enum TileEncoding : uint8_t { kEncodingUndefined = 0, kEncodingIris = 1, kEncodingJpeg = 2, kEncodingAvif = 3 };
enum ImageEncoding : uint8_t { kImageUndefined = 0, kImagePng = 1, kImageJpeg = 2, kImageAvif = 3 };
enum PixelFormat : uint8_t {
    kFormatUndefined = 0,
    kFormatB8G8R8 = 1,
    kFormatR8G8B8 = 2,
    kFormatB8G8R8A8 = 3,
    kFormatR8G8B8A8 = 4,
};
// Version 1.0 has no FREE_TEXT code of its own: free text is I2S with attribute VERSION 0.
enum MetadataFormat : uint8_t { kMetadataUndefined = 0, kMetadataI2S = 1, kMetadataDicom = 2, kMetadataFreeText = 3 };

struct Layer {
    uint32_t xTiles = 0;
    uint32_t yTiles = 0;
    float scale = 0;         // as stored: 1 at the lowest resolution, growing
    uint64_t firstTile = 0;  // index of its tile (0, 0) in TILE_OFFSETS
    int64_t width = 0;       // derived true pixel size (see parse())
    int64_t height = 0;
    double downsample = 1;   // finest scale / this scale
};

struct AssociatedImage {
    std::string name;        // the IMAGE_BYTES title ("label", "macro", "thumbnail", …)
    uint64_t offset = 0;     // the encoded image's bytes in the file
    uint32_t size = 0;
    uint32_t width = 0;      // as the IMAGES entry states them
    uint32_t height = 0;
    uint8_t encoding = 0;    // ImageEncoding
    uint8_t format = 0;      // pixel format
    float orientation = 0;   // degrees
};

struct TileStream {
    uint64_t offset = 0;
    uint32_t size = 0;       // 0: no data (NULL_TILE), drawn as transparent
};

struct Layout {
    uint16_t major = 0, minor = 0;
    uint32_t revision = 0;
    uint8_t encoding = 0;    // TileEncoding
    uint8_t pixelFormat = 0;
    uint32_t tileLength = kTileLength;
    uint32_t xExtent = 0, yExtent = 0;  // as stored
    bool extentIsLowestLayer = false;   // which reading of X/Y_EXTENT matched
    std::vector<Layer> layers;          // as stored: lowest resolution first
    uint64_t tileEntries = 0;           // file offset of TILE_OFFSETS entry 0
    uint16_t tileStride = 0;
    uint64_t tileCount = 0;
    int64_t width = 0, height = 0;      // the highest-resolution layer's true size
    uint16_t codecMajor = 0, codecMinor = 0, codecBuild = 0;
    float micronsPerPixel = 0;          // at scale 1 (the lowest-resolution layer)
    float magnification = 0;            // at scale 1
    float micronsPlane = 0;             // 1.1; 0 when absent
    bool hasAttributes = false;
    uint8_t attributeFormat = 0;
    uint16_t attributeVersion = 0;
    std::vector<std::pair<std::string, std::string>> attributes; // in file order
    std::vector<AssociatedImage> images;
    bool hasIcc = false;
    uint64_t iccOffset = 0;
    uint32_t iccSize = 0;
    bool hasAnnotations = false;
    uint32_t annotationCount = 0;
    bool hasClinical = false;
    uint32_t clinicalSize = 0;
    uint8_t clinicalEncoding = 0;
};

// The bytes parse() and slideInfo() read: a whole file in memory (tests, fuzzing), or an open
// file read with pread in 64 KiB blocks kept for the parse (IrisFileSource::open). The file
// is never memory-mapped: a file truncated while it is parsed would raise SIGBUS on a map's
// pages past its new end, which kills the host. A read past what the file holds now (it
// shrank after its size was taken) gives zeros and makes failure() an IoError, which parse()
// returns. One thread at a time.
class ByteSource {
public:
    static ByteSource memory(const uint8_t* data, uint64_t size);
    static ByteSource file(int fd, uint64_t size, std::string name);
    uint64_t size() const { return size_; }
    // Bytes [off, off + n), which the caller has checked lie inside size().
    void read(uint64_t off, void* dst, size_t n) const;
    // OK, or the first failed read's IoError.
    const Result& failure() const { return failure_; }

private:
    ByteSource() = default;
    const uint8_t* data_ = nullptr; // memory()
    int fd_ = -1;                   // file()
    uint64_t size_ = 0;
    std::string name_;
    mutable std::unordered_map<uint64_t, std::vector<uint8_t>> blocks_; // file(): block index → bytes
    mutable Result failure_;
};

// Parses and validates the whole structure of an .iris file. Never reads outside
// [0, source.size()), whatever the bytes say; every offset and length is checked with
// overflow-safe arithmetic. `name` is the file name the messages use ("Cannot open 'NAME':
// …"). Returns CorruptData for a broken file and UnsupportedFormat for a valid one this reader
// cannot show (another major version, encrypted tiles, the reserved IRIS codec, tiles other
// than 256 pixels), and IoError when the file could not be read (truncated meanwhile).
Expected<Layout> parse(const ByteSource& source, const std::string& name);
// The same over a whole file in memory.
Expected<Layout> parse(const uint8_t* data, uint64_t size, const std::string& name);

// The tile stream of tile (x, y) of `layer` (indices as stored); the layout must come from
// parse() of the same bytes, and x, y must lie inside the layer.
TileStream tileStream(const uint8_t* data, const Layout& layout, size_t layer, uint32_t x, uint32_t y);

// Where readTile and readAssociatedImage find the file's bytes: the whole file in memory
// (`data`: what parse() read; tests and fuzzing), or the open file (`fd`), read with pread —
// IrisFileSource's way once open() has parsed the file, so that a file truncated while it is
// open fails the reads past its new end with an IoError instead of raising SIGBUS, as a
// memory map would, and killing the host.
struct Bytes {
    const uint8_t* data = nullptr;
    int fd = -1;
    std::string name; // for messages
    // Bytes [offset, offset + n): a pointer into `data`, or read into `scratch`.
    Expected<const uint8_t*> at(uint64_t offset, size_t n, std::vector<uint8_t>& scratch) const;
};
// The tile stream of tile (x, y) of `layer`, read through `bytes` (as tileStream()).
Expected<TileStream> tileStream(const Bytes& bytes, const Layout& layout, size_t layer, uint32_t x, uint32_t y);

// What IrisFileSource does with a parsed file, as pure functions of the bytes parse() read
// and its layout (IrisFileSource calls them on its open file; tests/fuzz on the bytes).
// `name` is the file name the messages use, as for parse().
//
// The SlideInfo open() returns: the engine's levels (finest first), mpp and magnification,
// the properties (the reader's own "iris.*" entries, then the attributes), the associated
// images' names and the ICC profile. `path` becomes SlideInfo::path.
SlideInfo slideInfo(const uint8_t* data, const Layout& layout, const std::string& path);
// The same through a ByteSource (a failed read leaves zeros and source.failure() set).
SlideInfo slideInfo(const ByteSource& source, const Layout& layout, const std::string& path);
// SlideSource::readTile: tile (tx, ty) of engine level `level` decoded into dst (kTileBytes).
Result readTile(const uint8_t* data, const Layout& layout, const std::string& name, int level, int64_t tx, int64_t ty,
                uint8_t* dst);
Result readTile(const Bytes& bytes, const Layout& layout, int level, int64_t tx, int64_t ty, uint8_t* dst);
// SlideSource::readTileCoefficients: the same tile's JPEG stream read as a coefficient record
// (jpegrecord) into dst (kTileBytes); UnsupportedFormat for a tile with no data or of AVIF.
Result readTileCoefficients(const Bytes& bytes, const Layout& layout, int level, int64_t tx, int64_t ty, uint8_t* dst);
// SlideSource::readAssociatedImage; an image of more than maxPixels pixels is refused
// (CorruptData) before any memory is allocated for its pixels.
Expected<Image> readAssociatedImage(const uint8_t* data, const Layout& layout, const std::string& name,
                                    const std::string& image, uint64_t maxPixels);
Expected<Image> readAssociatedImage(const Bytes& bytes, const Layout& layout, const std::string& image,
                                    uint64_t maxPixels);

} // namespace ife

class IrisFileSource final : public SlideSource {
public:
    // The name ends in .iris (any case) or the file starts with the magic bytes "sirI"; a
    // file named .iris that is broken is then explained by open() instead of OpenSlide.
    static bool detect(const std::string& path);
    static Expected<std::unique_ptr<SlideSource>> open(const std::string& path);
    ~IrisFileSource() override;
    IrisFileSource(const IrisFileSource&) = delete;
    IrisFileSource& operator=(const IrisFileSource&) = delete;

    const SlideInfo& info() const override { return info_; }
    Result readTile(int level, int64_t tx, int64_t ty, uint8_t* dst) override;
    // Every level of JPEG tiles (the engine's grid is the file's).
    bool readsCoefficients(int level) const override;
    Result readTileCoefficients(int level, int64_t tx, int64_t ty, uint8_t* dst) override;
    Expected<Image> readAssociatedImage(const std::string& name) override;

    const ife::Layout& layout() const { return layout_; }

private:
    IrisFileSource(int fd, std::string fileName, ife::Layout layout, SlideInfo info);

    // The open file, read with pread by any thread (ife::Bytes); a file replaced or deleted
    // while open is still this one, a truncated one fails the reads past its end.
    int fd_;
    ife::Bytes bytes_;
    std::string fileName_;
    ife::Layout layout_;
    SlideInfo info_;
};

} // namespace iris
