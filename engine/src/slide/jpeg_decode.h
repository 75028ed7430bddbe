// JPEG decoding with libjpeg-turbo's TurboJPEG API, for the slide readers that store bare
// JPEG streams (the .iris reader's tiles and associated images).
//
// Threading: every function may be called from any number of threads at once; each thread
// keeps its own TurboJPEG decompressor (thread_local), made on first use.
#pragma once

#include <cstddef>
#include <cstdint>

#include "iris/types.h"

namespace iris {

struct JpegDimensions {
    int width = 0;
    int height = 0;
};

// Reads a JPEG's header. CorruptData with TurboJPEG's reason when it is not a JPEG header.
Expected<JpegDimensions> jpegDimensions(const uint8_t* data, size_t size);

// Decodes a JPEG of exactly width × height pixels straight into dst as RGBA8 (alpha 255),
// rows `pitch` bytes apart; nothing else is written. A JPEG of other dimensions is refused
// before anything is written, and any libjpeg warning (bad Huffman code, premature end of
// data, …) is an error: both give CorruptData whose message is TurboJPEG's reason, without
// context (the caller says which tile). OutOfMemory when no decompressor can be made.
Result decodeJpegRgba(const uint8_t* data, size_t size, int width, int height, uint8_t* dst, size_t pitch);

// Decodes a whole JPEG into a new straight-alpha RGBA image (alpha 255). Images of more than
// maxPixels pixels are refused (CorruptData) before any memory is allocated for them.
Expected<Image> decodeJpegImage(const uint8_t* data, size_t size, uint64_t maxPixels);

} // namespace iris
