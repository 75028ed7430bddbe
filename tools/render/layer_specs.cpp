#include "layer_specs.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>

namespace iris::render {

namespace {

bool isFile(const std::string& path) {
    std::error_code ec;
    return !path.empty() && std::filesystem::is_regular_file(path, ec);
}

const char* optionOf(bool labels) { return labels ? "--label-map" : "--heatmap"; }

// CLI11 puts the option's name before it.
Result bad(const std::string& spec, const std::string& why) {
    return Result(Status::InvalidArgument, "'" + spec + "': " + why);
}

// "" keeps the default; else a number from 0 to 1.
Result parseOpacity(const std::string& text, std::optional<double>& out, const std::string& spec) {
    if (text.empty()) return {};
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (end == text.c_str() || *end != '\0' || !(v >= 0 && v <= 1))
        return bad(spec, "the opacity '" + text + "' is not a number from 0 to 1");
    out = v;
    return {};
}

} // namespace

Expected<LayerSpec> parseLayerSpec(const std::string& spec, bool labels) {
    LayerSpec out;
    out.labels = labels;
    if (isFile(spec)) {
        out.file = spec;
        return out;
    }
    const size_t last = spec.rfind(':');
    if (last != std::string::npos && isFile(spec.substr(0, last))) {
        out.file = spec.substr(0, last);
        if (Result r = parseOpacity(spec.substr(last + 1), out.opacity, spec); !r.ok()) return r;
        return out;
    }
    const size_t before = last == std::string::npos || last == 0 ? std::string::npos : spec.rfind(':', last - 1);
    if (before != std::string::npos && isFile(spec.substr(0, before))) {
        if (labels) return bad(spec, "a label map takes FILE[:opacity] (its colours are its classes')");
        out.file = spec.substr(0, before);
        if (Result r = parseOpacity(spec.substr(before + 1, last - before - 1), out.opacity, spec); !r.ok())
            return r;
        out.colorMap = spec.substr(last + 1);
        if (out.colorMap.empty()) return bad(spec, "the colour map is empty");
        if (!ColorMap::builtin(out.colorMap) && !isFile(out.colorMap))
            return bad(spec,
                       "the colour map '" + out.colorMap + "' is neither viridis, magma, jet, gray nor a LUT file");
        return out;
    }
    return bad(spec,
               std::string("no such map file (the form is ") + (labels ? "FILE[:opacity]" : "FILE[:opacity[:colormap]]") +
                   ")");
}

Expected<LoadedLayer> loadLayer(const LayerSpec& spec) {
    RasterLoadOptions options;
    options.asLabels = spec.labels;
    Expected<RasterMap> map = loadRasterMap(spec.file, options);
    if (!map) return Result(map.error().status(), std::string(optionOf(spec.labels)) + ": " + map.error().message());
    if (spec.labels && map->kind != RasterKind::Label)
        return Result(Status::UnsupportedFormat, std::string(optionOf(spec.labels)) + ": " + spec.file + " holds " +
                                                     rasterKindName(map->kind) +
                                                     " pixels, not class ids (a single-channel integer file)");
    LoadedLayer out;
    if (spec.opacity) out.style.opacity = *spec.opacity;
    if (!spec.colorMap.empty()) {
        if (std::optional<ColorMap> builtin = ColorMap::builtin(spec.colorMap)) {
            out.style.colorMap = std::move(*builtin);
        } else {
            Expected<ColorMap> lut = ColorMap::fromFile(spec.colorMap);
            if (!lut) return Result(lut.error().status(), std::string(optionOf(spec.labels)) + ": " + lut.error().message());
            out.style.colorMap = std::move(lut).value();
        }
    }
    if (map->kind == RasterKind::Label && std::isfinite(map->maxValue))
        out.style.classes = defaultLabelClasses(int(map->maxValue) + 1);
    out.map = std::make_shared<const RasterMap>(std::move(map).value());
    return out;
}

} // namespace iris::render
