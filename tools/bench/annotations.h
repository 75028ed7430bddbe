// iris-bench --annotations N[,N…]: the annotation layer's cost (issue 18). For each count, N
// detections (irregular 20-vertex polygons of 10–24 level-0 pixels, a quarter of them filled,
// three classes) spread over the slide are loaded into a store (replaceAll, timed), and one
// engine draws them: the first frame at fit view after they are shown (it builds the fit-view
// aggregate), then settled frames at fit view and at three zooms (the view nudged by a quarter
// pixel per frame: nothing to load) and a pan at 1:1 (an eighth of the window per frame, tiles
// loading), each with the annotations shown and, as the baseline in the same run, hidden,
// alternated twice. Per frame: the GPU time (timestamp queries) and the render thread's CPU
// time (the annotation geometry is built there).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "iris/engine.h"

struct AnnotationBenchOptions {
    std::string slide;
    std::vector<std::pair<uint32_t, uint32_t>> sizes;
    std::vector<size_t> counts;
    bool validation = false;
    iris::EngineTuning tuning;
    uint64_t seed = 1;
    std::string json; // write the results here too
};

// Prints a table per size and count; 0 on success, 1 when the engine or the slide failed.
int runAnnotationBench(const AnnotationBenchOptions& o);
