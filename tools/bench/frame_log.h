// iris-bench: the frames of a measured stretch (the engine's frame callback, on its render
// thread, appends while on), their JSON summary and the tables' number format; shared by the
// annotation and raster-layer benches.
#pragma once

#include <chrono>
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

// Settled frames of the engine's current view: three to warm up (uploads, triangulations, the
// first frames' GPU start-up), then 24 logged, the view nudged a quarter pixel each (nothing
// new to load); their GPU and CPU times are appended to gpu and cpu.
inline void measureSettledFrames(iris::Engine& e, FrameLog& log, std::vector<double>& gpu, std::vector<double>& cpu) {
    for (int i = 0; i < 3; ++i) {
        e.translate(i % 2 ? -0.25 : 0.25, 0);
        (void)e.waitForFrame(std::chrono::seconds(60));
    }
    log.start();
    for (int i = 0; i < 24; ++i) {
        e.translate(i % 2 ? -0.25 : 0.25, 0);
        (void)e.waitForFrame(std::chrono::seconds(60));
    }
    log.stop();
    std::lock_guard lock(log.m);
    gpu.insert(gpu.end(), log.gpu.begin(), log.gpu.end());
    cpu.insert(cpu.end(), log.cpu.begin(), log.cpu.end());
}

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
