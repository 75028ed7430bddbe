#include "codec/jpeg_encode.h"

#include <cstring>
#include <string>

#include <turbojpeg.h>

namespace iris {

namespace {

int tjSubsampling(ChromaSubsampling s) {
    switch (s) {
    case ChromaSubsampling::S444: return TJSAMP_444;
    case ChromaSubsampling::S422: return TJSAMP_422;
    case ChromaSubsampling::S420: return TJSAMP_420;
    }
    return TJSAMP_422;
}

constexpr int kMaxJpegSide = 65535; // JPEG's frame header holds 16-bit dimensions

} // namespace

JpegEncoder::JpegEncoder() : handle_(tjInitCompress()) {}

JpegEncoder::~JpegEncoder() {
    if (buffer_) tjFree(buffer_);
    if (handle_) tjDestroy(static_cast<tjhandle>(handle_));
}

Expected<std::span<const uint8_t>> JpegEncoder::encodeRgba(const uint8_t* rgba, int width, int height, size_t pitch,
                                                         int quality, ChromaSubsampling subsampling) {
    if (!handle_) {
        return Result(Status::OutOfMemory,
                      std::string("cannot create a TurboJPEG compressor: ") + tjGetErrorStr2(nullptr));
    }
    if (width < 1 || height < 1 || width > kMaxJpegSide || height > kMaxJpegSide) {
        return Result(Status::InvalidArgument, "a JPEG image cannot be " + std::to_string(width) + "x" +
                                                   std::to_string(height) + " pixels (1 to 65535 a side)");
    }
    if (pitch < size_t(width) * 4 || pitch > size_t(INT32_MAX)) {
        return Result(Status::InvalidArgument, "bad row pitch for the JPEG encode");
    }
    const int samp = tjSubsampling(subsampling);
    // The worst case for these dimensions: with TJFLAG_NOREALLOC TurboJPEG never grows or
    // replaces the buffer, so it is allocated once for the largest image this encoder sees.
    const unsigned long need = tjBufSize(width, height, samp);
    if (need == static_cast<unsigned long>(-1)) {
        return Result(Status::InvalidArgument, std::string("tjBufSize: ") + tjGetErrorStr2(nullptr));
    }
    if (need > capacity_) {
        if (buffer_) tjFree(buffer_);
        buffer_ = tjAlloc(int(need));
        capacity_ = buffer_ ? need : 0;
        if (!buffer_) return Result(Status::OutOfMemory, "cannot allocate " + std::to_string(need) + " bytes for a JPEG");
    }
    unsigned char* out = buffer_;
    unsigned long size = capacity_;
    tjhandle tj = static_cast<tjhandle>(handle_);
    if (tjCompress2(tj, rgba, width, int(pitch), height, TJPF_RGBA, &out, &size, samp, quality, TJFLAG_NOREALLOC) != 0) {
        return Result(Status::IoError, std::string("JPEG compression failed: ") + tjGetErrorStr2(tj));
    }
    return std::span<const uint8_t>(out, size_t(size));
}

namespace {

// True when every pixel's alpha is 255: an AND over whole pixels, no early exit, so the
// compiler vectorises it (a slide's tiles are opaque: this is all that runs for them).
bool allOpaque(const uint8_t* rgba, size_t pixels) {
    uint32_t all = 0xFFFFFFFFu;
    for (size_t i = 0; i < pixels; ++i) {
        uint32_t p;
        std::memcpy(&p, rgba + 4 * i, 4);
        all &= p;
    }
    uint8_t bytes[4];
    std::memcpy(bytes, &all, 4);
    return bytes[3] == 255; // byte 3 of every pixel is its alpha, whatever the endianness
}

} // namespace

void compositePremultipliedOnWhite(uint8_t* rgba, size_t pixels) {
    if (allOpaque(rgba, pixels)) return;
    for (size_t i = 0; i < pixels; ++i) {
        uint8_t* p = rgba + 4 * i;
        const uint8_t a = p[3];
        if (a == 255) continue;
        const uint8_t add = uint8_t(255 - a);
        // Premultiplied: c ≤ a, so c + 255 − a ≤ 255; clamp anyway for bad input.
        for (int c = 0; c < 3; ++c) p[c] = uint8_t(p[c] > a ? 255 : p[c] + add);
        p[3] = 255;
    }
}

void compositeStraightOnWhite(uint8_t* rgba, size_t pixels) {
    if (allOpaque(rgba, pixels)) return;
    for (size_t i = 0; i < pixels; ++i) {
        uint8_t* p = rgba + 4 * i;
        const unsigned a = p[3];
        if (a == 255) continue;
        for (int c = 0; c < 3; ++c) p[c] = uint8_t((p[c] * a + 255u * (255u - a) + 127u) / 255u);
        p[3] = 255;
    }
}

} // namespace iris
