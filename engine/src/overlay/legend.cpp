#include "overlay/legend.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace iris::overlay {

namespace {

// The classes a label layer draws somewhere: visible, not transparent, an id in the class table
// and within the map's range of ids (minValue..maxValue; a map's ids lie there, so a class
// outside it is never drawn by this map).
std::optional<LegendContent> labelLegend(const Engine::LayerEntry& e) {
    const RasterMap& map = *e.map;
    if (e.style.classes.empty() || !std::isfinite(map.minValue) || !std::isfinite(map.maxValue)) return std::nullopt;
    const size_t lo = size_t(std::max(0.0, map.minValue));
    const size_t hi = std::min(size_t(std::max(0.0, map.maxValue)), e.style.classes.size() - 1);
    if (lo > hi) return std::nullopt;
    LegendContent c;
    c.layer = e.id;
    c.kind = RasterKind::Label;
    c.title = map.title;
    for (size_t id = lo; id <= hi; ++id) {
        const LabelClass& k = e.style.classes[id];
        if (!k.visible || k.color.a == 0) continue;
        if (int(c.classes.size()) == kLegendMaxClasses) {
            ++c.moreClasses;
            continue;
        }
        c.classes.push_back(LegendClass{uint16_t(id), k.name.empty() ? "class " + std::to_string(id) : k.name, k.color});
    }
    if (c.classes.empty()) return std::nullopt;
    return c;
}

} // namespace

std::optional<LegendContent> legendFor(const std::vector<Engine::LayerEntry>& layers) {
    for (auto it = layers.rbegin(); it != layers.rend(); ++it) {
        const Engine::LayerEntry& e = *it;
        if (!e.map || !e.style.visible || !(e.style.opacity > 0)) continue;
        if (e.map->kind == RasterKind::Label) {
            if (auto c = labelLegend(e)) return c;
            continue;
        }
        if (e.map->kind != RasterKind::Scalar) continue;
        // The same resolution of the window as the layer pass (render/layer_pass.cpp).
        const double low = std::isnan(e.style.low) ? e.map->minValue : e.style.low;
        const double high = std::isnan(e.style.high) ? e.map->maxValue : e.style.high;
        if (!std::isfinite(low) || !std::isfinite(high)) continue; // a map without a value
        LegendContent c;
        c.layer = e.id;
        c.title = e.map->title;
        c.low = low;
        c.high = high;
        c.colorMap = e.style.colorMap;
        return c;
    }
    return std::nullopt;
}

std::string legendNumber(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4g", v == 0 ? 0.0 : v);
    return buf;
}

std::string legendMoreLabel(int count) {
    std::string label(1, '+');
    return label.append(std::to_string(count)).append(" more");
}

} // namespace iris::overlay
