// A JPEG tile's quantised DCT coefficients, read with libjpeg-turbo's jpeg_read_coefficients
// (the entropy decode alone), for the GPU reconstruction (gpu/jpeg_reconstruct.h) that does
// the rest of libjpeg's default decode on the device: dequantisation, the islow inverse DCT,
// fancy chroma upsampling and the fixed-point YCbCr → RGB conversion, to the same bytes.
//
// What the GPU path takes (anything else is Status::UnsupportedFormat, and the caller decodes
// on the CPU as before): 8-bit samples; one component (grey) or three; with three, the
// chroma components sampled 1×1 and luma 1×1, 2×1 or 2×2 (4:4:4, 4:2:2, 4:2:0: the layouts
// slide scanners write); colour YCbCr or RGB as JpegColour says (Auto: libjpeg's guess from
// the markers, as decodeJpegFrameRgba). Baseline, extended and progressive, Huffman or
// arithmetic: the coefficients are the same thing however they were coded.
//
// Threading: may be called from any number of threads at once (one decompressor per call).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "iris/types.h"
#include "slide/jpeg_frame_decode.h"
#include "slide/slide_source.h" // kTileBytes

namespace iris {

struct JpegCoefficients {
    enum class Transform : uint32_t { Grey = 0, YCbCr = 1, Rgb = 2 };
    struct Component {
        uint32_t blocksWide = 0; // libjpeg's width_in_blocks: the blocks that hold image samples
        uint32_t blocksHigh = 0;
        uint32_t firstBlock = 0;      // index of its first block (of the tile's, all components')
        std::array<uint16_t, 64> quant{}; // its quantisation table, natural order
    };
    uint32_t width = 0;
    uint32_t height = 0;
    uint32_t components = 0; // 1 or 3
    Transform transform = Transform::Grey;
    uint32_t hMax = 1; // luma's sampling factors (the chroma components' are 1×1)
    uint32_t vMax = 1;
    std::array<Component, 3> comp{};
    uint32_t blocksTotal = 0; // all components'
    // Every component's blocks, row by row, one component after another; each block its 64
    // quantised coefficients in natural (row-major) order. Empty when they were read into the
    // caller's memory instead (the overload below), packed.
    std::vector<int16_t> blocks;
    // Words of the packed blocks (jpegblocks) written to the caller's memory; 0 otherwise.
    uint64_t packedWords = 0;

    uint32_t blockCount() const { return blocksTotal; }
};

// The blocks as the GPU reads them (shaders/jpeg_idct.comp), packed: most of a block's 64
// coefficients are zero in any JPEG a scanner writes, and a tile's dense blocks (128 bytes each,
// 192 KiB for a 4:2:0 tile, more than a tile buffer for 4:2:2 and 4:4:4) are what a coefficient
// record's size, its copies and the device's reads over the bus are made of.
//   [0, 3·blocks)  a table, three words a block: the 64-bit mask of its non-zero coefficients
//                  (bit k: natural-order coefficient k; the lower word first), and the word,
//                  counted from the table's first, where its values start
//   then           each block's non-zero coefficients in natural order, two int16 a word (the
//                  lower half first; an odd count's last upper half zero)
namespace jpegblocks {
inline constexpr uint32_t kTableWords = 3; // a block's table entry
// The words `count` dense blocks take packed.
uint64_t packedWords(const int16_t* blocks, uint32_t count);
// Packs `count` dense blocks into `dst` (room for `capacity` words): the words written, or 0
// when they do not fit.
uint64_t pack(const int16_t* blocks, uint32_t count, uint32_t* dst, uint64_t capacity);
// Whether `words` words at `packed` hold `count` packed blocks whose values all lie within them
// (what jpegrecord::write and readJpegCoefficients write; the tests and fuzzers check it).
bool valid(const uint32_t* packed, uint32_t count, uint64_t words);
} // namespace jpegblocks

// Reads the coefficients of a JPEG of exactly width × height pixels. CorruptData for a stream
// libjpeg cannot read or warns about (as decodeJpegFrameRgba), UnsupportedFormat for a valid
// stream whose layout the GPU path does not take (see above).
Expected<JpegCoefficients> readJpegCoefficients(const uint8_t* data, size_t size, int width, int height,
                                                JpegColour colour);
// The same, with the blocks packed (jpegblocks) into `dst` (room for `capacity` words) rather
// than written to the result's vector: a caller that lays tiles out for the GPU saves a copy.
// UnsupportedFormat when they do not fit: from the frame header when even the blocks' table
// would not, otherwise after the entropy decode.
Expected<JpegCoefficients> readJpegCoefficients(const uint8_t* data, size_t size, int width, int height,
                                                JpegColour colour, uint32_t* dst, uint64_t capacity);

// The RAM cache's form of a tile whose decode the GPU finishes (EngineTuning::JpegDecode::Gpu):
// one record in a tile buffer (kTileBytes), 32-bit words, read by the buffer thread and, from
// staging, by shaders/jpeg_idct.comp:
//   [0, 32)        header: kMagic, width, height, valid width, valid height, transform, hMax,
//                  vMax, components, blocks; per component (at 10 + 3c) blocksWide,
//                  blocksHigh, first block; at 19 the record's words in use
//   [32, 224)      three quantisation tables, 64 words each (unused ones zero)
//   [224, …)       the blocks, packed (jpegblocks)
// A tile whose packed blocks do not fit the buffer (only streams with a high share of non-zero
// coefficients: near-lossless quality, noise) has no record and is decoded on the CPU.
namespace jpegrecord {
inline constexpr uint32_t kMagic = 0x4a504743; // "JPGC"
inline constexpr uint32_t kHeaderWords = 32;
inline constexpr uint32_t kUsedWord = 19;
inline constexpr uint32_t kQuantWord = 32;
inline constexpr uint32_t kBlocksWord = kQuantWord + 3 * 64;
inline constexpr uint32_t kWords = uint32_t(kTileBytes) / 4;

// Reads a JPEG of width × height pixels (a whole file tile) into a record at `record`
// (kTileBytes); pixels at or beyond validWidth × validHeight will repeat the last valid column
// and row, as padTileEdges pads a level's edge tile. Errors as readJpegCoefficients, and
// UnsupportedFormat for a tile whose packed blocks do not fit.
Result write(const uint8_t* data, size_t size, int width, int height, JpegColour colour, int validWidth, int validHeight,
             uint8_t* record);
// The header of a record (no blocks: JpegCoefficients::blocks stays empty; packedWords is
// set); false when `record` holds none: its magic or sizes are wrong. The blocks' table is not
// walked (the buffer thread reads a header a tile; jpegblocks::valid does that): whatever it
// says, the shader reads no word outside the record's packed blocks.
bool header(const uint8_t* record, JpegCoefficients& out, uint32_t& validWidth, uint32_t& validHeight);
// The bytes of a record in use (its header, tables and packed blocks: what a copy of it needs),
// read from its header without checking it; kTileBytes when that is not a record's. (Inline:
// the RAM cache copies records by it without linking libjpeg.)
inline size_t usedBytes(const uint8_t* record) {
    uint32_t magic = 0, used = 0;
    std::memcpy(&magic, record, 4);
    std::memcpy(&used, record + size_t(kUsedWord) * 4, 4);
    if (magic != kMagic || used < kBlocksWord || used > kWords) return kTileBytes;
    return size_t(used) * 4;
}
} // namespace jpegrecord

} // namespace iris
