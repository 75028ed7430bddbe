// libFuzzer target for the raster-map loaders of the layers (engine/src/layers: the dispatch,
// png_raster.cpp through libpng, tiff_raster.cpp through libtiff, the hand-written
// npy_raster.cpp) and, behind them, the map checks, the colour-map reader and the CPU
// reference of the shading; see README.md.
//
// One input is one whole map file. It goes through loadRasterMapFromMemory (what loadRasterMap
// does after reading the file) as a Scalar/RGBA map and again as a label map, with the decoded
// limit lowered to 64 MiB (a valid header of a 1 GiB map is as hostile at 64 MiB, and a run
// stays fast); a loaded map is shaded at a few points; the bytes also go through
// ColorMap::fromMemory (a user LUT: a PNG strip or text).
//
// Besides the sanitizers it checks what the loaders promise:
//   * a refusal is UnsupportedFormat or CorruptData (OutOfMemory only when libpng/libtiff cannot
//     start) with a message that starts with the file's name;
//   * a loaded map passes rasterMapProblem (levels that get smaller, vectors of the right
//     length and kind, no infinity, within the limits), its range is the data's (NaN when a
//     Scalar map holds no value), its title is the file's name; a label load is a Label map
//     unless refused, an ordinary load never is;
//   * shadeLayerAt never reads outside the map (ASan) and gives nothing outside the rectangle;
//   * a colour map is refused with CorruptData or UnsupportedFormat naming the input.
#include <cmath>
#include <cstdint>
#include <cstring> // before fuzz_support.h, which uses std::memcmp
#include <span>
#include <string>

#include "fuzz_support.h"
#include "iris/layers.h"

namespace {

using namespace iris;

const std::string kName = "fuzz.map";

void checkRefusal(const Result& r) {
    if (fuzz::verbose()) fuzz::note("load", r);
    PROMISE(r.status() == Status::UnsupportedFormat || r.status() == Status::CorruptData ||
            r.status() == Status::OutOfMemory);
    PROMISE(r.message().rfind(kName + ": ", 0) == 0);
    PROMISE(r.message().size() > kName.size() + 2);
}

void checkMap(const RasterMap& m, bool asLabels, uint64_t maxBytes) {
    PROMISE(rasterMapProblem(m).empty());
    PROMISE(m.decodedBytes() <= maxBytes);
    PROMISE(m.title == kName);
    PROMISE((m.kind == RasterKind::Label) == asLabels);
    if (m.kind == RasterKind::Rgba) PROMISE(m.minValue == 0 && m.maxValue == 255);
    bool any = false;
    double lo = INFINITY, hi = -INFINITY;
    for (const RasterLevel& l : m.levels) {
        for (float v : l.scalar)
            if (!std::isnan(v)) any = true, lo = std::min(lo, double(v)), hi = std::max(hi, double(v));
        for (uint16_t v : l.label) any = true, lo = std::min(lo, double(v)), hi = std::max(hi, double(v));
    }
    if (m.kind != RasterKind::Rgba) {
        if (any) PROMISE(m.minValue == lo && m.maxValue == hi);
        else PROMISE(std::isnan(m.minValue) && std::isnan(m.maxValue));
    }
    // Shading: a few points inside, on the edges and outside, at several downsamples, for both
    // samplings and a rotated placement; the class table covers a few ids.
    LayerStyle style;
    style.opacity = 0.75;
    style.classes = defaultLabelClasses(8);
    const double w = m.width(), h = m.height();
    const Placement placements[] = {Placement::spanning(m.width(), m.height(), 1000, 700),
                                    Placement::scaleRotateOffset(3, 3, 30, 50, -20)};
    for (const Placement& p : placements)
        for (LayerSampling s : {LayerSampling::Bilinear, LayerSampling::Nearest}) {
            style.sampling = s;
            for (double ds : {0.5, 4.0, 1e6})
                for (auto [x, y] : {std::array<double, 2>{0, 0}, {w / 2, h / 3}, {w - 1e-9, h - 1e-9}, {w, h / 2}, {-1, 0}}) {
                    auto [sx, sy] = p.toSlide(x, y);
                    const auto px = shadeLayerAt(m, p, style, sx, sy, ds);
                    if (x >= w || x < 0) PROMISE(px[3] == 0 || std::fabs(x - w) < 1e-6);
                }
        }
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::span<const uint8_t> bytes(data, size);
    RasterLoadOptions options;
    options.maxBytes = 64u << 20;
    for (bool asLabels : {false, true}) {
        options.asLabels = asLabels;
        auto m = loadRasterMapFromMemory(bytes, kName, options);
        if (m.ok()) checkMap(*m, asLabels, options.maxBytes);
        else checkRefusal(m.error());
    }
    auto cm = ColorMap::fromMemory(bytes, kName);
    if (!cm.ok()) {
        PROMISE(cm.error().status() == Status::UnsupportedFormat || cm.error().status() == Status::CorruptData ||
                cm.error().status() == Status::OutOfMemory);
        PROMISE(cm.error().message().rfind(kName + ": ", 0) == 0);
    } else {
        PROMISE(cm->name == kName);
    }
    return 0;
}
