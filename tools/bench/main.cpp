// iris-bench: drives the headless engine through moves to entirely new fields of view and
// reports the paper's measures (TeFOV for the LR and HR layers, time per tile, buffer rate,
// frame time) beside baselines measured in the same run on the same fields, and the GPU time
// of settled frames (the last field of each magnification redrawn with nothing to load).
//
//   iris-bench SLIDE [--size WxH] [--moves N] [--magnifications LIST] [--source auto|openslide|iris]
//              [--baseline SLIDE] [--frame-cache DIR] [--json FILE] [--plots DIR] [--seed N] [--validation]
//              [--opens N] [--switch-to SLIDE]
//   iris-bench SLIDE --views N [--size WxH] [--ticks N] [--json FILE]
//
// Without --size it runs 2774×1750 (the paper's window) and 1920×1080. --views runs linked
// views instead (linked.h): the window split into N cells, one engine each, gliding together.
#include <algorithm>
#include <array>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

#include <nlohmann/json.hpp>

#include "baselines.h"
#include "gpu_split.h"
#include "annotations.h"
#include "layers.h"
#include "linked.h"
#include "iris/engine.h"
#include "iris/environment.h"
#include "tool_cli.h"
#include "stats.h"

namespace {

using Clock = std::chrono::steady_clock;

struct Options {
    std::string slide;
    std::vector<std::pair<uint32_t, uint32_t>> sizes;
    int moves = 30;
    int idleMoves = -1; // ≥ 0: each move waits for the field to settle, then this many ms
    unsigned loaders = 0; // EngineConfig::loaderThreads (0: the engine's default)
    std::vector<double> mags;
    std::string source = "auto";
    std::string baseline; // the slide the CPU baselines read (default: the benchmarked slide)
    std::string frameCache; // a DICOMweb series' frames kept there (NetworkOptions::frameCacheDirectory)
    std::string json, plots;
    uint64_t seed = 1;
    bool validation = false;
    iris::EngineTuning tuning; // from the IRIS_* environment variables
    std::string colorManaged = "on"; // on, off, or both (an A/B of the colour transform's cost)
    int opens = 5;            // opening trials per size (0: none)
    std::string switchTo;     // the slide opened in turn with SLIDE to time a switch (main: SLIDE when not given)
    int views = 0;   // > 0: the linked-views benchmark (linked.h) with this many views
    int ticks = 240; // its glide's display ticks
};

// --size: "WxH", whole numbers from 64 to 16384.
std::optional<std::pair<uint32_t, uint32_t>> parseSize(const std::string& s) {
    uint32_t w = 0, h = 0;
    const char *p = s.data(), *end = s.data() + s.size();
    auto r = std::from_chars(p, end, w);
    if (r.ec != std::errc() || r.ptr == end || *r.ptr != 'x') return std::nullopt;
    r = std::from_chars(r.ptr + 1, end, h);
    if (r.ec != std::errc() || r.ptr != end || w < 64 || h < 64 || w > 16384 || h > 16384) return std::nullopt;
    return std::pair{w, h};
}

// --magnifications: a comma-separated list of positive numbers.
std::vector<double> parseList(const std::string& s) {
    std::vector<double> v;
    size_t start = 0;
    while (true) {
        const size_t comma = s.find(',', start);
        const std::string item = s.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
        char* end = nullptr;
        const double d = std::strtod(item.c_str(), &end);
        if (end == item.c_str() || *end || !(d > 0) || !std::isfinite(d)) return {};
        v.push_back(d);
        if (comma == std::string::npos) return v;
        start = comma + 1;
    }
}

// A number as it appears in labels: six significant digits.
std::string shortNumber(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.6g", v);
    return b;
}

struct TracePoint {
    double tMs, intervalMs, gpuMs, rateGBps;
};

struct SizeResult {
    uint32_t w = 0, h = 0;
    bool colorManaged = true; // asked for
    bool colorApplied = false; // a transform was applied (the slide has a usable profile)
    std::string device;
    std::string mipSchedule;
    std::string tileUpload; // as the engine resolved it
    std::string jpegDecode; // as the engine resolved it
    std::vector<double> lrTefov, hrTefov, lrTpt, hrTpt, rate, frameMs;
    std::vector<double> settledGpuMs; // GPU time of frames redrawing a loaded field (nothing to upload)
    std::vector<double> settledCpuMs; // the render thread's time on the same frames (FrameStats::cpuMs)
    std::vector<std::string> condition; // per field: magnification label
    std::vector<double> condHr, condTpt;
    std::vector<iris::FieldStats> timed; // every timed field, for its stage times
    BaselineResult osr, osrMt, floor;
    std::vector<TracePoint> trace;
    int movesDone = 0, movesWanted = 0, timeouts = 0;
    int untimed = 0; // moves the engine did not time (the new field was already resident)
    double mipUsPerTile = NAN; // GPU time of the mip dispatch per tile (timestamps)
    double pickupUs = NAN;     // a tile's wait in staging, from its loader's copy to the buffer thread taking it
    double uploadUs = NAN;     // a transaction's time from submission to the buffer thread seeing it complete
    double prestageUs = NAN;   // a loader's copy of a tile into staging
    double decodeUs = NAN;     // a loader's read and decode of a tile (SlideSource::readTile)
    // The loaders' time over the timed walk, summed over them (EngineMetrics::loader*Ms), and
    // the tiles they decoded.
    double loaderWorkMs = 0, loaderAcquireMs = 0, loaderSearchMs = 0, loaderReplenishMs = 0, loaderAsleepMs = 0;
    uint64_t loaderTiles = 0;
    // Opening (issue 20): open() alone, and open() to the first complete frame of the fit view,
    // into a fresh engine (a first slide) and with another slide shown (a switch).
    std::vector<double> openCallMs, openFrameMs, switchCallMs, switchFrameMs;
    std::string notes;
};

bool progressTty() { return isatty(2); }

iris::EngineConfig benchConfig(const Options& o, bool colorManaged) {
    iris::EngineConfig cfg;
    cfg.color.managed = colorManaged;
    cfg.validation = o.validation;
    cfg.tuning = o.tuning;
    cfg.perimeterTiles = 1;
    cfg.loaderThreads = o.loaders;
    cfg.network.frameCacheDirectory = o.frameCache;
    cfg.source = o.source == "openslide" ? iris::SourcePreference::OpenSlide
                 : o.source == "iris"    ? iris::SourcePreference::Iris
                                         : iris::SourcePreference::Auto;
    cfg.log = [](iris::LogLevel l, std::string_view m) {
        if (l >= iris::LogLevel::Warning) std::fprintf(stderr, "iris-bench: %.*s\n", int(m.size()), m.data());
    };
    return cfg;
}

double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// Opening, as a host sees it: from the open() call to the first complete frame of the fit view
// (every visible tile drawn; Engine::waitForFrame), and the open() call alone (the header read
// it makes synchronously). First into engines that have shown nothing (one each, created and
// bound before the clock starts: a viewer's start-up is not the slide's opening), then as
// switches on one engine, where each open replaces a slide that was settled on screen (SLIDE
// and --switch-to in turn). Every open is a new slide to the engine: nothing of an earlier one
// is reused (the RAM cache drops other generations), but after the first trial the file's
// bytes are in the operating system's cache, as for a case reopened or a slide of the same case.
void measureOpening(const Options& o, uint32_t W, uint32_t H, bool colorManaged, SizeResult& res) {
    const auto once = [&](iris::Engine& e, const std::string& path, std::vector<double>& call,
                          std::vector<double>& frame) {
        const auto t0 = Clock::now();
        if (const iris::Result r = e.open(path); !r) {
            res.notes += "opening " + path + " failed: " + r.message() + ". ";
            return false;
        }
        const double callMs = msSince(t0);
        if (const iris::Result r = e.waitForFrame(std::chrono::seconds(60)); !r) {
            res.notes += "no complete frame after opening " + path + ": " + r.message() + ". ";
            return false;
        }
        call.push_back(callMs);
        frame.push_back(msSince(t0));
        return true;
    };
    // An engine bound to the offscreen target, or none (runSize reports why, making its own).
    const auto bound = [&]() -> std::unique_ptr<iris::Engine> {
        auto created = iris::Engine::create(benchConfig(o, colorManaged));
        if (!created || !(*created)->bindOffscreen(W, H, /*readback=*/false)) return nullptr;
        return std::move(*created);
    };
    for (int i = 0; i < o.opens; ++i) {
        const auto e = bound();
        if (!e || !once(*e, o.slide, res.openCallMs, res.openFrameMs)) return;
    }
    if (o.opens == 0) return;
    const auto e = bound();
    std::vector<double> ignored;
    if (!e || !once(*e, o.slide, ignored, ignored)) return;
    for (int i = 0; i < o.opens; ++i) {
        if (const iris::Result r = e->waitForSettled(std::chrono::seconds(60)); !r) {
            res.notes += "the slide shown before a switch did not settle: " + r.message() + ". ";
            return;
        }
        if (!once(*e, i % 2 == 0 ? o.switchTo : o.slide, res.switchCallMs, res.switchFrameMs)) return;
    }
}

SizeResult runSize(const Options& o, uint32_t W, uint32_t H, bool colorManaged) {
    SizeResult res;
    res.w = W;
    res.h = H;
    res.colorManaged = colorManaged;
    measureOpening(o, W, H, colorManaged, res);
    auto created = iris::Engine::create(benchConfig(o, colorManaged));
    if (!created) {
        res.notes = created.error().message();
        return res;
    }
    iris::Engine& e = **created;
    res.device = e.device().name;
    res.mipSchedule = e.device().mipSchedule;
    res.tileUpload = e.device().tileUpload;
    res.jpegDecode = e.device().jpegDecode;
    if (auto r = e.bindOffscreen(W, H, /*readback=*/false); !r) {
        res.notes = r.message();
        return res;
    }
    if (auto r = e.open(o.slide); !r) {
        res.notes = r.message();
        return res;
    }
    const iris::SlideInfo info = *e.slideInfo();
    res.colorApplied = e.colorStatus().applied;
    std::mutex traceMutex;
    const auto start = Clock::now();
    // While > 0: frames of a settled field are being drawn; the first ones still report the GPU
    // time of frames recorded before (timestamps are read back a frame slot later).
    int settledSkip = -1;
    e.setFrameCallback([&](const iris::FrameStats& s) {
        std::lock_guard lock(traceMutex);
        if (settledSkip < 0) { // the walk's frames; the settled ones are paced by this tool
            res.trace.push_back({std::chrono::duration<double, std::milli>(Clock::now() - start).count(), s.intervalMs,
                                 s.gpuMs, s.bufferRateGBps});
        } else if (settledSkip > 0) --settledSkip;
        else if (settledSkip == 0 && s.complete && s.gpuMs >= 0) {
            res.settledGpuMs.push_back(s.gpuMs);
            res.settledCpuMs.push_back(s.cpuMs);
        }
    });
    // Magnification → downsample: from the objective power, else from mpp (10 µm/px ≈ 1×),
    // else the list is read as downsamples.
    // The objective from mpp is rounded to six significant digits: DICOM Pixel Spacing is often
    // written in single precision (OrthancWSIDicomizer: 0.000312499993 mm), and a downsample a
    // hair under a level's (3.9999998 for 4) would draw from the level above and walk other
    // fields than the same slide's TIFF.
    const double objective = info.objectivePower > 0 ? info.objectivePower
                             : info.mppX > 0         ? std::strtod(shortNumber(10.0 / info.mppX).c_str(), nullptr)
                                                     : 0;
    std::mt19937_64 rng(o.seed);
    std::vector<BenchField> fields;
    const iris::EngineMetrics m0 = e.metrics();
    for (double mag : o.mags) {
        const double ds = objective > 0 ? objective / mag : mag;
        const std::string label =
            objective > 0 ? std::to_string(int(std::lround(mag))) + "x" : "ds " + shortNumber(mag);
        const double fw = W * ds, fh = H * ds;
        const int64_t cols = int64_t(double(info.width) / fw), rows = int64_t(double(info.height) / fh);
        if (cols < 1 || rows < 1) {
            res.notes += "at " + label + " the slide is smaller than one field; skipped. ";
            continue;
        }
        // A serpentine walk over whole fields, starting at a random row: never revisits a field.
        const int64_t total = cols * rows;
        const int64_t startIdx = int64_t(rng() % uint64_t(total));
        const int64_t steps = std::min<int64_t>(o.moves + 1, total);
        res.movesWanted += o.moves;
        if (steps - 1 < o.moves)
            res.notes += "at " + label + " only " + std::to_string(steps - 1) + " non-overlapping moves fit on the slide. ";
        std::vector<iris::View> walk;
        for (int64_t k = 0; k < steps; ++k) {
            const int64_t idx = (startIdx + k) % total;
            const int64_t r = idx / cols, c = (r % 2 == 0) ? idx % cols : cols - 1 - idx % cols;
            walk.push_back({(double(c) + 0.5) * fw, (double(r) + 0.5) * fh, ds});
        }
        e.setView(walk[0]);
        (void)e.waitForFrame(std::chrono::seconds(60));
        for (size_t k = 1; k < walk.size(); ++k) {
            if (o.idleMoves >= 0) { // a move from a settled, idle view, as a reader's moves come
                (void)e.waitForSettled(std::chrono::seconds(30));
                std::this_thread::sleep_for(std::chrono::milliseconds(o.idleMoves));
            }
            const size_t before = e.metrics().fields.size();
            e.setView(walk[k]);
            const auto t0 = Clock::now();
            bool done = false, untimed = false;
            std::optional<Clock::time_point> completeAt;
            while (Clock::now() - t0 < std::chrono::seconds(60)) {
                const iris::EngineMetrics m = e.metrics();
                if (m.fields.size() > before && m.fields.back().hrTeFovMs >= 0) {
                    const iris::FieldStats& f = m.fields.back();
                    res.hrTefov.push_back(f.hrTeFovMs);
                    if (f.lrTeFovMs >= 0) res.lrTefov.push_back(f.lrTeFovMs);
                    if (f.hrTptUs >= 0) res.hrTpt.push_back(f.hrTptUs);
                    if (f.lrTptUs >= 0) res.lrTpt.push_back(f.lrTptUs);
                    res.condition.push_back(label);
                    res.condHr.push_back(f.hrTeFovMs);
                    res.condTpt.push_back(f.hrTptUs);
                    res.timed.push_back(f);
                    done = true;
                    break;
                }
                // A move the engine did not time (every tile of the new field was already
                // resident) has a complete frame but never a field record: don't wait for one.
                if (!completeAt && e.waitForFrame(std::chrono::milliseconds(0)).ok()) completeAt = Clock::now();
                if (completeAt && Clock::now() - *completeAt > std::chrono::milliseconds(100)) {
                    untimed = true;
                    break;
                }
                std::this_thread::sleep_for(std::chrono::microseconds(200));
            }
            if (untimed) ++res.untimed;
            else if (!done) ++res.timeouts;
            ++res.movesDone;
            // The field the engine just drew, for the baselines.
            const iris::View& v = walk[k];
            const int level = info.levelFor(ds); // the engine's HR level
            const double lds = info.levels[size_t(level)].downsample;
            fields.push_back({v.centerX - W / 2.0 * ds, v.centerY - H / 2.0 * ds, level, lds,
                              int64_t(std::ceil(W * ds / lds)), int64_t(std::ceil(H * ds / lds))});
            if (progressTty())
                std::fprintf(stderr, "\riris-bench: %ux%u %s: move %zu/%zu   ", W, H, label.c_str(), k, walk.size() - 1);
        }
        // Settled frames: the walk's last field once its uploads (perimeter included) are
        // done, redrawn by quarter-pixel pans that load nothing: the drawing's own GPU cost.
        if (const iris::Result r = e.waitForSettled(std::chrono::seconds(30)); !r.ok())
            std::fprintf(stderr, "iris-bench: the last field did not settle: %s\n", r.message().c_str());
        {
            std::lock_guard lock(traceMutex);
            settledSkip = 3;
        }
        for (int i = 0; i < 24; ++i) {
            e.translate(i % 2 ? -0.25 : 0.25, 0);
            (void)e.waitForFrame(std::chrono::seconds(5));
        }
        std::lock_guard lock(traceMutex);
        settledSkip = -1;
    }
    if (progressTty()) std::fprintf(stderr, "\n");
    e.setFrameCallback({});
    const iris::EngineMetrics m1 = e.metrics();
    if (m1.mipTiles > m0.mipTiles)
        res.mipUsPerTile = (m1.mipGpuMs - m0.mipGpuMs) * 1000.0 / double(m1.mipTiles - m0.mipTiles);
    if (m1.stagedPickupTiles > m0.stagedPickupTiles)
        res.pickupUs = (m1.stagedPickupMs - m0.stagedPickupMs) * 1000.0 / double(m1.stagedPickupTiles - m0.stagedPickupTiles);
    if (m1.uploadTransactions > m0.uploadTransactions)
        res.uploadUs = (m1.uploadMs - m0.uploadMs) * 1000.0 / double(m1.uploadTransactions - m0.uploadTransactions);
    if (m1.prestageTiles > m0.prestageTiles)
        res.prestageUs = (m1.prestageCopyMs - m0.prestageCopyMs) * 1000.0 / double(m1.prestageTiles - m0.prestageTiles);
    if (m1.decodeTiles > m0.decodeTiles)
        res.decodeUs = (m1.decodeMs - m0.decodeMs) * 1000.0 / double(m1.decodeTiles - m0.decodeTiles);
    res.loaderWorkMs = m1.loaderWorkMs - m0.loaderWorkMs;
    res.loaderAcquireMs = m1.loaderAcquireMs - m0.loaderAcquireMs;
    res.loaderSearchMs = m1.loaderSearchMs - m0.loaderSearchMs;
    res.loaderReplenishMs = m1.loaderReplenishMs - m0.loaderReplenishMs;
    res.loaderAsleepMs = m1.loaderAsleepMs - m0.loaderAsleepMs;
    res.loaderTiles = m1.decodeTiles - m0.decodeTiles;
    {
        std::lock_guard lock(traceMutex);
        for (const TracePoint& t : res.trace) {
            if (t.intervalMs > 0) res.frameMs.push_back(t.intervalMs);
            if (t.rateGBps > 0) res.rate.push_back(t.rateGBps);
        }
    }
    if (e.validationMessageCount() > 0)
        res.notes += std::to_string(e.validationMessageCount()) + " Vulkan validation messages. ";
    created.value().reset(); // free the engine's threads before the CPU baselines
    const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
    std::fprintf(stderr, "iris-bench: %ux%u: baselines over %zu fields…\n", W, H, fields.size());
    // An .iris slide is compared with the slide it was encoded from (--baseline): OpenSlide and
    // the TIFF decode floor cannot read .iris.
    const std::string& base = o.baseline.empty() ? o.slide : o.baseline;
    res.osr = openslideBaseline(base, fields, 1);
    res.osrMt = openslideBaseline(base, fields, cores);
    // The floor split between the CPU and the GPU, on the device the engine used (gpu_split.h).
    std::string splitWhy;
    std::unique_ptr<benchsplit::GpuSplit> split = benchsplit::GpuSplit::create(benchConfig(o, false), splitWhy);
    res.floor = decodeFloorBaseline(base, fields, cores, split.get());
    if (!split) res.floor.splitNote = "no device for it: " + splitWhy;
    return res;
}

using Json = nlohmann::ordered_json; // keeps the keys in the order written

// A measure in the JSON: six significant digits (the precision the table and the stored results
// have), null where undefined: JSON has no NaN or infinity.
Json jsonNumber(double v) {
    return std::isfinite(v) ? Json(std::strtod(shortNumber(v).c_str(), nullptr)) : Json(nullptr);
}

Json jsonQuartiles(const Quartiles& q) {
    return {{"p25", jsonNumber(q.p25)}, {"median", jsonNumber(q.median)}, {"p75", jsonNumber(q.p75)}};
}

// Where the fields' time went (issue 20): for each tile stage, the median over the timed fields
// of its first, median and last event's offset from the move, and of its event count.
struct StageRow {
    double first = NAN, median = NAN, last = NAN, tiles = NAN;
};
std::array<StageRow, iris::kTileStageCount> stageTimeline(const std::vector<iris::FieldStats>& fields) {
    std::array<StageRow, iris::kTileStageCount> rows{};
    for (int s = 0; s < iris::kTileStageCount; ++s) {
        std::vector<double> first, median, last, tiles;
        for (const iris::FieldStats& f : fields) {
            const iris::StageTimes& t = f.stages[size_t(s)];
            tiles.push_back(t.tiles);
            if (t.tiles == 0) continue;
            first.push_back(t.firstMs);
            median.push_back(t.medianMs);
            last.push_back(t.lastMs);
        }
        rows[size_t(s)] = {quartiles(first).median, quartiles(median).median, quartiles(last).median,
                           quartiles(tiles).median};
    }
    return rows;
}
// The field whose HR-TeFOV is the median of the run's (the "typical field" plotted); null when none.
const iris::FieldStats* typicalField(const std::vector<iris::FieldStats>& fields) {
    if (fields.empty()) return nullptr;
    std::vector<const iris::FieldStats*> sorted;
    for (const iris::FieldStats& f : fields) sorted.push_back(&f);
    std::sort(sorted.begin(), sorted.end(), [](auto* a, auto* b) { return a->hrTeFovMs < b->hrTeFovMs; });
    return sorted[sorted.size() / 2];
}
Json stageJson(double first, double median, double last, double tiles) {
    return {{"first_ms", jsonNumber(first)}, {"median_ms", jsonNumber(median)}, {"last_ms", jsonNumber(last)},
            {"tiles", jsonNumber(tiles)}};
}

Json resultJson(const Options& o, const SizeResult& r) {
    const Quartiles hr = quartiles(r.hrTefov), osr = quartiles(r.osr.ms), flo = quartiles(r.floor.ms);
    std::vector<double> fps;
    for (double ms : r.frameMs) fps.push_back(1000.0 / ms);
    Json j;
    j["device"] = r.device;
    j["size"] = std::to_string(r.w) + "x" + std::to_string(r.h);
    j["color_managed"] = r.colorManaged;
    j["color_applied"] = r.colorApplied;
    j["source"] = o.source;
    j["baseline_slide"] = o.baseline.empty() ? o.slide : o.baseline;
    j["frame_cache"] = o.frameCache;
    j["lr_tefov_ms"] = jsonQuartiles(quartiles(r.lrTefov));
    j["hr_tefov_ms"] = jsonQuartiles(hr);
    j["lr_tpt_us"] = jsonQuartiles(quartiles(r.lrTpt));
    j["hr_tpt_us"] = jsonQuartiles(quartiles(r.hrTpt));
    j["buffer_rate_gbps"] = jsonQuartiles(quartiles(r.rate));
    j["frame_ms"] = jsonQuartiles(quartiles(r.frameMs));
    j["fps"] = jsonQuartiles(quartiles(fps));
    j["settled_frame_gpu_ms"] = jsonQuartiles(quartiles(r.settledGpuMs));
    j["settled_frame_cpu_ms"] = jsonQuartiles(quartiles(r.settledCpuMs));
    // Opening (measureOpening): into a fresh engine, and switching from a settled slide.
    j["open_to_first_frame_ms"] = jsonQuartiles(quartiles(r.openFrameMs));
    j["open_call_ms"] = jsonQuartiles(quartiles(r.openCallMs));
    j["switch_to_first_frame_ms"] = jsonQuartiles(quartiles(r.switchFrameMs));
    j["switch_call_ms"] = jsonQuartiles(quartiles(r.switchCallMs));
    j["opening"] = {{"trials", o.opens}, {"switch_to", o.switchTo}};
    j["baselines"] = {{"openslide_fov_ms", jsonQuartiles(osr)},
                      {"openslide_mt_fov_ms", jsonQuartiles(quartiles(r.osrMt.ms))},
                      {"decode_floor_fov_ms", jsonQuartiles(flo)},
                      {"decode_floor_split_fov_ms", jsonQuartiles(quartiles(r.floor.splitMs))},
                      {"decode_floor_split_gpu_ms", jsonQuartiles(quartiles(r.floor.splitGpuMs))},
                      {"decode_floor_split_gpu_compute_ms", jsonQuartiles(quartiles(r.floor.splitComputeMs))},
                      {"decode_floor_split_tiles", r.floor.splitTiles},
                      {"decode_floor_split_entropy_us_per_tile", jsonNumber(r.floor.splitEntropyUsPerTile)},
                      {"decode_floor_split_mismatched_tiles", r.floor.splitMismatched},
                      {"decode_floor_split_note", r.floor.splitNote},
                      {"notes", r.osr.note + (r.floor.note.empty() ? "" : " decode floor: " + r.floor.note)}};
    j["ratios"] = {{"hr_tefov_vs_openslide", jsonNumber(hr.median / osr.median)},
                   {"hr_tefov_vs_decode_floor", jsonNumber(hr.median / flo.median)}};
    j["moves"] = r.movesDone;
    j["idle_moves_ms"] = o.idleMoves; // -1: each move as soon as the field was complete
    j["loader_threads"] = o.loaders;  // 0: the engine's default (a loader a core, two fewer above 4)
    j["hardware_threads"] = std::thread::hardware_concurrency();
    j["mip_schedule"] = r.mipSchedule;
    j["tile_upload"] = r.tileUpload;
    j["jpeg_decode"] = r.jpegDecode;
    // What IRIS_* asked for (an A/B run's JSON says which side it is).
    const auto pacing = o.tuning.pacing == iris::EngineTuning::Pacing::On    ? "on"
                        : o.tuning.pacing == iris::EngineTuning::Pacing::Off ? "off"
                                                                             : "auto";
    j["tuning"] = {{"pacing", pacing},
                   {"draw_covered", o.tuning.drawCovered},
                   {"single_queue", o.tuning.singleQueue},
                   {"tile_resolve", o.tuning.tileResolve == iris::EngineTuning::TileResolve::Compute ? "compute"
                                    : o.tuning.tileResolve == iris::EngineTuning::TileResolve::Quads ? "quads"
                                                                                                     : "auto"},
                   {"color_lookup", o.tuning.colorLookup == iris::EngineTuning::ColorLookup::Sampler ? "sampler"
                                    : o.tuning.colorLookup == iris::EngineTuning::ColorLookup::Nodes ? "nodes"
                                                                                                     : "auto"},
                   {"exact_copy", o.tuning.exactCopy == iris::EngineTuning::ExactCopy::On    ? "on"
                                  : o.tuning.exactCopy == iris::EngineTuning::ExactCopy::Off ? "off"
                                                                                             : "auto"},
                   {"tile_upload", o.tuning.tileUpload == iris::EngineTuning::TileUpload::Host    ? "host"
                                   : o.tuning.tileUpload == iris::EngineTuning::TileUpload::Queue ? "queue"
                                                                                                  : "auto"},
                   {"jpeg_decode", o.tuning.jpegDecode == iris::EngineTuning::JpegDecode::Gpu   ? "gpu"
                                   : o.tuning.jpegDecode == iris::EngineTuning::JpegDecode::Cpu ? "cpu"
                                                                                                : "auto"},
                   {"device_filter", o.tuning.deviceName}};
    // Per stage, medians over the timed fields; then the typical field's own (see stageTimeline).
    Json timeline;
    const auto rows = stageTimeline(r.timed);
    for (int s = 0; s < iris::kTileStageCount; ++s) {
        const StageRow& row = rows[size_t(s)];
        timeline[iris::tileStageName(iris::TileStage(s))] = stageJson(row.first, row.median, row.last, row.tiles);
    }
    j["stage_timeline_ms"] = timeline;
    if (const iris::FieldStats* f = typicalField(r.timed)) {
        Json stages;
        for (int s = 0; s < iris::kTileStageCount; ++s) {
            const iris::StageTimes& t = f->stages[size_t(s)];
            stages[iris::tileStageName(iris::TileStage(s))] =
                t.tiles ? stageJson(t.firstMs, t.medianMs, t.lastMs, t.tiles) : stageJson(NAN, NAN, NAN, 0);
        }
        j["typical_field"] = {{"hr_tefov_ms", jsonNumber(f->hrTeFovMs)},
                              {"lr_tefov_ms", jsonNumber(f->lrTeFovMs)},
                              {"hr_tiles", f->hrTiles},
                              {"tiles_buffered", f->tilesBuffered},
                              {"decodes_in_flight", jsonNumber(f->decodesInFlight)},
                              {"stages", stages}};
    }
    j["mip_us_per_tile"] = jsonNumber(r.mipUsPerTile);
    j["mip_share_of_hr_tpt"] = jsonNumber(r.mipUsPerTile / quartiles(r.hrTpt).median);
    {
        std::vector<double> inFlight;
        for (const iris::FieldStats& f : r.timed)
            if (f.decodesInFlight >= 0) inFlight.push_back(f.decodesInFlight);
        j["decodes_in_flight"] = jsonQuartiles(quartiles(inFlight));
    }
    j["staged_pickup_us"] = jsonNumber(r.pickupUs);
    j["upload_transaction_us"] = jsonNumber(r.uploadUs);
    j["prestage_copy_us"] = jsonNumber(r.prestageUs);
    j["decode_us_per_tile"] = jsonNumber(r.decodeUs);
    j["loader_time_ms"] = {{"work", jsonNumber(r.loaderWorkMs)},
                           {"acquire_buffer", jsonNumber(r.loaderAcquireMs)},
                           {"search", jsonNumber(r.loaderSearchMs)},
                           {"replenish", jsonNumber(r.loaderReplenishMs)},
                           {"asleep", jsonNumber(r.loaderAsleepMs)},
                           {"tiles", r.loaderTiles}};
    j["floor_decode_us_per_tile"] = jsonNumber(r.floor.threadUsPerTile);
    j["floor_entropy_us_per_tile"] = jsonNumber(r.floor.entropyUsPerTile);
    j["timeouts"] = r.timeouts;
    j["untimed_moves"] = r.untimed;
    j["notes"] = r.notes;
    return j;
}

void printTable(const SizeResult& r) {
    const auto row = [](const char* name, const std::vector<double>& v, const char* unit) {
        const Quartiles q = quartiles(v);
        std::printf("  %-28s %10.3f %10.3f %10.3f  %-4s n=%zu\n", name, q.p25, q.median, q.p75, unit, q.n);
    };
    std::printf("\n%ux%u on %s, colour management %s — %d moves (%d timed out, %d not timed: already resident)\n", r.w,
                r.h, r.device.c_str(), r.colorApplied ? "on" : (r.colorManaged ? "on (the slide has no usable profile)" : "off"),
                r.movesDone, r.timeouts, r.untimed);
    std::printf("  %-28s %10s %10s %10s\n", "", "p25", "median", "p75");
    row("LR TeFOV", r.lrTefov, "ms");
    row("HR TeFOV", r.hrTefov, "ms");
    row("LR time per tile", r.lrTpt, "us");
    row("HR time per tile", r.hrTpt, "us");
    row("buffer rate", r.rate, "GB/s");
    row("frame interval", r.frameMs, "ms");
    row("settled frame GPU time", r.settledGpuMs, "ms");
    row("  its render thread time", r.settledCpuMs, "ms");
    row("open() to first frame", r.openFrameMs, "ms");
    row("  the open() call", r.openCallMs, "ms");
    row("switch to first frame", r.switchFrameMs, "ms");
    row("  the open() call", r.switchCallMs, "ms");
    row("baseline: OpenSlide 1 thread", r.osr.ms, "ms");
    row("baseline: OpenSlide all cores", r.osrMt.ms, "ms");
    row("baseline: decode floor", r.floor.ms, "ms");
    row("  split: CPU entropy, GPU rest", r.floor.splitMs, "ms");
    row("    of which the GPU's", r.floor.splitGpuMs, "ms");
    row("      its two dispatches", r.floor.splitComputeMs, "ms");
    const double hr = quartiles(r.hrTefov).median;
    std::printf("  HR TeFOV vs OpenSlide: %.3f×   vs decode floor: %.3f×\n", hr / quartiles(r.osr.ms).median,
                hr / quartiles(r.floor.ms).median);
    std::printf("  mip pass (%s schedule, %s): %.2f us per tile = %.1f%% of the HR time per tile\n",
                r.mipSchedule.c_str(), r.mipSchedule == "host" ? "buffer thread's clock" : "GPU timestamps", r.mipUsPerTile,
                100.0 * r.mipUsPerTile / quartiles(r.hrTpt).median);
    std::printf("  a loader reads and decodes a tile in %.1f us (the decode floor's threads: %.1f us) and copies it into\n"
                "  staging in %.1f us; a staged tile waits %.1f us for the buffer thread; an upload completes %.1f us\n"
                "  after its submission (means over the timed walk)\n",
                r.decodeUs, r.floor.threadUsPerTile, r.prestageUs, r.pickupUs, r.uploadUs);
    if (std::isfinite(r.floor.entropyUsPerTile))
        std::printf("  the decode floor's threads read and entropy-decode a tile alone (no inverse DCT, upsampling or\n"
                    "  colour conversion) in %.1f us, %.0f%% of the whole decode\n",
                    r.floor.entropyUsPerTile, 100.0 * r.floor.entropyUsPerTile / r.floor.threadUsPerTile);
    if (r.floor.splitTiles > 0)
        std::printf("  the split floor's threads read and entropy-decode a tile into the GPU's input in %.1f us; it\n"
                    "  reconstructed %llu tiles on the GPU, %llu of them unlike libjpeg-turbo's decode\n",
                    r.floor.splitEntropyUsPerTile, (unsigned long long)r.floor.splitTiles,
                    (unsigned long long)r.floor.splitMismatched);
    if (!r.floor.splitNote.empty()) std::printf("  split floor: %s\n", r.floor.splitNote.c_str());
    if (r.loaderTiles > 0) {
        const double t = double(r.loaderTiles);
        std::printf("  the loaders' time a tile decoded (us): %.1f working, of which %.1f getting a buffer; %.1f finding\n"
                    "  no tile, %.1f making the cache's reserve, %.1f asleep\n",
                    r.loaderWorkMs * 1e3 / t, r.loaderAcquireMs * 1e3 / t, r.loaderSearchMs * 1e3 / t,
                    r.loaderReplenishMs * 1e3 / t, r.loaderAsleepMs * 1e3 / t);
    }
    {
        std::vector<double> inFlight;
        for (const iris::FieldStats& f : r.timed)
            if (f.decodesInFlight >= 0) inFlight.push_back(f.decodesInFlight);
        if (!inFlight.empty())
            std::printf("  tiles being read at once, from the move to the field's last: %.2f (median over fields)\n",
                        quartiles(inFlight).median);
    }
    // Where a field's time goes: each stage's events from the move to HR completion.
    const auto rows = stageTimeline(r.timed);
    std::printf("  tile stages, ms after the move (medians over %zu fields): %10s %10s %10s %8s\n", r.timed.size(),
                "first", "median", "last", "tiles");
    for (int s = 0; s < iris::kTileStageCount; ++s) {
        const StageRow& row = rows[size_t(s)];
        std::printf("    %-54s %10.3f %10.3f %10.3f %8.0f\n", iris::tileStageName(iris::TileStage(s)), row.first, row.median,
                    row.last, row.tiles);
    }
    if (!r.floor.note.empty()) std::printf("  decode floor: %s\n", r.floor.note.c_str());
    if (!r.notes.empty()) std::printf("  notes: %s\n", r.notes.c_str());
}

bool writePlots(const std::string& dir, const std::vector<SizeResult>& results, std::string& err) {
    namespace fs = std::filesystem;
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) {
        err = "cannot create " + dir + ": " + ec.message();
        return false;
    }
    std::ofstream fields(dir + "/fields.dat"), trace(dir + "/trace.dat");
    fields << "# condition hr_tefov_ms hr_tpt_us\n";

    for (const SizeResult& r : results) {
        for (size_t i = 0; i < r.condition.size(); ++i) {
            std::string label = std::to_string(r.w) + "x" + std::to_string(r.h) + " " + r.condition[i];
            if (!r.colorManaged) label += " (colour off)";
            fields << '"' << label << "\" " << r.condHr[i] << " " << r.condTpt[i] << "\n"; // a gnuplot string
        }
    }
    const SizeResult& first = results.front();
    trace << "# t_ms fps buffer_rate_gbps gpu_ms\n";
    for (const TracePoint& t : first.trace)
        trace << t.tMs << " " << (t.intervalMs > 0 ? 1000.0 / t.intervalMs : 0) << " " << t.rateGBps << " "
              << (t.gpuMs >= 0 ? t.gpuMs : 0) << "\n";
    // The typical field's stages, one bar each from its first to its last event (the median
    // event marked), in the order a tile passes them.
    std::ofstream stages(dir + "/stages.dat");
    stages << "# index stage first_ms median_ms last_ms tiles\n";
    const iris::FieldStats* typical = typicalField(first.timed);
    if (typical)
        for (int s = 0; s < iris::kTileStageCount; ++s) {
            const iris::StageTimes& t = typical->stages[size_t(s)];
            if (t.tiles)
                stages << s << " \"" << iris::tileStageName(iris::TileStage(s)) << "\" " << t.firstMs << " " << t.medianMs
                       << " " << t.lastMs << " " << t.tiles << "\n";
        }
    stages.close();
    fields.close();
    trace.close();
    std::ofstream gp(dir + "/plots.gp");
    gp << "set terminal pngcairo size 1200,700 font 'DejaVu Sans,11'\nset grid\nset logscale y\n"
       << "set style fill solid 0.4 border -1\nset style boxplot outliers pointtype 7\nset style data boxplot\n"
       << "set xtics rotate by -20\nunset key\nset xrange [0.3:*]\n"
       << "set output '" << dir << "/tefov.png'\nset title 'HR TeFOV per field (ms, log scale)'\nset ylabel 'ms'\n"
       << "plot '" << dir << "/fields.dat' using (1):2:(0.5):1\n"
       << "set output '" << dir << "/tpt.png'\nset title 'HR time per tile (µs, log scale)'\nset ylabel 'µs'\n"
       << "plot '" << dir << "/fields.dat' using (1):3:(0.5):1\n"
       << "unset logscale y\nunset title\nset autoscale x\nset xtics auto norotate\nset style data lines\nset output '" << dir << "/trace.png'\n"
       << "set multiplot layout 3,1 title 'Time trace, " << first.w << "x" << first.h << "'\nset xlabel 't (ms)'\n"
       << "set ylabel 'FPS'\nplot '" << dir << "/trace.dat' using 1:2 with lines\n"
       << "set ylabel 'GB/s'\nplot '" << dir << "/trace.dat' using 1:3 with lines\n"
       << "set ylabel 'GPU ms'\nplot '" << dir << "/trace.dat' using 1:4 with lines\nunset multiplot\n";
    gp.close();
    // Its own script, so that a failure of the plots above does not take it along.
    if (typical) {
        std::ofstream sg(dir + "/stages.gp");
        sg << "set terminal pngcairo noenhanced size 1200,500 font 'DejaVu Sans,11'\nset output '" << dir << "/stages.png'\n"
           << "set title 'Tile stages of a typical field, " << first.w << "x" << first.h << ": HR TeFOV "
           << shortNumber(typical->hrTeFovMs) << " ms, " << typical->tilesBuffered
           << " tiles buffered (bar: first to last event; dot: median)'\n"
           << "set xlabel 'ms after the move'\nset yrange [" << iris::kTileStageCount - 0.4 << ":-0.6]\n"
           << "set grid x\nunset key\nset xrange [0:*]\n"
           << "set arrow from " << typical->hrTeFovMs << ", graph 0 to " << typical->hrTeFovMs
           << ", graph 1 nohead dt 2 lc rgb 'red'\n"
           << "plot '" << dir << "/stages.dat' using 3:1:3:5:($1-0.3):($1+0.3):ytic(2) with boxxyerror fill solid 0.5, "
           << "'' using 4:1 with points pointtype 7 pointsize 1.2 lc rgb 'black'\n";
    }
    const std::string cmd = "gnuplot '" + dir + "/plots.gp' 2>&1";
    const std::string stagesCmd = "gnuplot '" + dir + "/stages.gp' 2>&1";
    const bool stagesOk = !typical || std::system(stagesCmd.c_str()) == 0;
    if (std::system(cmd.c_str()) != 0 || !stagesOk) {
        err = "gnuplot failed or is not installed (apt-get install gnuplot-nox); data left in " + dir;
        return false;
    }
    return true;
}

} // namespace

// The linked-views benchmark: for each window size, one view in one cell (the baseline), then
// o.views views in a grid of cells filling the window, the same glide.
int runLinkedViews(const Options& o) {
    const auto ms = [](double v) { return std::isnan(v) ? std::string("-") : shortNumber(v); };
    Json all = Json::array();
    for (auto [W, H] : o.sizes) {
        const int cols = int(std::ceil(std::sqrt(double(o.views))));
        const int rows = (o.views + cols - 1) / cols;
        const uint32_t cw = W / uint32_t(cols), ch = H / uint32_t(rows);
        iris::EngineConfig cfg;
        cfg.validation = o.validation;
        cfg.tuning = o.tuning;
        cfg.color.managed = o.colorManaged != "off";
        for (int n : {1, o.views}) {
            std::fprintf(stderr, "iris-bench: %d linked view%s of %ux%u, %d ticks…\n", n, n > 1 ? "s" : "", cw, ch,
                         o.ticks);
            const LinkedResult r = runLinked(o.slide, n, cw, ch, o.ticks, cfg);
            if (r.device.empty()) {
                std::fprintf(stderr, "iris-bench: %s\n", r.notes.c_str());
                return 1;
            }
            const double fpsMin = r.fps.empty() ? NAN : *std::min_element(r.fps.begin(), r.fps.end());
            std::printf("%d view%s of %ux%u on %s: view published -> submitted by every view: median %s ms, p95 %s "
                        "ms, max %s ms; frame GPU time median %s ms, p95 %s ms; ticks missed %d of %d; slowest view %s "
                        "frames/s%s%s\n",
                        n, n > 1 ? "s" : "", cw, ch, r.device.c_str(), ms(percentile(r.latencyMs, 0.5)).c_str(),
                        ms(percentile(r.latencyMs, 0.95)).c_str(), ms(percentile(r.latencyMs, 1.0)).c_str(),
                        ms(percentile(r.gpuMs, 0.5)).c_str(), ms(percentile(r.gpuMs, 0.95)).c_str(), r.missed, r.ticks,
                        ms(fpsMin).c_str(), r.notes.empty() ? "" : "; ", r.notes.c_str());
            all.push_back({{"views", n},
                           {"cell", {{"w", cw}, {"h", ch}}},
                           {"device", r.device},
                           {"ticks", r.ticks},
                           {"ticks_missed", r.missed},
                           {"latency_ms", {{"median", jsonNumber(percentile(r.latencyMs, 0.5))},
                                           {"p95", jsonNumber(percentile(r.latencyMs, 0.95))},
                                           {"max", jsonNumber(percentile(r.latencyMs, 1.0))}}},
                           {"gpu_ms", {{"median", jsonNumber(percentile(r.gpuMs, 0.5))},
                                       {"p95", jsonNumber(percentile(r.gpuMs, 0.95))}}},
                           {"frames_per_s_slowest", jsonNumber(fpsMin)},
                           {"notes", r.notes}});
            if (o.views == 1) break;
        }
    }
    if (!o.json.empty()) {
        std::ofstream f(o.json);
        f << Json{{"linked_views", all}}.dump(2, ' ', false, Json::error_handler_t::replace) << "\n";
        f.close();
        if (!f) {
            std::fprintf(stderr, "iris-bench: cannot write %s\n", o.json.c_str());
            return 1;
        }
    }
    return 0;
}

int main(int argc, char** argv) {
    Options o;
    std::vector<std::string> sizes;
    std::string mags = "40,20,10,5";
    CLI::App app{"Benchmark the engine on a slide: the time to an entirely new field of view,\n"
                 "beside baselines from the same run.\n"
                 "\n"
                 "A headless engine walks, at each magnification, a serpentine path of whole\n"
                 "fields that never revisits one, and reports per field the time until every LR\n"
                 "and HR tile is drawable (TeFOV), the time per tile, the buffer rate and the\n"
                 "frame time, then the GPU time of settled frames. Over the same fields it times\n"
                 "OpenSlide (one thread and all cores) and the JPEG decode floor. It prints a\n"
                 "table for each window size; docs/BENCHMARKS.md describes the measures and the\n"
                 "JSON.\n",
                 "iris-bench"};
    iris::tools::setUpApp(app, "iris-bench");
    app.add_option("SLIDE", o.slide,
                   "The slide to benchmark: a file, a DICOM folder, or a\n"
                   "DICOMweb series URL (then --baseline names a file)")
        ->required();
    app.add_option("--size", sizes,
                   "Window size, whole numbers from 64 to 16384; repeat\n"
                   "for several (2774x1750 is the paper's window)")
        ->option_text("WxH")
        ->allow_extra_args(false) // one size per --size: `--size 640x480 SLIDE` keeps its slide
        ->check(CLI::Validator(
            [](std::string& v) {
                return parseSize(v) ? std::string() : "'" + v + "' is not WxH with whole numbers from 64 to 16384";
            },
            ""))
        ->default_str("2774x1750 and 1920x1080");
    app.add_option("--moves", o.moves, "Moves to a new field at each magnification")
        ->option_text("N")
        ->check(iris::tools::wholeNumber(1, std::numeric_limits<int>::max()));
    app.add_option("--idle-moves", o.idleMoves,
                   "Each move MS ms after the field before settled, as a reader's\n"
                   "moves come (default: as soon as it is complete)")
        ->option_text("MS")
        ->default_str("")
        ->check(iris::tools::wholeNumber(0, 60000));
    app.add_option("--loaders", o.loaders,
                   "Decoding threads (EngineConfig::loaderThreads; default: one a\n"
                   "hardware thread, two fewer above 4)")
        ->option_text("N")
        ->default_str("")
        ->check(iris::tools::wholeNumber(1, 256));
    app.add_option("--magnifications", mags,
                   "Comma-separated magnifications (from the objective\n"
                   "power, else from mpp; without either, read as\n"
                   "downsamples)")
        ->option_text("LIST")
        ->check(CLI::Validator(
            [](std::string& v) {
                return parseList(v).empty() ? "'" + v + "' is not a list of positive numbers such as 40,20,10,5"
                                            : std::string();
            },
            ""));
    app.add_option("--source", o.source, "Reader of SLIDE: auto, openslide or iris")
        ->option_text("R")
        ->check(CLI::IsMember({"auto", "openslide", "iris"}).description(""));
    app.add_option("--baseline", o.baseline,
                   "The slide the CPU baselines read; for an .iris file,\n"
                   "the slide it was encoded from")
        ->option_text("SLIDE")
        ->default_str("SLIDE");
    app.add_option("--frame-cache", o.frameCache,
                   "For a DICOMweb series: keep its frames in DIR, and\n"
                   "read those kept there by an earlier run (a series\n"
                   "opened again) instead of asking the server")
        ->option_text("DIR");
    app.add_option("--opens", o.opens,
                   "Opening trials per size: open() to the first complete\n"
                   "frame, into a fresh engine and as a switch from a\n"
                   "settled slide (0: none)")
        ->option_text("N")
        ->check(iris::tools::wholeNumber(0, 1000));
    app.add_option("--switch-to", o.switchTo,
                   "The slide opened in turn with SLIDE when timing\n"
                   "switches")
        ->option_text("SLIDE")
        ->default_str("SLIDE");
    app.add_option("--json", o.json, "Write the results as JSON to FILE")->option_text("FILE");
    app.add_option("--plots", o.plots, "Write plot data and a gnuplot script to DIR, and run\ngnuplot")
        ->option_text("DIR");
    app.add_option("--seed", o.seed, "Seed of the walks' random starting fields")
        ->option_text("N")
        ->check(iris::tools::wholeNumber<uint64_t>(0, std::numeric_limits<uint64_t>::max()));
    app.add_flag("--validation", o.validation, "Run with the Vulkan validation layer");
    app.add_option("--views", o.views,
                   "Linked views instead of the walk: the window split\n"
                   "into N cells, an engine each, gliding together (a pan\n"
                   "and a turn every 60 Hz tick); one view is the baseline")
        ->option_text("N")
        ->check(iris::tools::wholeNumber(1, 16));
    app.add_option("--ticks", o.ticks, "Display ticks of the linked views' glide")
        ->option_text("N")
        ->check(iris::tools::wholeNumber(10, 100000));
    std::string annotationCounts;
    app.add_option("--annotations", annotationCounts,
                   "The annotation layer instead of the walk: N generated\n"
                   "detections per count in the comma-separated list\n"
                   "(e.g. 10000,100000,1000000), frames with them shown\n"
                   "and hidden")
        ->option_text("N[,N...]")
        ->check(CLI::Validator(
            [](std::string& v) {
                for (double d : parseList(v))
                    if (d < 1 || d > 2e7 || d != std::floor(d)) return "'" + v + "' is not a list of counts from 1 to 2e7";
                return parseList(v).empty() ? "'" + v + "' is not a list of counts" : std::string();
            },
            ""));
    bool heatmap = false;
    app.add_flag("--heatmap", heatmap,
                 "The raster-layer pass instead of the walk: a synthetic\n"
                 "heat map of 1/224 and one of 1/4 of the slide's side,\n"
                 "frames with 0, 1 and 4 layers at fit and a mid zoom");
    app.add_option("--color-managed", o.colorManaged,
                   "Colour management (docs/COLOR.md); both: each size\n"
                   "is run off, then on, in this run (its cost)")
        ->option_text("on|off|both")
        ->check(CLI::IsMember({"on", "off", "both"}).description(""));
    app.footer(std::string("Exit status: 0 done; 1 the engine, slide or an output failed; 2 bad arguments.") +
               iris::tools::kTuningEnvironmentHelp);
    if (const int status = iris::tools::parseArguments(app, argc, argv); status >= 0) return status;
    if (auto tuning = iris::tuningFromEnvironment(); tuning.ok()) {
        o.tuning = *tuning;
    } else {
        return iris::tools::usageError(app, tuning.error().message());
    }
    for (const std::string& s : sizes) o.sizes.push_back(*parseSize(s)); // each checked above
    if (o.sizes.empty()) o.sizes = {{2774, 1750}, {1920, 1080}};
    o.mags = parseList(mags);
    if (o.switchTo.empty()) o.switchTo = o.slide;
    if (!annotationCounts.empty()) {
        AnnotationBenchOptions a;
        a.slide = o.slide;
        a.sizes = sizes.empty() ? std::vector<std::pair<uint32_t, uint32_t>>{{1920, 1080}} : o.sizes;
        for (double d : parseList(annotationCounts)) a.counts.push_back(size_t(d));
        a.validation = o.validation;
        a.tuning = o.tuning;
        a.seed = o.seed;
        a.json = o.json;
        return runAnnotationBench(a);
    }
    if (heatmap) {
        LayerBenchOptions l;
        l.slide = o.slide;
        l.sizes = sizes.empty() ? std::vector<std::pair<uint32_t, uint32_t>>{{1920, 1080}} : o.sizes;
        l.validation = o.validation;
        l.tuning = o.tuning;
        l.json = o.json;
        return runLayerBench(l);
    }
    if (o.views > 0) {
        if (sizes.empty()) o.sizes = {{1920, 1080}};
        return runLinkedViews(o);
    }

    std::vector<SizeResult> results;
    std::vector<bool> colorModes;
    if (o.colorManaged != "on") colorModes.push_back(false);
    if (o.colorManaged != "off") colorModes.push_back(true);
    for (auto [w, h] : o.sizes) for (bool colorManaged : colorModes) {
        results.push_back(runSize(o, w, h, colorManaged));
        if (results.back().device.empty() || results.back().movesDone == 0) {
            std::fprintf(stderr, "iris-bench: %s\n", results.back().notes.empty() ? "no move could be run" : results.back().notes.c_str());
            return 1;
        }
        printTable(results.back());
    }
    if (!o.json.empty()) {
        // The primary size's object, plus the same object for every other size.
        Json j = resultJson(o, results[0]);
        if (results.size() > 1) {
            j["other_sizes"] = Json::array();
            for (size_t i = 1; i < results.size(); ++i) j["other_sizes"].push_back(resultJson(o, results[i]));
        }
        std::ofstream f(o.json);
        // Replace, don't throw on, bytes that are not UTF-8 (a device name, a file name).
        f << j.dump(2, ' ', false, Json::error_handler_t::replace) << "\n";
        f.close();
        if (!f) {
            std::fprintf(stderr, "iris-bench: cannot write %s\n", o.json.c_str());
            return 1;
        }
    }
    if (!o.plots.empty()) {
        std::string err;
        if (!writePlots(o.plots, results, err)) {
            std::fprintf(stderr, "iris-bench: %s\n", err.c_str());
            return 1;
        }
    }
    return 0;
}
