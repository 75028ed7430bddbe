// iris-encode: converts a slide into an .iris file (Iris File Extension 1.0).
//
//   iris-encode SOURCE [-o OUT.iris] [--quality Q] [--subsampling 444|422|420]
//               [--threads N] [--source auto|openslide|iris] [--quiet]
//
// SOURCE is any slide the engine opens (OpenSlide vendors, TIFF, .iris, synthetic:WxH). The
// default output is SOURCE's file name with the extension .iris, in the current folder.
// Progress goes to stderr: a bar when stderr is a terminal, otherwise a line every few
// seconds. SIGINT/SIGTERM stop the encode cleanly (no output, no partial file) with exit
// status 130; a second signal kills at once.
//
// Exit status: 0 written, 1 the source or the output failed, 2 bad arguments, 130 cancelled.
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <unistd.h>

#include "iris/encoder.h"
#include "tool_cli.h"

namespace {

std::atomic<bool> g_cancel{false};
static_assert(std::atomic<bool>::is_always_lock_free, "the signal handler stores to it");

extern "C" void onSignal(int) { g_cancel.store(true, std::memory_order_relaxed); }

void installSignals() {
    struct sigaction sa {};
    sa.sa_handler = onSignal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESETHAND; // a second signal takes the default action (the process ends)
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
}

std::string duration(double s) {
    if (!std::isfinite(s) || s < 0) return "?";
    const long t = std::lround(s);
    char buf[32];
    if (t >= 3600) std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", t / 3600, (t / 60) % 60, t % 60);
    else std::snprintf(buf, sizeof buf, "%ld:%02ld", t / 60, t % 60);
    return buf;
}

std::string megabytes(uint64_t bytes) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.1f MB", double(bytes) / 1e6);
    return buf;
}

// Progress on stderr: a redrawn bar on a terminal, a periodic line otherwise.
class Progress {
public:
    Progress(bool quiet) : quiet_(quiet), tty_(::isatty(STDERR_FILENO) == 1) {}

    void update(uint64_t done, uint64_t total) {
        if (quiet_) return;
        const auto now = std::chrono::steady_clock::now();
        if (done == 0) {
            start_ = now;
            last_ = now - std::chrono::hours(1);
        }
        const double sinceLast = std::chrono::duration<double>(now - last_).count();
        const bool end = done == total;
        if (!end && sinceLast < (tty_ ? 0.1 : 5.0)) return;
        last_ = now;
        const double elapsed = std::chrono::duration<double>(now - start_).count();
        const double rate = elapsed > 0 ? double(done) / elapsed : 0;
        const double pct = total ? 100.0 * double(done) / double(total) : 100.0;
        const double eta = rate > 0 ? double(total - done) / rate : NAN;
        if (tty_) {
            constexpr int kWidth = 30;
            const int filled = total ? int(double(kWidth) * double(done) / double(total)) : kWidth;
            std::string bar(size_t(filled), '#');
            bar.append(size_t(kWidth - filled), '.');
            std::fprintf(stderr, "\r[%s] %llu/%llu tiles %5.1f%%  %.0f tiles/s  ETA %s   ", bar.c_str(),
                         (unsigned long long)done, (unsigned long long)total, pct, rate,
                         done == 0 ? "?" : duration(eta).c_str());
            if (end) std::fputc('\n', stderr);
        } else {
            std::fprintf(stderr, "iris-encode: %llu/%llu tiles (%.1f%%), %.0f tiles/s, ETA %s\n",
                         (unsigned long long)done, (unsigned long long)total, pct, rate,
                         done == 0 ? "?" : duration(eta).c_str());
        }
        std::fflush(stderr);
        drawn_ = true;
    }

    // Ends a half-drawn bar line before another message.
    void interrupt() {
        if (tty_ && drawn_ && !quiet_) std::fputc('\n', stderr);
        drawn_ = false;
    }

private:
    bool quiet_, tty_;
    bool drawn_ = false;
    std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now(), last_;
};

} // namespace

int main(int argc, char** argv) {
    std::string source, output, subsampling = "422", reader = "auto";
    iris::EncodeOptions options;
    bool quiet = false;
    using iris::ChromaSubsampling, iris::SourcePreference;
    const std::vector<std::pair<std::string, ChromaSubsampling>> subsamplings{
        {"444", ChromaSubsampling::S444}, {"422", ChromaSubsampling::S422}, {"420", ChromaSubsampling::S420},
        {"4:4:4", ChromaSubsampling::S444}, {"4:2:2", ChromaSubsampling::S422}, {"4:2:0", ChromaSubsampling::S420}};
    const std::vector<std::pair<std::string, SourcePreference>> readers{
        {"auto", SourcePreference::Auto}, {"openslide", SourcePreference::OpenSlide}, {"iris", SourcePreference::Iris}};

    // (The last line also keeps the phrase "usage: iris-encode" that tests/iris looks for in --help;
    // the usage line itself must start "Usage:" for help2man.)
    CLI::App app{"Convert a slide into an .iris file (Iris File Extension 1.0).\n"
                 "\n"
                 "SOURCE is any slide Iris View opens (Aperio, Hamamatsu, MIRAX, generic TIFF,\n"
                 "..., .iris, a DICOM WSI series as its folder or one of its .dcm files, a\n"
                 "DICOMweb series URL, or synthetic:WIDTHxHEIGHT). The .iris file holds every\n"
                 "level as 256x256 JPEG tiles, the slide's properties, associated images, ICC\n"
                 "profile, microns per pixel and magnification. It is written under a temporary\n"
                 "name and renamed when complete. Progress goes to stderr: a bar on a terminal,\n"
                 "otherwise a line every few seconds. SIGINT or SIGTERM stops the encode\n"
                 "cleanly (no output, no partial file); a second signal kills at once.\n"
                 "\n"
                 "Typical usage: iris-encode slide.svs (writes slide.iris in the current folder).\n",
                 "iris-encode"};
    iris::tools::setUpApp(app, "iris-encode");
    app.add_option("SOURCE", source, "The slide to convert")->required();
    app.add_option("-o,--output", output, "Output file")
        ->option_text("FILE")
        ->check([](const std::string& v) { return v.empty() ? std::string("empty file name") : std::string(); })
        ->default_str("SOURCE's name with .iris, in this folder");
    app.add_option("-q,--quality", options.quality, "JPEG quality, 1 to 100")
        ->option_text("Q")
        ->check(iris::tools::wholeNumber(1, 100))
        ->default_str("90, as the reference encoder");
    app.add_option("--subsampling", subsampling, "Chroma subsampling: 444, 422 or 420")
        ->option_text("S")
        ->check(CLI::IsMember(subsamplings).description(""));
    app.add_option("-j,--threads", options.threads, "Decode+encode threads, 1 to 1024")
        ->option_text("N")
        ->check(iris::tools::wholeNumber(1u, 1024u))
        ->default_str("every hardware thread");
    app.add_option("--source", reader, "Reader of SOURCE: auto, openslide or iris")
        ->option_text("R")
        ->check(CLI::IsMember(readers).description(""));
    app.add_flag("--quiet", quiet, "No progress, only errors and warnings");
    app.footer("Exit status: 0 written, 1 the source or the output failed, 2 bad arguments,\n"
               "130 interrupted (SIGINT/SIGTERM; nothing is left behind).");
    if (const int status = iris::tools::parseArguments(app, argc, argv, "no source slide given"); status >= 0) return status;
    for (const auto& [name, value] : subsamplings)
        if (name == subsampling) options.subsampling = value;
    for (const auto& [name, value] : readers)
        if (name == reader) options.source = value;
    if (output.empty()) output = iris::irisFileName(source);

    installSignals();
    Progress progress(quiet);
    options.progress = [&progress](uint64_t done, uint64_t total) { progress.update(done, total); };
    options.cancel = &g_cancel;

    auto stats = iris::encodeIris(source, output, options);
    progress.interrupt();
    if (!stats) {
        if (stats.error().status() == iris::Status::Cancelled) {
            std::fprintf(stderr, "iris-encode: interrupted; nothing was written to '%s'\n", output.c_str());
            return 130;
        }
        std::fprintf(stderr, "iris-encode: %s\n", stats.error().message().c_str());
        return 1;
    }
    for (const std::string& w : stats->warnings) std::fprintf(stderr, "iris-encode: warning: %s\n", w.c_str());
    const double s = stats->seconds > 0 ? stats->seconds : 1e-9;
    std::printf("Wrote %s: %llu tiles in %u levels, %u associated image%s, JPEG quality %d %s\n", output.c_str(),
                (unsigned long long)stats->tiles, stats->levels, stats->associatedImages,
                stats->associatedImages == 1 ? "" : "s", options.quality, iris::chromaSubsamplingName(options.subsampling));
    const double ts = stats->tileSeconds > 0 ? stats->tileSeconds : 1e-9;
    std::printf("  %.2f s in all, %.2f s for the tiles with %u threads: %.0f tiles/s, %.1f MB/s of decoded pixels "
                "(%.0f tiles/s overall)\n",
                stats->seconds, stats->tileSeconds, stats->threads, double(stats->tiles) / ts,
                double(stats->pixelBytes) / 1e6 / ts, double(stats->tiles) / s);
    if (stats->sourceBytes > 0) {
        std::printf("  %s, %.2fx the source's %s\n", megabytes(stats->bytesWritten).c_str(),
                    double(stats->bytesWritten) / double(stats->sourceBytes), megabytes(stats->sourceBytes).c_str());
    } else {
        std::printf("  %s\n", megabytes(stats->bytesWritten).c_str());
    }
    return 0;
}
