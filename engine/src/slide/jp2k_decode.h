// JPEG 2000 codestream decoding with OpenJPEG, for Aperio SVS tiles stored with TIFF
// compression 33003 (YCbCr components) or 33005 (RGB components).
//
// The conversion to RGB follows OpenSlide 3.4.1's openslide-decode-jp2k.c exactly (the same
// fixed-point YCbCr tables and rounding, components truncated to 8 bits the same way), so that
// the pixels equal OpenSlide's read_region at level 0 byte for byte.
//
// Threading: every function may be called from any number of threads at once (each call makes
// its own OpenJPEG codec).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "iris/types.h"

namespace iris {

enum class Jp2kColour { YCbCr, Rgb };

// Decodes a raw J2K codestream (no JP2 box) of exactly width × height pixels into dst as
// RGBA8, alpha 255, rows `pitch` bytes apart. A codestream of other dimensions, without three
// components, or that OpenJPEG cannot decode gives CorruptData whose message is the reason,
// without context (the caller says which tile and file).
Result decodeJp2kRgba(const uint8_t* data, size_t size, int width, int height, Jp2kColour colour, uint8_t* dst,
                      size_t pitch);

// Whether OpenSlide 3.4.1 can decode the codestream as a width × height tile without reading
// past the end of a component. Its decoder (openslide-decode-jp2k.c) checks the image size only,
// then samples component c at (y / (height / h_c)) · w_c + x / (width / w_c): a component of
// another size than its subsampling implies is read past its end, and one larger than the tile
// divides by zero. This reader clamps such indices itself, but OpenSlide decodes the first tile
// of an Aperio JPEG 2000 slide when the file is opened (found by tests/fuzz). Reads the header
// only. CorruptData saying which component is at fault when OpenSlide would read past it, or
// that the image is not width × height (which OpenSlide refuses, but only after OpenJPEG has
// read the header).
//
// Both check the codestream's SIZ marker before OpenJPEG sees it: an image of another size
// than the tile, or one divided into more than 4096 codestream tiles (OpenJPEG allocates per
// tile as it reads the header), is refused without calling it.
Result checkJp2kForOpenSlide(const uint8_t* data, size_t size, int width, int height);

} // namespace iris
