// The resolve on the host (render/host_resolve.h): on a CPU device whose atlas is written from
// the host, a settled view of the HR level that is not drawn exactly (enlarged, 1:1 off the
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
//     reaches them come from their own tile, as the quads draw them (the host's fallback).
//
// The host resolve serves CPU devices only: on a GPU this suite skips.
#include <QtTest>

#include <cmath>
#include <cstdlib>

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
};

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
        auto tuning = iris::tuningFromEnvironment(cfg.tuning);
        if (!tuning) {
            t.error = tuning.error();
            return t;
        }
        cfg.tuning = *tuning;
        cfg.log = [sink = t.log, rl](iris::LogLevel level, std::string_view line) {
            sink->add(level, line);
            std::lock_guard lock(rl->mutex);
            if (line.find("settled filtered views on the host") != std::string_view::npos) rl->available = true;
            if (line.starts_with("tile resolve: frame ")) rl->last = std::string(line);
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
};

QTEST_GUILESS_MAIN(TstHostResolve)
#include "tst_host_resolve.moc"
