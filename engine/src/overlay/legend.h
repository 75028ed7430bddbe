// What the legend overlay shows (Overlay::Legend): the colour map of the topmost visible
// Scalar layer over that layer's window, the window's ends as numbers and the map's title.
// Pure functions of the layer stack; overlay_layout places and draws the result.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "iris/engine.h"

namespace iris::overlay {

struct LegendContent {
    uint64_t layer = 0;  // the layer described
    std::string title;   // RasterMap::title ("" : no title line)
    double low = 0;      // the resolved window (LayerStyle::low/high, NaN → the map's range)
    double high = 0;
    ColorMap colorMap;
};

// The topmost layer (the last of `layers`, bottom first) that is visible, has an opacity above
// 0 and a Scalar map whose resolved window is finite; none when no layer qualifies. Label and
// Rgba layers are passed over (a legend of classes is not drawn yet).
std::optional<LegendContent> legendFor(const std::vector<Engine::LayerEntry>& layers);

// A window end as the legend writes it: up to 4 significant digits ("0", "0.25", "1e+04"),
// never "-0".
std::string legendNumber(double v);

} // namespace iris::overlay
