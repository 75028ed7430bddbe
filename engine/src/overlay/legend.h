// What the legend overlay shows (Overlay::Legend): for the topmost visible layer with something
// to show, either a Scalar map's colour map over its window, the window's ends as numbers and
// the map's title, or a Label map's visible classes as swatches and names under its title.
// Pure functions of the layer stack; overlay_layout places and draws the result.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "iris/engine.h"

namespace iris::overlay {

// The most class rows a label legend lists; the rest are summed up in one "+N more" line.
inline constexpr int kLegendMaxClasses = 12;

struct LegendClass {
    uint16_t id = 0;
    std::string name; // LabelClass::name, or "class <id>" when it is empty
    Rgba8 color;
};

struct LegendContent {
    uint64_t layer = 0;  // the layer described
    RasterKind kind = RasterKind::Scalar; // Scalar: a colour bar; Label: class rows
    std::string title;   // RasterMap::title ("" : no title line)
    // Scalar:
    double low = 0;      // the resolved window (LayerStyle::low/high, NaN → the map's range)
    double high = 0;
    ColorMap colorMap;
    // Label: the classes drawn (visible, alpha above 0, an id within the map's range of ids and
    // the class table), by id, at most kLegendMaxClasses of them; moreClasses counts the others.
    std::vector<LegendClass> classes;
    int moreClasses = 0;
};

// The topmost layer (the last of `layers`, bottom first) that is visible, has an opacity above
// 0 and either a Scalar map whose resolved window is finite or a Label map with at least one
// class drawn; none when no layer qualifies. Rgba layers (already coloured) are passed over.
std::optional<LegendContent> legendFor(const std::vector<Engine::LayerEntry>& layers);

// A window end as the legend writes it: up to 4 significant digits ("0", "0.25", "1e+04"),
// never "-0".
std::string legendNumber(double v);

// The line that stands for `count` classes left out of a label legend: "+3 more".
std::string legendMoreLabel(int count);

} // namespace iris::overlay
