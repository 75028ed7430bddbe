// iris-sample: writes the built-in sample slide (a pyramidal tiled-JPEG TIFF that OpenSlide
// opens as "generic-tiff").
//
//   iris-sample [--out FILE] [--width W --height H] [--seed N] [--quality Q] [--threads N]

#include "sample_slide.h"

#include <unistd.h>

#include <charconv>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <string_view>

namespace {

constexpr const char* kUsage =
    "usage: iris-sample [--out FILE] [--width W --height H] [--seed N] [--quality Q] [--threads N]\n"
    "\n"
    "Writes a procedurally generated H&E-like whole-slide image as a pyramidal tiled-JPEG\n"
    "TIFF (0.25 um/pixel, OpenSlide vendor generic-tiff). The same options always give a\n"
    "byte-identical file.\n"
    "\n"
    "  --out FILE     output path (default: iris-sample.tiff)\n"
    "  --width W      level-0 width in pixels, 1..1000000 (default: 50000)\n"
    "  --height H     level-0 height in pixels, 1..1000000 (default: 40000)\n"
    "  --seed N       content seed, unsigned 64-bit (default: 1)\n"
    "  --quality Q    JPEG quality 1..100 (default: 90)\n"
    "  --threads N    worker threads (default: all cores)\n"
    "  -h, --help     show this help\n";

template <typename T>
bool parseNumber(std::string_view text, T& out) {
  if (text.empty()) return false;
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, out);
  return ec == std::errc() && ptr == end;
}

int usageError(const std::string& message) {
  std::fprintf(stderr, "iris-sample: error: %s\n(run 'iris-sample --help' for usage)\n",
               message.c_str());
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  iris::sample::Options options;
  for (int i = 1; i < argc; ++i) {
    std::string_view arg = argv[i];
    if (arg == "-h" || arg == "--help") {
      std::fputs(kUsage, stdout);
      return 0;
    }
    std::string_view name = arg, value;
    bool haveValue = false;
    if (const auto eq = arg.find('='); arg.starts_with("--") && eq != std::string_view::npos) {
      name = arg.substr(0, eq);
      value = arg.substr(eq + 1);
      haveValue = true;
    }
    const bool known = name == "--out" || name == "--width" || name == "--height" ||
                       name == "--seed" || name == "--quality" || name == "--threads";
    if (!known) return usageError("unknown argument '" + std::string(arg) + "'");
    if (!haveValue) {
      if (i + 1 >= argc) return usageError("missing value for " + std::string(name));
      value = argv[++i];
    }
    const std::string shown = "'" + std::string(value) + "' for " + std::string(name);
    if (name == "--out") {
      if (value.empty()) return usageError("empty path for --out");
      options.outPath = std::string(value);
    } else if (name == "--width") {
      if (!parseNumber(value, options.width)) return usageError("invalid width " + shown);
    } else if (name == "--height") {
      if (!parseNumber(value, options.height)) return usageError("invalid height " + shown);
    } else if (name == "--seed") {
      if (!parseNumber(value, options.seed)) return usageError("invalid seed " + shown);
    } else if (name == "--quality") {
      if (!parseNumber(value, options.quality)) return usageError("invalid quality " + shown);
    } else if (name == "--threads") {
      if (!parseNumber(value, options.threads) || options.threads < 1)
        return usageError("invalid thread count " + shown);
    }
  }
  if (auto check = iris::sample::validateOptions(options); !check.ok)
    return usageError(check.message);

  const bool tty = isatty(STDERR_FILENO) != 0;
  const auto start = std::chrono::steady_clock::now();
  int lastPercent = -1;
  auto progress = [&](double fraction) {
    if (!tty) return;
    const int percent = static_cast<int>(fraction * 100.0);
    if (percent == lastPercent) return;
    lastPercent = percent;
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::fprintf(stderr, "\riris-sample: %3d%%  %.1f s", percent, elapsed);
    std::fflush(stderr);
  };

  const iris::sample::Result result = iris::sample::writeSampleSlide(options, progress);
  if (tty && lastPercent >= 0) std::fputc('\n', stderr);
  if (!result.ok) {
    std::fprintf(stderr, "iris-sample: error: %s\n", result.message.c_str());
    return 1;
  }
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("iris-sample: %s in %.2f s\n", result.message.c_str(), elapsed);
  return 0;
}
