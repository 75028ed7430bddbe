// iris-bench --views N: linked views (issue 17). N engines share one window split into a grid,
// each in its own cell and with its own render thread, as IrisViewGroup's members are, and all
// follow one glide: a pan and a turn published to every engine once per display tick (60 Hz),
// as a linked group propagates a user's drag. Measured per tick: the time from publishing the
// view to each engine's submission (present) of the first frame showing it — its frame
// callback — the group's being its slowest member's; the ticks some engine never showed
// (superseded by the next before it was drawn); and the frames' GPU time (timestamp queries),
// which runs after the submission. The baseline, in the same run on the same machine: one
// engine in one cell, the same glide.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "iris/engine.h"

struct LinkedResult {
    int views = 0;
    uint32_t cellW = 0, cellH = 0;
    std::string device;
    int ticks = 0;
    int missed = 0;                 // ticks at least one engine never drew
    std::vector<double> latencyMs;  // per tick drawn by every engine: the slowest engine's latency
    std::vector<double> fps;        // per engine: frames drawn per second over the glide
    std::vector<double> gpuMs;      // every engine's frames' GPU time during the glide
    std::string notes;              // why it could not run, or validation messages
};

// The glide of `ticks` display ticks over `slide` with `views` engines of cellW × cellH each.
LinkedResult runLinked(const std::string& slide, int views, uint32_t cellW, uint32_t cellH, int ticks,
                       const iris::EngineConfig& base);
