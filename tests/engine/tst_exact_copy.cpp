// The exact copy (render/tile_pass.h; EngineTuning::exactCopy): where the HR level is drawn
// exactly (a level at its own scale, every pixel centre on a texel centre), unturned, with no
// colour step, into an offscreen target, its opaque tiles are copied from the atlas instead of
// drawn. The copy must change nothing but the cost:
//
//   * settled frames of one engine that copies (On) and one that draws (Off) are byte-identical,
//     with the HUD drawn over them, at 1:1 in the slide and across its edges (tiles clipped by
//     the target; partial tiles at the right and bottom, where coarser tiles are drawn under
//     the copied ones in the first render pass), and at a coarser level's own scale;
//   * the copying engine did copy (FrameStats::tilesCopied) where the view allows it, and
//     copied nothing where it does not: turned a right angle (drawn exactly, not copied), at
//     a downsample between levels, and in the engine with the copy off.
#include <QtTest>

#include <cmath>
#include <cstdlib>

#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;

namespace {

constexpr uint32_t kW = 640, kH = 480;

} // namespace

class TstExactCopy : public QObject {
    Q_OBJECT

    TestEngine copying_, drawing_;

private slots:
    void initTestCase() {
        ::unsetenv("IRIS_EXACT_COPY"); // the engines' tuning is this suite's, not the shell's
        ::unsetenv("IRIS_TILE_RESOLVE");
        iris::EngineConfig on, off;
        on.tuning.exactCopy = iris::EngineTuning::ExactCopy::On;
        off.tuning.exactCopy = iris::EngineTuning::ExactCopy::Off;
        // Quads on every device: a GPU resolves offscreen frames per pixel by default, which
        // copies nothing. (On a CPU device the copying engine's atlas and target are BGRA, the
        // drawing engine's RGBA: the frames read back must still be equal.)
        on.tuning.tileResolve = off.tuning.tileResolve = iris::EngineTuning::TileResolve::Quads;
        copying_ = createTestEngine(on);
        QVERIFY2(copying_, describe(copying_.error).c_str());
        drawing_ = createTestEngine(off);
        QVERIFY2(drawing_, describe(drawing_.error).c_str());
        QVERIFY(copying_->bindOffscreen(kW, kH).ok());
        QVERIFY(drawing_->bindOffscreen(kW, kH).ok());
        // The HUD over the slide: in a copying frame it is drawn in the second render pass, over
        // the copied tiles; the overview's thumbnail is drawn tiles, the scale bar glyphs.
        for (TestEngine* e : {&copying_, &drawing_}) {
            (*e)->setOverlayVisible(iris::Overlay::Overview, true);
            (*e)->setOverlayVisible(iris::Overlay::ScaleBar, true);
        }
    }

    void cleanupTestCase() {
        for (TestEngine* e : {&copying_, &drawing_}) {
            const std::string during = e->endTest(); // the whole suite's: no beginTest
            QVERIFY2(during.empty(), during.c_str());
            const std::string finished = e->finish();
            QVERIFY2(finished.empty(), finished.c_str());
        }
    }

    void sameFramesCopied() {
        const auto path = sampleSlidePath();
        if (!path) QSKIP("the sample slide is not built");
        QVERIFY(copying_->open(path->string()).ok());
        QVERIFY(drawing_->open(path->string()).ok());
        const iris::SlideInfo info = *copying_->slideInfo();
        QVERIFY(info.levels.size() >= 2);
        const double w = double(info.width), h = double(info.height);
        const double ds1 = info.levels[1].downsample;
        QVERIFY2(ds1 == std::floor(ds1), "the sample slide's level 1 has a whole downsample");
        struct Case {
            const char* what;
            iris::View view;
            bool copies; // the copying engine copies tiles of this view
        };
        // Even target sizes: the view's centre on a level's texel corner puts every pixel centre
        // on a texel centre.
        const Case cases[] = {
            {"1:1 centre", {std::round(w / 2), std::round(h / 2), 1.0}, true},
            {"1:1 top-left corner, the slide's edges inside the target", viewWithOrigin(-120, -64, 1.0, kW, kH), true},
            {"1:1 bottom-right corner, partial tiles", viewWithOrigin(w - 500, h - 300, 1.0, kW, kH), true},
            {"1:1, tiles cut by the target on every side", viewWithOrigin(1000, 700, 1.0, kW, kH), true},
            {"level 1 at its own scale", {std::round(w / 2 / ds1) * ds1, std::round(h / 3 / ds1) * ds1, ds1}, true},
            {"1:1 turned 90: exact, drawn", turnedViewAt(900, 600, 1.0, 90, false, false, kW, kH), false},
            {"1:1 mirrored: exact, drawn", turnedViewAt(900, 600, 1.0, 0, true, false, kW, kH), false},
            {"downsample 1.37: filtered", {w * 0.43 + 0.37, h * 0.51 + 0.61, 1.37}, false},
            {"1:1 a quarter pixel off: filtered", {std::round(w / 2) + 0.25, std::round(h / 2), 1.0}, false},
        };
        for (const Case& c : cases) {
            std::string why;
            auto a = renderSettled(*copying_.engine, c.view, kW, kH, 60s, &why);
            QVERIFY2(a, (std::string(c.what) + ": " + why).c_str());
            const iris::FrameStats copied = copying_->metrics().lastFrame;
            auto b = renderSettled(*drawing_.engine, c.view, kW, kH, 60s, &why);
            QVERIFY2(b, (std::string(c.what) + " (drawn): " + why).c_str());
            const iris::FrameStats drawn = drawing_->metrics().lastFrame;
            const DiffStats d = compareImages(a->image, b->image, nullptr, 4);
            qInfo("%s: tiles %u, copied %u (drawing engine: %u, copied %u); %s", c.what, copied.tilesDrawn,
                  copied.tilesCopied, drawn.tilesDrawn, drawn.tilesCopied, d.summary().c_str());
            if (d.differing)
                qWarning("%s", saveFailureArtefacts(std::string("exact_copy.") + c.what, a->image, b->image, nullptr).c_str());
            QVERIFY2(d.differing == 0, c.what);
            QCOMPARE(drawn.tilesCopied, 0u);
            QCOMPARE(copied.tilesDrawn, drawn.tilesDrawn);
            if (c.copies) QVERIFY2(copied.tilesCopied > 0, c.what);
            else QVERIFY2(copied.tilesCopied == 0, c.what);
        }
    }
};

QTEST_GUILESS_MAIN(TstExactCopy)
#include "tst_exact_copy.moc"
