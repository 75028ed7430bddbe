// Culling of covered tiles (render/render_thread.cpp, RenderThread::coveredBy): the render
// thread leaves out a base or LR tile whose visible part lies wholly under HR (or LR) tiles the
// same frame draws. Those pixels are drawn over anyway, so leaving them out must change nothing
// but the fill work:
//
//   * a settled frame (every tile loaded) is byte-identical to the same view rendered by an
//     engine that draws every resident tile (EngineTuning::drawCovered), at downsamples between
//     pyramid levels, at fractional centres, along the slide's edges and at the fitted view,
//     on the sample slide (JPEG, exact 2× levels), the JPEG 2000 TCGA slide (downsample 2.0005,
//     so the levels' extents differ by a fraction of a pixel) and a one-level slide with
//     synthetic levels;
//   * and it draws fewer tiles (FrameStats::tilesDrawn) wherever HR covers the field.
#include <QtTest>

#include <cstdlib>

#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;

namespace {

constexpr uint32_t kW = 640, kH = 480;

} // namespace

class TstCulling : public QObject {
    Q_OBJECT

    TestEngine culled_, all_;

private slots:
    void initTestCase() {
        // Two engines in one process, set up differently (EngineConfig::tuning); the variable
        // is cleared so that it cannot turn culling off in the engine under test.
        ::unsetenv("IRIS_DRAW_COVERED");
        culled_ = createTestEngine();
        QVERIFY2(culled_, describe(culled_.error).c_str());
        iris::EngineConfig drawAll;
        drawAll.tuning.drawCovered = true;
        all_ = createTestEngine(drawAll);
        QVERIFY2(all_, describe(all_.error).c_str());
        QVERIFY(culled_->bindOffscreen(kW, kH).ok());
        QVERIFY(all_->bindOffscreen(kW, kH).ok());
    }

    void cleanupTestCase() {
        for (TestEngine* e : {&culled_, &all_}) {
            const std::string during = e->endTest(); // the whole suite's: no beginTest
            QVERIFY2(during.empty(), during.c_str());
            const std::string finished = e->finish();
            QVERIFY2(finished.empty(), finished.c_str());
        }
    }

    void sameFramesFewerTiles_data() {
        QTest::addColumn<QString>("slide");
        if (auto s = sampleSlidePath()) QTest::newRow("sample") << QString::fromStdString(s->string());
        if (auto d = slidesDir("aperio"))
            QTest::newRow("tcga-jp2k") << QString::fromStdString((*d / "tcga-cr-7395-01a-01-ts1.svs").string());
        QTest::newRow("one level, synthetic levels") << QStringLiteral("synthetic:9000x6000:1");
    }

    void sameFramesFewerTiles() {
        QFETCH(QString, slide);
        const std::string path = slide.toStdString();
        if (!path.starts_with("synthetic:") && !std::filesystem::exists(path)) QSKIP("slide not present");
        QVERIFY(culled_->open(path).ok());
        QVERIFY(all_->open(path).ok());
        const iris::SlideInfo info = *culled_->slideInfo();
        const double w = double(info.width), h = double(info.height);
        const iris::View fit = culled_->fitView();
        struct Case {
            const char* what;
            iris::View view;
        };
        const Case cases[] = {
            {"1:1 centre", {w / 2, h / 2, 1.0}},
            {"ds 1.37, fractional centre", {w * 0.43 + 0.37, h * 0.51 + 0.61, 1.37}},
            {"ds 2.6", {w * 0.55 + 0.2, h * 0.47 + 0.9, 2.6}},
            {"ds 3.3, right and bottom edge", {w - 200.3, h - 150.7, 3.3}},
            {"ds 1.9, top-left corner", {120.25, 90.75, 1.9}},
            {"zoomed in 3x", {w * 0.3 + 0.1, h * 0.6 + 0.3, 1.0 / 3}},
            // Turned views: coarse tiles under the turned field's drawn finer tiles are culled,
            // those at its corners (fine tiles outside the field are not drawn) are not.
            {"turned 30, ds 1.37", {w * 0.43 + 0.37, h * 0.51 + 0.61, 1.37, 30}},
            {"turned 90 flipped, ds 2.6", {w * 0.55 + 0.2, h * 0.47 + 0.9, 2.6, 90, true}},
            {"turned 217, top-left corner", {120.25, 90.75, 1.9, 217}},
            {"fitted", fit},
        };
        int fewer = 0;
        for (const Case& c : cases) {
            std::string why;
            auto a = renderSettled(*culled_.engine, c.view, kW, kH, 60s, &why);
            QVERIFY2(a, (std::string(c.what) + ": " + why).c_str());
            const uint32_t drawnCulled = culled_->metrics().lastFrame.tilesDrawn;
            auto b = renderSettled(*all_.engine, c.view, kW, kH, 60s, &why);
            QVERIFY2(b, (std::string(c.what) + " (drawing every tile): " + why).c_str());
            const uint32_t drawnAll = all_->metrics().lastFrame.tilesDrawn;
            const DiffStats d = compareImages(a->image, b->image, nullptr, 4);
            qInfo("%s: tiles drawn %u (every resident tile: %u); %s", c.what, drawnCulled, drawnAll, d.summary().c_str());
            if (d.differing)
                qWarning("%s", saveFailureArtefacts(std::string("culling.") + slide.toStdString() + "." + c.what, a->image,
                                                    b->image, nullptr).c_str());
            QVERIFY2(d.differing == 0, c.what);
            QVERIFY2(drawnCulled <= drawnAll, c.what);
            fewer += drawnCulled < drawnAll;
        }
        // Wherever a coarser level is drawn under HR, most of it is covered.
        QVERIFY2(fewer >= 3, std::to_string(fewer).c_str());
    }
};

QTEST_GUILESS_MAIN(TstCulling)
#include "tst_culling.moc"
