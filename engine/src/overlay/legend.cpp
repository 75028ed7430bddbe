#include "overlay/legend.h"

#include <cmath>
#include <cstdio>

namespace iris::overlay {

std::optional<LegendContent> legendFor(const std::vector<Engine::LayerEntry>& layers) {
    for (auto it = layers.rbegin(); it != layers.rend(); ++it) {
        const Engine::LayerEntry& e = *it;
        if (!e.map || e.map->kind != RasterKind::Scalar || !e.style.visible || !(e.style.opacity > 0)) continue;
        // The same resolution of the window as the layer pass (render/layer_pass.cpp).
        const double low = std::isnan(e.style.low) ? e.map->minValue : e.style.low;
        const double high = std::isnan(e.style.high) ? e.map->maxValue : e.style.high;
        if (!std::isfinite(low) || !std::isfinite(high)) continue; // a map without a value
        return LegendContent{e.id, e.map->title, low, high, e.style.colorMap};
    }
    return std::nullopt;
}

std::string legendNumber(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4g", v == 0 ? 0.0 : v);
    return buf;
}

} // namespace iris::overlay
