// Placement and the CPU reference of the layer pass: the level pick, the sampling, the
// threshold/window/colour-map chain and the blend, exactly as iris/layers.h writes them down.
// Tests of the GPU pass compare its frames to these functions.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>

#include "iris/layers.h"

namespace iris {

std::array<double, 4> ColorMap::at(double t) const noexcept {
    const double p = 255.0 * (t > 0 ? std::min(t, 1.0) : 0.0); // NaN: the low end
    const int i0 = int(std::floor(p));
    const int i1 = std::min(i0 + 1, 255);
    const double f = p - i0;
    const Rgba8 a = entries[size_t(i0)], b = entries[size_t(i1)];
    return {(1 - f) * a.r + f * b.r, (1 - f) * a.g + f * b.g, (1 - f) * a.b + f * b.b, (1 - f) * a.a + f * b.a};
}

Placement Placement::spanning(int64_t mapWidth, int64_t mapHeight, int64_t slideWidth, int64_t slideHeight) noexcept {
    Placement p;
    p.m = {mapWidth > 0 ? double(slideWidth) / double(mapWidth) : 0, 0, 0,
           0, mapHeight > 0 ? double(slideHeight) / double(mapHeight) : 0, 0};
    return p;
}

Placement Placement::scaleRotateOffset(double scaleX, double scaleY, double degrees, double offsetX,
                                       double offsetY) noexcept {
    // Exact quarter turns, so that 90° does not leave a 6e-17 shear behind.
    double c, s;
    const double q = degrees / 90.0;
    if (q == std::floor(q)) {
        static constexpr double kCos[4] = {1, 0, -1, 0}, kSin[4] = {0, 1, 0, -1};
        const int k = int(((long long)q % 4 + 4) % 4);
        c = kCos[k], s = kSin[k];
    } else {
        const double r = degrees * std::numbers::pi / 180.0;
        c = std::cos(r), s = std::sin(r);
    }
    // y points down, so a positive angle turns clockwise on screen: [c −s; s c] · diag(sx, sy).
    Placement p;
    p.m = {c * scaleX, -s * scaleY, offsetX, s * scaleX, c * scaleY, offsetY};
    return p;
}

std::optional<std::array<double, 2>> Placement::toMap(double slideX, double slideY) const noexcept {
    const double det = m[0] * m[4] - m[1] * m[3];
    if (!std::isfinite(det) || det == 0) return std::nullopt;
    for (double v : m)
        if (!std::isfinite(v)) return std::nullopt;
    const double dx = slideX - m[2], dy = slideY - m[5];
    return std::array<double, 2>{(m[4] * dx - m[1] * dy) / det, (m[0] * dy - m[3] * dx) / det};
}

std::array<double, 2> Placement::toSlide(double mapX, double mapY) const noexcept {
    return {m[0] * mapX + m[1] * mapY + m[2], m[3] * mapX + m[4] * mapY + m[5]};
}

Box2 Placement::bounds(int64_t mapWidth, int64_t mapHeight) const noexcept {
    Box2 b;
    const double w = double(mapWidth), h = double(mapHeight);
    for (auto [x, y] : {std::array<double, 2>{0, 0}, {w, 0}, {0, h}, {w, h}}) {
        auto [sx, sy] = toSlide(x, y);
        b.expand(Point2{sx, sy});
    }
    return b;
}

int chooseRasterLevel(const RasterMap& map, const Placement& placement, double downsample) noexcept {
    const int n = int(map.levels.size());
    if (n <= 1 || !(downsample > 0)) return 0;
    const double sx = std::hypot(placement.m[0], placement.m[3]);
    const double sy = std::hypot(placement.m[1], placement.m[4]);
    const double w0 = map.levels[0].width, h0 = map.levels[0].height;
    for (int k = 0; k < n; ++k) {
        const RasterLevel& l = map.levels[size_t(k)];
        const double px = std::min(sx * w0 / l.width, sy * h0 / l.height) / downsample;
        if (px >= 1 - 1e-9) return k;
    }
    return n - 1;
}

namespace {

constexpr std::array<uint8_t, 4> kNothing{0, 0, 0, 0};

// Real-valued colour (codes 0..255) and its alpha (0..1) → the rounded straight RGBA8 result.
std::array<uint8_t, 4> finish(const std::array<double, 4>& colour, double opacity) {
    auto code = [](double v) { return uint8_t(std::clamp(std::floor(v + 0.5), 0.0, 255.0)); };
    const double alpha = std::clamp(opacity, 0.0, 1.0) * colour[3] / 255.0;
    return {code(colour[0]), code(colour[1]), code(colour[2]), code(255.0 * alpha)};
}

struct Taps {
    int x[2], y[2];   // columns and rows of the taps, clamped into the level
    double fx, fy;    // the second column's and row's weights
};

Taps bilinearTaps(double u, double v, int w, int h) {
    const double s = u - 0.5, t = v - 0.5;
    const double i = std::floor(s), j = std::floor(t);
    Taps taps;
    taps.fx = s - i, taps.fy = t - j;
    taps.x[0] = std::clamp(int(i), 0, w - 1), taps.x[1] = std::clamp(int(i) + 1, 0, w - 1);
    taps.y[0] = std::clamp(int(j), 0, h - 1), taps.y[1] = std::clamp(int(j) + 1, 0, h - 1);
    return taps;
}

size_t nearestIndex(double u, double v, int w, int h) {
    const int x = std::clamp(int(std::floor(u)), 0, w - 1), y = std::clamp(int(std::floor(v)), 0, h - 1);
    return size_t(y) * size_t(w) + size_t(x);
}

// One pixel of a level, held or streamed (a streamed level's read goes through its source's
// block cache; a failed read is "no pixel": the reference draws nothing there).
bool pixel(RasterKind kind, const RasterLevel& l, size_t index, void* out) {
    const size_t bpp = kind == RasterKind::Label ? 2 : 4;
    if (l.streamed()) {
        const int32_t x = int32_t(index % size_t(l.width)), y = int32_t(index / size_t(l.width));
        return l.source->read(x, y, 1, 1, out).ok();
    }
    const uint8_t* src = kind == RasterKind::Scalar  ? reinterpret_cast<const uint8_t*>(l.scalar.data())
                         : kind == RasterKind::Label ? reinterpret_cast<const uint8_t*>(l.label.data())
                                                     : l.rgba.data();
    std::memcpy(out, src + index * bpp, bpp);
    return true;
}
float scalarAt(const RasterLevel& l, size_t index) {
    float v = std::numeric_limits<float>::quiet_NaN();
    return pixel(RasterKind::Scalar, l, index, &v) ? v : std::numeric_limits<float>::quiet_NaN();
}
std::array<uint8_t, 4> rgbaAt(const RasterLevel& l, size_t index) {
    std::array<uint8_t, 4> p{0, 0, 0, 0};
    return pixel(RasterKind::Rgba, l, index, p.data()) ? p : std::array<uint8_t, 4>{0, 0, 0, 0};
}

std::array<uint8_t, 4> shadeScalar(const RasterMap& map, const RasterLevel& l, const LayerStyle& style, double u,
                                   double v) {
    double value;
    if (style.sampling == LayerSampling::Nearest) {
        value = scalarAt(l, nearestIndex(u, v, l.width, l.height));
        if (std::isnan(value)) return kNothing;
    } else {
        const Taps t = bilinearTaps(u, v, l.width, l.height);
        double tap[2][2];
        for (int r = 0; r < 2; ++r)
            for (int c = 0; c < 2; ++c) {
                tap[r][c] = scalarAt(l, size_t(t.y[r]) * size_t(l.width) + size_t(t.x[c]));
                if (std::isnan(tap[r][c])) return kNothing;
            }
        value = (1 - t.fy) * ((1 - t.fx) * tap[0][0] + t.fx * tap[0][1]) +
                t.fy * ((1 - t.fx) * tap[1][0] + t.fx * tap[1][1]);
    }
    if (value < style.threshold) return kNothing;
    const double low = std::isnan(style.low) ? map.minValue : style.low;
    const double high = std::isnan(style.high) ? map.maxValue : style.high;
    const double t = high > low ? std::clamp((value - low) / (high - low), 0.0, 1.0) : (value >= high ? 1.0 : 0.0);
    return finish(style.colorMap.at(t), style.opacity);
}

std::array<uint8_t, 4> shadeRgba(const RasterLevel& l, const LayerStyle& style, double u, double v) {
    if (style.sampling == LayerSampling::Nearest) {
        const std::array<uint8_t, 4> p = rgbaAt(l, nearestIndex(u, v, l.width, l.height));
        return finish({double(p[0]), double(p[1]), double(p[2]), double(p[3])}, style.opacity);
    }
    const Taps t = bilinearTaps(u, v, l.width, l.height);
    std::array<double, 4> sum{0, 0, 0, 0}; // premultiplied RGB, alpha
    for (int r = 0; r < 2; ++r)
        for (int c = 0; c < 2; ++c) {
            const double w = (r ? t.fy : 1 - t.fy) * (c ? t.fx : 1 - t.fx);
            const std::array<uint8_t, 4> p = rgbaAt(l, size_t(t.y[r]) * size_t(l.width) + size_t(t.x[c]));
            const double a = p[3] / 255.0;
            for (int ch = 0; ch < 3; ++ch) sum[size_t(ch)] += w * p[ch] * a;
            sum[3] += w * a;
        }
    if (!(sum[3] > 0)) return kNothing;
    return finish({sum[0] / sum[3], sum[1] / sum[3], sum[2] / sum[3], 255.0 * sum[3]}, style.opacity);
}

std::array<uint8_t, 4> shadeLabel(const RasterLevel& l, const LayerStyle& style, double u, double v) {
    uint16_t id = 0;
    if (!pixel(RasterKind::Label, l, nearestIndex(u, v, l.width, l.height), &id)) return kNothing;
    if (id >= style.classes.size() || !style.classes[id].visible) return kNothing;
    const Rgba8 c = style.classes[id].color;
    return finish({double(c.r), double(c.g), double(c.b), double(c.a)}, style.opacity);
}

} // namespace

std::array<uint8_t, 4> shadeLayerAt(const RasterMap& map, const Placement& placement, const LayerStyle& style,
                                     double slideX, double slideY, double downsample) noexcept {
    if (!style.visible || !(style.opacity > 0) || map.levels.empty()) return kNothing;
    const auto at = placement.toMap(slideX, slideY);
    if (!at) return kNothing;
    const auto [x, y] = *at;
    const RasterLevel& l0 = map.levels.front();
    if (!(x >= 0 && x < l0.width && y >= 0 && y < l0.height)) return kNothing;
    const RasterLevel& l = map.levels[size_t(chooseRasterLevel(map, placement, downsample))];
    // A map that rasterMapProblem would refuse (built by hand, not through fromHostMemory or a
    // loader) draws nothing rather than reading past its vectors.
    const size_t n = size_t(std::max(l.width, 0)) * size_t(std::max(l.height, 0));
    const size_t have = map.kind == RasterKind::Scalar ? l.scalar.size()
                        : map.kind == RasterKind::Label ? l.label.size()
                                                        : l.rgba.size() / 4;
    if (n == 0 || (have < n && !l.streamed())) return kNothing;
    const double u = x * l.width / l0.width, v = y * l.height / l0.height;
    switch (map.kind) {
    case RasterKind::Scalar: return shadeScalar(map, l, style, u, v);
    case RasterKind::Rgba: return shadeRgba(l, style, u, v);
    case RasterKind::Label: return shadeLabel(l, style, u, v);
    }
    return kNothing;
}

std::array<uint8_t, 3> blendOver(std::array<uint8_t, 3> dst, std::array<uint8_t, 4> layer) noexcept {
    const unsigned a = layer[3];
    std::array<uint8_t, 3> out;
    for (size_t c = 0; c < 3; ++c) out[c] = uint8_t((layer[c] * a + dst[c] * (255 - a) + 127) / 255);
    return out;
}

} // namespace iris
