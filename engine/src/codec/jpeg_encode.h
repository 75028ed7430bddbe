// JPEG compression with libjpeg-turbo's TurboJPEG API, for the .iris encoder.
//
// Threading: a JpegEncoder is used by one thread at a time; the encoder gives each of its
// worker threads its own (a TurboJPEG handle and its output buffer, reused for every tile).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "iris/encoder.h"

namespace iris {

class JpegEncoder {
public:
    JpegEncoder();
    ~JpegEncoder();
    JpegEncoder(const JpegEncoder&) = delete;
    JpegEncoder& operator=(const JpegEncoder&) = delete;

    // Compresses width × height RGBA8 pixels (rows `pitch` bytes apart; alpha ignored) into
    // a baseline JFIF stream. The returned bytes live in this encoder's buffer until the
    // next call. OutOfMemory when no compressor can be made, InvalidArgument for sizes JPEG
    // cannot hold, IoError with TurboJPEG's reason otherwise.
    Expected<std::span<const uint8_t>> encodeRgba(const uint8_t* rgba, int width, int height, size_t pitch,
                                                  int quality, ChromaSubsampling subsampling);

private:
    void* handle_ = nullptr;        // tjhandle
    unsigned char* buffer_ = nullptr; // tjAlloc'd, grown to the worst case of the largest image
    unsigned long capacity_ = 0;
};

// Composites premultiplied RGBA8 pixels over opaque white in place (c + 255 − a, alpha 255).
// Does nothing to opaque pixels.
void compositePremultipliedOnWhite(uint8_t* rgba, size_t pixels);

// The same for straight (not premultiplied) alpha: c·a/255 + 255 − a, rounded.
void compositeStraightOnWhite(uint8_t* rgba, size_t pixels);

} // namespace iris
