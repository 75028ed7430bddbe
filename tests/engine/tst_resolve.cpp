// The per-pixel resolve (EngineTuning::TileResolve::Compute, render/resolve_pass.h) against
// the tile pass's quads: two engines on the same slide, settled frames of the same views.
//
//   * 1:1 and level downsamples with integer alignment: byte-identical (both sample the same
//     texel centres of the same mips);
//   * the fitted view, fractional downsamples past 1:1 and between levels: the same picture
//     within float rounding of the texel positions and the filter hardware's rounding (the
//     resolve filters every pixel by hand, the quads through the sampler except in the seam
//     pass's bands): mean |Δ| ≤ 0.5 and max |Δ| ≤ 4 of 255;
//   * the overlays drawn over a resolved frame (the HUD pass loads it, not clears it).
#include <QtTest>

#include <cmath>

#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;

namespace {
constexpr uint32_t kW = 640, kH = 480;

} // namespace

class TestResolve : public QObject {
    Q_OBJECT
    TestEngine quads_, resolve_;

private slots:
    void initTestCase() {
        ::unsetenv("IRIS_TILE_RESOLVE");
        iris::EngineConfig quads;
        quads.tuning.tileResolve = iris::EngineTuning::TileResolve::Quads; // not Auto: compute on a GPU
        quads_ = createTestEngine(quads);
        QVERIFY2(quads_, describe(quads_.error).c_str());
        iris::EngineConfig cfg;
        cfg.tuning.tileResolve = iris::EngineTuning::TileResolve::Compute;
        resolve_ = createTestEngine(cfg);
        QVERIFY2(resolve_, describe(resolve_.error).c_str());
        QVERIFY(quads_->bindOffscreen(kW, kH).ok());
        QVERIFY(resolve_->bindOffscreen(kW, kH).ok());
    }
    void cleanupTestCase() {
        for (TestEngine* e : {&quads_, &resolve_}) {
            if (!*e) continue;
            const std::string problems = e->finish();
            QVERIFY2(problems.empty(), problems.c_str());
        }
    }

    void sameFrames_data() {
        QTest::addColumn<QString>("slide");
        if (auto s = sampleSlidePath()) QTest::newRow("sample") << QString::fromStdString(s->string());
        if (auto d = slidesDir("aperio"))
            QTest::newRow("tcga-jp2k") << QString::fromStdString((*d / "tcga-cr-7395-01a-01-ts1.svs").string());
    }
    void sameFrames() {
        QFETCH(QString, slide);
        const std::string path = slide.toStdString();
        if (!std::filesystem::exists(path)) QSKIP("slide not present");
        QVERIFY(quads_->open(path).ok());
        QVERIFY(resolve_->open(path).ok());
        const iris::SlideInfo info = *quads_->slideInfo();
        const double cx = double(info.width / 2 / 256 * 256), cy = double(info.height / 2 / 256 * 256);
        const double l1 = info.levels.size() > 1 ? info.levels[1].downsample : 2.0;
        struct Case {
            const char* what;
            iris::View view;
            bool exact;
        };
        const std::vector<Case> cases = {
            {"fitted", quads_->fitView(),
             false}, // a fractional origin: the two compute texel positions differently rounded
            {"1:1 aligned", viewWithOrigin(cx - 300, cy - 200, 1.0, kW, kH), true},
            // Exact where the level's downsample is a whole number; TCGA's 2.0005 puts the
            // level's texels at fractional positions, filtered by the two paths' own weights.
            {"level 1 aligned", viewWithOrigin(cx - 600, cy - 400, l1, kW, kH), l1 == std::round(l1)},
            {"zoomed in 0.6", {cx + 0.37, cy + 0.71, 0.6}, false},
            {"between levels 1.37", {cx + 0.37, cy + 0.71, 1.37}, false},
            // Turned: both paths map each pixel into the unturned frame by the same exact
            // expression at multiples of 90° (tile_turn.glsl).
            {"1:1 aligned, turned 90", turnedViewAt(int64_t(cx), int64_t(cy), 1.0, 90, false, false, kW, kH), true},
            {"1:1 aligned, turned 270 and flipped", turnedViewAt(int64_t(cx), int64_t(cy), 1.0, 270, true, false, kW, kH), true},
            {"between levels 1.37, turned 30", {cx + 0.37, cy + 0.71, 1.37, 30}, false},
        };
        for (const Case& c : cases) {
            std::string why;
            const auto a = renderSettled(*quads_.engine, c.view, kW, kH, 60s, &why);
            QVERIFY2(a, why.c_str());
            const auto b = renderSettled(*resolve_.engine, c.view, kW, kH, 60s, &why);
            QVERIFY2(b, why.c_str());
            const DiffStats d = compareImages(b->image, a->image);
            qInfo("%s, %s: %s", qPrintable(slide.section('/', -1)), c.what, d.summary().c_str());
            if (c.exact) {
                if (d.maxAbs != 0) {
                    const std::string art =
                        saveFailureArtefacts(std::string("resolve.") + c.what, b->image, a->image, nullptr);
                    QFAIL((std::string(c.what) + ": the resolve differs from the quads; " + art).c_str());
                }
            } else {
                QVERIFY2(d.meanAbs <= 0.5 && d.maxAbs <= 4, c.what);
            }
        }
    }

    void overlaysOverAResolvedFrame() {
        auto s = sampleSlidePath();
        if (!s) QSKIP("no sample slide");
        for (TestEngine* e : {&quads_, &resolve_}) {
            QVERIFY((*e)->open(s->string()).ok());
            (*e)->setOverlayVisible(iris::Overlay::ScaleBar, true);
            (*e)->setOverlayVisible(iris::Overlay::Overview, true);
        }
        std::string why;
        // 1:1 with integer alignment, where the two paths give the same bytes (the overview's
        // thumbnail is drawn by the HUD pass through the tile pipeline in both).
        const iris::View v = viewWithOrigin(1000, 800, 1.0, kW, kH);
        const auto a = renderSettled(*quads_.engine, v, kW, kH, 60s, &why);
        QVERIFY2(a, why.c_str());
        const auto b = renderSettled(*resolve_.engine, v, kW, kH, 60s, &why);
        QVERIFY2(b, why.c_str());
        const DiffStats d = compareImages(b->image, a->image);
        qInfo("1:1 with the scale bar and the overview: %s", d.summary().c_str());
        QCOMPARE(d.maxAbs, 0);
    }
};

QTEST_GUILESS_MAIN(TestResolve)
#include "tst_resolve.moc"
