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
// result's vector: a caller that packs tiles for the GPU saves a copy. CorruptData when they
// do not fit.
Expected<JpegCoefficients> readJpegCoefficients(const uint8_t* data, size_t size, int width, int height,
                                                JpegColour colour, int16_t* dst, size_t capacity);

} // namespace iris
