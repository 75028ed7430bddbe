// The map model: its checks, its value range, the host-memory constructors, and the helpers
// every reader shares (raster_readers.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "layers/raster_readers.h"
#include "layers/streamed_raster.h"

namespace iris {

using namespace layers_detail;

namespace {

int bytesPerPixel(RasterKind k) {
    return k == RasterKind::Label ? 2 : 4;
}

// The number of elements level `l` must hold for kind `k` (4 per pixel for Rgba).
uint64_t expectedElements(RasterKind k, const RasterLevel& l) {
    return uint64_t(l.width) * uint64_t(l.height) * (k == RasterKind::Rgba ? 4 : 1);
}

void setRange(RasterMap& map) {
    double lo = std::numeric_limits<double>::quiet_NaN(), hi = lo;
    switch (map.kind) {
    case RasterKind::Rgba: lo = 0, hi = 255; break;
    case RasterKind::Scalar: {
        float fl = std::numeric_limits<float>::infinity(), fh = -fl;
        for (const RasterLevel& l : map.levels)
            for (float v : l.scalar)
                if (v == v) fl = std::min(fl, v), fh = std::max(fh, v);
        if (fl <= fh) lo = fl, hi = fh;
        break;
    }
    case RasterKind::Label: {
        int il = 65536, ih = -1;
        for (const RasterLevel& l : map.levels)
            for (uint16_t v : l.label) il = std::min<int>(il, v), ih = std::max<int>(ih, v);
        if (il <= ih) lo = il, hi = ih;
        break;
    }
    }
    map.minValue = lo;
    map.maxValue = hi;
}

} // namespace

const char* rasterKindName(RasterKind k) noexcept {
    switch (k) {
    case RasterKind::Scalar: return "scalar";
    case RasterKind::Label: return "label";
    case RasterKind::Rgba: return "RGBA";
    }
    return "unknown";
}

uint64_t RasterMap::decodedBytes() const noexcept {
    uint64_t n = 0;
    for (const RasterLevel& l : levels) n += uint64_t(std::max(l.width, 0)) * uint64_t(std::max(l.height, 0));
    return n * uint64_t(bytesPerPixel(kind));
}

uint64_t RasterMap::residentBytes() const noexcept {
    uint64_t n = 0;
    for (const RasterLevel& l : levels)
        if (!l.streamed()) n += uint64_t(std::max(l.width, 0)) * uint64_t(std::max(l.height, 0));
    return n * uint64_t(bytesPerPixel(kind));
}

bool RasterMap::streamed() const noexcept {
    return std::any_of(levels.begin(), levels.end(), [](const RasterLevel& l) { return l.streamed(); });
}

RasterMap withRasterPyramid(RasterMap map, int32_t coarsest) {
    if (map.levels.size() != 1 || coarsest < 1) return map;
    // A read error of a streamed level leaves the levels made so far (the map is still whole).
    (void)extendPyramid(map, coarsest, kHeldLevelBytes);
    return map;
}

Result readRasterRegion(const RasterMap& map, int level, int32_t x, int32_t y, int32_t w, int32_t h, void* out) {
    if (level < 0 || size_t(level) >= map.levels.size())
        return Result(Status::InvalidArgument, "no level " + std::to_string(level) + " in a map of " +
                                                   std::to_string(map.levels.size()));
    const RasterLevel& l = map.levels[size_t(level)];
    if (x < 0 || y < 0 || w <= 0 || h <= 0 || int64_t(x) + w > l.width || int64_t(y) + h > l.height)
        return Result(Status::InvalidArgument, "a read of " + std::to_string(w) + "x" + std::to_string(h) + " at (" +
                                                   std::to_string(x) + ", " + std::to_string(y) + ") outside level " +
                                                   std::to_string(level) + " of " + std::to_string(l.width) + "x" +
                                                   std::to_string(l.height));
    if (l.streamed()) return l.source->read(x, y, w, h, out);
    const size_t bpp = size_t(bytesPerPixel(map.kind));
    const uint8_t* src = map.kind == RasterKind::Scalar  ? reinterpret_cast<const uint8_t*>(l.scalar.data())
                         : map.kind == RasterKind::Label ? reinterpret_cast<const uint8_t*>(l.label.data())
                                                         : l.rgba.data();
    if (expectedElements(map.kind, l) != (map.kind == RasterKind::Scalar  ? l.scalar.size()
                                          : map.kind == RasterKind::Label ? l.label.size()
                                                                          : l.rgba.size()))
        return Result(Status::InvalidArgument, "level " + std::to_string(level) + " does not hold its pixels");
    auto* dst = static_cast<uint8_t*>(out);
    for (int32_t r = 0; r < h; ++r)
        std::memcpy(dst + size_t(r) * size_t(w) * bpp, src + (size_t(y + r) * size_t(l.width) + size_t(x)) * bpp,
                    size_t(w) * bpp);
    return {};
}

std::string rasterMapProblem(const RasterMap& map) {
    if (map.levels.empty()) return "the map has no level";
    for (size_t i = 0; i < map.levels.size(); ++i) {
        const RasterLevel& l = map.levels[i];
        const std::string which = "level " + std::to_string(i);
        if (l.width <= 0 || l.height <= 0)
            return which + " is " + std::to_string(l.width) + "x" + std::to_string(l.height) + " pixels";
        if (l.width > kMaxRasterSide || l.height > kMaxRasterSide)
            return which + " is " + std::to_string(l.width) + "x" + std::to_string(l.height) +
                   " pixels, over the limit of " + std::to_string(kMaxRasterSide) + " a side";
        if (i > 0) {
            const RasterLevel& p = map.levels[i - 1];
            if (l.width > p.width || l.height > p.height || (l.width == p.width && l.height == p.height))
                return which + " (" + std::to_string(l.width) + "x" + std::to_string(l.height) +
                       ") is not smaller than level " + std::to_string(i - 1) + " (" + std::to_string(p.width) + "x" +
                       std::to_string(p.height) + ")";
        }
        const size_t s = l.scalar.size(), b = l.label.size(), r = l.rgba.size();
        if (l.streamed()) {
            if (s || b || r) return which + " is streamed and holds pixels too";
            continue;
        }
        const uint64_t n = expectedElements(map.kind, l);
        const bool sizesOk = map.kind == RasterKind::Scalar ? (s == n && b == 0 && r == 0)
                             : map.kind == RasterKind::Label ? (b == n && s == 0 && r == 0)
                                                             : (r == n && s == 0 && b == 0);
        if (!sizesOk)
            return which + " of a " + rasterKindName(map.kind) + " map of " + std::to_string(l.width) + "x" +
                   std::to_string(l.height) + " needs " + std::to_string(n) + " " +
                   (map.kind == RasterKind::Scalar ? "float values"
                    : map.kind == RasterKind::Label ? "label values"
                                                    : "RGBA bytes") +
                   " (and no other kind's), and holds " + std::to_string(s) + " float, " + std::to_string(b) +
                   " label and " + std::to_string(r) + " RGBA";
        for (size_t k = 0; k < s; ++k)
            if (std::isinf(l.scalar[k]))
                return which + " holds an infinite value at (" + std::to_string(k % size_t(l.width)) + ", " +
                       std::to_string(k / size_t(l.width)) + ") (NaN marks no data; infinity is refused)";
    }
    if (map.residentBytes() > kMaxRasterBytes)
        return "the map needs " + std::to_string(map.residentBytes()) + " bytes decoded, over the limit of " +
               std::to_string(kMaxRasterBytes);
    if (map.decodedBytes() > kMaxStreamedRasterBytes)
        return "the map's levels need " + std::to_string(map.decodedBytes()) +
               " bytes decoded in all, over the limit of " + std::to_string(kMaxStreamedRasterBytes) +
               " for a streamed map";
    return {};
}

namespace {

Expected<RasterMap> fromLevels(RasterKind kind, std::vector<RasterLevel> levels, std::string title) {
    RasterMap map;
    map.kind = kind;
    map.levels = std::move(levels);
    map.title = std::move(title);
    if (std::string p = rasterMapProblem(map); !p.empty()) return Result(Status::InvalidArgument, p);
    setRange(map);
    if (map.streamed() && kind != RasterKind::Rgba) {
        // A host's streamed levels are read once for their range (and their values checked).
        ValueRange range;
        if (!std::isnan(map.minValue)) range.add(map.minValue), range.add(map.maxValue);
        for (size_t i = 0; i < map.levels.size(); ++i)
            if (Result r = scanLevel(kind, map.levels[i], range); !r.ok())
                return Result(r.status(), "level " + std::to_string(i) + ": " + r.message());
        if (!range.empty()) map.minValue = range.lo, map.maxValue = range.hi;
    }
    return map;
}

// Checks a host buffer's length against width × height × `per` before anything is copied.
Result checkHostBuffer(size_t have, int32_t width, int32_t height, int per) {
    if (width <= 0 || height <= 0 || width > kMaxRasterSide || height > kMaxRasterSide)
        return Result(Status::InvalidArgument, "a map of " + std::to_string(width) + "x" + std::to_string(height) +
                                                   " pixels (1.." + std::to_string(kMaxRasterSide) + " a side)");
    const uint64_t need = uint64_t(width) * uint64_t(height) * uint64_t(per);
    if (have != need)
        return Result(Status::InvalidArgument, "a map of " + std::to_string(width) + "x" + std::to_string(height) +
                                                   " needs " + std::to_string(need) + " elements, given " +
                                                   std::to_string(have));
    return {};
}

} // namespace

Expected<RasterMap> fromHostMemory(std::span<const float> values, int32_t width, int32_t height, std::string title) {
    if (Result r = checkHostBuffer(values.size(), width, height, 1); !r) return r;
    RasterLevel l{width, height, std::vector<float>(values.begin(), values.end()), {}, {}};
    return fromLevels(RasterKind::Scalar, {std::move(l)}, std::move(title));
}

Expected<RasterMap> fromHostMemory(std::span<const uint16_t> labels, int32_t width, int32_t height,
                                   std::string title) {
    if (Result r = checkHostBuffer(labels.size(), width, height, 1); !r) return r;
    RasterLevel l{width, height, {}, std::vector<uint16_t>(labels.begin(), labels.end()), {}};
    return fromLevels(RasterKind::Label, {std::move(l)}, std::move(title));
}

Expected<RasterMap> fromHostMemoryRgba(std::span<const uint8_t> rgba, int32_t width, int32_t height,
                                       std::string title) {
    if (Result r = checkHostBuffer(rgba.size(), width, height, 4); !r) return r;
    RasterLevel l{width, height, {}, {}, std::vector<uint8_t>(rgba.begin(), rgba.end())};
    return fromLevels(RasterKind::Rgba, {std::move(l)}, std::move(title));
}

Expected<RasterMap> fromHostMemory(RasterKind kind, std::vector<RasterLevel> levels, std::string title) {
    return fromLevels(kind, std::move(levels), std::move(title));
}

namespace layers_detail {

Result fail(Status status, const std::string& name, const std::string& what) {
    return Result(status, name + ": " + what);
}

Result checkLevelSize(int64_t w, int64_t h, int bytesPerPixel, uint64_t usedBytes, const Limits& limits,
                      const std::string& name) {
    const std::string size = std::to_string(w) + "x" + std::to_string(h);
    if (w <= 0 || h <= 0) return fail(Status::CorruptData, name, "an image of " + size + " pixels");
    if (w > limits.maxSide || h > limits.maxSide)
        return fail(Status::UnsupportedFormat, name,
                    "an image of " + size + " pixels is over the limit of " + std::to_string(limits.maxSide) +
                        " pixels a side");
    const uint64_t bytes = uint64_t(w) * uint64_t(h) * uint64_t(bytesPerPixel);
    if (bytes > limits.maxBytes || usedBytes + bytes > limits.maxBytes)
        return fail(Status::UnsupportedFormat, name,
                    "an image of " + size + " pixels needs " + std::to_string(usedBytes + bytes) +
                        " bytes decoded, over the limit of " + std::to_string(limits.maxBytes));
    return {};
}

Result valueProblem(RasterKind kind, double v, uint64_t x, uint64_t y, const std::string& name) {
    const std::string at = " at (" + std::to_string(x) + ", " + std::to_string(y) + ")";
    if (kind == RasterKind::Label) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%.17g", v);
        return fail(Status::CorruptData, name, std::string("label ") + buf + at + " is not a whole number in 0..65535");
    }
    if (std::isinf(v)) return fail(Status::CorruptData, name, "an infinite value" + at + " (NaN marks no data; infinity is refused)");
    return fail(Status::CorruptData, name, "the value" + at + " is beyond float32's range");
}

Result finishMap(RasterMap& map, const std::string& name, const std::string& title) {
    if (std::string p = rasterMapProblem(map); !p.empty()) return fail(Status::CorruptData, name, p);
    setRange(map);
    if (!title.empty()) {
        map.title = title;
    } else {
        const size_t slash = name.find_last_of('/');
        map.title = slash == std::string::npos ? name : name.substr(slash + 1);
    }
    return {};
}

} // namespace layers_detail
} // namespace iris
