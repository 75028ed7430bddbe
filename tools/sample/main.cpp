// iris-sample: writes the built-in sample slide (a pyramidal tiled-JPEG TIFF that OpenSlide
// opens as "generic-tiff").
//
//   iris-sample [--out FILE] [--width W --height H] [--seed N] [--quality Q] [--threads N]
//
// Exit status: 0 written, 1 the slide could not be written, 2 bad arguments.

#include "sample_slide.h"
#include "tool_cli.h"

#include <unistd.h>

#include <charconv>
#include <chrono>
#include <fstream>
#include <iterator>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace {} // namespace

int main(int argc, char** argv) {
    iris::sample::Options options;
    CLI::App app{"Write a synthetic H&E-like whole-slide image as a pyramidal tiled-JPEG TIFF.\n"
                 "\n"
                 "The slide is 0.25 um/pixel (a 40x scan); OpenSlide opens it as vendor\n"
                 "generic-tiff. The same options always give a byte-identical file, whatever the\n"
                 "thread count.\n",
                 "iris-sample"};
    iris::tools::setUpApp(app, "iris-sample");
    app.add_option("--out", options.outPath, "Output file")->option_text("FILE")->check([](const std::string& v) {
        return v.empty() ? std::string("empty path") : std::string();
    });
    const auto dimension = iris::tools::wholeNumber<int64_t>(1, iris::sample::kMaxDimension);
    app.add_option("--width", options.width, "Level-0 width in pixels, 1 to 1000000")
        ->option_text("W")
        ->check(dimension);
    app.add_option("--height", options.height, "Level-0 height in pixels, 1 to 1000000")
        ->option_text("H")
        ->check(dimension);
    app.add_option("--seed", options.seed, "Content seed, an unsigned 64-bit number")
        ->option_text("N")
        ->check(iris::tools::wholeNumber<uint64_t>(0));
    app.add_option("--quality", options.quality, "JPEG quality, 1 to 100")
        ->option_text("Q")
        ->check(iris::tools::wholeNumber(1, 100));
    app.add_option("--threads", options.threads, "Worker threads")
        ->option_text("N")
        ->check(iris::tools::wholeNumber(1))
        ->default_str("all cores");
    std::string iccPath;
    app.add_option("--icc-profile", iccPath, "Embed this ICC profile (TIFF tag 34675), as scanners\ndo")
        ->option_text("FILE.icc")
        ->check(CLI::ExistingFile.description(""));
    app.footer("Exit status: 0 written, 1 the slide could not be written, 2 bad arguments.");
    if (const int status = iris::tools::parseArguments(app, argc, argv); status >= 0) return status;
    if (auto check = iris::sample::validateOptions(options); !check.ok)
        return iris::tools::usageError(app, check.message);
    if (!iccPath.empty()) {
        std::ifstream in(iccPath, std::ios::binary);
        options.iccProfile.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
        if (options.iccProfile.empty()) return iris::tools::usageError(app, "cannot read the ICC profile " + iccPath);
    }

    const bool tty = isatty(STDERR_FILENO) != 0;
    const auto start = std::chrono::steady_clock::now();
    int lastPercent = -1;
    auto progress = [&](double fraction) {
        if (!tty) return;
        const int percent = static_cast<int>(fraction * 100.0);
        if (percent == lastPercent) return;
        lastPercent = percent;
        const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::fprintf(stderr, "\riris-sample: %3d%%  %.1f s", percent, elapsed);
        std::fflush(stderr);
    };

    const iris::sample::Result result = iris::sample::writeSampleSlide(options, progress);
    if (tty && lastPercent >= 0) std::fputc('\n', stderr);
    if (!result.ok) {
        std::fprintf(stderr, "iris-sample: error: %s\n", result.message.c_str());
        return 1;
    }
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("iris-sample: %s in %.2f s\n", result.message.c_str(), elapsed);
    return 0;
}
