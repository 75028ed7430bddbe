// tst_legend: the engine's legend overlay (Overlay::Legend, issue 19) on the offscreen target,
// on lavapipe with the validation layers on, measured from the rendered frames:
//
//   * off by default, BottomRight by default; its rectangle is in its corner and moves with
//     it; it is absent without a layer to describe (none, a label map with every class hidden,
//     hidden, opacity 0) and describes the topmost visible one when there are several;
//   * a label map's legend: a swatch of each class's colour (within one code) with its name
//     beside it, by id, only classes the map draws, at most 12 rows then "+N more", at device
//     pixel ratio 1 and 2; an RGBA layer above it is passed over;
//   * the window's numbers are the layer's resolved window (NaN → the map's range);
//   * the colour bar's pixel columns are the colour map at each column centre's t (within two
//     codes), at device pixel ratio 1 and 2; the title and the numbers are drawn (white ink
//     above and below the bar); nothing changes outside the legend's rectangle.
//
// Failure artefacts go to $IRIS_TEST_OUT/failures (IRIS_TEST_SAVE_FRAMES=1: always).
#include <QtTest>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>

#include "iris/layers.h"
#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;
using iris::Corner;
using iris::Overlay;
using iris::PixelRect;

namespace {

constexpr uint32_t kW = 640, kH = 480;
constexpr auto kTimeout = 60s;
const std::string kSlide = "synthetic:60000x40000";
constexpr int kMargin = 10; // the engine's corner margin, logical pixels (overlay/overlay_layout.h)
const iris::View kView{30000, 20000, 25};

std::string str(const PixelRect& r) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "[%d, %d %dx%d]", int(r.x), int(r.y), int(r.width), int(r.height));
    return buf;
}

// A 4 × 2 map of values from `low` to `high`, titled.
std::shared_ptr<const iris::RasterMap> scalarMap(float low, float high, const std::string& title) {
    const std::vector<float> v{low, high, low, high, high, low, high, low};
    auto m = iris::fromHostMemory(std::span<const float>(v), 4, 2, title);
    return m ? std::make_shared<const iris::RasterMap>(std::move(m).value()) : nullptr;
}

std::shared_ptr<const iris::RasterMap> labelMap() {
    const std::vector<uint16_t> v{0, 1, 2, 1};
    auto m = iris::fromHostMemory(std::span<const uint16_t>(v), 2, 2, "classes");
    return m ? std::make_shared<const iris::RasterMap>(std::move(m).value()) : nullptr;
}

// Pixels inside `area` that are text ink: near white, which neither the dark plate nor the
// colour maps used here (viridis, magma) produce.
int whitePixels(const iris::Image& img, const PixelRect& area) {
    int n = 0;
    for (int y = std::max(0, area.y); y < std::min<int>(int(img.height), area.y + area.height); ++y)
        for (int x = std::max(0, area.x); x < std::min<int>(int(img.width), area.x + area.width); ++x) {
            const uint8_t* p = pixel(img, uint32_t(x), uint32_t(y));
            n += p[0] >= 200 && p[1] >= 200 && p[2] >= 200 ? 1 : 0;
        }
    return n;
}

} // namespace

class TstLegend : public QObject {
    Q_OBJECT

    TestEngine e_;

    void openEngine() {
        e_ = createTestEngine();
        QVERIFY2(e_, describe(e_.error).c_str());
        QVERIFY(e_->bindOffscreen(kW, kH).ok());
        const iris::Result r = e_->open(kSlide);
        QVERIFY2(r.ok(), describe(r).c_str());
    }
    std::optional<iris::Frame> render(const iris::View& v) {
        std::string why;
        auto f = renderView(*e_.engine, v, kW, kH, kTimeout, &why);
        if (!f) qWarning("%s", why.c_str());
        return f;
    }
    uint64_t addLayer(std::shared_ptr<const iris::RasterMap> map, const iris::LayerStyle& style = {}) {
        if (!map) return 0;
        auto id = e_->addLayer(std::move(map), style);
        return id ? *id : 0;
    }
    void save(const iris::Image& img, const std::string& what) {
        if (QTest::currentTestFailed() || std::getenv("IRIS_TEST_SAVE_FRAMES")) {
            const fs::path dir = testOutDir() / "failures";
            fs::create_directories(dir);
            writePng(dir / ("legend." + what + ".png"), img);
        }
    }

private slots:
    void init() { e_ = {}; }
    void cleanup() {
        if (e_) {
            QVERIFY2(e_->validationMessageCount() == 0, "the Vulkan validation layers reported messages (see the log)");
            e_.engine.reset();
        }
    }

    // Off by default, in the corner no other overlay takes by default.
    void offByDefaultBottomRight() {
        openEngine();
        QVERIFY(!e_->overlayVisible(Overlay::Legend));
        QCOMPARE(e_->overlayCorner(Overlay::Legend), Corner::BottomRight);
        QVERIFY(addLayer(scalarMap(0, 1, "p")) != 0);
        auto f = render(kView);
        QVERIFY(f);
        QVERIFY(f->overlays.rect(Overlay::Legend).empty());
        QCOMPARE(f->overlays.legendLayer, uint64_t(0));
    }

    // In its corner, moving with it; only where a visible Scalar layer is; the topmost one.
    void layoutFollowsCornerAndLayers() {
        openEngine();
        e_->setOverlayVisible(Overlay::Legend, true);
        QVERIFY(e_->overlayVisible(Overlay::Legend));

        // No layer, then only a label map whose classes are all hidden: no legend; with its
        // classes shown, the label map is described.
        auto none = render(kView);
        QVERIFY(none);
        QVERIFY(none->overlays.rect(Overlay::Legend).empty());
        iris::LayerStyle labels;
        labels.classes = iris::defaultLabelClasses(3);
        for (iris::LabelClass& c : labels.classes) c.visible = false;
        const uint64_t label = addLayer(labelMap(), labels);
        QVERIFY(label != 0);
        auto hiddenLabels = render(iris::View{kView.centerX + 1, kView.centerY, kView.downsample});
        QVERIFY(hiddenLabels);
        QVERIFY(hiddenLabels->overlays.rect(Overlay::Legend).empty());
        labels.classes = iris::defaultLabelClasses(3);
        QVERIFY(e_->setLayerStyle(label, labels).ok());
        auto onlyLabels = render(kView);
        QVERIFY(onlyLabels);
        QVERIFY(!onlyLabels->overlays.rect(Overlay::Legend).empty());
        QCOMPARE(onlyLabels->overlays.legendLayer, label);
        QVERIFY(onlyLabels->overlays.legendBar.empty());
        QCOMPARE(onlyLabels->overlays.legendClassIds, (std::vector<uint16_t>{1, 2}));

        // A Scalar layer: the legend in each corner, at the margin.
        const uint64_t heat = addLayer(scalarMap(0.1f, 0.9f, "tumour probability"));
        QVERIFY(heat != 0);
        for (Corner c : {Corner::BottomRight, Corner::TopLeft, Corner::TopRight, Corner::BottomLeft}) {
            e_->setOverlayCorner(Overlay::Legend, c);
            QCOMPARE(e_->overlayCorner(Overlay::Legend), c);
            auto f = render(kView);
            QVERIFY(f);
            const PixelRect r = f->overlays.rect(Overlay::Legend);
            QVERIFY2(!r.empty(), "no legend");
            const bool left = c == Corner::TopLeft || c == Corner::BottomLeft;
            const bool top = c == Corner::TopLeft || c == Corner::TopRight;
            QVERIFY2(left ? r.x == kMargin : r.x + r.width == int(kW) - kMargin, str(r).c_str());
            QVERIFY2(top ? r.y == kMargin : r.y + r.height == int(kH) - kMargin, str(r).c_str());
            QVERIFY(r == e_->overlayLayout().rect(Overlay::Legend));
            // The bar lies inside, the layer and its resolved window (the map's range) reported.
            const PixelRect& bar = f->overlays.legendBar;
            QVERIFY2(bar.width >= 160 && bar.x > r.x && bar.y > r.y && bar.x + bar.width < r.x + r.width &&
                         bar.y + bar.height < r.y + r.height,
                     str(bar).c_str());
            QCOMPARE(f->overlays.legendLayer, heat);
            QCOMPARE(f->overlays.legendTitle, std::string("tumour probability"));
            QCOMPARE(f->overlays.legendLowLabel, std::string("0.1"));
            QCOMPARE(f->overlays.legendHighLabel, std::string("0.9"));
        }
        e_->setOverlayCorner(Overlay::Legend, Corner::BottomRight);

        // Another Scalar layer on top with its own window: it is the one described.
        iris::LayerStyle windowed;
        windowed.low = -2.5;
        windowed.high = 40;
        windowed.colorMap = iris::ColorMap::magma();
        const uint64_t score = addLayer(scalarMap(0, 1, "score"), windowed);
        QVERIFY(score != 0);
        auto two = render(kView);
        QVERIFY(two);
        QCOMPARE(two->overlays.legendLayer, score);
        QCOMPARE(two->overlays.legendLowLabel, std::string("-2.5"));
        QCOMPARE(two->overlays.legendHighLabel, std::string("40"));
        // Hidden, or at opacity 0, it no longer qualifies: the one below is described.
        windowed.visible = false;
        QVERIFY(e_->setLayerStyle(score, windowed).ok());
        auto hidden = render(kView);
        QVERIFY(hidden);
        QCOMPARE(hidden->overlays.legendLayer, heat);
        windowed.visible = true;
        windowed.opacity = 0;
        QVERIFY(e_->setLayerStyle(score, windowed).ok());
        auto transparent = render(kView);
        QVERIFY(transparent);
        QCOMPARE(transparent->overlays.legendLayer, heat);

        // Switched off, and with no layer left to describe: no legend.
        e_->setOverlayVisible(Overlay::Legend, false);
        auto off = render(kView);
        QVERIFY(off);
        QVERIFY(off->overlays.rect(Overlay::Legend).empty());
        e_->setOverlayVisible(Overlay::Legend, true);
        e_->removeLayer(score);
        e_->removeLayer(heat);
        auto labelsLeft = render(kView);
        QVERIFY(labelsLeft);
        QCOMPARE(labelsLeft->overlays.legendLayer, label);
        e_->removeLayer(label);
        auto gone = render(kView);
        QVERIFY(gone);
        QVERIFY(gone->overlays.rect(Overlay::Legend).empty());
        QCOMPARE(gone->overlays.legendLayer, uint64_t(0));
    }

    // A label map's legend: a row per class it draws, by id (visible, not transparent, within
    // the map's ids and the table), each an opaque swatch of the class's colour with its name
    // to the right; at most 12 rows, then "+N more"; an Rgba layer above is passed over;
    // nothing outside the legend's rectangle changes.
    void labelClassesAsSwatches_data() {
        QTest::addColumn<double>("ratio");
        QTest::addRow("ratio 1") << 1.0;
        QTest::addRow("ratio 2") << 2.0;
    }
    void labelClassesAsSwatches() {
        QFETCH(double, ratio);
        openEngine();
        e_->setDevicePixelRatio(ratio);
        const std::vector<uint16_t> ids{0, 1, 2, 3, 3, 2, 1, 0};
        auto map = iris::fromHostMemory(std::span<const uint16_t>(ids), 4, 2, "tissue classes");
        QVERIFY(map.ok());
        iris::LayerStyle style;
        style.opacity = 0.6;
        style.classes = iris::defaultLabelClasses(6); // ids 4 and 5 are not in the map
        style.classes[1] = {"tumour", {200, 30, 40, 255}, true};
        style.classes[2] = {"stroma", {40, 90, 210, 128}, true}; // half transparent: an opaque swatch
        style.classes[3].name.clear();                           // unnamed: "class 3"
        const uint64_t id = addLayer(std::make_shared<const iris::RasterMap>(std::move(map).value()), style);
        QVERIFY(id != 0);
        // An RGBA map on top has no legend: the label map below is described.
        const std::vector<uint8_t> rgba(4 * 4, 128);
        auto coloured = iris::fromHostMemoryRgba(std::span<const uint8_t>(rgba), 2, 2, "rgba");
        QVERIFY(coloured.ok());
        QVERIFY(addLayer(std::make_shared<const iris::RasterMap>(std::move(coloured).value())) != 0);
        auto without = render(kView);
        QVERIFY(without);
        e_->setOverlayVisible(Overlay::Legend, true);
        auto f = render(kView);
        QVERIFY(f);
        const iris::OverlayLayout& l = f->overlays;
        save(f->image, std::string("classes.") + QTest::currentDataTag());
        QCOMPARE(l.legendLayer, id);
        QCOMPARE(l.legendTitle, std::string("tissue classes"));
        QCOMPARE(l.legendClassIds, (std::vector<uint16_t>{1, 2, 3}));
        QCOMPARE(l.legendClassNames, (std::vector<std::string>{"tumour", "stroma", "class 3"}));
        QCOMPARE(l.legendMoreClasses, 0);
        QVERIFY(l.legendBar.empty() && l.legendLowLabel.empty() && l.legendHighLabel.empty());
        QVERIFY(l.text);
        const PixelRect r = l.rect(Overlay::Legend);
        QCOMPARE(l.legendSwatches.size(), size_t(3));
        for (size_t i = 0; i < l.legendSwatches.size(); ++i) {
            const PixelRect sw = l.legendSwatches[i];
            QCOMPARE(sw.width, int(std::lround(12 * ratio)));
            QCOMPARE(sw.height, sw.width);
            QVERIFY2(sw.x > r.x && sw.y > r.y && sw.x + sw.width < r.x + r.width && sw.y + sw.height < r.y + r.height,
                     (str(sw) + " in " + str(r)).c_str());
            if (i > 0) QVERIFY(sw.y >= l.legendSwatches[i - 1].y + l.legendSwatches[i - 1].height);
            // Every swatch pixel is the class's colour, opaque.
            const iris::Rgba8 want = style.classes[l.legendClassIds[i]].color;
            int worst = 0;
            for (int y = sw.y; y < sw.y + sw.height; ++y)
                for (int x = sw.x; x < sw.x + sw.width; ++x) {
                    const uint8_t* p = pixel(f->image, uint32_t(x), uint32_t(y));
                    worst = std::max({worst, std::abs(p[0] - want.r), std::abs(p[1] - want.g), std::abs(p[2] - want.b)});
                }
            QVERIFY2(worst <= 1, qPrintable(QString("swatch %1 is %2 codes off its class colour").arg(i).arg(worst)));
            // Its name, in white ink, to its right on the same row.
            const PixelRect name{sw.x + sw.width, sw.y - int(2 * ratio), r.x + r.width - (sw.x + sw.width), sw.height + int(4 * ratio)};
            QVERIFY2(whitePixels(f->image, name) > 10, qPrintable(QString("no name beside swatch %1").arg(i)));
        }
        QVERIFY2(whitePixels(f->image, {r.x, r.y, r.width, l.legendSwatches[0].y - r.y}) > 20, "no title drawn");
        int outside = 0;
        for (uint32_t y = 0; y < kH; ++y)
            for (uint32_t x = 0; x < kW; ++x)
                if (!r.contains(x + 0.5, y + 0.5) && std::memcmp(pixel(f->image, x, y), pixel(without->image, x, y), 4) != 0)
                    ++outside;
        QCOMPARE(outside, 0);

        // A class hidden, or made transparent, leaves the list.
        style.classes[2].visible = false;
        style.classes[3].color.a = 0;
        QVERIFY(e_->setLayerStyle(id, style).ok());
        auto fewer = render(iris::View{kView.centerX + 1, kView.centerY, kView.downsample});
        QVERIFY(fewer);
        QCOMPARE(fewer->overlays.legendClassIds, (std::vector<uint16_t>{1}));
        QVERIFY(fewer->overlays.rect(Overlay::Legend).height < r.height);
    }

    // A map of 20 classes lists the first 12 it draws, then "+N more" under them.
    void manyClassesEndWithMore() {
        openEngine();
        std::vector<uint16_t> ids(20);
        for (uint16_t i = 0; i < 20; ++i) ids[i] = i;
        auto map = iris::fromHostMemory(std::span<const uint16_t>(ids), 20, 1, "classes");
        QVERIFY(map.ok());
        iris::LayerStyle style;
        style.classes = iris::defaultLabelClasses(20); // id 0 hidden: 19 drawn
        QVERIFY(addLayer(std::make_shared<const iris::RasterMap>(std::move(map).value()), style) != 0);
        e_->setOverlayVisible(Overlay::Legend, true);
        auto f = render(kView);
        QVERIFY(f);
        const iris::OverlayLayout& l = f->overlays;
        save(f->image, "many");
        QCOMPARE(l.legendClassIds.size(), size_t(12));
        QCOMPARE(l.legendClassIds.front(), uint16_t(1));
        QCOMPARE(l.legendClassIds.back(), uint16_t(12));
        QCOMPARE(l.legendMoreClasses, 7);
        const PixelRect r = l.rect(Overlay::Legend), last = l.legendSwatches.back();
        QVERIFY2(whitePixels(f->image, {r.x, last.y + last.height, r.width, r.y + r.height - (last.y + last.height)}) > 10,
                 "no \"+7 more\" line drawn");
    }

    // Stacked with the scale bar in one corner, each in its own rectangle.
    void stacksWithTheOtherOverlays() {
        openEngine();
        QVERIFY(addLayer(scalarMap(0, 1, "p")) != 0);
        e_->setOverlayVisible(Overlay::ScaleBar, true);
        e_->setOverlayVisible(Overlay::Legend, true);
        e_->setOverlayCorner(Overlay::ScaleBar, Corner::BottomRight);
        auto f = render(kView);
        QVERIFY(f);
        const PixelRect bar = f->overlays.rect(Overlay::ScaleBar), legend = f->overlays.rect(Overlay::Legend);
        QVERIFY(!bar.empty() && !legend.empty());
        QCOMPARE(bar.y + bar.height, int(kH) - kMargin); // the scale bar comes first (Overlay order)
        QVERIFY2(legend.y + legend.height <= bar.y, (str(legend) + " over " + str(bar)).c_str());
    }

    // The bar's columns are the colour map from low to high; the text is drawn; nothing
    // outside the rectangle changes.
    void barPixelsAreTheColourMap_data() {
        QTest::addColumn<double>("ratio");
        QTest::addColumn<QString>("map");
        QTest::addRow("viridis at ratio 1") << 1.0 << "viridis";
        QTest::addRow("magma at ratio 2") << 2.0 << "magma";
    }
    void barPixelsAreTheColourMap() {
        QFETCH(double, ratio);
        QFETCH(QString, map);
        openEngine();
        e_->setDevicePixelRatio(ratio);
        iris::LayerStyle style;
        style.colorMap = *iris::ColorMap::builtin(map.toStdString());
        QVERIFY(addLayer(scalarMap(0, 1, "tumour probability"), style) != 0);
        auto without = render(kView);
        QVERIFY(without);
        e_->setOverlayVisible(Overlay::Legend, true);
        auto f = render(kView);
        QVERIFY(f);
        const iris::OverlayLayout& l = f->overlays;
        const PixelRect r = l.rect(Overlay::Legend), bar = l.legendBar;
        QVERIFY(!r.empty() && !bar.empty());
        QVERIFY(l.text);
        QCOMPARE(bar.width, int(std::lround(160 * ratio)));
        save(f->image, std::string("bar.") + QTest::currentDataTag());

        // Every column, on each of its rows: the map at t = (column + 0.5) / width.
        int worst = 0, worstColumn = -1;
        for (int i = 0; i < bar.width; ++i) {
            const std::array<double, 4> want = style.colorMap.at((i + 0.5) / bar.width);
            for (int y = bar.y; y < bar.y + bar.height; ++y) {
                const uint8_t* p = pixel(f->image, uint32_t(bar.x + i), uint32_t(y));
                for (int ch = 0; ch < 3; ++ch) {
                    const int d = std::abs(int(p[ch]) - int(std::lround(want[size_t(ch)])));
                    if (d > worst) worst = d, worstColumn = i;
                }
            }
        }
        QVERIFY2(worst <= 2, qPrintable(QString("column %1 is %2 codes off the colour map").arg(worstColumn).arg(worst)));

        // The title above the bar, the numbers below it.
        const PixelRect above{r.x, r.y, r.width, bar.y - r.y};
        const PixelRect below{r.x, bar.y + bar.height, r.width, r.y + r.height - (bar.y + bar.height)};
        QVERIFY2(whitePixels(f->image, above) > 20, "no title drawn");
        const PixelRect lowEnd{below.x, below.y, below.width / 2, below.height};
        const PixelRect highEnd{below.x + below.width / 2, below.y, below.width - below.width / 2, below.height};
        QVERIFY2(whitePixels(f->image, lowEnd) > 3, "no low number drawn");
        QVERIFY2(whitePixels(f->image, highEnd) > 3, "no high number drawn");

        // Only the legend's rectangle differs from the frame without it.
        int outside = 0;
        for (uint32_t y = 0; y < kH; ++y)
            for (uint32_t x = 0; x < kW; ++x)
                if (!r.contains(x + 0.5, y + 0.5) && std::memcmp(pixel(f->image, x, y), pixel(without->image, x, y), 4) != 0)
                    ++outside;
        QCOMPARE(outside, 0);
    }
};

QTEST_GUILESS_MAIN(TstLegend)
#include "tst_legend.moc"
