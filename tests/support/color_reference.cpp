// See color_reference.h.
#include "color_reference.h"

#include <lcms2.h>

#include <algorithm>
#include <cmath>

namespace iristest::color {

namespace {

using iris::color::halfToFloat;

// The weight t ∈ [0, 1] rounded to `bits` fractional bits (0: as is).
float quantiseWeight(float t, int bits) {
    if (bits <= 0) return t;
    const float scale = float(1 << bits);
    return std::round(t * scale) / scale;
}

std::vector<uint8_t> saveToMemory(cmsHPROFILE profile) {
    cmsUInt32Number bytes = 0;
    std::vector<uint8_t> out;
    if (!profile || !cmsSaveProfileToMem(profile, nullptr, &bytes)) return out;
    out.resize(bytes);
    if (!cmsSaveProfileToMem(profile, out.data(), &bytes)) out.clear();
    return out;
}

void setDescription(cmsHPROFILE profile, const char* text) {
    cmsMLU* mlu = cmsMLUalloc(nullptr, 1);
    cmsMLUsetASCII(mlu, "en", "US", text);
    cmsWriteTag(profile, cmsSigProfileDescriptionTag, mlu);
    cmsMLUfree(mlu);
}

cmsHPROFILE openOrSrgb(std::span<const uint8_t> bytes) {
    return bytes.empty() ? cmsCreate_sRGBProfile() : cmsOpenProfileFromMem(bytes.data(), cmsUInt32Number(bytes.size()));
}

// The global LittleCMS context would print its errors: keep them quiet (the reference reports
// failure through its return values).
void quietLcms() {
    static const bool once = [] {
        cmsSetLogErrorHandler([](cmsContext, cmsUInt32Number, const char*) {});
        return true;
    }();
    (void)once;
}

} // namespace

std::array<float, 3> sampleLut(const Lut3D& lut, float r, float g, float b, int weightBits) {
    const uint32_t n = lut.size;
    const float in[3] = {r, g, b};
    uint32_t i0[3], i1[3];
    float t[3];
    for (int c = 0; c < 3; ++c) {
        // Texel units: node i is source value i / (n − 1). Clamp-to-edge at both ends.
        const float x = std::clamp(in[c], 0.0f, 1.0f) * float(n - 1);
        const float fl = std::min(std::floor(x), float(n - 1));
        i0[c] = uint32_t(fl);
        i1[c] = std::min(i0[c] + 1, n - 1);
        t[c] = quantiseWeight(x - fl, weightBits);
    }
    auto at = [&](uint32_t x, uint32_t y, uint32_t z, int c) {
        return halfToFloat(lut.rgba[((std::size_t(z) * n + y) * n + x) * 4 + c]);
    };
    std::array<float, 3> out{};
    for (int c = 0; c < 3; ++c) {
        const float c00 = at(i0[0], i0[1], i0[2], c) * (1 - t[0]) + at(i1[0], i0[1], i0[2], c) * t[0];
        const float c10 = at(i0[0], i1[1], i0[2], c) * (1 - t[0]) + at(i1[0], i1[1], i0[2], c) * t[0];
        const float c01 = at(i0[0], i0[1], i1[2], c) * (1 - t[0]) + at(i1[0], i0[1], i1[2], c) * t[0];
        const float c11 = at(i0[0], i1[1], i1[2], c) * (1 - t[0]) + at(i1[0], i1[1], i1[2], c) * t[0];
        const float c0 = c00 * (1 - t[1]) + c10 * t[1];
        const float c1 = c01 * (1 - t[1]) + c11 * t[1];
        out[size_t(c)] = c0 * (1 - t[2]) + c1 * t[2];
    }
    return out;
}

uint8_t toUnorm8(float v) {
    if (!(v > 0)) return 0;
    if (v >= 1) return 255;
    return uint8_t(std::floor(v * 255.0f + 0.5f));
}

std::array<uint8_t, 3> applyLut(const Lut3D& lut, uint8_t r, uint8_t g, uint8_t b, int weightBits) {
    const auto v = sampleLut(lut, float(r) / 255.0f, float(g) / 255.0f, float(b) / 255.0f, weightBits);
    return {toUnorm8(v[0]), toUnorm8(v[1]), toUnorm8(v[2])};
}

// ---- Transform ------------------------------------------------------------------------

std::optional<Transform> Transform::create(std::span<const uint8_t> source, std::span<const uint8_t> display,
                                           Intent intent, std::string* error) {
    quietLcms();
    cmsHPROFILE src = openOrSrgb(source);
    cmsHPROFILE dst = openOrSrgb(display);
    cmsHTRANSFORM xf = nullptr;
    if (src && dst) {
        const bool rel = intent == Intent::RelativeColorimetric;
        xf = cmsCreateTransform(src, TYPE_RGB_FLT, dst, TYPE_RGB_FLT,
                                rel ? INTENT_RELATIVE_COLORIMETRIC : INTENT_PERCEPTUAL,
                                cmsFLAGS_NOCACHE | (rel ? cmsFLAGS_BLACKPOINTCOMPENSATION : 0));
    }
    if (src) cmsCloseProfile(src);
    if (dst) cmsCloseProfile(dst);
    if (!xf) {
        if (error) *error = "LittleCMS could not build the reference transform";
        return std::nullopt;
    }
    Transform t;
    t.handle_ = std::shared_ptr<void>(xf, cmsDeleteTransform);
    return t;
}

void Transform::apply(const float* rgb, float* out, std::size_t n) const {
    cmsDoTransform(handle_.get(), rgb, out, cmsUInt32Number(n));
}

std::array<uint8_t, 3> Transform::apply8(uint8_t r, uint8_t g, uint8_t b) const {
    const float in[3] = {float(r) / 255.0f, float(g) / 255.0f, float(b) / 255.0f};
    float out[3];
    apply(in, out, 1);
    return {toUnorm8(out[0]), toUnorm8(out[1]), toUnorm8(out[2])};
}

// ---- Lab ------------------------------------------------------------------------------

std::optional<LabConverter> LabConverter::create(std::span<const uint8_t> display, std::string* error) {
    quietLcms();
    cmsHPROFILE dst = openOrSrgb(display);
    cmsHPROFILE lab = cmsCreateLab4Profile(nullptr); // D50
    cmsHTRANSFORM xf = nullptr, xff = nullptr;
    if (dst && lab) {
        xf = cmsCreateTransform(dst, TYPE_RGB_8, lab, TYPE_Lab_DBL, INTENT_RELATIVE_COLORIMETRIC,
                                cmsFLAGS_NOCACHE | cmsFLAGS_NOOPTIMIZE);
        xff = cmsCreateTransform(dst, TYPE_RGB_FLT, lab, TYPE_Lab_DBL, INTENT_RELATIVE_COLORIMETRIC,
                                 cmsFLAGS_NOCACHE | cmsFLAGS_NOOPTIMIZE);
    }
    if (dst) cmsCloseProfile(dst);
    if (lab) cmsCloseProfile(lab);
    LabConverter c;
    if (xf) c.handle_ = std::shared_ptr<void>(xf, cmsDeleteTransform);
    if (xff) c.float_ = std::shared_ptr<void>(xff, cmsDeleteTransform);
    if (!xf || !xff) {
        if (error) *error = "LittleCMS could not build the display → Lab transform";
        return std::nullopt;
    }
    return c;
}

Lab LabConverter::toLab(const std::array<uint8_t, 3>& rgb) const { return toLab(rgb.data(), 1)[0]; }

std::vector<Lab> LabConverter::toLab(const uint8_t* rgb, std::size_t n) const {
    static_assert(sizeof(Lab) == sizeof(cmsCIELab));
    std::vector<Lab> out(n);
    if (n) cmsDoTransform(handle_.get(), rgb, out.data(), cmsUInt32Number(n));
    return out;
}

std::vector<Lab> LabConverter::toLab(const float* rgb, std::size_t n) const {
    std::vector<Lab> out(n);
    if (n) cmsDoTransform(float_.get(), rgb, out.data(), cmsUInt32Number(n));
    return out;
}

double deltaE2000(const Lab& x, const Lab& y) {
    const cmsCIELab a{x.L, x.a, x.b}, b{y.L, y.a, y.b};
    return cmsCIE2000DeltaE(&a, &b, 1, 1, 1);
}

// ---- profiles -------------------------------------------------------------------------

std::vector<uint8_t> srgbProfile() {
    quietLcms();
    cmsHPROFILE p = cmsCreate_sRGBProfile();
    std::vector<uint8_t> out = saveToMemory(p);
    cmsCloseProfile(p);
    return out;
}

std::vector<uint8_t> strongCurvesProfile() {
    quietLcms();
    cmsCIExyY white;
    cmsWhitePointFromTemp(&white, 6504);
    const cmsCIExyYTRIPLE primaries{{0.71, 0.28, 1.0}, {0.14, 0.82, 1.0}, {0.17, 0.03, 1.0}};
    // Green: a steep logistic S-curve, renormalised to pass through 0 and 1.
    std::vector<cmsFloat32Number> s(4096);
    const auto logistic = [](double x) { return 1.0 / (1.0 + std::exp(-14.0 * (x - 0.45))); };
    const double lo = logistic(0), hi = logistic(1);
    for (size_t i = 0; i < s.size(); ++i)
        s[i] = cmsFloat32Number((logistic(double(i) / double(s.size() - 1)) - lo) / (hi - lo));
    // Blue: IEC 61966-style type 4 with a long linear toe: Y = (aX + b)^g for X ≥ d, cX below
    // (c makes it continuous at d: (0.4 / 1.2)⁴ / 0.2 = 5/81).
    const cmsFloat64Number blueParams[5] = {4.0, 1.0 / 1.2, 0.2 / 1.2, 5.0 / 81.0, 0.2};
    cmsToneCurve* curves[3] = {cmsBuildGamma(nullptr, 3.0), cmsBuildTabulatedToneCurveFloat(nullptr, 4096, s.data()),
                               cmsBuildParametricToneCurve(nullptr, 4, blueParams)};
    cmsHPROFILE p = cmsCreateRGBProfile(&white, &primaries, curves);
    for (cmsToneCurve* c : curves) cmsFreeToneCurve(c);
    setDescription(p, "Iris test: strong curves");
    std::vector<uint8_t> out = saveToMemory(p);
    cmsCloseProfile(p);
    return out;
}

std::vector<uint8_t> wideGamma18Profile() {
    quietLcms();
    cmsCIExyY white;
    cmsWhitePointFromTemp(&white, 6504);
    const cmsCIExyYTRIPLE adobe{{0.64, 0.33, 1.0}, {0.21, 0.71, 1.0}, {0.15, 0.06, 1.0}};
    cmsToneCurve* gamma = cmsBuildGamma(nullptr, 1.8);
    cmsToneCurve* curves[3] = {gamma, gamma, gamma};
    cmsHPROFILE p = cmsCreateRGBProfile(&white, &adobe, curves);
    cmsFreeToneCurve(gamma);
    setDescription(p, "Iris test: wide gamut gamma 1.8");
    std::vector<uint8_t> out = saveToMemory(p);
    cmsCloseProfile(p);
    return out;
}

} // namespace iristest::color
