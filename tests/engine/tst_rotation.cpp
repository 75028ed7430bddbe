// Turned and mirrored views (issue 17, "Tests").
//
//   * Right angles: at 90°, 180° and 270° (and mirrored), with every output pixel centre on a
//     level pixel centre at that level's downsample (turnedViewAt), the frame equals
//     OpenSlide's level pixels turned the same way, byte for byte, and everything outside the
//     slide is the background. The expected frame is built by mapping each output pixel through
//     iris::ViewTransform, whose right-angle entries are exact, into the region read_region
//     returns — not by turning an image, so a wrong turn direction, a mirrored axis or an
//     off-by-one centre each fail.
//   * A walk at 30°: panning a turned view over a large slide, every complete frame matches a
//     CPU reference of the turned view (the field's corners are loaded: a hole would show a
//     coarser level or the background), and the engine stays within its memory budgets.
// Other angles against a CPU reference resampling: tst_resample's turned rows.
#include <QtTest>

#include <cmath>
#include <cstring>
#include <map>

#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;

namespace {

struct Orientation {
    const char* name;
    double rotation;
    bool flipH, flipV;
};
constexpr Orientation kOrientations[] = {
    {"90", 90, false, false},          {"180", 180, false, false},          {"270", 270, false, false},
    {"mirrored", 0, true, false},      {"90 mirrored top-bottom", 90, false, true},
    {"270 mirrored both", 270, true, true},
};
constexpr uint32_t kW = 333, kH = 257; // odd and straddling tile boundaries both ways

} // namespace

class TestRotation : public QObject {
    Q_OBJECT
    TestEngine e_;
    std::string openPath_;
    OpenSlideRefs refs_;

    OpenSlideRef* ref(const std::filesystem::path& p, std::string* err) { return refs_.get(p, err); }
    bool openSlide(const std::string& path, std::string* err) {
        if (openPath_ == path) return true;
        openPath_.clear();
        if (const iris::Result r = e_->open(path); !r.ok()) {
            *err = "open(" + path + "): " + describe(r);
            return false;
        }
        openPath_ = path;
        return true;
    }

private slots:
    void initTestCase() {
        iris::EngineConfig cfg;
        cfg.color.managed = false; // compared with OpenSlide's stored bytes
        e_ = createTestEngine(cfg);
        QVERIFY2(e_, describe(e_.error).c_str());
        QVERIFY(e_->bindOffscreen(kW, kH).ok());
        e_->setEnhance(false);
    }
    void init() { e_.beginTest(); }
    void cleanup() {
        const std::string why = e_.endTest();
        QVERIFY2(why.empty(), why.c_str());
    }
    void cleanupTestCase() {
        const std::string why = e_.finish();
        QVERIFY2(why.empty(), why.c_str());
    }

    void rightAnglesMatchOpenSlide_data() {
        QTest::addColumn<QString>("path");
        QTest::addColumn<int>("level");
        QTest::addColumn<QString>("position");
        QTest::addColumn<double>("rotation");
        QTest::addColumn<bool>("flipH");
        QTest::addColumn<bool>("flipV");
        std::vector<std::pair<QString, std::filesystem::path>> slides;
        if (auto s = sampleSlidePath()) slides.emplace_back("sample", *s);
        if (auto d = slidesDir("aperio")) slides.emplace_back("CMU", *d / "CMU-1-Small-Region.svs");
        if (slides.empty()) {
            QTest::newRow("no test data") << QString() << 0 << QString() << 0.0 << false << false;
            return;
        }
        for (const auto& [name, path] : slides) {
            std::string err;
            auto os = OpenSlideRef::open(path, &err);
            const int levels = os ? os->levelCount() : 1;
            for (int level : {0, 1}) {
                if (level >= levels) continue;
                for (const Orientation& o : kOrientations) {
                    for (const char* position : {"interior", "bottom-right"}) {
                        QTest::addRow("%s L%d %s %s", name.toUtf8().constData(), level, o.name, position)
                            << QString::fromStdString(path.string()) << level << QString(position) << o.rotation
                            << o.flipH << o.flipV;
                    }
                }
            }
        }
    }
    void rightAnglesMatchOpenSlide() {
        QFETCH(QString, path);
        QFETCH(int, level);
        QFETCH(QString, position);
        QFETCH(double, rotation);
        QFETCH(bool, flipH);
        QFETCH(bool, flipV);
        if (path.isEmpty()) QSKIP("no test data (set IRIS_TESTDATA or IRIS_TESTDATA_DEFAULT)");
        std::string err;
        OpenSlideRef* os = ref(path.toStdString(), &err);
        QVERIFY2(os, err.c_str());
        if (!os->levelPixelsTrustworthy(level, &err)) QSKIP(("pixels not checked: " + err).c_str());
        QVERIFY2(openSlide(path.toStdString(), &err), err.c_str());
        const iris::SlideInfo info = *e_->slideInfo();
        const iris::LevelInfo& li = info.levels[size_t(level)];
        const double ds = li.downsample;

        // Output pixel (0, 0) on level pixel (kx, ky): inside the level, or (bottom-right) so
        // that the turned frame runs past the level's last pixels into the background.
        int64_t kx = int64_t(double(li.width) * 0.37), ky = int64_t(double(li.height) * 0.41);
        const iris::View probe{0, 0, ds, rotation, flipH, flipV};
        const iris::ViewTransform pt = iris::ViewTransform::of(probe, kW, kH);
        if (position == "bottom-right") {
            // Choose (kx, ky) so that the frame's far corner lies 40 level pixels past the level.
            const auto a = pt.toSlide(0.5, 0.5), b = pt.toSlide(kW - 0.5, kH - 0.5);
            const auto c = pt.toSlide(kW - 0.5, 0.5), d = pt.toSlide(0.5, kH - 0.5);
            const double maxX = std::max({a[0], b[0], c[0], d[0]}) - a[0], maxY = std::max({a[1], b[1], c[1], d[1]}) - a[1];
            kx = li.width + 40 - int64_t(std::lround(maxX / ds));
            ky = li.height + 40 - int64_t(std::lround(maxY / ds));
        }
        const iris::View view = turnedViewAt(kx, ky, ds, rotation, flipH, flipV, kW, kH);
        auto frame = renderView(*e_.engine, view, kW, kH, 60s, &err);
        QVERIFY2(frame.has_value(), err.c_str());
        QCOMPARE(countNotOpaque(frame->image), uint64_t(0));
        QCOMPARE(frame->view.rotation, rotation);

        // The level pixel under each output pixel, and the region of the level they span.
        const iris::ViewTransform t = iris::ViewTransform::of(view, kW, kH);
        std::vector<std::pair<int64_t, int64_t>> at(size_t(kW) * kH);
        int64_t x0 = INT64_MAX, y0 = INT64_MAX, x1 = INT64_MIN, y1 = INT64_MIN;
        for (uint32_t j = 0; j < kH; ++j) {
            for (uint32_t i = 0; i < kW; ++i) {
                const auto s = t.toSlide(i + 0.5, j + 0.5);
                const double lx = s[0] / ds, ly = s[1] / ds;
                // Exact: the pixel centre is a level pixel centre.
                QCOMPARE(lx - std::floor(lx), 0.5);
                QCOMPARE(ly - std::floor(ly), 0.5);
                const std::pair<int64_t, int64_t> p{int64_t(std::floor(lx)), int64_t(std::floor(ly))};
                at[size_t(j) * kW + i] = p;
                x0 = std::min(x0, p.first), y0 = std::min(y0, p.second);
                x1 = std::max(x1, p.first), y1 = std::max(y1, p.second);
            }
        }
        QCOMPARE(x1 - x0 + 1, int64_t(std::fmod(rotation, 180.0) == 0 ? kW : kH)); // a right angle: no resampling
        auto region = os->readLevelRegion(level, x0, y0, uint32_t(x1 - x0 + 1), uint32_t(y1 - y0 + 1), &err);
        QVERIFY2(region.has_value(), err.c_str());

        double extentW = double(info.width), extentH = double(info.height);
        for (const auto& l : info.levels) {
            extentW = std::max(extentW, double(l.width) * l.downsample);
            extentH = std::max(extentH, double(l.height) * l.downsample);
        }
        const auto bg = backgroundBytes();
        iris::Image expected = makeImage(kW, kH, {bg[0], bg[1], bg[2], 255});
        Mask inside(size_t(kW) * kH, 0), outside(size_t(kW) * kH, 0);
        for (uint32_t j = 0; j < kH; ++j) {
            for (uint32_t i = 0; i < kW; ++i) {
                const auto [lx, ly] = at[size_t(j) * kW + i];
                const double cx = (double(lx) + 0.5) * ds, cy = (double(ly) + 0.5) * ds;
                const bool inLevel = lx >= 0 && ly >= 0 && lx < li.width && ly < li.height;
                const bool inSlide = cx >= 0 && cy >= 0 && cx < double(info.width) && cy < double(info.height);
                const size_t idx = size_t(j) * kW + i;
                if (inLevel && inSlide) {
                    const uint8_t* s = pixel(*region, uint32_t(lx - x0), uint32_t(ly - y0));
                    if (s[3] != 255) continue; // OpenSlide's "no data": not pinned down
                    std::memcpy(pixel(expected, i, j), s, 4);
                    inside[idx] = 1;
                } else if (!(cx >= 0 && cy >= 0 && cx < extentW && cy < extentH)) {
                    outside[idx] = 1;
                }
            }
        }
        const DiffStats st = compareImages(frame->image, expected, &inside);
        const uint64_t badBackground = countNotColour(frame->image, bg, &outside);
        if (st.differing != 0 || badBackground != 0) {
            Mask both(inside.size());
            for (size_t i = 0; i < both.size(); ++i) both[i] = inside[i] | outside[i];
            const std::string name = std::string("rotation.") + QTest::currentDataTag();
            QFAIL(("inside the slide: " + st.summary() + "; outside: " + std::to_string(badBackground) +
                   " px not the background; " + saveFailureArtefacts(name, frame->image, expected, &both))
                      .c_str());
        }
        QVERIFY2(st.compared > uint64_t(kW) * kH / 4, "less than a quarter of the frame was compared");
        if (position == "bottom-right") QVERIFY(std::count(outside.begin(), outside.end(), 1) > 0);
    }

    // Pans a view turned by 30° at 1:1 across a slide of many tiles. Every complete frame must
    // match a CPU reference (bilinear interpolation of the synthetic slide's level-0 pixels,
    // syntheticPixel, at each output pixel's turned position): a corner of the turned field
    // left out of the visible set would show the coarser LR or base level there — the slide's
    // fine diagonal pattern averaged away, tens of levels off — or the background.
    void walkAtThirtyDegreesHasNoHoles() {
        std::string err;
        constexpr uint32_t W = 640, H = 480;
        QVERIFY(e_->bindOffscreen(W, H).ok());
        QVERIFY2(openSlide("synthetic:60000x40000", &err), err.c_str());
        e_->setView(iris::View{21000.37, 17000.71, 1.0, 30});
        for (int step = 0; step < 10; ++step) {
            e_->translate(-173.0, -61.0); // onwards to the right and a little down, on screen
            QVERIFY2(e_->waitForFrame(60s).ok(), "no complete frame");
            auto f = e_->readFrame();
            QVERIFY(f.ok());
            const iris::ViewTransform t = iris::ViewTransform::of(f->view, W, H);
            QCOMPARE(f->view.rotation, 30.0);
            iris::Image expected = makeImage(W, H);
            uint8_t taps[4][4];
            for (uint32_t j = 0; j < H; ++j) {
                for (uint32_t i = 0; i < W; ++i) {
                    const auto s = t.toSlide(i + 0.5, j + 0.5);
                    const double qx = s[0] - 0.5, qy = s[1] - 0.5;
                    const int64_t x0 = int64_t(std::floor(qx)), y0 = int64_t(std::floor(qy));
                    const double fx = qx - double(x0), fy = qy - double(y0);
                    syntheticPixel(x0, y0, taps[0]);
                    syntheticPixel(x0 + 1, y0, taps[1]);
                    syntheticPixel(x0, y0 + 1, taps[2]);
                    syntheticPixel(x0 + 1, y0 + 1, taps[3]);
                    uint8_t* o = pixel(expected, i, j);
                    for (int c = 0; c < 4; ++c) {
                        const double v = (taps[0][c] * (1 - fx) + taps[1][c] * fx) * (1 - fy) +
                                         (taps[2][c] * (1 - fx) + taps[3][c] * fx) * fy;
                        o[c] = uint8_t(std::lround(v));
                    }
                }
            }
            const DiffStats d = compareImages(f->image, expected);
            if (d.meanAbs > 0.5 || d.maxAbs > 4) {
                QFAIL(("step " + std::to_string(step) + ": " + d.summary() + "; " +
                       saveFailureArtefacts("rotation.walk" + std::to_string(step), f->image, expected, nullptr))
                          .c_str());
            }
            const iris::MemoryStats m = e_->memoryStats();
            QVERIFY2(m.ramCacheBytes <= m.ramBudgetBytes, "RAM cache over its budget");
            QVERIFY2(m.atlasActive <= m.atlasSlots, "more tiles active than the atlas has slots");
        }
        QVERIFY(e_->bindOffscreen(kW, kH).ok());
        openPath_.clear();
    }
};

QTEST_GUILESS_MAIN(TestRotation)
#include "tst_rotation.moc"
