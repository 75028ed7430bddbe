// Not API: what the raster-map readers (png_raster.cpp, tiff_raster.cpp, npy_raster.cpp), the
// loader's dispatch (raster_loader.cpp) and the colour-map loader (colormap.cpp) share.
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <span>
#include <string>

#include "iris/layers.h"

namespace iris::layers_detail {

// The effective limits of one load: the options', never above the hard ones.
struct Limits {
    int32_t maxSide = kMaxRasterSide;
    uint64_t maxBytes = kMaxRasterBytes;
    static Limits of(const RasterLoadOptions& o) {
        Limits l;
        if (o.maxSide > 0 && o.maxSide < l.maxSide) l.maxSide = o.maxSide;
        if (o.maxBytes > 0 && o.maxBytes < l.maxBytes) l.maxBytes = o.maxBytes;
        return l;
    }
};

// "<name>: <what>" as a Result of `status`.
Result fail(Status status, const std::string& name, const std::string& what);

// Whether a level of w × h pixels of `bytesPerPixel`, after `usedBytes` of levels already
// read, fits the limits; the refusal names the file, the size and the limit.
Result checkLevelSize(int64_t w, int64_t h, int bytesPerPixel, uint64_t usedBytes, const Limits& limits,
                      const std::string& name);

// Checks a map the readers built (rasterMapProblem, as CorruptData naming the file), and sets
// its range and, when empty, its title.
Result finishMap(RasterMap& map, const std::string& name, const std::string& title);

// Stores value v as pixel (x, y) of a Scalar or Label level (sized already): refuses an infinite
// value or one beyond float32 (Scalar) and a value outside 0..65535 or not whole (Label),
// naming the pixel. Shared by the readers whose files hold numbers (TIFF, .npy).
Result valueProblem(RasterKind kind, double v, uint64_t x, uint64_t y, const std::string& name);
// The same into one pixel's bytes at `dst` (a float or a uint16_t); (x, y) names it.
inline Result storeValueTo(RasterKind kind, uint8_t* dst, uint64_t x, uint64_t y, double v, const std::string& name) {
    if (kind == RasterKind::Label) {
        if (!(v >= 0 && v <= 65535 && v == std::floor(v))) return valueProblem(kind, v, x, y, name);
        const uint16_t id = uint16_t(v);
        std::memcpy(dst, &id, 2);
    } else {
        if (std::isinf(v) || std::fabs(v) > double(std::numeric_limits<float>::max()))
            return valueProblem(kind, v, x, y, name);
        const float f = float(v);
        std::memcpy(dst, &f, 4);
    }
    return {};
}
inline Result storeValue(RasterKind kind, RasterLevel& l, uint64_t x, uint64_t y, double v, const std::string& name) {
    const size_t i = size_t(y) * size_t(l.width) + size_t(x);
    uint8_t* dst = kind == RasterKind::Label ? reinterpret_cast<uint8_t*>(&l.label[i])
                                             : reinterpret_cast<uint8_t*>(&l.scalar[i]);
    return storeValueTo(kind, dst, x, y, v, name);
}

// The readers, each over a whole file in memory. `name` names it in messages.
Expected<RasterMap> readPngRaster(std::span<const uint8_t> bytes, const std::string& name,
                                  const RasterLoadOptions& options);
Expected<RasterMap> readTiffRaster(std::span<const uint8_t> bytes, const std::string& name,
                                   const RasterLoadOptions& options);
Expected<RasterMap> readNpyRaster(std::span<const uint8_t> bytes, const std::string& name,
                                  const RasterLoadOptions& options);

bool isPng(std::span<const uint8_t> bytes);
bool isTiff(std::span<const uint8_t> bytes);
bool isNpy(std::span<const uint8_t> bytes);

// A whole regular file into memory, at most maxBytes (NotFound, NotAFile, IoError, or
// UnsupportedFormat for a larger file).
Expected<std::vector<uint8_t>> readWholeFile(const std::string& path, uint64_t maxBytes);

enum class SampleKind { Float, Int, Uint, Bool };

// One sample of `size` bytes of a kind, in this machine's byte order or swapped, as a double
// (the .npy reader's elements, the TIFF reader's samples; the caller checks the bounds).
struct Sample {
    SampleKind kind;
    int size;
    bool swap; // stored in the other byte order than this machine's

    double operator()(const uint8_t* p) const {
        uint8_t b[8];
        for (int k = 0; k < size; ++k) b[k] = swap ? p[size - 1 - k] : p[k];
        switch (kind) {
        case SampleKind::Bool: return b[0] ? 1.0 : 0.0;
        case SampleKind::Float:
            if (size == 2) return half(load<uint16_t>(b));
            if (size == 4) return double(load<float>(b));
            return load<double>(b);
        case SampleKind::Int:
            if (size == 1) return double(int8_t(b[0]));
            if (size == 2) return double(load<int16_t>(b));
            if (size == 4) return double(load<int32_t>(b));
            return double(load<int64_t>(b));
        case SampleKind::Uint:
            if (size == 1) return double(b[0]);
            if (size == 2) return double(load<uint16_t>(b));
            if (size == 4) return double(load<uint32_t>(b));
            return double(load<uint64_t>(b));
        }
        return 0;
    }
    template <class T>
    static T load(const uint8_t* b) {
        T v;
        std::memcpy(&v, b, sizeof v);
        return v;
    }
    static double half(uint16_t h) {
        const int e = (h >> 10) & 0x1f, m = h & 0x3ff;
        const double sign = (h & 0x8000) ? -1.0 : 1.0;
        if (e == 0) return sign * std::ldexp(m, -24);
        if (e == 31) return m ? std::numeric_limits<double>::quiet_NaN() : sign * std::numeric_limits<double>::infinity();
        return sign * std::ldexp(m + 1024, e - 25);
    }
};

} // namespace iris::layers_detail
