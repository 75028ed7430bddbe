// iris-render's raster layers: --heatmap FILE[:opacity[:colormap]] and --label-map
// FILE[:opacity] (issue 19, docs/LAYERS.md). A spec is read from the right, so a file name may
// itself hold ':' (the longest prefix that names an existing file is the file): an empty
// opacity keeps the default (0.5); colormap is viridis, magma, jet, gray or a LUT file
// (iris::ColorMap::fromFile). Parsing looks at the file system only to find the file; loading
// reads the map and the LUT.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "iris/layers.h"
#include "iris/types.h"

namespace iris::render {

struct LayerSpec {
    std::string file;
    std::optional<double> opacity;
    std::string colorMap; // "" = the default (viridis)
    bool labels = false;  // --label-map: class ids, drawn through defaultLabelClasses
};

// The spec, or why it is malformed (InvalidArgument, naming the spec and the part at fault;
// the caller names the option).
Expected<LayerSpec> parseLayerSpec(const std::string& spec, bool labels);

struct LoadedLayer {
    std::shared_ptr<const RasterMap> map;
    LayerStyle style;
};
// Reads the spec's map (and LUT): the loader's error, prefixed with the option, when it cannot.
Expected<LoadedLayer> loadLayer(const LayerSpec& spec);

} // namespace iris::render
