// iris-bench: the frames of a measured stretch (the engine's frame callback, on its render
// thread, appends while on), their JSON summary and the tables' number format; shared by the
// annotation and raster-layer benches.
#pragma once

#include <cmath>
#include <cstdio>
#include <mutex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "iris/engine.h"
#include "stats.h"

struct FrameLog {
    std::mutex m;
    bool on = false;
    std::vector<double> gpu, cpu;
    void start() {
        std::lock_guard lock(m);
        gpu.clear();
        cpu.clear();
        on = true;
    }
    void stop() {
        std::lock_guard lock(m);
        on = false;
    }
    void add(const iris::FrameStats& s) {
        std::lock_guard lock(m);
        if (!on) return;
        if (s.gpuMs >= 0) gpu.push_back(s.gpuMs);
        cpu.push_back(s.cpuMs);
    }
};

inline nlohmann::json frameStat(const std::vector<double>& v) {
    return {{"median", percentile(v, 0.5)}, {"p95", percentile(v, 0.95)}, {"frames", v.size()}};
}

// Milliseconds in a table: three significant digits or so, "-" for none.
inline std::string fmtMs(double v) {
    if (std::isnan(v)) return "-";
    char b[32];
    std::snprintf(b, sizeof b, v < 1 ? "%.3f" : v < 10 ? "%.2f" : "%.1f", v);
    return b;
}
