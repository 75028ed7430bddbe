// The slide → display colour transform baked into a 3D table (color_lut.h, docs/COLOR.md).
//
// Every call has its own LittleCMS context: its error handler writes into that call's message
// (nothing is printed, and two threads never share LittleCMS state), and everything opened in
// it is closed before it goes. The profile bytes are checked here first (size, signature, tag
// table) so that the common defects get a message naming the field; LittleCMS then parses
// the tags and builds the transform, and whatever it rejects is reported in its own words.
#include "color/color_lut.h"

#include <lcms2.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <memory>
#include <type_traits>

namespace iris::color {

namespace {

// Larger profiles exist (big device links), but no scanner embeds one: 64 MiB bounds what a
// hostile file can make LittleCMS read and allocate.
constexpr std::size_t kMaxProfileBytes = std::size_t(64) << 20;
constexpr std::size_t kHeaderBytes = 128; // then the tag count (4 bytes) and 12 bytes a tag
constexpr uint32_t kMinLutSize = 2;
constexpr uint32_t kMaxLutSize = 129;

uint32_t be32(const uint8_t* p) {
    return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | uint32_t(p[3]);
}

std::string sigName(uint32_t sig) {
    std::string s;
    for (int shift = 24; shift >= 0; shift -= 8) {
        const char c = char((sig >> shift) & 0xff);
        s += (c >= 0x20 && c < 0x7f) ? c : '?';
    }
    return "'" + s + "'";
}

// The structure LittleCMS trusts least: the header's size and signature and the tag table.
// `what` names the profile in messages ("the slide's ICC profile").
Result checkProfileBytes(std::span<const uint8_t> bytes, const std::string& what) {
    if (bytes.empty()) return {Status::InvalidArgument, what + " is empty"};
    if (bytes.size() > kMaxProfileBytes)
        return {Status::UnsupportedFormat,
                what + " is " + std::to_string(bytes.size()) + " bytes, more than the 64 MiB limit"};
    if (bytes.size() < kHeaderBytes + 4)
        return {Status::CorruptData, what + " is truncated: " + std::to_string(bytes.size()) +
                                         " bytes, less than its 132-byte header and tag count"};
    const uint8_t* p = bytes.data();
    if (be32(p + 36) != 0x61637370) // 'acsp'
        return {Status::CorruptData,
                what + " is no ICC profile: byte 36 holds " + sigName(be32(p + 36)) + ", not the signature 'acsp'"};
    const uint32_t declared = be32(p);
    if (declared > kMaxProfileBytes)
        return {Status::UnsupportedFormat,
                what + " declares " + std::to_string(declared) + " bytes, more than the 64 MiB limit"};
    if (declared > bytes.size())
        return {Status::CorruptData, what + " is truncated: header says " + std::to_string(declared) + " bytes, " +
                                         std::to_string(bytes.size()) + " present"};
    if (declared < bytes.size())
        return {Status::CorruptData, what + " has a wrong size: header says " + std::to_string(declared) + " bytes, " +
                                         std::to_string(bytes.size()) + " present"};
    const uint64_t tagCount = be32(p + kHeaderBytes);
    if (kHeaderBytes + 4 + tagCount * 12 > declared)
        return {Status::CorruptData, what + "'s tag table (" + std::to_string(tagCount) +
                                         " tags) runs past the end of its " + std::to_string(declared) + " bytes"};
    for (uint64_t i = 0; i < tagCount; ++i) {
        const uint8_t* t = p + kHeaderBytes + 4 + i * 12;
        const uint64_t offset = be32(t + 4), size = be32(t + 8);
        if (offset + size > declared)
            return {Status::CorruptData, what + "'s tag " + sigName(be32(t)) + " (offset " + std::to_string(offset) +
                                             ", " + std::to_string(size) + " bytes) runs past the end of its " +
                                             std::to_string(declared) + " bytes"};
    }
    return Result::success();
}

// One call's LittleCMS context; the first error LittleCMS reports in it is kept.
struct Context {
    std::string error;
    std::unique_ptr<std::remove_pointer_t<cmsContext>, void (*)(cmsContext)> handle{nullptr, cmsDeleteContext};

    Context(const Context&) = delete; // LittleCMS holds its address
    Context& operator=(const Context&) = delete;
    Context() {
        handle.reset(cmsCreateContext(nullptr, this));
        if (handle) cmsSetLogErrorHandlerTHR(handle.get(), &Context::onError);
    }
    static void onError(cmsContext ctx, cmsUInt32Number /*code*/, const char* text) {
        auto* self = static_cast<Context*>(cmsGetContextUserData(ctx));
        if (self && self->error.empty() && text) self->error = text;
    }
    std::string why() const { return error.empty() ? "no reason given" : error; }
};

using Profile = std::unique_ptr<void, cmsBool (*)(cmsHPROFILE)>;
using Transform = std::unique_ptr<void, void (*)(cmsHTRANSFORM)>;

Profile openProfile(Context& ctx, std::span<const uint8_t> bytes) {
    return Profile(cmsOpenProfileFromMemTHR(ctx.handle.get(), bytes.data(), cmsUInt32Number(bytes.size())),
                   cmsCloseProfile);
}

// Control characters (a hostile profile's description can hold anything) become '?'.
std::string descriptionOf(cmsHPROFILE profile) {
    const auto* mlu = static_cast<const cmsMLU*>(cmsReadTag(profile, cmsSigProfileDescriptionTag));
    if (!mlu) return {};
    // "en"/"US" first; LittleCMS falls back to the same language, then to the first entry.
    const cmsUInt32Number needed = cmsMLUgetASCII(mlu, "en", "US", nullptr, 0);
    if (needed == 0) return {};
    constexpr cmsUInt32Number kMaxChars = 256;
    std::string text(std::min(needed, kMaxChars + 1), '\0');
    cmsMLUgetASCII(mlu, "en", "US", text.data(), cmsUInt32Number(text.size()));
    text.resize(std::strlen(text.c_str()));
    for (char& c : text)
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
    return text;
}

// A profile whose colours are RGB and that can take part in a two-profile transform.
// The header's signatures are whatever the file holds, mostly values that LittleCMS's enums do
// not name; holding one in a variable of the enum type is undefined behaviour (found by
// tests/fuzz, regressions/icc_profile/colour-space-outside-enum.fuzz), so they are compared as
// the 32-bit numbers they are.
Result checkRgbProfile(cmsHPROFILE profile, const std::string& what) {
    const uint32_t space = uint32_t(cmsGetColorSpace(profile));
    if (space != uint32_t(cmsSigRgbData))
        return {Status::UnsupportedFormat, what + " describes " + sigName(space) + " colours, not RGB ('RGB ')"};
    const uint32_t cls = uint32_t(cmsGetDeviceClass(profile));
    if (cls == uint32_t(cmsSigLinkClass) || cls == uint32_t(cmsSigAbstractClass) ||
        cls == uint32_t(cmsSigNamedColorClass))
        return {Status::UnsupportedFormat,
                what + " is of class " + sigName(cls) + ", not a device or colour-space profile"};
    return Result::success();
}

// The source → display transform both bakeLut and transformImage evaluate: the profiles
// checked and opened in `ctx`, the intent's flags, pixel formats `in` → `out`. The
// descriptions are filled when asked for.
Expected<Transform> openTransform(Context& ctx, std::span<const uint8_t> source, std::span<const uint8_t> display,
                                  Intent intent, cmsUInt32Number in, cmsUInt32Number out, cmsUInt32Number extraFlags,
                                  std::string* sourceDescription, std::string* displayDescription) {
    const std::string srcWhat = "the slide's ICC profile", dstWhat = "the display's ICC profile";
    if (Result r = checkProfileBytes(source, srcWhat); !r) return r;
    if (!display.empty())
        if (Result r = checkProfileBytes(display, dstWhat); !r) return r;
    if (!ctx.handle) return Result(Status::OutOfMemory, "LittleCMS could not create a context");
    Profile src = openProfile(ctx, source);
    if (!src) return Result(Status::CorruptData, "LittleCMS rejected " + srcWhat + ": " + ctx.why());
    Profile dst = display.empty() ? Profile(cmsCreate_sRGBProfileTHR(ctx.handle.get()), cmsCloseProfile)
                                  : openProfile(ctx, display);
    if (!dst) return Result(Status::CorruptData, "LittleCMS rejected " + dstWhat + ": " + ctx.why());
    if (Result r = checkRgbProfile(src.get(), srcWhat); !r) return r;
    if (Result r = checkRgbProfile(dst.get(), dstWhat); !r) return r;
    if (sourceDescription) *sourceDescription = descriptionOf(src.get());
    if (displayDescription) *displayDescription = display.empty() ? "sRGB" : descriptionOf(dst.get());

    const cmsUInt32Number flags =
        extraFlags | (intent == Intent::RelativeColorimetric ? cmsFLAGS_BLACKPOINTCOMPENSATION : 0);
    const cmsUInt32Number lcmsIntent =
        intent == Intent::RelativeColorimetric ? INTENT_RELATIVE_COLORIMETRIC : INTENT_PERCEPTUAL;
    // The transform keeps what it needs of the profiles; they may be closed after this.
    Transform xf(cmsCreateTransformTHR(ctx.handle.get(), src.get(), in, dst.get(), out, lcmsIntent, flags),
                 cmsDeleteTransform);
    if (!xf)
        return Result(Status::UnsupportedFormat,
                      "LittleCMS could not build the transform from " + srcWhat + " to " + dstWhat + ": " + ctx.why());
    return xf;
}

} // namespace

Expected<Lut3D> bakeLut(std::span<const uint8_t> source, std::span<const uint8_t> display, Intent intent,
                        uint32_t size) {
    if (size < kMinLutSize || size > kMaxLutSize)
        return Result(Status::InvalidArgument,
                      "a colour table of " + std::to_string(size) + "³ entries: the size must be 2 to 129");
    Lut3D lut;
    lut.size = size;
    Context ctx;
    // Float in and out: LittleCMS then evaluates the whole pipeline in floating point (its
    // 8/16-bit optimisations, which resample the transform into a table of their own, are
    // not used on float formats), so the table's entries are the transform itself.
    Expected<Transform> xf = openTransform(ctx, source, display, intent, TYPE_RGB_FLT, TYPE_RGB_FLT, cmsFLAGS_NOCACHE,
                                           &lut.sourceDescription, &lut.displayDescription);
    if (!xf) return xf.error();

    const std::size_t n = std::size_t(size) * size * size;
    std::vector<float> grid(n * 3), out(n * 3);
    const float step = 1.0f / float(size - 1);
    std::size_t i = 0;
    for (uint32_t b = 0; b < size; ++b)
        for (uint32_t g = 0; g < size; ++g)
            for (uint32_t r = 0; r < size; ++r, i += 3) {
                // The last node is exactly 1 (r · step might round below it).
                grid[i + 0] = r + 1 == size ? 1.0f : float(r) * step;
                grid[i + 1] = g + 1 == size ? 1.0f : float(g) * step;
                grid[i + 2] = b + 1 == size ? 1.0f : float(b) * step;
            }
    cmsDoTransform(xf.value().get(), grid.data(), out.data(), cmsUInt32Number(n));

    lut.rgba.resize(n * 4);
    for (std::size_t k = 0; k < n; ++k) {
        for (int c = 0; c < 3; ++c) {
            const float v = out[k * 3 + c];
            // Out of the display's gamut: clipped here, per channel (NaN, which a degenerate
            // profile can produce, becomes 0).
            lut.rgba[k * 4 + c] = floatToHalf(v > 0 ? std::min(v, 1.0f) : 0.0f);
        }
        lut.rgba[k * 4 + 3] = 0x3c00; // 1.0
    }
    return lut;
}

Result transformImage(std::span<const uint8_t> source, std::span<const uint8_t> display, Intent intent, Image& image) {
    if (uint64_t(image.width) * image.height * 4 != image.rgba.size())
        return Result(Status::InvalidArgument, "an image of " + std::to_string(image.width) + "x" +
                                                   std::to_string(image.height) + " pixels holds " +
                                                   std::to_string(image.rgba.size()) + " bytes, not 4 a pixel");
    Context ctx;
    // Floats in and out, as bakeLut: LittleCMS's 8- and 16-bit paths resample the transform
    // into tables of their own, which are off by several codes in the darks of steep curves.
    Expected<Transform> xf =
        openTransform(ctx, source, display, intent, TYPE_RGB_FLT, TYPE_RGB_FLT, cmsFLAGS_NOCACHE, nullptr, nullptr);
    if (!xf) return xf.error();
    // Row by row, so that the scratch stays small whatever the image's size. The colour is
    // converted unpremultiplied, as the tile shader converts it, and premultiplied again.
    std::vector<float> row(std::size_t(image.width) * 3), out(row.size());
    for (uint32_t y = 0; y < image.height; ++y) {
        uint8_t* px = image.rgba.data() + std::size_t(y) * image.width * 4;
        for (uint32_t x = 0; x < image.width; ++x) {
            const float a = px[x * 4 + 3];
            for (int c = 0; c < 3; ++c) row[x * 3 + c] = a == 0 ? 0.0f : std::min(1.0f, px[x * 4 + c] / a);
        }
        cmsDoTransform(xf.value().get(), row.data(), out.data(), image.width);
        for (uint32_t x = 0; x < image.width; ++x) {
            const uint32_t a = px[x * 4 + 3];
            for (int c = 0; c < 3; ++c) {
                // Clipped to the display's range (NaN becomes 0), rounded to 8 bits, premultiplied.
                const float v = out[x * 3 + c];
                const uint32_t v8 = uint32_t(std::lround((v > 0 ? std::min(v, 1.0f) : 0.0f) * 255.0f));
                px[x * 4 + c] = uint8_t((v8 * a + 127) / 255);
            }
        }
    }
    return Result::success();
}

std::string profileDescription(std::span<const uint8_t> profile) {
    if (!checkProfileBytes(profile, "profile")) return {};
    Context ctx;
    if (!ctx.handle) return {};
    Profile p = openProfile(ctx, profile);
    return p ? descriptionOf(p.get()) : std::string();
}

uint16_t floatToHalf(float f) {
    uint32_t x = std::bit_cast<uint32_t>(f);
    const uint16_t sign = uint16_t((x >> 16) & 0x8000);
    x &= 0x7fffffff;
    if (x >= 0x7f800000) return sign | (x > 0x7f800000 ? 0x7e00 : 0x7c00); // NaN, infinity
    if (x >= 0x477ff000) return sign | 0x7c00;                             // ≥ 65520 rounds to infinity
    if (x < 0x38800000) {
        // Below the smallest normal half (2⁻¹⁴): a multiple of 2⁻²⁴. Scaling by 2²⁴ is exact,
        // and nearbyint rounds to nearest even (the default rounding mode). 1024 is the
        // smallest normal, whose bits are 0x400: the carry is right.
        return sign | uint16_t(std::nearbyint(std::bit_cast<float>(x) * 16777216.0f));
    }
    // Normal: rebias the exponent (127 → 15) and round the 13 dropped mantissa bits to
    // nearest even; a carry out of the mantissa steps the exponent, as it should.
    x += 0xc8000fffu + ((x >> 13) & 1);
    return sign | uint16_t(x >> 13);
}

float halfToFloat(uint16_t h) {
    const uint32_t sign = uint32_t(h & 0x8000) << 16;
    const uint32_t exp = (h >> 10) & 0x1f, mant = h & 0x3ff;
    if (exp == 0) {
        const float v = float(mant) * (1.0f / 16777216.0f); // subnormal (or zero): mant · 2⁻²⁴
        return std::bit_cast<float>(std::bit_cast<uint32_t>(v) | sign);
    }
    if (exp == 31) return std::bit_cast<float>(sign | 0x7f800000 | (mant << 13));
    return std::bit_cast<float>(sign | ((exp + 112) << 23) | (mant << 13));
}

} // namespace iris::color
