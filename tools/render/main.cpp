// iris-render: renders one frame of a slide headless, once every visible tile is resident,
// and writes it as PNG.
//
//   iris-render SLIDE --out FILE.png [--size WxH] [--center X,Y] [--downsample D]
//               [--rotate DEG] [--flip h|v|hv] [--enhance on|off] [--color-managed on|off] [--display-profile FILE.icc]
//               [--intent perceptual|relative] [--annotations FILE]... [--heatmap FILE[:OPACITY[:COLORMAP]]]...
//               [--label-map FILE[:OPACITY]]... [--timeout S] [--validation] [--verbose]
//
// --heatmap and --label-map draw raster layers (a scalar map through a colour map, class ids
// through the default class colours) over the slide and under the annotations, each spanning
// the slide, in the order given, the last on top (layer_specs.h reads the specs).
//
// --annotations draws a QuPath GeoJSON or ASAP XML file's objects over the slide (the format
// is chosen by content; several files are drawn together), as the viewer does.
//
// --center is in level-0 pixels and --downsample is level-0 pixels per output pixel, so the
// output's top-left pixel covers level-0 (X − W/2·D, Y − H/2·D). Without them the whole slide
// is fitted into the output. --rotate turns the slide clockwise about the centre and --flip
// mirrors it first (h: left-right, v: top-bottom), as the viewer does (iris::View).
#include <chrono>
#include <fstream>
#include <iterator>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>


#include "iris/annotations.h"
#include "iris/engine.h"
#include "iris/environment.h"
#include "layer_specs.h"
#include "tool_cli.h"
#include "png_write.h"

namespace {

bool parseNumber(const std::string& s, double& out) {
    char* end = nullptr;
    out = std::strtod(s.c_str(), &end);
    return end != s.c_str() && *end == '\0' && std::isfinite(out);
}

// "AxB" or "A,B": two finite numbers around the separator.
bool parsePair(const std::string& s, char sep, double& a, double& b) {
    const size_t p = s.find(sep);
    return p != std::string::npos && parseNumber(s.substr(0, p), a) && parseNumber(s.substr(p + 1), b);
}

bool parseSize(const std::string& s, double& w, double& h) {
    const auto side = [](double v) { return v >= 1 && v <= 16384 && v == std::floor(v); };
    return parsePair(s, 'x', w, h) && side(w) && side(h);
}

} // namespace

int main(int argc, char** argv) {
    std::string slide, out, size = "1920x1080", center, enhance = "on", colorManaged = "on", displayProfile,
        intent = "perceptual";
    std::string flip;
    double ds = 0, timeout = 60, rotate = 0;
    bool validation = false, verbose = false;
    CLI::App app{"Render one frame of a slide headless and write it as PNG.\n"
                 "\n"
                 "The frame is written once every visible tile is resident. --center is in\n"
                 "level-0 pixels and --downsample is level-0 pixels per output pixel, so the\n"
                 "output's top-left pixel covers level-0 (X - W/2*D, Y - H/2*D). Without them the\n"
                 "whole slide is fitted into the output. --rotate turns the slide clockwise about\n"
                 "the centre; --flip mirrors it before the turn.\n",
                 "iris-render"};
    iris::tools::setUpApp(app, "iris-render");
    app.add_option("SLIDE", slide, "The slide: any file Iris View opens, or\nsynthetic:WIDTHxHEIGHT")->required();
    app.add_option("--out", out, "Output PNG file")->option_text("FILE.png")->required();
    app.add_option("--size", size, "Output size in pixels, whole numbers from 1 to 16384")
        ->option_text("WxH")
        ->check(iris::tools::textCheck([](const std::string& v) { double w = 0, h = 0; return parseSize(v, w, h); },
                          "WxH with whole numbers from 1 to 16384"));
    app.add_option("--center", center, "View centre in level-0 pixels")
        ->option_text("X,Y")
        ->check(iris::tools::textCheck([](const std::string& v) { double x = 0, y = 0; return parsePair(v, ',', x, y); },
                          "X,Y in level-0 pixels"))
        ->default_str("the slide's centre");
    app.add_option("--downsample", ds, "Level-0 pixels per output pixel")
        ->option_text("D")
        ->check(iris::tools::textCheck([](const std::string& v) { double d = 0; return parseNumber(v, d) && d > 0; },
                          "a positive number"))
        ->default_str("the whole slide fitted");
    app.add_option("--rotate", rotate, "Turn the slide clockwise by DEG degrees about the\nview centre")
        ->option_text("DEG")
        ->check(iris::tools::textCheck([](const std::string& v) { double d = 0; return parseNumber(v, d); },
                          "a finite number of degrees"))
        ->default_str("0");
    app.add_option("--flip", flip, "Mirror the slide before the turn: h left-right,\nv top-bottom, hv both")
        ->option_text("h|v|hv")
        ->check(CLI::IsMember({"h", "v", "hv", "vh"}).description(""));
    app.add_option("--enhance", enhance,
                   "Reduction-enhancement of the mip levels (a sharpened\n"
                   "area average); off gives the exact area average")
        ->option_text("on|off")
        ->check(CLI::IsMember({"on", "off"}).description(""));
    app.add_option("--color-managed", colorManaged,
                   "Apply the slide's embedded ICC profile, converting\n"
                   "to the display profile (docs/COLOR.md); off writes\n"
                   "the slide's stored bytes")
        ->option_text("on|off")
        ->check(CLI::IsMember({"on", "off"}).description(""));
    app.add_option("--display-profile", displayProfile, "ICC profile of the output's colour space")
        ->option_text("FILE.icc")
        ->default_str("sRGB")
        ->check(CLI::ExistingFile.description(""));
    app.add_option("--intent", intent, "Rendering intent of the colour transform\n(relative: relative colorimetric with\nblack-point compensation)")
        ->option_text("perceptual|relative")
        ->check(CLI::IsMember({"perceptual", "relative"}).description(""));
    std::vector<std::string> annotationFiles;
    app.add_option("--annotations", annotationFiles,
                   "Draw the annotations of a QuPath GeoJSON or ASAP XML\n"
                   "file over the slide (repeatable)")
        ->option_text("FILE")
        ->check(CLI::ExistingFile.description(""));
    std::vector<std::string> heatmapSpecs, labelMapSpecs;
    const auto specCheck = [](bool labels) {
        return CLI::Validator(
            [labels](std::string& text) {
                const iris::Expected<iris::render::LayerSpec> spec = iris::render::parseLayerSpec(text, labels);
                return spec ? std::string() : spec.error().message();
            },
            "");
    };
    CLI::Option* heatmapOption =
        app.add_option("--heatmap", heatmapSpecs,
                       "Draw a scalar map (PNG, TIFF or NumPy .npy: a heat\n"
                       "map, a probability) over the slide, spanning it, at\n"
                       "OPACITY 0..1 (default 0.5) through COLORMAP: viridis\n"
                       "(default), magma, jet, gray or a 256-entry LUT file\n"
                       "(repeatable; layers stack in the order given)")
            ->option_text("FILE[:OPACITY[:COLORMAP]]")
            ->check(specCheck(false));
    CLI::Option* labelMapOption =
        app.add_option("--label-map", labelMapSpecs,
                       "Draw a label map (class ids in a single-channel\n"
                       "integer PNG, TIFF or .npy) over the slide in the\n"
                       "default class colours, class 0 hidden (repeatable)")
            ->option_text("FILE[:OPACITY]")
            ->check(specCheck(true));
    app.add_option("--timeout", timeout, "Seconds to wait for the complete frame")
        ->option_text("S")
        ->check(iris::tools::textCheck([](const std::string& v) { double t = 0; return parseNumber(v, t) && t > 0; },
                          "a positive number of seconds"));
    app.add_flag("--validation", validation, "Run with the Vulkan validation layer; fail if it\nreports anything");
    app.add_flag("-v,--verbose", verbose, "Log every engine message and the frame's timing\nto stderr");
    app.footer("Exit status: 0 written; 1 the device, the slide or the output failed, the frame\n"
               "was not complete in time, or validation reported messages; 2 bad arguments." +
               std::string(iris::tools::kTuningEnvironmentHelp));
    if (const int status = iris::tools::parseArguments(app, argc, argv); status >= 0) return status;
    auto tuning = iris::tuningFromEnvironment();
    if (!tuning) return iris::tools::usageError(app, tuning.error().message());
    // The maps are read before the device starts, so that a bad one costs nothing; in the
    // order the options were given (parse_order lists each option once per value).
    std::vector<iris::render::LoadedLayer> layers;
    {
        size_t nextHeatmap = 0, nextLabelMap = 0;
        for (const CLI::Option* option : app.parse_order()) {
            const bool labels = option == labelMapOption;
            if (option != heatmapOption && !labels) continue;
            const std::string& text = labels ? labelMapSpecs[nextLabelMap++] : heatmapSpecs[nextHeatmap++];
            iris::Expected<iris::render::LayerSpec> spec = iris::render::parseLayerSpec(text, labels); // checked above
            iris::Expected<iris::render::LoadedLayer> layer =
                spec ? iris::render::loadLayer(*spec) : iris::Expected<iris::render::LoadedLayer>(spec.error());
            if (!layer) {
                std::fprintf(stderr, "iris-render: %s\n", layer.error().message().c_str());
                return 1;
            }
            layers.push_back(std::move(layer).value());
        }
    }
    double w = 0, h = 0, cx = 0, cy = 0;
    parseSize(size, w, h); // both checked above
    const bool haveCenter = !center.empty() && parsePair(center, ',', cx, cy);

    iris::EngineConfig cfg;
    cfg.validation = validation;
    cfg.tuning = *tuning;
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
    e.setEnhance(enhance == "on");
    iris::ColorSettings color;
    color.managed = colorManaged == "on";
    color.intent = intent == "relative" ? iris::RenderingIntent::RelativeColorimetric : iris::RenderingIntent::Perceptual;
    if (!displayProfile.empty()) {
        std::ifstream in(displayProfile, std::ios::binary);
        color.displayProfile.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
        if (!in.good() && !in.eof()) {
            std::fprintf(stderr, "iris-render: cannot read the display profile %s\n", displayProfile.c_str());
            return 1;
        }
    }
    e.setColorSettings(color);
    if (iris::Result r = e.bindOffscreen(uint32_t(w), uint32_t(h)); !r.ok()) {
        std::fprintf(stderr, "iris-render: %s\n", r.message().c_str());
        return 1;
    }
    if (iris::Result r = e.open(slide); !r.ok()) {
        std::fprintf(stderr, "iris-render: %s\n", r.message().c_str());
        return 1;
    }
    if (!annotationFiles.empty()) {
        auto store = std::make_shared<iris::AnnotationStore>();
        for (size_t i = 0; i < annotationFiles.size(); ++i) {
            iris::AnnotationLoader loader(*store, annotationFiles[i], {},
                                          i == 0 ? iris::AnnotationLoader::Mode::Replace
                                                 : iris::AnnotationLoader::Mode::Append);
            if (iris::Result r = loader.wait(); !r.ok()) {
                std::fprintf(stderr, "iris-render: %s: %s\n", annotationFiles[i].c_str(), r.message().c_str());
                return 1;
            }
        }
        if (verbose)
            std::fprintf(stderr, "iris-render: %zu annotation objects\n", store->snapshot()->size());
        e.setAnnotations(store);
    }
    for (const iris::render::LoadedLayer& layer : layers) {
        if (iris::Expected<uint64_t> id = e.addLayer(layer.map, layer.style); !id) {
            std::fprintf(stderr, "iris-render: %s\n", id.error().message().c_str());
            return 1;
        }
        if (verbose)
            std::fprintf(stderr, "iris-render: layer %s: %s %dx%d, %zu levels, values %g..%g\n",
                         layer.map->title.c_str(), iris::rasterKindName(layer.map->kind), layer.map->width(),
                         layer.map->height(), layer.map->levels.size(), layer.map->minValue, layer.map->maxValue);
    }
    if (verbose) {
        const iris::ColorStatus cs = e.colorStatus();
        std::fprintf(stderr, "iris-render: colour: %s (slide profile: %s; display: %s)\n",
                     cs.applied ? "the slide's profile is applied" : "no transform",
                     cs.slideProfile.empty() ? "none" : cs.slideProfile.c_str(), cs.displayProfile.c_str());
    }
    {
        // Fitted as turned (the turned slide's bounding box fills the output).
        iris::View turned = e.view();
        turned.rotation = rotate;
        turned.flipH = flip.find('h') != std::string::npos;
        turned.flipV = flip.find('v') != std::string::npos;
        e.setView(turned);
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
        std::fprintf(stderr,
                     "iris-render: %s on %s: complete frame in %.1f ms, view centre (%.1f, %.1f) downsample %.4g "
                     "rotation %.4g%s%s\n",
                     out.c_str(), e.device().name.c_str(), ms, frame->view.centerX, frame->view.centerY,
                     frame->view.downsample, frame->view.rotation, frame->view.flipH ? " flipped-h" : "",
                     frame->view.flipV ? " flipped-v" : "");
    }
    if (validation && e.validationMessageCount() > 0) {
        std::fprintf(stderr, "iris-render: %llu Vulkan validation messages\n",
                     (unsigned long long)e.validationMessageCount());
        return 1;
    }
    return 0;
}
