#include "slide/jpeg_decode.h"

#include <limits>
#include <string>

#include <turbojpeg.h>

namespace iris {

namespace {

// One decompressor per thread: TurboJPEG handles are not thread-safe, and making one per
// call costs more than decoding a small tile.
//
// After a failed call the thread starts over with a new one: TurboJPEG 2.1 leaves a handle
// in the middle of a header when tjDecompressHeader3() fails, and every later call on it
// then fails with the same error, so one corrupt tile made every tile after it on that
// loader thread fail (found by tests/fuzz).
class Decompressor {
public:
    Decompressor() : handle_(tjInitDecompress()) {}
    ~Decompressor() {
        if (handle_) tjDestroy(handle_);
    }
    Decompressor(const Decompressor&) = delete;
    Decompressor& operator=(const Decompressor&) = delete;
    tjhandle get() const { return handle_; }
    void renew() {
        if (handle_) tjDestroy(handle_);
        handle_ = tjInitDecompress();
    }

private:
    tjhandle handle_;
};

Decompressor& threadDecompressor() {
    thread_local Decompressor d;
    return d;
}

Result noDecompressor() {
    return Result(Status::OutOfMemory, std::string("cannot create a TurboJPEG decompressor: ") + tjGetErrorStr2(nullptr));
}

// Warnings (corrupt entropy data, premature end of data) stop the decode: a tile that
// libjpeg had to guess at is reported, not shown as if it were right.
constexpr int kFlags = TJFLAG_STOPONWARNING
#ifdef TJFLAG_LIMITSCANS
                       | TJFLAG_LIMITSCANS // a progressive JPEG with thousands of scans is an attack
#endif
    ;

bool sizeFits(size_t size) {
    return size > 0 && size <= std::numeric_limits<unsigned long>::max();
}

} // namespace

Expected<JpegDimensions> jpegDimensions(const uint8_t* data, size_t size) {
    if (!sizeFits(size)) return Result(Status::CorruptData, "the JPEG stream is empty");
    Decompressor& d = threadDecompressor();
    tjhandle tj = d.get();
    if (!tj) return noDecompressor();
    int w = 0, h = 0, subsamp = 0, colorspace = 0;
    if (tjDecompressHeader3(tj, data, static_cast<unsigned long>(size), &w, &h, &subsamp, &colorspace) != 0) {
        Result r(Status::CorruptData, std::string("not a valid JPEG header (") + tjGetErrorStr2(tj) + ")");
        d.renew();
        return r;
    }
    if (w <= 0 || h <= 0) return Result(Status::CorruptData, "the JPEG header gives no image size");
    return JpegDimensions{w, h};
}

Result decodeJpegRgba(const uint8_t* data, size_t size, int width, int height, uint8_t* dst, size_t pitch) {
    Expected<JpegDimensions> dims = jpegDimensions(data, size);
    if (!dims) return dims.error();
    if (dims->width != width || dims->height != height) {
        return Result(Status::CorruptData, "the JPEG is " + std::to_string(dims->width) + "x" +
                                               std::to_string(dims->height) + " pixels, expected " +
                                               std::to_string(width) + "x" + std::to_string(height));
    }
    if (pitch > size_t(std::numeric_limits<int>::max()) || pitch < size_t(width) * 4) {
        return Result(Status::InvalidArgument, "bad row pitch for the JPEG decode");
    }
    Decompressor& d = threadDecompressor();
    tjhandle tj = d.get();
    if (tjDecompress2(tj, data, static_cast<unsigned long>(size), dst, width, int(pitch), height, TJPF_RGBA, kFlags) !=
        0) {
        Result r(Status::CorruptData, std::string("the JPEG data is corrupt (") + tjGetErrorStr2(tj) + ")");
        d.renew();
        return r;
    }
    return {};
}

Expected<Image> decodeJpegImage(const uint8_t* data, size_t size, uint64_t maxPixels) {
    Expected<JpegDimensions> dims = jpegDimensions(data, size);
    if (!dims) return dims.error();
    const uint64_t pixels = uint64_t(dims->width) * uint64_t(dims->height);
    if (pixels > maxPixels) {
        return Result(Status::CorruptData, "the JPEG claims " + std::to_string(dims->width) + "x" +
                                               std::to_string(dims->height) + " pixels, more than the " +
                                               std::to_string(maxPixels) + " allowed");
    }
    Image img;
    img.width = uint32_t(dims->width);
    img.height = uint32_t(dims->height);
    img.rgba.resize(size_t(pixels) * 4);
    if (Result r = decodeJpegRgba(data, size, dims->width, dims->height, img.rgba.data(), size_t(img.width) * 4);
        !r.ok()) {
        return r;
    }
    return img;
}

} // namespace iris
