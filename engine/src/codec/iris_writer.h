// Serialisation of the .iris blocks (Iris File Extension version 1.0, the layout the released
// reference encoder writes; shared/formats/iris-file-extension.md), for the encoder.
//
// The file is: FILE_HEADER (38 bytes) | tile streams | TILE_OFFSETS | LAYER_EXTENTS |
// TILE_TABLE | METADATA | ICC_PROFILE | IMAGE_BYTES… | IMAGES | ATTRIBUTE_SIZES |
// ATTRIBUTE_BYTES | ATTRIBUTES — the reference encoder's order. The tiles are streamed by the
// caller; buildTrailer() makes everything after them in memory (a few bytes a tile plus the
// metadata), and fileHeader() the header that is written last, at byte 0.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "iris/types.h"
#include "slide/iris_file.h"

namespace iris::ife {

// One TILE_OFFSETS entry packed as written: offset (u40) | size (u24) << 40.
using PackedTile = uint64_t;
inline PackedTile packTile(uint64_t offset, uint32_t size) { return offset | (uint64_t(size) << 40); }

struct WriteLayer {
    uint32_t xTiles = 0;
    uint32_t yTiles = 0;
    float scale = 1; // 1 at the lowest resolution, strictly increasing
};

struct WriteImage {
    std::string title;           // "label", "macro", "thumbnail", …
    uint32_t width = 0;
    uint32_t height = 0;
    uint8_t encoding = kImageJpeg;
    uint8_t format = kFormatR8G8B8A8;
    std::vector<uint8_t> bytes;  // the encoded image
};

struct WriteInfo {
    uint8_t tileEncoding = kEncodingJpeg;
    uint8_t pixelFormat = kFormatR8G8B8A8;
    uint32_t xExtent = 0, yExtent = 0;        // the lowest-resolution layer's size, as the reference writes it
    std::vector<WriteLayer> layers;           // lowest resolution first
    uint16_t codecMajor = 0, codecMinor = 0, codecBuild = 0;
    float micronsPerPixel = 0;                // at scale 1; 0 when unknown
    float magnification = 0;                  // at scale 1; 0 when unknown
    std::vector<std::pair<std::string, std::string>> attributes; // FREE_TEXT key/value pairs, in order
    std::vector<WriteImage> images;
    std::vector<uint8_t> icc;
};

struct Trailer {
    std::vector<uint8_t> bytes;   // to be written at file offset `base`
    uint64_t tileTable = 0;       // file offsets for the header
    uint64_t metadata = 0;
};

// Everything after the tile streams, placed at file offset `base` (the end of the last tile).
// `tiles` holds one entry per tile of every layer, lowest layer first, each row-major.
// InvalidArgument when something cannot be expressed in the format (a tile count that does
// not match the layers, more than 2^32 attribute bytes, a title longer than 65535 bytes, …).
Expected<Trailer> buildTrailer(uint64_t base, const WriteInfo& info, const std::vector<PackedTile>& tiles);

// The FILE_HEADER of a file of `fileSize` bytes (version 1.0, revision 0).
std::array<uint8_t, kHeaderSize> fileHeader(uint64_t fileSize, uint64_t tileTable, uint64_t metadata);

} // namespace iris::ife
