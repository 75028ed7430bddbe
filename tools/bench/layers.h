// iris-bench --heatmap: the raster-layer pass's cost (issue 19). Two synthetic scalar maps
// (smooth blobs with a no-data hole) span the slide: a small one at 1/224 of level 0 per side
// (a patch-level model's output) and a big one at 1/4 (a dense segmentation's scores; capped
// at the engine's map limits on a huge slide). For each map, one engine draws the slide with
// 0, 1 and 4 layers of it (four styles over one shared map), at fit view and a mid zoom
// (downsample √fit), the counts alternated twice in the same run, settled frames (the view
// nudged a quarter pixel per frame). Per frame: GPU time (timestamp queries) and the render
// thread's CPU time; and the first frame after the first layer was added (its upload).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "iris/engine.h"

struct LayerBenchOptions {
    std::string slide;
    std::vector<std::pair<uint32_t, uint32_t>> sizes;
    bool validation = false;
    iris::EngineTuning tuning;
    std::string json; // write the results here too
};

// Prints a table per size and map; 0 on success, 1 when the engine, the slide or a layer failed.
int runLayerBench(const LayerBenchOptions& o);
