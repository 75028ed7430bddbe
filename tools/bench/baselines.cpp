#include "baselines.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <csetjmp>
#include <cstdio>
#include <thread>

#include <jpeglib.h>
#include <openslide.h>
#include <tiffio.h>
#include <turbojpeg.h>

#include "gpu_split.h"
#include "slide/jpeg_frame_decode.h"

namespace {
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// The entropy decode alone of one JPEG stream (libjpeg's coefficient API); false if it failed.
struct JpegError {
    jpeg_error_mgr mgr;
    std::jmp_buf jump;
};
bool entropyDecode(jpeg_decompress_struct& cinfo, JpegError& err, const uint8_t* data, size_t len) {
    if (setjmp(err.jump)) {
        jpeg_abort_decompress(&cinfo);
        return false;
    }
    jpeg_mem_src(&cinfo, data, (unsigned long)len);
    if (jpeg_read_header(&cinfo, TRUE) != JPEG_HEADER_OK) return false;
    if (!jpeg_read_coefficients(&cinfo)) return false;
    jpeg_finish_decompress(&cinfo);
    return true;
}
} // namespace

BaselineResult openslideBaseline(const std::string& slide, const std::vector<BenchField>& fields, unsigned threads) {
    BaselineResult r;
    openslide_t* osr = openslide_open(slide.c_str());
    if (!osr || openslide_get_error(osr)) {
        r.note = "OpenSlide cannot open the slide";
        if (osr) openslide_close(osr);
        return r;
    }
    threads = std::max(1u, threads);
    for (const BenchField& f : fields) {
        const int64_t rows = (f.h + threads - 1) / threads;
        const auto t0 = Clock::now();
        std::vector<std::thread> pool;
        for (unsigned t = 0; t < threads; ++t) {
            const int64_t y = int64_t(t) * rows;
            const int64_t h = std::min<int64_t>(rows, f.h - y);
            if (h <= 0) break;
            auto work = [&, y, h] {
                std::vector<uint32_t> buf(size_t(f.w) * size_t(h));
                openslide_read_region(osr, buf.data(), int64_t(f.x0), int64_t(f.y0 + double(y) * f.levelDs), f.level, f.w, h);
            };
            if (threads == 1) work();
            else pool.emplace_back(work);
        }
        for (auto& t : pool) t.join();
        r.ms.push_back(msSince(t0));
    }
    if (openslide_get_error(osr)) r.note = std::string("OpenSlide error: ") + openslide_get_error(osr);
    openslide_close(osr);
    return r;
}

namespace {

struct LevelDir {
    tdir_t dir;
    uint32_t tw, th, width, height;
    bool ycbcr;                  // photometric YCbCr (else RGB: the JPEG's components taken as they are)
    std::vector<uint8_t> tables; // JPEGTables without the trailing EOI, or empty
};

// Finds the TIFF directory of each OpenSlide level by dimensions.
bool mapLevels(TIFF* tif, openslide_t* osr, std::vector<LevelDir>& out, std::string& why) {
    const int32_t levels = openslide_get_level_count(osr);
    for (int32_t l = 0; l < levels; ++l) {
        int64_t w = 0, h = 0;
        openslide_get_level_dimensions(osr, l, &w, &h);
        bool found = false;
        for (tdir_t d = 0; TIFFSetDirectory(tif, d); ++d) {
            uint32_t iw = 0, ih = 0, tw = 0, th = 0;
            uint16_t comp = 0;
            TIFFGetField(tif, TIFFTAG_IMAGEWIDTH, &iw);
            TIFFGetField(tif, TIFFTAG_IMAGELENGTH, &ih);
            if (!TIFFIsTiled(tif) || iw != uint32_t(w) || ih != uint32_t(h)) continue;
            TIFFGetField(tif, TIFFTAG_TILEWIDTH, &tw);
            TIFFGetField(tif, TIFFTAG_TILELENGTH, &th);
            TIFFGetField(tif, TIFFTAG_COMPRESSION, &comp);
            if (comp != COMPRESSION_JPEG) {
                why = "level " + std::to_string(l) + " is not JPEG-compressed (compression " + std::to_string(comp) + ")";
                return false;
            }
            uint16_t photometric = 0;
            TIFFGetField(tif, TIFFTAG_PHOTOMETRIC, &photometric);
            LevelDir ld{d, tw, th, iw, ih, photometric == PHOTOMETRIC_YCBCR, {}};
            uint32_t n = 0;
            void* tables = nullptr;
            if (TIFFGetField(tif, TIFFTAG_JPEGTABLES, &n, &tables) && n > 2) {
                const auto* p = static_cast<const uint8_t*>(tables);
                ld.tables.assign(p, p + n - 2); // drop EOI
            }
            out.push_back(std::move(ld));
            found = true;
            break;
        }
        if (!found) {
            why = "no tiled TIFF directory matches level " + std::to_string(l);
            return false;
        }
    }
    return true;
}

// The third pass of a field (BaselineResult::splitMs): every core reads and entropy-decodes
// the field's tiles into the GPU's input, one batch reconstructs them; then, untimed, each
// tile's pixels are compared with libjpeg-turbo's decode of its stream.
template <class Worker, class Stream>
void splitPass(benchsplit::GpuSplit& split, BaselineResult& r, const LevelDir& ld, size_t count,
               std::vector<Worker>& workers, const Stream& stream) {
    if (ld.tw > 256 || ld.th > 256) {
        r.splitNote = "tiles larger than 256x256";
        return;
    }
    if (!split.reserve(uint32_t(count), r.splitNote)) return;
    const auto across = [&](auto&& body) {
        std::atomic<size_t> next{0};
        std::vector<std::thread> pool;
        for (Worker& w : workers)
            pool.emplace_back([&, wp = &w] {
                for (size_t i; (i = next.fetch_add(1)) < count;) body(*wp, i);
            });
        for (auto& t : pool) t.join();
    };
    std::atomic<bool> refused{false};
    std::atomic<uint64_t> busyNs{0};
    const auto t0 = Clock::now();
    across([&](Worker& k, size_t i) {
        const auto tileStart = Clock::now();
        const uint8_t* src = nullptr;
        size_t len = 0;
        if (!stream(k, i, src, len) ||
            !split.entropyDecode(uint32_t(i), {src, len}, int(ld.tw), int(ld.th), ld.ycbcr))
            refused = true;
        busyNs += uint64_t(std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - tileStart).count());
    });
    if (refused) {
        r.splitNote = "a tile the GPU path does not take (its layout, or a read failed)";
        return;
    }
    double gpuMs = NAN, computeMs = NAN;
    if (!split.reconstruct(uint32_t(count), gpuMs, computeMs, r.splitNote)) return;
    r.splitMs.push_back(msSince(t0));
    r.splitGpuMs.push_back(gpuMs);
    r.splitComputeMs.push_back(computeMs);
    if (!split.readBack(uint32_t(count), r.splitNote)) return;
    std::atomic<uint64_t> mismatched{0};
    across([&](Worker& k, size_t i) {
        const uint8_t* src = nullptr;
        size_t len = 0;
        const size_t bytes = size_t(ld.tw) * ld.th * 4;
        k.rgb.resize(bytes);
        if (!stream(k, i, src, len) ||
            !iris::decodeJpegFrameRgba(src, len, int(ld.tw), int(ld.th),
                                       ld.ycbcr ? iris::JpegColour::YCbCr : iris::JpegColour::Rgb, k.rgb.data(), size_t(ld.tw) * 4)
                 .ok() ||
            std::memcmp(k.rgb.data(), split.pixels(uint32_t(i)), bytes) != 0)
            ++mismatched;
    });
    // A running mean over the fields' tiles.
    const double us = double(busyNs) / 1000.0;
    const double before = std::isfinite(r.splitEntropyUsPerTile) ? r.splitEntropyUsPerTile * double(r.splitTiles) : 0.0;
    r.splitTiles += count;
    r.splitEntropyUsPerTile = (before + us) / double(r.splitTiles);
    r.splitMismatched += mismatched;
}

} // namespace

BaselineResult decodeFloorBaseline(const std::string& slide, const std::vector<BenchField>& fields, unsigned threads,
                                   benchsplit::GpuSplit* split) {
    BaselineResult r;
    openslide_t* osr = openslide_open(slide.c_str());
    if (!osr || openslide_get_error(osr)) {
        r.note = "OpenSlide cannot open the slide";
        if (osr) openslide_close(osr);
        return r;
    }
    TIFFSetWarningHandler(nullptr);
    TIFF* probe = TIFFOpen(slide.c_str(), "r");
    if (!probe) {
        r.note = "not a TIFF: no compressed tiles to decode directly";
        openslide_close(osr);
        return r;
    }
    std::vector<LevelDir> dirs;
    std::string why;
    const bool ok = mapLevels(probe, osr, dirs, why);
    TIFFClose(probe);
    openslide_close(osr);
    if (!ok) {
        r.note = why;
        return r;
    }
    threads = std::max(1u, threads);
    // One libtiff handle and one decoder per thread, opened outside the timed part (a viewer
    // keeps its file open); reading the compressed bytes is inside it.
    struct Worker {
        TIFF* tif = nullptr;
        tjhandle tj = nullptr;
        jpeg_decompress_struct coef{};
        JpegError err{};
        tdir_t dir = tdir_t(-1);
        std::vector<uint8_t> raw, stream, rgb;
    };
    std::vector<Worker> workers(threads);
    for (Worker& w : workers) {
        w.coef.err = jpeg_std_error(&w.err.mgr);
        w.err.mgr.error_exit = [](j_common_ptr c) { std::longjmp(reinterpret_cast<JpegError*>(c->err)->jump, 1); };
        w.err.mgr.output_message = [](j_common_ptr) {};
        jpeg_create_decompress(&w.coef);
        w.tif = TIFFOpen(slide.c_str(), "r");
        w.tj = tjInitDecompress();
        if (!w.tif || !w.tj) {
            r.note = "cannot open the TIFF or a JPEG decoder";
            break;
        }
    }
    uint64_t allNs = 0, allTiles = 0, allEntropyNs = 0, allEntropyTiles = 0;
    for (const BenchField& f : fields) {
        if (!r.note.empty()) break;
        const LevelDir& ld = dirs[size_t(f.level)];
        for (Worker& w : workers) {
            if (w.dir != ld.dir) {
                TIFFSetDirectory(w.tif, ld.dir);
                w.dir = ld.dir;
            }
            w.rgb.resize(size_t(ld.tw) * ld.th * 4);
        }
        const int64_t lx = int64_t(std::floor(f.x0 / f.levelDs)), ly = int64_t(std::floor(f.y0 / f.levelDs));
        const int64_t tx0 = std::max<int64_t>(0, lx / ld.tw), ty0 = std::max<int64_t>(0, ly / ld.th);
        const int64_t tx1 = std::min<int64_t>((ld.width - 1) / ld.tw, (lx + f.w - 1) / ld.tw);
        const int64_t ty1 = std::min<int64_t>((ld.height - 1) / ld.th, (ly + f.h - 1) / ld.th);
        std::vector<std::pair<int64_t, int64_t>> tiles;
        for (int64_t ty = ty0; ty <= ty1; ++ty)
            for (int64_t tx = tx0; tx <= tx1; ++tx) tiles.emplace_back(tx, ty);
        // One tile's compressed bytes as a whole JPEG stream in the worker's buffers (false: none).
        const auto stream = [&](Worker& k, size_t i, const uint8_t*& src, size_t& len) {
            uint64_t* sizes = nullptr;
            TIFFGetField(k.tif, TIFFTAG_TILEBYTECOUNTS, &sizes);
            const ttile_t tile =
                TIFFComputeTile(k.tif, uint32_t(tiles[i].first * ld.tw), uint32_t(tiles[i].second * ld.th), 0, 0);
            const uint64_t sz = sizes ? sizes[tile] : 0;
            k.raw.resize(size_t(sz));
            if (sz == 0 || TIFFReadRawTile(k.tif, tile, k.raw.data(), tmsize_t(sz)) <= 0) return false;
            src = k.raw.data();
            len = k.raw.size();
            if (!ld.tables.empty() && len > 2) { // abbreviated stream: tables + tile minus its SOI
                k.stream.assign(ld.tables.begin(), ld.tables.end());
                k.stream.insert(k.stream.end(), k.raw.begin() + 2, k.raw.end());
                src = k.stream.data();
                len = k.stream.size();
            }
            return true;
        };
        // The timed pass (full decodes), then an untimed one of the entropy decode alone.
        for (const bool entropyOnly : {false, true}) {
            std::atomic<size_t> next{0};
            std::atomic<uint64_t> busyNs{0}, decoded{0};
            const auto t0 = Clock::now();
            std::vector<std::thread> pool;
            for (Worker& w : workers) {
                pool.emplace_back([&, wp = &w] {
                    Worker& k = *wp;
                    uint64_t ns = 0, n = 0;
                    for (size_t i; (i = next.fetch_add(1)) < tiles.size();) {
                        const auto tileStart = Clock::now();
                        const uint8_t* src = nullptr;
                        size_t len = 0;
                        if (!stream(k, i, src, len)) continue;
                        if (entropyOnly) {
                            if (!entropyDecode(k.coef, k.err, src, len)) continue;
                        } else {
                            tjDecompress2(k.tj, src, (unsigned long)len, k.rgb.data(), int(ld.tw), int(ld.tw) * 4,
                                          int(ld.th), TJPF_RGBA, 0);
                        }
                        ns += uint64_t(
                            std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - tileStart).count());
                        ++n;
                    }
                    busyNs += ns;
                    decoded += n;
                });
            }
            for (auto& t : pool) t.join();
            if (entropyOnly) {
                allEntropyNs += busyNs;
                allEntropyTiles += decoded;
            } else {
                r.ms.push_back(msSince(t0));
                allNs += busyNs;
                allTiles += decoded;
            }
        }
        if (split && r.splitNote.empty()) splitPass(*split, r, ld, tiles.size(), workers, stream);
    }
    if (allTiles > 0) r.threadUsPerTile = double(allNs) / 1000.0 / double(allTiles);
    if (allEntropyTiles > 0) r.entropyUsPerTile = double(allEntropyNs) / 1000.0 / double(allEntropyTiles);
    for (Worker& w : workers) {
        jpeg_destroy_decompress(&w.coef);
        if (w.tj) tjDestroy(w.tj);
        if (w.tif) TIFFClose(w.tif);
    }
    return r;
}
