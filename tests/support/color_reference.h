// The CPU reference of colour management (docs/COLOR.md), for the unit suite (tests/color) and
// the GPU suites that check the tile shader's colour step:
//
//   * applyLut: what the shader does with a baked table (color/color_lut.h): trilinear
//     interpolation between the nodes around c·(size − 1) (node i holds the colour i/(size−1)),
//     in float (shaders/color_lut.glsl fetches the eight nodes itself), then written to an
//     8-bit UNORM target (round(v·255)); weightBits models a sampler's fixed-point weights;
//   * Transform: LittleCMS applied to the pixels directly (float pipeline, no table): the
//     colours the table approximates;
//   * LabConverter + deltaE2000: what a display's RGB looks like (CIELAB, D50, through the
//     display's profile) and how far apart two such colours are (LittleCMS's CIEDE2000);
//   * profiles to test with: LittleCMS's sRGB, one with strong curves and odd primaries, a
//     wide-gamut gamma-1.8 display.
//
// LittleCMS stays inside color_reference.cpp; nothing here needs a GPU or Qt.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "color/color_lut.h"

namespace iristest::color {

using iris::color::Intent;
using iris::color::Lut3D;

// The table sampled at source colour (r, g, b) ∈ [0, 1]³ with trilinear interpolation, as a
// GPU's linear filter does at texture coordinate (c·(size − 1) + 0.5) / size. weightBits > 0
// rounds each interpolation weight to that many fractional bits (GPUs filter with 8:
// Vulkan's subTexelPrecisionBits, 8 on NVIDIA, AMD and lavapipe); 0: exact weights.
std::array<float, 3> sampleLut(const Lut3D& lut, float r, float g, float b, int weightBits = 0);
// sampleLut of an 8-bit pixel (c = v / 255), each channel rounded to 8 bits (round(v·255),
// clamped): what the shader's output holds in an RGBA8 target.
std::array<uint8_t, 3> applyLut(const Lut3D& lut, uint8_t r, uint8_t g, uint8_t b, int weightBits = 0);

// Rounds a display value in [0, 1] to 8 bits (clamped), as the UNORM conversion does.
uint8_t toUnorm8(float v);

// LittleCMS's source → display transform of RGB floats, evaluated without tables (the
// intent and flags bakeLut uses). Move-only; thread-compatible (one thread at a time).
class Transform {
public:
    // display empty: LittleCMS's built-in sRGB. nullopt with *error set when LittleCMS refuses.
    static std::optional<Transform> create(std::span<const uint8_t> source, std::span<const uint8_t> display,
                                           Intent intent, std::string* error);
    // n RGB triples in [0, 1] → n display RGB triples (not clamped).
    void apply(const float* rgb, float* out, std::size_t n) const;
    // One 8-bit pixel, the result clamped and rounded to 8 bits.
    std::array<uint8_t, 3> apply8(uint8_t r, uint8_t g, uint8_t b) const;

private:
    std::shared_ptr<void> handle_;
};

struct Lab {
    double L = 0, a = 0, b = 0;
};

// Display RGB → CIELAB (D50) through the display's profile (empty: built-in sRGB),
// relative colorimetric: the colour the display shows for that RGB.
class LabConverter {
public:
    static std::optional<LabConverter> create(std::span<const uint8_t> display, std::string* error);
    Lab toLab(const std::array<uint8_t, 3>& rgb) const;
    // n 8-bit RGB triples (packed) → n Lab values.
    std::vector<Lab> toLab(const uint8_t* rgb, std::size_t n) const;
    // n float RGB triples in [0, 1] (packed) → n Lab values.
    std::vector<Lab> toLab(const float* rgb, std::size_t n) const;

private:
    std::shared_ptr<void> handle_, float_;
};

// CIEDE2000 (kL = kC = kH = 1), LittleCMS's cmsCIE2000DeltaE.
double deltaE2000(const Lab& x, const Lab& y);

// ---- profiles -------------------------------------------------------------------------

// LittleCMS's built-in sRGB (v4), as profile bytes.
std::vector<uint8_t> srgbProfile();
// A slide profile with strong curves: per channel a gamma-3.0 curve (R), a steep tabulated
// S-curve (G) and a parametric curve with a long toe (B), over odd primaries (a wide red, a
// green beyond sRGB, a purplish blue) and a D65 white; description "Iris test: strong curves".
std::vector<uint8_t> strongCurvesProfile();
// A display that is not sRGB: AdobeRGB (1998) primaries, D65 white, pure gamma 1.8;
// description "Iris test: wide gamut gamma 1.8".
std::vector<uint8_t> wideGamma18Profile();

} // namespace iristest::color
