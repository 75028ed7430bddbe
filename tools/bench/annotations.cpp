#include "annotations.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>

#include <nlohmann/json.hpp>

#include "iris/annotations.h"
#include "frame_log.h"

namespace {

using Clock = std::chrono::steady_clock;
using Json = nlohmann::json;

double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

std::vector<iris::AnnotationObject> detections(size_t n, double w, double h, uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> ux(12, w - 12), uy(12, h - 12), ur(5, 12), jitter(0.75, 1.0);
    const char* classes[3] = {"Tumor", "Stroma", "Immune cells"};
    std::vector<iris::AnnotationObject> v;
    v.reserve(n);
    for (size_t i = 0; i < n; ++i) {
        iris::AnnotationObject o;
        o.kind = iris::AnnotationKind::Polygon;
        o.type = iris::AnnotationType::Detection;
        o.className = classes[i % 3];
        o.fill = i % 4 == 0;
        o.lineWidth = 1.5f;
        const double cx = ux(rng), cy = uy(rng), r = ur(rng);
        iris::PolygonPart p;
        for (int k = 0; k < 20; ++k) {
            const double a = k * 3.14159265358979 / 10, rr = r * jitter(rng);
            p.outer.push_back({cx + rr * std::cos(a), cy + rr * std::sin(a)});
        }
        o.polygons.push_back(std::move(p));
        v.push_back(std::move(o));
    }
    return v;
}

struct Series {
    std::vector<double> gpuShown, gpuHidden, cpuShown, cpuHidden;
};

} // namespace

int runAnnotationBench(const AnnotationBenchOptions& o) {
    Json all = Json::array();
    for (auto [W, H] : o.sizes) {
        for (size_t n : o.counts) {
            iris::EngineConfig cfg;
            cfg.validation = o.validation;
            cfg.tuning = o.tuning;
            cfg.color.managed = false;
            auto created = iris::Engine::create(cfg);
            if (!created) {
                std::fprintf(stderr, "iris-bench: %s\n", created.error().message().c_str());
                return 1;
            }
            iris::Engine& e = **created;
            if (iris::Result r = e.bindOffscreen(W, H, false); !r.ok()) {
                std::fprintf(stderr, "iris-bench: %s\n", r.message().c_str());
                return 1;
            }
            if (iris::Result r = e.open(o.slide); !r.ok()) {
                std::fprintf(stderr, "iris-bench: %s\n", r.message().c_str());
                return 1;
            }
            const iris::SlideInfo info = *e.slideInfo();
            const double sw = double(info.levels[0].width), sh = double(info.levels[0].height);
            std::fprintf(stderr, "iris-bench: %zu annotations over %.0fx%.0f, %ux%u…\n", n, sw, sh, W, H);
            auto objects = detections(n, sw, sh, o.seed);
            auto store = std::make_shared<iris::AnnotationStore>();
            const auto tLoad = Clock::now();
            if (iris::Result r = store->replaceAll(std::move(objects), {}); !r.ok()) {
                std::fprintf(stderr, "iris-bench: %s\n", r.message().c_str());
                return 1;
            }
            const double loadMs = msSince(tLoad);

            FrameLog log;
            e.setFrameCallback([&log](const iris::FrameStats& s) { log.add(s); });
            const iris::View fit = e.fitView();
            e.setView(fit);
            (void)e.waitForSettled(std::chrono::seconds(120));
            e.setAnnotations(store);
            e.setAnnotationsVisible(true);
            const auto tFirst = Clock::now();
            (void)e.waitForFrame(std::chrono::seconds(120));
            const double firstFitMs = msSince(tFirst);

            // Settled frames of `view`: nudged a quarter pixel each (the bench's settled measure).
            const auto settled = [&](const iris::View& view, Series& s) {
                e.setView(view);
                (void)e.waitForSettled(std::chrono::seconds(120));
                for (int round = 0; round < 4; ++round) {
                    const bool shown = round % 2 == 1;
                    e.setAnnotationsVisible(shown);
                    (void)e.waitForFrame(std::chrono::seconds(60));
                    measureSettledFrames(e, log, shown ? s.gpuShown : s.gpuHidden,
                                         shown ? s.cpuShown : s.cpuHidden);
                }
            };
            struct Row {
                std::string name;
                double downsample;
                Series s;
            };
            std::vector<Row> rows{{"fit", fit.downsample, {}}, {"ds 16", 16, {}}, {"ds 4", 4, {}}, {"ds 1", 1, {}}};
            for (Row& r : rows) {
                iris::View v = fit;
                v.downsample = std::min(r.downsample, fit.downsample);
                settled(v, r.s);
            }
            // A pan at 1:1 over new tiles, an eighth of the window per frame, shown then hidden
            // over the same path.
            Row pan{"pan 1:1", 1, {}};
            for (int round = 0; round < 2; ++round) {
                const bool shown = round == 0;
                e.setAnnotationsVisible(shown);
                iris::View v = fit;
                v.downsample = 1;
                v.centerX = sw * 0.3;
                v.centerY = sh * 0.4;
                e.setView(v);
                (void)e.waitForSettled(std::chrono::seconds(120));
                log.start();
                for (int i = 0; i < 48; ++i) {
                    e.translate(double(W) / 8, 0);
                    (void)e.waitForFrame(std::chrono::seconds(60));
                }
                log.stop();
                std::lock_guard lock(log.m);
                (shown ? pan.s.gpuShown : pan.s.gpuHidden) = log.gpu;
                (shown ? pan.s.cpuShown : pan.s.cpuHidden) = log.cpu;
            }
            rows.push_back(pan);
            e.setFrameCallback({});

            std::printf("\n%zu annotations, %ux%u on %s: replaceAll %s ms; first fit frame shown %s ms\n", n, W, H,
                        e.device().name.c_str(), fmtMs(loadMs).c_str(), fmtMs(firstFitMs).c_str());
            std::printf("%-8s %9s | %-27s | %-27s\n", "view", "downsmpl", "GPU ms shown / hidden (p50)",
                        "render CPU ms shown / hidden");
            Json rowsJson = Json::array();
            for (const Row& r : rows) {
                std::printf("%-8s %9s | %12s / %-12s | %12s / %-12s\n", r.name.c_str(),
                            fmtMs(std::min(r.downsample, fit.downsample)).c_str(),
                            fmtMs(percentile(r.s.gpuShown, 0.5)).c_str(), fmtMs(percentile(r.s.gpuHidden, 0.5)).c_str(),
                            fmtMs(percentile(r.s.cpuShown, 0.5)).c_str(), fmtMs(percentile(r.s.cpuHidden, 0.5)).c_str());
                rowsJson.push_back({{"view", r.name},
                                    {"downsample", std::min(r.downsample, fit.downsample)},
                                    {"gpu_ms_shown", frameStat(r.s.gpuShown)},
                                    {"gpu_ms_hidden", frameStat(r.s.gpuHidden)},
                                    {"cpu_ms_shown", frameStat(r.s.cpuShown)},
                                    {"cpu_ms_hidden", frameStat(r.s.cpuHidden)}});
            }
            std::fflush(stdout);
            all.push_back({{"annotations", n},
                           {"size", {{"w", W}, {"h", H}}},
                           {"device", e.device().name},
                           {"replace_all_ms", loadMs},
                           {"first_fit_frame_ms", firstFitMs},
                           {"views", rowsJson}});
            if (o.validation && e.validationMessageCount() > 0) {
                std::fprintf(stderr, "iris-bench: %llu validation messages\n",
                             (unsigned long long)e.validationMessageCount());
                return 1;
            }
        }
    }
    if (!o.json.empty()) {
        std::ofstream f(o.json);
        f << Json{{"annotations", all}}.dump(2, ' ', false, Json::error_handler_t::replace) << "\n";
        if (!f) {
            std::fprintf(stderr, "iris-bench: cannot write %s\n", o.json.c_str());
            return 1;
        }
    }
    return 0;
}
