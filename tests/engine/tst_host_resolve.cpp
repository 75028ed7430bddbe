// The resolve on the host (render/host_resolve.h): on a CPU device whose atlas is written from
// the host, a view of the HR level that is not drawn exactly (enlarged, 1:1 off the
// pixel grid, or shrunk between levels) is resampled on the CPU and copied into the target,
// instead of drawn as quads. It must change nothing but the cost:
//
//   * settled frames of an engine with the default tuning (Auto: the host resolve) and one
//     that draws quads are the same picture (no channel more than 2 codes apart, 0.3 on
//     average: the two round differently, 8-bit weights against llvmpipe's sampler and the
//     seam pass's float filter), the HUD drawn over both, at several
//     scales (enlarged, off the grid, shrunk through one mip and between two), near the
//     slide's edge, and at a coarser level's scale;
//   * the host resolved exactly the frames it should (its Debug log names each change): those
//     above, views across the slide's edges (where a coarser level, then the background, shows),
//     and not a turned or mirrored view, or an exact one;
//   * with no perimeter buffered, the tiles around a view are absent: the pixels whose filter
//     reaches them come from their own tile, as the quads draw them (the host's fallback);
//   * the frames of a new field while it loads (HR, LR and base in part, each pixel the finest
//     whose tile is there) are resolved on the host too, and each of their pixels is one of the
//     pictures the quads draw of that view: the HR level's, the LR level's or the base level's
//     (each the settled frame of a slide written at test time from the sample's levels from that
//     one down, the view scaled to it), or the background. Pixels by a tile edge, where a level
//     next to an absent tile samples its own tile alone, are left out. Fields at 1:1 on the
//     pixel grid too: their HR level is the exact copy's once whole, the host's while it loads.
//
// The host resolve serves CPU devices only: on a GPU this suite skips.
#include <QtTest>

#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <cstring>

#include <openslide.h>
#include <tiffio.h>

#include <iris/environment.h>

#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;

namespace {

constexpr uint32_t kW = 640, kH = 480;

// Debug and Info lines of one engine, the latest "tile resolve: frame N ..." kept.
struct ResolveLog {
    std::mutex mutex;
    std::string last;       // the latest change of the host resolve
    bool available = false; // the engine said at startup that it resolves on the host
    // Every change: from frame `first` on, the host resolves (true) or the quads draw.
    std::vector<std::pair<uint64_t, bool>> changes;

    bool hostResolved(uint64_t serial) {
        std::lock_guard lock(mutex);
        bool host = false;
        for (const auto& [first, h] : changes)
            if (first <= serial) host = h;
        return host;
    }
};

// Writes the sample's levels from `from` down as a tiled TIFF (uncompressed RGB, 256-px tiles):
// a slide whose level 0 is the sample's level `from`, read through OpenSlide.
bool writeLevelsFrom(const fs::path& sample, int from, const fs::path& out, std::string* why) {
    openslide_t* osr = openslide_open(sample.c_str());
    if (!osr || openslide_get_error(osr)) {
        if (osr) openslide_close(osr);
        return *why = "OpenSlide cannot open " + sample.string(), false;
    }
    TIFF* tif = TIFFOpen(out.c_str(), "w");
    if (!tif) {
        openslide_close(osr);
        return *why = "TIFFOpen failed for " + out.string(), false;
    }
    bool ok = true;
    constexpr uint32_t kT = 256;
    std::vector<uint32_t> argb;
    std::vector<uint8_t> rgba, tile(size_t(kT) * kT * 3);
    for (int32_t l = from; ok && l < openslide_get_level_count(osr); ++l) {
        int64_t w = 0, h = 0;
        openslide_get_level_dimensions(osr, l, &w, &h);
        argb.resize(size_t(w * h));
        openslide_read_region(osr, argb.data(), 0, 0, l, w, h);
        if (openslide_get_error(osr)) {
            ok = false;
            *why = std::string("OpenSlide: ") + openslide_get_error(osr);
            break;
        }
        rgba.resize(argb.size() * 4);
        argbPremultipliedToRgba(argb.data(), rgba.data(), argb.size());
        TIFFSetField(tif, TIFFTAG_SUBFILETYPE, l == from ? 0 : FILETYPE_REDUCEDIMAGE);
        TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, uint32_t(w));
        TIFFSetField(tif, TIFFTAG_IMAGELENGTH, uint32_t(h));
        TIFFSetField(tif, TIFFTAG_TILEWIDTH, kT);
        TIFFSetField(tif, TIFFTAG_TILELENGTH, kT);
        TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, 8);
        TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, 3);
        TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_RGB);
        TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
        TIFFSetField(tif, TIFFTAG_COMPRESSION, COMPRESSION_NONE);
        for (int64_t ty = 0; ok && ty < h; ty += kT)
            for (int64_t tx = 0; ok && tx < w; tx += kT) {
                std::fill(tile.begin(), tile.end(), 0);
                for (int64_t y = ty; y < std::min<int64_t>(h, ty + kT); ++y)
                    for (int64_t x = tx; x < std::min<int64_t>(w, tx + kT); ++x)
                        std::memcpy(&tile[size_t((y - ty) * kT + (x - tx)) * 3], &rgba[size_t(y * w + x) * 4], 3);
                if (TIFFWriteEncodedTile(tif, TIFFComputeTile(tif, uint32_t(tx), uint32_t(ty), 0, 0), tile.data(),
                                         tmsize_t(tile.size())) < 0) {
                    ok = false;
                    *why = "TIFFWriteEncodedTile failed";
                }
            }
        if (ok && !TIFFWriteDirectory(tif)) {
            ok = false;
            *why = "TIFFWriteDirectory failed";
        }
    }
    TIFFClose(tif);
    openslide_close(osr);
    return ok;
}

} // namespace

class TstHostResolve : public QObject {
    Q_OBJECT

    TestEngine host_, quads_;
    std::shared_ptr<ResolveLog> resolveLog_ = std::make_shared<ResolveLog>();

    // An engine with the default tuning (Auto) whose log also goes to `rl`.
    static TestEngine hostEngine(const std::shared_ptr<ResolveLog>& rl, iris::EngineConfig base = {}) {
        TestEngine t;
        t.log = std::make_shared<LogSink>();
        iris::EngineConfig cfg = testEngineConfig(t.log, base);
        if (base.loaderThreads) cfg.loaderThreads = base.loaderThreads; // (testEngineConfig sets 2)
        auto tuning = iris::tuningFromEnvironment(cfg.tuning);
        if (!tuning) {
            t.error = tuning.error();
            return t;
        }
        cfg.tuning = *tuning;
        cfg.log = [sink = t.log, rl](iris::LogLevel level, std::string_view line) {
            sink->add(level, line);
            std::lock_guard lock(rl->mutex);
            if (line.find("filtered views on the host") != std::string_view::npos) rl->available = true;
            if (line.starts_with("tile resolve: frame ")) {
                rl->last = std::string(line);
                rl->changes.emplace_back(std::strtoull(rl->last.c_str() + 20, nullptr, 10),
                                         line.find("on the host") != std::string_view::npos);
            }
        };
        auto created = iris::Engine::create(cfg);
        if (created)
            t.engine = std::move(created.value());
        else
            t.error = created.error();
        return t;
    }

    // Whether the host resolved the last frame, from the engine's log.
    bool hostResolvedLast() {
        std::lock_guard lock(resolveLog_->mutex);
        return resolveLog_->last.find("on the host") != std::string::npos;
    }

private slots:
    void initTestCase() {
        ::unsetenv("IRIS_TILE_RESOLVE"); // the engines' tuning is this suite's, not the shell's
        ::unsetenv("IRIS_EXACT_COPY");
        ::unsetenv("IRIS_TILE_UPLOAD");
        iris::EngineConfig q;
        q.tuning.tileResolve = iris::EngineTuning::TileResolve::Quads;
        quads_ = createTestEngine(q);
        QVERIFY2(quads_, describe(quads_.error).c_str());
        host_ = hostEngine(resolveLog_);
        QVERIFY2(host_, describe(host_.error).c_str());
        {
            std::lock_guard lock(resolveLog_->mutex);
            if (!resolveLog_->available)
                QSKIP("the engine resolves nothing on the host here (a GPU, or no host-written atlas)");
        }
        QVERIFY(host_->bindOffscreen(kW, kH).ok());
        QVERIFY(quads_->bindOffscreen(kW, kH).ok());
        for (TestEngine* e : {&host_, &quads_}) {
            (*e)->setOverlayVisible(iris::Overlay::Overview, true);
            (*e)->setOverlayVisible(iris::Overlay::ScaleBar, true);
        }
    }

    void cleanupTestCase() {
        for (TestEngine* e : {&host_, &quads_}) {
            if (!*e) continue;
            const std::string during = e->endTest(); // the whole suite's: no beginTest
            QVERIFY2(during.empty(), during.c_str());
            const std::string finished = e->finish();
            QVERIFY2(finished.empty(), finished.c_str());
        }
    }

    void framesMatchQuads() {
        const auto path = sampleSlidePath();
        if (!path) QSKIP("the sample slide is not built");
        QVERIFY(host_->open(path->string()).ok());
        QVERIFY(quads_->open(path->string()).ok());
        const iris::SlideInfo info = *host_->slideInfo();
        QVERIFY(info.levels.size() >= 2);
        const double w = double(info.width), h = double(info.height);
        const double ds1 = info.levels[1].downsample;
        struct Case {
            const char* what;
            iris::View view;
            bool host; // the host resolves this view
        };
        const Case cases[] = {
            {"1:1 a quarter pixel off", {std::round(w / 2) + 0.25, std::round(h / 2), 1.0}, true},
            {"1:1 a third of a pixel off both ways",
             {std::round(w / 3) + 1.0 / 3, std::round(h / 3) - 1.0 / 3, 1.0},
             true},
            {"enlarged 1.43", {w * 0.43 + 0.37, h * 0.51 + 0.61, 0.7}, true},
            {"enlarged 3.3", {w * 0.61 + 0.11, h * 0.29 + 0.83, 0.3}, true},
            {"enlarged 1.1, the slide's top-left corner just outside", viewWithOrigin(0.6, 0.4, 0.9, kW, kH), true},
            {"enlarged 1.1, at the bottom-right corner, partial tiles",
             viewWithOrigin(w - kW * 0.9 - 0.7, h - kH * 0.9 - 0.3, 0.9, kW, kH), true},
            {"level 1 at its own scale, half a pixel off",
             {std::round(w / 2 / ds1) * ds1 + ds1 / 2, std::round(h / 3 / ds1) * ds1, ds1},
             true},
            {"across the slide's top-left edge: the background", viewWithOrigin(-40.5, -20.25, 0.8, kW, kH), true},
            // Past the right edge of level 0 the base level, whose tiles reach further, shows a
            // strip (the sample's 6000 pixels are 187.5 of its base's; it holds 188).
            {"past the bottom-right edge: the base level, then the background",
             viewWithOrigin(w - kW * 0.5 * 0.5 + 10.3, h - kH * 0.5 * 0.5 + 5.7, 0.5, kW, kH), true},
            {"turned 30: quads", turnedViewAt(900.3, 600.7, 0.8, 30, false, false, kW, kH), false},
            {"mirrored: quads", turnedViewAt(900.3, 600.7, 0.8, 0, true, false, kW, kH), false},
            {"shrunk 1.37 (between mips 0 and 1)", {w * 0.43 + 0.37, h * 0.51 + 0.61, 1.37}, true},
            {"shrunk 1.6 at a field's corner", {std::round(w * 0.2), std::round(h * 0.25), 1.6}, true},
            {"shrunk 1.1", {w * 0.55 + 0.21, h * 0.45 + 0.47, 1.1}, true},
            {"shrunk 1.9", {w * 0.25 + 0.71, h * 0.65 + 0.17, 1.9}, true},
            {"shrunk 2.0 (mip 1 alone)", {w * 0.37 + 0.29, h * 0.44 + 0.13, 2.0}, true},
            {"shrunk 3.1 near the bottom-right corner (mips 1 and 2)",
             viewWithOrigin(w - kW * 3.1 - 1.3, h - kH * 3.1 - 2.1, 3.1, kW, kH), true},
            {"level 1 shrunk 1.5", {w * 0.5 + 0.7, h * 0.5 + 0.9, ds1 * 1.5}, true},
            {"1:1 on the pixel grid: exact", {std::round(w / 2), std::round(h / 2), 1.0}, false},
        };
        for (const Case& c : cases) {
            std::string why;
            auto a = renderSettled(*host_.engine, c.view, kW, kH, 60s, &why);
            QVERIFY2(a, (std::string(c.what) + ": " + why).c_str());
            const bool resolved = hostResolvedLast();
            auto b = renderSettled(*quads_.engine, c.view, kW, kH, 60s, &why);
            QVERIFY2(b, (std::string(c.what) + " (quads): " + why).c_str());
            const DiffStats d = compareImages(a->image, b->image, nullptr, 4);
            qInfo("%s: %s; %s", c.what, resolved ? "on the host" : "quads", d.summary().c_str());
            if (d.maxAbs > 2 || d.meanAbs > 0.3)
                qWarning(
                    "%s",
                    saveFailureArtefacts(std::string("host_resolve.") + c.what, a->image, b->image, nullptr).c_str());
            QVERIFY2(d.maxAbs <= 2 && d.meanAbs <= 0.3, c.what);
            QVERIFY2(resolved == c.host, c.what);
        }
    }

    void absentNeighboursLikeQuads() {
        const auto path = sampleSlidePath();
        if (!path) QSKIP("the sample slide is not built");
        // Fresh engines that buffer no perimeter: each view's ring of tiles stays absent.
        iris::EngineConfig base;
        base.perimeterTiles = 0;
        auto rl = std::make_shared<ResolveLog>();
        TestEngine host = hostEngine(rl, base);
        QVERIFY2(host, describe(host.error).c_str());
        iris::EngineConfig q = base;
        q.tuning.tileResolve = iris::EngineTuning::TileResolve::Quads;
        TestEngine quads = createTestEngine(q);
        QVERIFY2(quads, describe(quads.error).c_str());
        for (TestEngine* e : {&host, &quads}) {
            QVERIFY((*e)->bindOffscreen(kW, kH).ok());
            QVERIFY((*e)->open(path->string()).ok());
        }
        const iris::SlideInfo info = *host->slideInfo();
        const double w = double(info.width), h = double(info.height);
        struct Case {
            const char* what;
            iris::View view;
        };
        const Case cases[] = {
            {"enlarged 1.43", {w * 0.31 + 0.37, h * 0.67 + 0.61, 0.7}},
            {"1:1 a third of a pixel off", {std::round(w * 0.77) + 1.0 / 3, std::round(h * 0.21) + 1.0 / 3, 1.0}},
            {"shrunk 1.37", {w * 0.62 + 0.37, h * 0.38 + 0.61, 1.37}},
            // The target's top and left edges a hair past a tile boundary: the filter of the
            // first row and column reaches into the absent tiles before it (half a texel at
            // LOD 0, half a texel of mip 1 when shrunk).
            {"enlarged 4, edges just past tile boundaries",
             viewWithOrigin(256 * 10 + 0.05, 256 * 8 + 0.05, 0.25, kW, kH)},
            {"shrunk 1.37, edges just past tile boundaries",
             viewWithOrigin(256 * 5 + 0.1, 256 * 4 + 0.1, 1.37, kW, kH)},
        };
        for (const Case& c : cases) {
            std::string why;
            auto a = renderSettled(*host.engine, c.view, kW, kH, 60s, &why);
            QVERIFY2(a, (std::string(c.what) + ": " + why).c_str());
            bool resolved;
            {
                std::lock_guard lock(rl->mutex);
                resolved = rl->last.find("on the host") != std::string::npos;
            }
            auto b = renderSettled(*quads.engine, c.view, kW, kH, 60s, &why);
            QVERIFY2(b, (std::string(c.what) + " (quads): " + why).c_str());
            const DiffStats d = compareImages(a->image, b->image, nullptr, 4);
            qInfo("no perimeter, %s: %s; %s", c.what, resolved ? "on the host" : "quads", d.summary().c_str());
            if (d.maxAbs > 2 || d.meanAbs > 0.3)
                qWarning("%s",
                         saveFailureArtefacts(std::string("host_resolve.ring.") + c.what, a->image, b->image, nullptr)
                             .c_str());
            QVERIFY2(d.maxAbs <= 2 && d.meanAbs <= 0.3, c.what);
            QVERIFY2(resolved, c.what);
        }
        for (TestEngine* e : {&host, &quads}) {
            const std::string finished = e->finish();
            QVERIFY2(finished.empty(), finished.c_str());
        }
    }

    void loadingFramesShowTheLevels() {
        const auto path = sampleSlidePath();
        if (!path) QSKIP("the sample slide is not built");
        // A field of more tiles than the other cases' (20 HR tiles and more): it loads over
        // several frames.
        constexpr uint32_t kLW = 1280, kLH = 960;
        auto rl = std::make_shared<ResolveLog>();
        iris::EngineConfig one;
        one.loaderThreads = 1; // the field's tiles arrive one at a time
        TestEngine host = hostEngine(rl, one);
        QVERIFY2(host, describe(host.error).c_str());
        iris::EngineConfig q;
        q.tuning.tileResolve = iris::EngineTuning::TileResolve::Quads;
        TestEngine quads = createTestEngine(q);
        QVERIFY2(quads, describe(quads.error).c_str());
        for (TestEngine* e : {&host, &quads}) QVERIFY((*e)->bindOffscreen(kLW, kLH).ok());
        QVERIFY(quads->open(path->string()).ok());
        const iris::SlideInfo info = *quads->slideInfo();
        const size_t n = info.levels.size();
        QVERIFY2(n >= 3, "the sample slide has an HR, an LR and a base level");
        const double w = double(info.width), h = double(info.height);
        // Enlarged 1.43: HR level 0, LR level 1, base the coarsest; fields spread over the slide
        // (golden-ratio steps), as many as it takes to catch frames with the HR level in part
        // (at least three; most fields give one or two).
        // And four at 1:1 on the pixel grid, whose HR level is drawn exactly (the tile pass's
        // copy) once whole, and while it loads over LR and base resolved on the host.
        iris::View views[12];
        for (int i = 0; i < 12; ++i) {
            const double fx = std::fmod(0.5 + i * 0.381966, 1.0), fy = std::fmod(0.3 + i * 0.618034, 1.0);
            views[i] = i < 8 ? iris::View{w * (0.12 + 0.76 * fx) + 0.37, h * (0.15 + 0.7 * fy) + 0.61, 0.7}
                             : iris::View{std::round(w * (0.12 + 0.76 * fx)), std::round(h * (0.15 + 0.7 * fy)), 1.0};
        }
        constexpr size_t kViews = std::size(views);
        // The pictures each level gives of each view: the settled frames of the quads.
        const size_t levelsShown[3] = {0, 1, n - 1};
        std::vector<iris::Image> picture[3];
        for (int k = 0; k < 3; ++k) {
            const size_t level = levelsShown[k];
            const double ds = info.levels[level].downsample;
            std::string why;
            fs::path slide = *path;
            if (level > 0) {
                slide = testOutDir() / ("host_resolve.levels-from-" + std::to_string(level) + ".tiff");
                QVERIFY2(writeLevelsFrom(*path, int(level), slide, &why), why.c_str());
            }
            QVERIFY(quads->open(slide.string()).ok());
            for (const iris::View& v : views) {
                const iris::View scaled{v.centerX / ds, v.centerY / ds, v.downsample / ds};
                auto f = renderSettled(*quads.engine, scaled, kLW, kLH, 60s, &why);
                QVERIFY2(f, ("level " + std::to_string(level) + ": " + why).c_str());
                picture[k].push_back(std::move(f->image));
            }
        }
        const std::array<uint8_t, 3> bg = backgroundBytes();
        // Frames of each view while its field loads, from the settled whole slide.
        std::mutex m;
        std::condition_variable cv;
        uint64_t drawn = 0;
        host->setFrameCallback([&](const iris::FrameStats&) {
            {
                std::lock_guard lock(m);
                ++drawn;
            }
            cv.notify_all();
        });
        QVERIFY(host->open(path->string()).ok());
        int mixed = 0, checked = 0, checkedExact = 0;
        for (size_t vi = 0; vi < kViews; ++vi) {
            const iris::View& v = views[vi];
            std::string why;
            // The 1:1 fields lie near earlier ones (their tiles would be in already): each
            // starts from the slide opened again, its tiles all to load.
            if (v.downsample == 1.0) QVERIFY(host->open(path->string()).ok());
            QVERIFY2(renderSettled(*host.engine, host->fitView(), kLW, kLH, 60s, &why), why.c_str());
            // Left out: the target's pixels within 2 of a tile edge of a level shown.
            const double left = v.centerX - kLW * 0.5 * v.downsample, top = v.centerY - kLH * 0.5 * v.downsample;
            std::vector<uint8_t> nearX(kLW), nearY(kLH);
            for (const size_t level : levelsShown) {
                const double step = 256 * info.levels[level].downsample / v.downsample; // target px a tile
                for (uint32_t x = 0; x < kLW; ++x) {
                    const double t = (left + (x + 0.5) * v.downsample) / (256 * info.levels[level].downsample);
                    nearX[x] |= std::abs(t - std::round(t)) * step <= 2.0;
                }
                for (uint32_t y = 0; y < kLH; ++y) {
                    const double t = (top + (y + 0.5) * v.downsample) / (256 * info.levels[level].downsample);
                    nearY[y] |= std::abs(t - std::round(t)) * step <= 2.0;
                }
            }
            uint64_t seen = 0;
            host->setView(v);
            const auto until = std::chrono::steady_clock::now() + 60s;
            for (;;) {
                {
                    std::unique_lock lock(m);
                    QVERIFY2(cv.wait_until(lock, until, [&] { return drawn > seen; }), "no frame of the view in 60 s");
                    seen = drawn;
                }
                auto f = host->readFrame();
                QVERIFY(f.ok());
                if (f->view.centerX != v.centerX || f->view.centerY != v.centerY) continue;
                if (f->complete) break;
                if (!rl->hostResolved(f->serial)) continue;
                ++checked;
                if (v.downsample == 1.0) ++checkedExact;
                uint64_t hrOnly = 0, coarserOnly = 0, none = 0;
                int badX = -1, badY = -1;
                for (uint32_t y = 0; y < kLH; ++y) {
                    if (nearY[y]) continue;
                    for (uint32_t x = 0; x < kLW; ++x) {
                        if (nearX[x]) continue;
                        const uint8_t* p = pixel(f->image, x, y);
                        const auto near = [&](const uint8_t* r) {
                            for (int c = 0; c < 3; ++c)
                                if (std::abs(int(p[c]) - int(r[c])) > 2) return false;
                            return true;
                        };
                        const bool hr = near(pixel(picture[0][vi], x, y));
                        const bool coarser = near(pixel(picture[1][vi], x, y)) || near(pixel(picture[2][vi], x, y));
                        if (hr && !coarser) ++hrOnly;
                        if (coarser && !hr) ++coarserOnly;
                        if (!hr && !coarser && !near(bg.data())) {
                            if (none++ == 0) badX = int(x), badY = int(y);
                        }
                    }
                }
                qInfo("view %zu, frame %llu (loading, on the host): %llu px the HR level's alone, %llu a coarser "
                      "level's alone, %llu none of them",
                      vi, (unsigned long long)f->serial, (unsigned long long)hrOnly, (unsigned long long)coarserOnly,
                      (unsigned long long)none);
                if (none > 0) {
                    qWarning("%s", saveFailureArtefacts("host_resolve.loading", f->image, picture[0][vi], nullptr).c_str());
                    QFAIL(("a pixel of a loading frame is no level's picture, first at (" + std::to_string(badX) + ", " +
                           std::to_string(badY) + ")")
                              .c_str());
                }
                if (hrOnly >= 200 && coarserOnly >= 200) ++mixed;
            }
        }
        host->setFrameCallback({});
        qInfo("%d loading frames resolved on the host checked, %d with the HR level in part", checked, mixed);
        QVERIFY2(mixed > 0, "no frame resolved on the host showed a field in part (HR and a coarser level)");
        qInfo("of them %d of fields at 1:1 on the pixel grid (the HR level exact)", checkedExact);
        QVERIFY2(checkedExact > 0, "no loading frame of a field at 1:1 on the pixel grid was resolved on the host");
        for (TestEngine* e : {&host, &quads}) {
            const std::string finished = e->finish();
            QVERIFY2(finished.empty(), finished.c_str());
        }
    }
};

QTEST_GUILESS_MAIN(TstHostResolve)
#include "tst_host_resolve.moc"
