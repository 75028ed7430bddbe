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
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include <unistd.h>

#include "iris/encoder.h"

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

const char* kUsage =
    "usage: iris-encode SOURCE [-o OUT.iris] [--quality Q] [--subsampling 444|422|420]\n"
    "                   [--threads N] [--source auto|openslide|iris] [--quiet]\n";

int usage(const char* msg) {
    if (msg) std::fprintf(stderr, "iris-encode: %s\n", msg);
    std::fputs(kUsage, stderr);
    return 2;
}

void help() {
    std::fputs(kUsage, stdout);
    std::fputs("\n"
               "Converts SOURCE (any slide Iris View opens: Aperio, Hamamatsu, MIRAX, generic TIFF, …,\n"
               ".iris, or synthetic:WIDTHxHEIGHT) into an .iris file: every level as 256x256 JPEG tiles,\n"
               "the slide's properties, associated images, ICC profile, microns per pixel and\n"
               "magnification. The file is written under a temporary name and renamed when complete.\n"
               "\n"
               "  -o, --output FILE     output file (default: SOURCE's name with .iris, in this folder)\n"
               "  -q, --quality Q       JPEG quality 1..100 (default 90, as the reference encoder)\n"
               "  --subsampling S       chroma subsampling 444, 422 or 420 (default 422)\n"
               "  -j, --threads N       decode+encode threads (default: every hardware thread)\n"
               "  --source R            reader of SOURCE: auto (default), openslide or iris\n"
               "  --quiet               no progress, only errors and warnings\n"
               "  -h, --help            this text\n"
               "\n"
               "Exit status: 0 written, 1 the source or the output failed, 2 bad arguments,\n"
               "130 interrupted (SIGINT/SIGTERM; nothing is left behind).\n",
               stdout);
}

bool parseInt(const char* s, long lo, long hi, long& out) {
    char* end = nullptr;
    errno = 0;
    out = std::strtol(s, &end, 10);
    return end != s && *end == '\0' && errno == 0 && out >= lo && out <= hi;
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
    std::string source, output;
    iris::EncodeOptions options;
    bool quiet = false;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() -> const char* { return i + 1 < argc ? argv[++i] : nullptr; };
        long v = 0;
        if (a == "-o" || a == "--output") {
            const char* s = next();
            if (!s || !*s) return usage("-o needs a file name");
            output = s;
        } else if (a == "-q" || a == "--quality") {
            const char* s = next();
            if (!s || !parseInt(s, 1, 100, v)) return usage("--quality needs a whole number from 1 to 100");
            options.quality = int(v);
        } else if (a == "--subsampling") {
            const char* s = next();
            const std::string sv = s ? s : "";
            if (sv == "444" || sv == "4:4:4") options.subsampling = iris::ChromaSubsampling::S444;
            else if (sv == "422" || sv == "4:2:2") options.subsampling = iris::ChromaSubsampling::S422;
            else if (sv == "420" || sv == "4:2:0") options.subsampling = iris::ChromaSubsampling::S420;
            else return usage("--subsampling needs 444, 422 or 420");
        } else if (a == "-j" || a == "--threads") {
            const char* s = next();
            if (!s || !parseInt(s, 1, 1024, v)) return usage("--threads needs a whole number from 1 to 1024");
            options.threads = uint32_t(v);
        } else if (a == "--source") {
            const char* s = next();
            const std::string sv = s ? s : "";
            if (sv == "auto") options.source = iris::SourcePreference::Auto;
            else if (sv == "openslide") options.source = iris::SourcePreference::OpenSlide;
            else if (sv == "iris") options.source = iris::SourcePreference::Iris;
            else return usage("--source needs auto, openslide or iris");
        } else if (a == "--quiet") {
            quiet = true;
        } else if (a == "-h" || a == "--help") {
            help();
            return 0;
        } else if (a.size() > 1 && a[0] == '-') {
            return usage(("unknown option " + a).c_str());
        } else if (source.empty()) {
            source = a;
        } else {
            return usage("give one source slide (and the output with -o)");
        }
    }
    if (source.empty()) return usage("no source slide given");
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
