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
        uint32_t firstBlock = 0;      // index of its first block in `blocks` (64 values each)
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
    // caller's memory instead (the overload below).
    std::vector<int16_t> blocks;

    uint32_t blockCount() const { return blocksTotal; }
};

// Reads the coefficients of a JPEG of exactly width × height pixels. CorruptData for a stream
// libjpeg cannot read or warns about (as decodeJpegFrameRgba), UnsupportedFormat for a valid
// stream whose layout the GPU path does not take (see above).
Expected<JpegCoefficients> readJpegCoefficients(const uint8_t* data, size_t size, int width, int height,
                                                JpegColour colour);
// The same, with the blocks written to `dst` (room for `capacity` values) rather than to the
// result's vector: a caller that packs tiles for the GPU saves a copy. UnsupportedFormat when
// the frame header says they will not fit (before the entropy decode).
Expected<JpegCoefficients> readJpegCoefficients(const uint8_t* data, size_t size, int width, int height,
                                                JpegColour colour, int16_t* dst, size_t capacity);

// The RAM cache's form of a tile whose decode the GPU finishes (EngineTuning::JpegDecode::Gpu):
// one record in a tile buffer (kTileBytes), 32-bit words, read by the buffer thread and, from
// staging, by shaders/jpeg_idct.comp:
//   [0, 32)        header: kMagic, width, height, valid width, valid height, transform, hMax,
//                  vMax, components, blocks; then per component (at 10 + 3c) blocksWide,
//                  blocksHigh, first block
//   [32, 224)      three quantisation tables, 64 words each (unused ones zero)
//   [224, …)       the blocks, 32 words each (two int16 a word, the lower first)
// A tile of more than kMaxBlocks blocks has no record (4:2:2 and 4:4:4 256×256 tiles: their
// coefficients fill more than a tile's pixels) and is decoded on the CPU.
namespace jpegrecord {
inline constexpr uint32_t kMagic = 0x4a504743; // "JPGC"
inline constexpr uint32_t kHeaderWords = 32;
inline constexpr uint32_t kQuantWord = 32;
inline constexpr uint32_t kBlocksWord = kQuantWord + 3 * 64;
inline constexpr uint32_t kMaxBlocks = (uint32_t(kTileBytes) / 4 - kBlocksWord) / 32;

// Reads a JPEG of width × height pixels (a whole file tile) into a record at `record`
// (kTileBytes); pixels at or beyond validWidth × validHeight will repeat the last valid column
// and row, as padTileEdges pads a level's edge tile. Errors as readJpegCoefficients, and
// UnsupportedFormat for a tile of more than kMaxBlocks blocks.
Result write(const uint8_t* data, size_t size, int width, int height, JpegColour colour, int validWidth, int validHeight,
             uint8_t* record);
// The header of a record (no blocks: JpegCoefficients::blocks stays empty); false when `record`
// holds none (its magic or sizes are wrong).
bool header(const uint8_t* record, JpegCoefficients& out, uint32_t& validWidth, uint32_t& validHeight);
} // namespace jpegrecord

} // namespace iris
