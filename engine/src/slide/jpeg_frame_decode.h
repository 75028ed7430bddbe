// JPEG decoding with libjpeg-turbo's libjpeg API, for frames whose colour space is stated
// outside the stream: a DICOM frame's Photometric Interpretation says whether its three
// components are YCbCr (YBR_FULL_422, YBR_FULL: convert) or RGB (RGB: take them as they are),
// and a stream without a JFIF or Adobe marker cannot say so itself. TurboJPEG's API always
// guesses from the markers, so it cannot decode an RGB frame that looks like YCbCr.
//
// The decode is libjpeg's default (islow DCT, fancy upsampling), the one libtiff's JPEG codec
// and TurboJPEG use, so a frame copied unchanged from a TIFF tile decodes to the same bytes.
//
// Threading: may be called from any number of threads at once (one decompressor per call).
#pragma once

#include <cstddef>
#include <cstdint>

#include "iris/types.h"

namespace iris {

enum class JpegColour {
    Auto,  // as the stream's markers say (libjpeg's guess): grey for one component
    YCbCr, // three components, converted to RGB
    Rgb,   // three components, taken as R, G, B
};

// Decodes a baseline or progressive JPEG of exactly width × height pixels into dst as RGBA8
// (alpha 255), rows `pitch` bytes apart. A stream of other dimensions, of a component count
// that does not fit `colour`, or that makes libjpeg warn (corrupt data, premature end) gives
// CorruptData whose message is the reason, without context (the caller says which frame).
Result decodeJpegFrameRgba(const uint8_t* data, size_t size, int width, int height, JpegColour colour, uint8_t* dst,
                           size_t pitch);

} // namespace iris
