// libFuzzer target for the ICC profile path (engine/src/color/color_lut.cpp with LittleCMS),
// see README.md.
//
// Each input is the bytes of one ICC profile, as a reader hands the engine a slide's embedded
// profile (TIFF tag 34675, the .iris ICC block, DICOM (0028,2000)); the engine then asks for its
// description (the properties dock) and bakes the slide → display table. The input goes
// through what the engine does with it (Engine's bakeColor):
//   profileDescription()   the description shown, or "";
//   bakeLut()              as the slide's profile, to the built-in sRGB display, with both
//                          rendering intents; and as the display's profile, from sRGB.
// The tables are baked at 5³ (the engine's is 65³): the grid size changes only how many colours
// go through the transform, and 65³ of them would make each input take a tenth of a second.
//
// Mutations that change a profile's length first break its declared size, which the engine
// checks before LittleCMS sees anything; so that they still reach LittleCMS, an input whose
// size field is wrong is also tried with the field corrected.
//
// Besides the sanitizers it checks what bakeLut and profileDescription promise:
//   * a profile is refused with InvalidArgument, CorruptData or UnsupportedFormat (OutOfMemory
//     when LittleCMS cannot make a context) and a message naming which profile is at fault;
//     one whose declared size is not its length is CorruptData (UnsupportedFormat past the
//     64 MiB limit) before LittleCMS parses it;
//   * a baked table has size³ entries, each a finite half float in [0, 1] with alpha 1;
//   * descriptions are at most 256 characters, without control characters, and the table's
//     source description is profileDescription()'s; the built-in display is "sRGB".
#include <lcms2.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include "color/color_lut.h"
#include "fuzz_support.h"

namespace {

using namespace iris;

constexpr uint32_t kFuzzLutSize = 5;

uint32_t be32(const uint8_t* p) {
    return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | uint32_t(p[3]);
}

// LittleCMS's sRGB, serialised: the other end of the transform when the input is the display's.
const std::vector<uint8_t>& srgbBytes() {
    static const std::vector<uint8_t> bytes = [] {
        cmsHPROFILE p = cmsCreate_sRGBProfile();
        cmsUInt32Number n = 0;
        if (!p || !cmsSaveProfileToMem(p, nullptr, &n)) std::abort();
        std::vector<uint8_t> v(n);
        if (!cmsSaveProfileToMem(p, v.data(), &n)) std::abort();
        cmsCloseProfile(p);
        return v;
    }();
    return bytes;
}

void checkDescription(const std::string& d) {
    PROMISE(d.size() <= 256);
    for (char c : d) PROMISE(static_cast<unsigned char>(c) >= 0x20 && c != 0x7f);
}

bool sizeFieldWrong(std::span<const uint8_t> p) {
    return p.size() >= 132 && be32(p.data() + 36) == 0x61637370 && be32(p.data()) != p.size();
}

// One bake; `which` is the role the fuzzed profile plays ("slide" or "display").
void bake(std::span<const uint8_t> source, std::span<const uint8_t> display, color::Intent intent, const char* which,
          std::span<const uint8_t> fuzzed, const std::string& description) {
    Expected<color::Lut3D> lut = color::bakeLut(source, display, intent, kFuzzLutSize);
    if (!lut) {
        const Result& e = lut.error();
        if (fuzz::verbose()) fuzz::note(which, e);
        PROMISE(e.status() == Status::InvalidArgument || e.status() == Status::CorruptData ||
                e.status() == Status::UnsupportedFormat || e.status() == Status::OutOfMemory);
        if (e.status() != Status::OutOfMemory)
            PROMISE(fuzz::contains(e.message(), std::string("the ") + which + "'s ICC profile"));
        if (sizeFieldWrong(fuzzed)) {
            // Refused before LittleCMS: CorruptData, or UnsupportedFormat for a size over the limit.
            PROMISE(e.status() ==
                    (be32(fuzzed.data()) > (64u << 20) ? Status::UnsupportedFormat : Status::CorruptData));
        }
        return;
    }
    PROMISE(!sizeFieldWrong(fuzzed));
    PROMISE(lut->size == kFuzzLutSize);
    PROMISE(lut->rgba.size() == size_t(kFuzzLutSize) * kFuzzLutSize * kFuzzLutSize * 4);
    for (size_t i = 0; i < lut->rgba.size(); i += 4) {
        for (size_t c = 0; c < 3; ++c) {
            const float v = color::halfToFloat(lut->rgba[i + c]);
            PROMISE(std::isfinite(v) && v >= 0.0f && v <= 1.0f);
        }
        PROMISE(lut->rgba[i + 3] == 0x3c00);
    }
    checkDescription(lut->sourceDescription);
    checkDescription(lut->displayDescription);
    if (display.empty()) PROMISE(lut->displayDescription == "sRGB");
    if (source.data() == fuzzed.data()) PROMISE(lut->sourceDescription == description);
    if (display.data() == fuzzed.data()) PROMISE(lut->displayDescription == description);
}

void tryProfile(std::span<const uint8_t> p) {
    const std::string description = color::profileDescription(p);
    checkDescription(description);
    bake(p, {}, color::Intent::Perceptual, "slide", p, description);
    bake(p, {}, color::Intent::RelativeColorimetric, "slide", p, description);
    bake(srgbBytes(), p, color::Intent::Perceptual, "display", p, description);
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    // An empty display profile means "the built-in sRGB": not an input to test here.
    if (size == 0) return 0;
    const std::span<const uint8_t> p(data, size);
    tryProfile(p);
    if (sizeFieldWrong(p) && size <= UINT32_MAX) {
        std::vector<uint8_t> fixed(data, data + size); // exactly `size` bytes, as the input
        for (int i = 0; i < 4; ++i) fixed[size_t(i)] = uint8_t(uint32_t(size) >> (24 - 8 * i));
        tryProfile(fixed);
    }
    return 0;
}
