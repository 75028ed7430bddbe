// libFuzzer target for the JPEG 2000 tile decoder (engine/src/slide/jp2k_decode.cpp), see
// README.md.
//
// Each input is a bare J2K codestream, as an Aperio 33003/33005 tile or a DICOM JPEG 2000 frame
// holds it. The caller of decodeJp2kRgba always knows the size the tile must have (the TIFF
// directory's tile size, the DICOM Rows and Columns); here it is read from the codestream's
// SIZ marker, so that mutations that change the image size still reach the decoder. The
// codestream is decoded as RGB components and as YCbCr components, into a tile whose rows
// are further apart than its width.
//
// Besides the sanitizers it checks what the decoder promises its callers:
//   * success or CorruptData (OutOfMemory only where OpenJPEG cannot make a decoder), with a
//     message; a size other than the stated one is refused (CorruptData naming both sizes);
//   * a decoded tile writes exactly width × height RGBA pixels, alpha 255, rows `pitch` apart:
//     the bytes between rows and past the last row keep their pattern (OpenJPEG is not
//     instrumented, so ASan would not see it write past the buffer);
//   * the YCbCr decode is OpenSlide's conversion (its integer tables, computed here from
//     OpenSlide's formulas) of the RGB decode's components, pixel for pixel;
//   * both colour modes succeed or fail together;
//   * checkJp2kForOpenSlide (the TIFF reader's guard before OpenSlide) answers or refuses.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "fuzz_support.h"
#include "slide/jp2k_decode.h"

namespace {

using namespace iris;

// Bigger images are skipped: a tile of an SVS or a DICOM frame is far smaller, and a decode of
// tens of megapixels makes a slow input, not a better one.
constexpr uint64_t kMaxPixels = uint64_t(1) << 20;
constexpr size_t kRowGap = 12; // bytes between a row's last pixel and the next row
constexpr uint8_t kFill = 0x5C;

uint32_t be32(const uint8_t* p) {
    return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | uint32_t(p[3]);
}

// The image area the SIZ marker states (Xsiz − XOsiz, Ysiz − YOsiz); false without one.
bool sizFromCodestream(const uint8_t* d, size_t n, uint32_t* w, uint32_t* h) {
    // SOC (FF4F), then SIZ (FF51): Lsiz(2) Rsiz(2) Xsiz(4) Ysiz(4) XOsiz(4) YOsiz(4) …
    if (n < 2 + 2 + 2 + 2 + 16 || d[0] != 0xFF || d[1] != 0x4F || d[2] != 0xFF || d[3] != 0x51) return false;
    const uint32_t xsiz = be32(d + 8), ysiz = be32(d + 12), xo = be32(d + 16), yo = be32(d + 20);
    if (xsiz <= xo || ysiz <= yo) return false;
    *w = xsiz - xo;
    *h = ysiz - yo;
    return true;
}

// OpenSlide 3.4.1's YCbCr → RGB (openslide-decode-jp2k.c with the tables of make-tables.c).
void ycbcrToRgb(uint8_t y, uint8_t cb, uint8_t cr, uint8_t out[3]) {
    const auto clamp8 = [](int v) { return uint8_t(std::clamp(v, 0, 255)); };
    const int rCr = int(std::round(1.402 * (cr - 128)));
    const int gCb = int(std::round((1 << 16) * (0.5 - 0.34414 * (cb - 128))));
    const int gCr = int(std::round((1 << 16) * -0.71414 * (cr - 128)));
    const int bCb = int(std::round(1.772 * (cb - 128)));
    out[0] = clamp8(y + rCr);
    out[1] = clamp8(y + int16_t((gCb + gCr) >> 16));
    out[2] = clamp8(y + bCb);
}

struct Decoded {
    Result result;
    std::vector<uint8_t> buffer; // rows `pitch` apart, plus a guard row
};

Decoded decode(const uint8_t* data, size_t size, uint32_t w, uint32_t h, Jp2kColour colour) {
    const size_t pitch = size_t(w) * 4 + kRowGap;
    Decoded d;
    d.buffer.assign(pitch * (h + 1), kFill);
    d.result = decodeJp2kRgba(data, size, int(w), int(h), colour, d.buffer.data(), pitch);
    // Nothing outside the w × h pixels is written, on success or failure.
    for (uint32_t y = 0; y <= h; ++y) {
        const uint8_t* row = d.buffer.data() + size_t(y) * pitch;
        const size_t from = y < h ? size_t(w) * 4 : 0;
        PROMISE(std::all_of(row + from, row + pitch, [](uint8_t b) { return b == kFill; }));
    }
    if (d.result.ok()) {
        for (uint32_t y = 0; y < h; ++y)
            for (uint32_t x = 0; x < w; ++x) PROMISE(d.buffer[size_t(y) * pitch + size_t(x) * 4 + 3] == 255);
    } else {
        if (fuzz::verbose()) fuzz::note(colour == Jp2kColour::Rgb ? "rgb" : "ycbcr", d.result);
        PROMISE(d.result.status() == Status::CorruptData || d.result.status() == Status::OutOfMemory);
        PROMISE(!d.result.message().empty());
    }
    return d;
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    uint32_t w = 0, h = 0;
    if (!sizFromCodestream(data, size, &w, &h) || w > uint32_t(kTileSize) * 64 || h > uint32_t(kTileSize) * 64 ||
        uint64_t(w) * h > kMaxPixels) {
        // Still a codestream to the decoder: it must refuse it cleanly (a tile of 1×1 is asked).
        uint8_t px[4 + kRowGap];
        std::memset(px, kFill, sizeof px);
        const Result r = decodeJp2kRgba(data, size, 1, 1, Jp2kColour::Rgb, px, 4);
        PROMISE(r.ok() || r.status() == Status::CorruptData);
        PROMISE(std::all_of(px + 4, px + sizeof px, [](uint8_t b) { return b == kFill; }));
        return 0;
    }

    // A caller expecting another size is refused before anything is decoded.
    {
        std::vector<uint8_t> px(size_t(w + 1) * h * 4, kFill);
        const Result r = decodeJp2kRgba(data, size, int(w + 1), int(h), Jp2kColour::Rgb, px.data(), size_t(w + 1) * 4);
        PROMISE(r.status() == Status::CorruptData);
        PROMISE(std::all_of(px.begin(), px.end(), [](uint8_t b) { return b == kFill; }));
    }

    // The check the TIFF reader makes before OpenSlide decodes a first tile (header only).
    {
        const Result r = checkJp2kForOpenSlide(data, size, int(w), int(h));
        PROMISE(r.ok() || r.status() == Status::CorruptData || r.status() == Status::OutOfMemory);
        if (fuzz::verbose()) fuzz::note("OpenSlide check", r);
    }

    const Decoded rgb = decode(data, size, w, h, Jp2kColour::Rgb);
    const Decoded ycc = decode(data, size, w, h, Jp2kColour::YCbCr);
    PROMISE(rgb.result.ok() == ycc.result.ok());
    if (!rgb.result.ok()) return 0;
    const size_t pitch = size_t(w) * 4 + kRowGap;
    for (uint32_t y = 0; y < h; ++y) {
        for (uint32_t x = 0; x < w; ++x) {
            const uint8_t* c = rgb.buffer.data() + size_t(y) * pitch + size_t(x) * 4; // the components
            const uint8_t* p = ycc.buffer.data() + size_t(y) * pitch + size_t(x) * 4;
            uint8_t want[3];
            ycbcrToRgb(c[0], c[1], c[2], want);
            PROMISE(std::equal(want, want + 3, p));
        }
    }
    return 0;
}
