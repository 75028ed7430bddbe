// iris-render: renders one frame of a slide headless, once every visible tile is resident,
// and writes it as PNG.
//
//   iris-render SLIDE --out FILE.png [--size WxH] [--center X,Y] [--downsample D]
//               [--enhance on|off] [--timeout S] [--validation] [--verbose]
//
// --center is in level-0 pixels and --downsample is level-0 pixels per output pixel, so the
// output's top-left pixel covers level-0 (X − W/2·D, Y − H/2·D). Without them the whole slide
// is fitted into the output.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "iris/engine.h"
#include "png_write.h"

namespace {

int usage(const char* msg) {
    if (msg) std::fprintf(stderr, "iris-render: %s\n", msg);
    std::fprintf(stderr,
                 "usage: iris-render SLIDE --out FILE.png [--size WxH] [--center X,Y] [--downsample D]\n"
                 "                   [--enhance on|off] [--timeout S] [--validation] [--verbose]\n");
    return 2;
}

bool parseNumber(const char* s, double& out) {
    char* end = nullptr;
    out = std::strtod(s, &end);
    return end != s && *end == '\0' && std::isfinite(out);
}

bool parsePair(const char* s, char sep, double& a, double& b) {
    const char* p = std::strchr(s, sep);
    if (!p) return false;
    const std::string first(s, p);
    return parseNumber(first.c_str(), a) && parseNumber(p + 1, b);
}

} // namespace

int main(int argc, char** argv) {
    std::string slide, out;
    double w = 1920, h = 1080, cx = 0, cy = 0, ds = 0, timeout = 60;
    bool haveCenter = false, validation = false, verbose = false, enhance = true;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() -> const char* { return i + 1 < argc ? argv[++i] : nullptr; };
        if (a == "--out") {
            const char* v = next();
            if (!v) return usage("--out needs a file");
            out = v;
        } else if (a == "--size") {
            const char* v = next();
            if (!v || !parsePair(v, 'x', w, h) || w < 1 || h < 1 || w > 16384 || h > 16384 || w != std::floor(w) ||
                h != std::floor(h))
                return usage("--size needs WxH, whole numbers from 1 to 16384");
        } else if (a == "--center") {
            const char* v = next();
            if (!v || !parsePair(v, ',', cx, cy)) return usage("--center needs X,Y in level-0 pixels");
            haveCenter = true;
        } else if (a == "--downsample") {
            const char* v = next();
            if (!v || !parseNumber(v, ds) || ds <= 0) return usage("--downsample needs a positive number");
        } else if (a == "--enhance") {
            const char* v = next();
            if (!v || (std::strcmp(v, "on") && std::strcmp(v, "off"))) return usage("--enhance needs on or off");
            enhance = std::strcmp(v, "on") == 0;
        } else if (a == "--timeout") {
            const char* v = next();
            if (!v || !parseNumber(v, timeout) || timeout <= 0) return usage("--timeout needs seconds");
        } else if (a == "--validation") {
            validation = true;
        } else if (a == "--verbose" || a == "-v") {
            verbose = true;
        } else if (a == "--help" || a == "-h") {
            usage(nullptr);
            return 0;
        } else if (!a.empty() && a[0] == '-') {
            return usage(("unknown option " + a).c_str());
        } else if (slide.empty()) {
            slide = a;
        } else {
            return usage("only one slide can be rendered at a time");
        }
    }
    if (slide.empty()) return usage("no slide given");
    if (out.empty()) return usage("no output given (--out FILE.png)");

    iris::EngineConfig cfg;
    cfg.validation = validation;
    cfg.log = [verbose](iris::LogLevel lvl, std::string_view msg) {
        if (verbose || lvl >= iris::LogLevel::Warning)
            std::fprintf(stderr, "iris-render: %.*s\n", int(msg.size()), msg.data());
    };
    auto engine = iris::Engine::create(cfg);
    if (!engine) {
        std::fprintf(stderr, "iris-render: %s\n", engine.error().message().c_str());
        return 1;
    }
    iris::Engine& e = **engine;
    e.setEnhance(enhance);
    if (iris::Result r = e.bindOffscreen(uint32_t(w), uint32_t(h)); !r.ok()) {
        std::fprintf(stderr, "iris-render: %s\n", r.message().c_str());
        return 1;
    }
    if (iris::Result r = e.open(slide); !r.ok()) {
        std::fprintf(stderr, "iris-render: %s\n", r.message().c_str());
        return 1;
    }
    iris::View v = e.fitView();
    if (haveCenter) {
        v.centerX = cx;
        v.centerY = cy;
    }
    if (ds > 0) v.downsample = ds;
    e.setView(v);
    const auto t0 = std::chrono::steady_clock::now();
    if (iris::Result r = e.waitForFrame(std::chrono::milliseconds(int64_t(timeout * 1000))); !r.ok()) {
        std::fprintf(stderr, "iris-render: %s\n", r.message().c_str());
        return 1;
    }
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    if (iris::Result r = e.error(); !r.ok()) {
        std::fprintf(stderr, "iris-render: %s\n", r.message().c_str());
        return 1;
    }
    auto frame = e.readFrame();
    if (!frame) {
        std::fprintf(stderr, "iris-render: %s\n", frame.error().message().c_str());
        return 1;
    }
    if (std::string err = writePng(out, frame->image); !err.empty()) {
        std::fprintf(stderr, "iris-render: %s\n", err.c_str());
        return 1;
    }
    if (verbose) {
        std::fprintf(stderr, "iris-render: %s on %s: complete frame in %.1f ms, view centre (%.1f, %.1f) downsample %.4g\n",
                     out.c_str(), e.device().name.c_str(), ms, frame->view.centerX, frame->view.centerY, frame->view.downsample);
    }
    if (validation && e.validationMessageCount() > 0) {
        std::fprintf(stderr, "iris-render: %llu Vulkan validation messages\n",
                     (unsigned long long)e.validationMessageCount());
        return 1;
    }
    return 0;
}
