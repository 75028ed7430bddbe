#include "layers.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <memory>

#include <nlohmann/json.hpp>

#include "frame_log.h"
#include "iris/layers.h"

namespace {

using Clock = std::chrono::steady_clock;
using Json = nlohmann::json;

// A map of `side` = level-0 side / divisor, whole pixels, within the engine's limits.
std::pair<int32_t, int32_t> mapSize(int64_t slideW, int64_t slideH, double divisor) {
    double w = std::max(1.0, std::round(double(slideW) / divisor));
    double h = std::max(1.0, std::round(double(slideH) / divisor));
    const double maxPixels = double(iris::kMaxRasterBytes / 4);
    const double shrink = std::max({1.0, w / iris::kMaxRasterSide, h / iris::kMaxRasterSide, std::sqrt(w * h / maxPixels)});
    return {int32_t(std::max(1.0, std::floor(w / shrink))), int32_t(std::max(1.0, std::floor(h / shrink)))};
}

// Smooth blobs in 0..1, with a no-data (NaN) rectangle in the first eighth.
std::shared_ptr<const iris::RasterMap> syntheticMap(int32_t w, int32_t h, const std::string& title) {
    std::vector<float> v(size_t(w) * size_t(h));
    for (int32_t y = 0; y < h; ++y) {
        const double fy = double(y) / h;
        for (int32_t x = 0; x < w; ++x) {
            const double fx = double(x) / w;
            float value = float(0.5 + 0.25 * std::sin(fx * 17.0) + 0.25 * std::cos(fy * 11.0 + fx * 3.0));
            if (fx < 0.125 && fy < 0.125) value = std::numeric_limits<float>::quiet_NaN();
            v[size_t(y) * size_t(w) + size_t(x)] = value;
        }
    }
    auto map = iris::fromHostMemory(v, w, h, title);
    return map ? std::make_shared<const iris::RasterMap>(std::move(map).value()) : nullptr;
}

// Four styles a viewer would stack: different maps, opacities, a threshold, nearest sampling.
iris::LayerStyle styleOf(int i) {
    iris::LayerStyle s;
    s.opacity = 0.35 + 0.1 * i;
    s.colorMap = i == 1 ? iris::ColorMap::magma() : i == 2 ? iris::ColorMap::jet() : i == 3 ? iris::ColorMap::gray()
                                                                                            : iris::ColorMap::viridis();
    if (i == 2) s.threshold = 0.4;
    if (i == 3) s.sampling = iris::LayerSampling::Nearest;
    return s;
}

int fail(const std::string& message) {
    std::fprintf(stderr, "iris-bench: %s\n", message.c_str());
    return 1;
}

constexpr int kCounts[] = {0, 1, 4};

} // namespace

int runLayerBench(const LayerBenchOptions& o) {
    Json all = Json::array();
    for (auto [W, H] : o.sizes) {
        iris::EngineConfig cfg;
        cfg.validation = o.validation;
        cfg.tuning = o.tuning;
        cfg.color.managed = false;
        auto created = iris::Engine::create(cfg);
        if (!created) return fail(created.error().message());
        iris::Engine& e = **created;
        if (iris::Result r = e.bindOffscreen(W, H, false); !r.ok()) return fail(r.message());
        if (iris::Result r = e.open(o.slide); !r.ok()) return fail(r.message());
        const iris::SlideInfo info = *e.slideInfo();
        const int64_t sw = info.levels[0].width, sh = info.levels[0].height;
        FrameLog log;
        e.setFrameCallback([&log](const iris::FrameStats& s) { log.add(s); });
        const iris::View fit = e.fitView();

        struct MapCase {
            const char* name;
            double divisor;
        };
        for (const MapCase mc : {MapCase{"small (1/224)", 224}, MapCase{"big (1/4)", 4}}) {
            const auto [mw, mh] = mapSize(sw, sh, mc.divisor);
            std::fprintf(stderr, "iris-bench: %s map %dx%d over %lldx%lld, %ux%u…\n", mc.name, mw, mh, (long long)sw,
                         (long long)sh, W, H);
            const auto tMake = Clock::now();
            const std::shared_ptr<const iris::RasterMap> map = syntheticMap(mw, mh, mc.name);
            if (!map) return fail("cannot make the synthetic map");
            const double makeMs = std::chrono::duration<double, std::milli>(Clock::now() - tMake).count();

            const auto showLayers = [&](int count) -> iris::Result {
                e.clearLayers();
                for (int i = 0; i < count; ++i) {
                    if (auto id = e.addLayer(map, styleOf(i)); !id) return id.error();
                }
                return {};
            };
            // The first frame with one layer of this map at fit view: it uploads what it needs.
            e.setView(fit);
            (void)e.waitForSettled(std::chrono::seconds(120));
            if (iris::Result r = showLayers(1); !r.ok()) return fail(r.message());
            const auto tFirst = Clock::now();
            (void)e.waitForFrame(std::chrono::seconds(120));
            const double firstMs = std::chrono::duration<double, std::milli>(Clock::now() - tFirst).count();

            Json viewsJson = Json::array();
            std::printf("\n%s map %dx%d, %ux%u on %s: made in %s ms; first fit frame with it %s ms\n", mc.name, mw, mh,
                        W, H, e.device().name.c_str(), fmtMs(makeMs).c_str(), fmtMs(firstMs).c_str());
            std::printf("%-8s %9s | %-26s | %-26s\n", "view", "downsmpl", "GPU ms p50, 0 / 1 / 4 layers",
                        "render CPU ms p50, 0 / 1 / 4");
            for (const auto& [viewName, downsample] :
                 {std::pair<const char*, double>{"fit", fit.downsample},
                  std::pair<const char*, double>{"mid", std::max(1.0, std::sqrt(fit.downsample))}}) {
                iris::View v = fit;
                v.downsample = downsample;
                e.setView(v);
                std::vector<double> gpu[3], cpu[3];
                for (int round = 0; round < 2; ++round) {
                    for (int c = 0; c < 3; ++c) {
                        if (iris::Result r = showLayers(kCounts[c]); !r.ok()) return fail(r.message());
                        (void)e.waitForSettled(std::chrono::seconds(120));
                        measureSettledFrames(e, log, gpu[c], cpu[c]);
                    }
                }
                std::printf("%-8s %9s | %8s / %-7s / %-7s | %8s / %-7s / %-7s\n", viewName, fmtMs(downsample).c_str(),
                            fmtMs(percentile(gpu[0], 0.5)).c_str(), fmtMs(percentile(gpu[1], 0.5)).c_str(),
                            fmtMs(percentile(gpu[2], 0.5)).c_str(), fmtMs(percentile(cpu[0], 0.5)).c_str(),
                            fmtMs(percentile(cpu[1], 0.5)).c_str(), fmtMs(percentile(cpu[2], 0.5)).c_str());
                Json counts = Json::array();
                for (int c = 0; c < 3; ++c)
                    counts.push_back({{"layers", kCounts[c]}, {"gpu_ms", frameStat(gpu[c])}, {"cpu_ms", frameStat(cpu[c])}});
                viewsJson.push_back({{"view", viewName}, {"downsample", downsample}, {"counts", counts}});
            }
            std::fflush(stdout);
            e.clearLayers();
            all.push_back({{"map", mc.name},
                           {"map_size", {{"w", mw}, {"h", mh}}},
                           {"size", {{"w", W}, {"h", H}}},
                           {"device", e.device().name},
                           {"make_ms", makeMs},
                           {"first_fit_frame_ms", firstMs},
                           {"views", viewsJson}});
        }
        e.setFrameCallback({});
        if (iris::Result r = e.error(); !r.ok()) return fail(r.message());
        if (o.validation && e.validationMessageCount() > 0)
            return fail(std::to_string(e.validationMessageCount()) + " validation messages");
    }
    if (!o.json.empty()) {
        std::ofstream f(o.json);
        f << Json{{"heatmap", all}}.dump(2, ' ', false, Json::error_handler_t::replace) << "\n";
        if (!f) return fail("cannot write " + o.json);
    }
    return 0;
}
