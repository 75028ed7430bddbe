// Colour management (docs/COLOR.md): the transform from a slide's embedded ICC profile to the
// display's, built with LittleCMS and baked into a 3D lookup table that the tile shader applies
// to every sample after mip sampling (trilinear interpolation of the table on the GPU).
//
// Thread-safety: pure functions; call from any thread.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "iris/types.h"

namespace iris::color {

// ICC rendering intent of the slide → display transform (the public RenderingIntent).
using Intent = RenderingIntent;

// A baked transform: size³ entries; entry (r, g, b) (r fastest, then g, then b) holds the
// display RGB, as IEEE half floats (RGBA, A = 1), of the source colour (r, g, b) / (size - 1).
struct Lut3D {
    uint32_t size = 0;
    std::vector<uint16_t> rgba; // size³ × 4 half floats
    std::string sourceDescription;  // the slide profile's description tag ("" when it has none)
    std::string displayDescription; // the display profile's ("sRGB" for the built-in one)
};

// The grid size the engine uses (docs/COLOR.md says why): at 33³ a profile with strong curves
// is off by up to 1.6 ΔE2000 before the frame's rounding, at 65³ by 0.6; 65³ RGBA16F is 2.2 MB.
inline constexpr uint32_t kLutSize = 65;

// Builds the transform from `source` (the slide's ICC profile bytes) to `display` (the display's
// profile bytes; empty: LittleCMS's built-in sRGB) with `intent`, and bakes it into a size³
// table. Errors (InvalidArgument / CorruptData / UnsupportedFormat) say why: a truncated or
// malformed profile, one LittleCMS rejects, a non-RGB profile, an absurd size.
Expected<Lut3D> bakeLut(std::span<const uint8_t> source, std::span<const uint8_t> display, Intent intent,
                        uint32_t size = kLutSize);

// Converts `image` (RGBA8, premultiplied alpha, as SlideSource::readAssociatedImage returns it)
// in place with the transform bakeLut tabulates, evaluated by LittleCMS directly (no table):
// the associated images of a slide, shown beside its tiles, in the same colours. The colour is
// converted unpremultiplied, as the tile shader does; alpha is unchanged. Errors as bakeLut's.
Result transformImage(std::span<const uint8_t> source, std::span<const uint8_t> display, Intent intent, Image& image);

// The profile's description tag (ASCII), or "" when it has none or the bytes are no profile.
std::string profileDescription(std::span<const uint8_t> profile);

// IEEE 754 binary16 conversions of the table's entries (a helper of our own: GCC 12 has no
// _Float16 in C++). floatToHalf rounds to nearest, ties to even; overflow gives ±infinity,
// NaN a quiet NaN. halfToFloat is exact.
uint16_t floatToHalf(float f);
float halfToFloat(uint16_t h);

} // namespace iris::color
