// Pixel-exact rendering (issue 2, "Tests"): where the view maps output pixels one-to-one
// onto pixels of a pyramid level, the frame must equal OpenSlide's read_region of the same
// pixels byte for byte, and everything outside the slide must be the background colour.
//
// The engine's contract for output pixel (i, j): it shows the level-0 point
//     origin + (i + 0.5, j + 0.5) · ds,   origin = centre − (W/2, H/2) · ds.
// With ds equal to a level's downsample and origin = k · ds (k integer), that point is the
// centre of level pixel k + (i, j), which the engine draws from that level (the coarsest
// level whose downsample does not exceed the view's) sampling exactly at a texel centre.
//
// Slides: the built-in sample ($IRIS_TEST_SAMPLE) and every slide OpenSlide can read in
// testdata/slides/aperio and testdata/slides/generic-tiff. Levels that OpenSlide 3.4.1 itself
// misreads (SOURCES.md's warning) are checked for dimensions and a complete frame only.
#include <QtTest>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>

#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;

namespace {

struct Position {
    const char* name;
    uint32_t w, h;
};
// Level-0 (1:1) cases. Every frame is wider than 256 px, so an interior frame straddles the
// engine's tile boundaries in both directions; "bottom-right" reaches past the last (partial)
// edge tiles into the background; "outside-top-left" starts left of and above the slide.
constexpr Position kLevel0Positions[] = {
    {"origin", 512, 384},          {"interior", 512, 384}, {"bottom-right", 512, 384},
    {"outside-top-left", 512, 384}, {"interior", 333, 257}, {"bottom-right", 333, 257},
};
// Cases at each coarser level's own downsample.
constexpr Position kLevelNPositions[] = {
    {"origin", 512, 384},
    {"interior", 333, 257},
    {"bottom-right", 512, 384},
};

// Top-left level pixel of the frame for a named position on a level of lw × lh pixels.
std::pair<int64_t, int64_t> originFor(const QString& position, int64_t lw, int64_t lh, uint32_t w, uint32_t h) {
    if (position == "origin") return {0, 0};
    if (position == "interior") return {int64_t(double(lw) * 0.37), int64_t(double(lh) * 0.41)};
    if (position == "bottom-right") return {lw - int64_t(w) + 61, lh - int64_t(h) + 47};
    if (position == "outside-top-left") return {-45, -29};
    return {0, 0};
}

// A slide of a vendor that only the OpenSlide reader reads: a one-level tiled TIFF tagged as
// Trestle's (Software "MedScan", which OpenSlide 3.4.1 reads as vendor "trestle"). The TIFF tile
// reader passes it on by its vendor alone, and the format table's last reader opens it.
// Written once per run; empty when it cannot be.
std::optional<std::filesystem::path> trestleSlide() {
    static const std::optional<std::filesystem::path> path = []() -> std::optional<std::filesystem::path> {
        const auto p = testOutDir() / "pixel-exact-trestle.tif";
        std::string err;
        if (!writeOneLevelTiff(p, 1300, 700, {}, &err, {}, "MedScan", "Trestle test slide;OverlapsXY= 0 0")) {
            qWarning("%s", err.c_str());
            return std::nullopt;
        }
        return p;
    }();
    return path;
}

std::vector<std::filesystem::path> slidesToTest() {
    std::vector<std::filesystem::path> out;
    if (auto s = sampleSlidePath()) out.push_back(*s);
    if (auto s = trestleSlide()) out.push_back(*s);
    for (const char* sub : {"aperio", "generic-tiff"}) {
        if (auto dir = slidesDir(sub)) {
            for (auto& f : filesUnder(*dir, false)) out.push_back(f);
        }
    }
    return out;
}

QString shortName(const std::filesystem::path& p) {
    if (auto s = sampleSlidePath(); s && p == *s) return QStringLiteral("sample");
    return QString::fromStdString(p.filename().string());
}

} // namespace

class TestPixelExact : public QObject {
    Q_OBJECT

    TestEngine e_;
    uint32_t boundW_ = 0, boundH_ = 0;
    std::string openPath_;
    OpenSlideRefs refs_;

    OpenSlideRef* ref(const std::filesystem::path& p, std::string* err) { return refs_.get(p, err); }

    // Binds W×H and opens `path` unless that is already so.
    bool prepare(const std::filesystem::path& path, uint32_t w, uint32_t h, std::string* err) {
        if (w != boundW_ || h != boundH_) {
            const iris::Result r = e_->bindOffscreen(w, h);
            if (!r.ok()) {
                *err = "bindOffscreen(" + std::to_string(w) + ", " + std::to_string(h) + "): " + describe(r);
                return false;
            }
            boundW_ = w;
            boundH_ = h;
        }
        if (openPath_ != path.string()) {
            openPath_.clear();
            const iris::Result r = e_->open(path.string());
            if (!r.ok()) {
                *err = "open(" + path.string() + "): " + describe(r);
                return false;
            }
            openPath_ = path.string();
        }
        return true;
    }

    // Slides listed as data rows, or a single "no data" row that the test skips.
    static bool addSlideRows(const std::function<void(const std::filesystem::path&)>& add) {
        const auto slides = slidesToTest();
        for (const auto& p : slides) add(p);
        return !slides.empty();
    }

private slots:
    void initTestCase() {
        if (!validationLayerInstalled()) {
            qWarning("VK_LAYER_KHRONOS_validation is not installed: validation messages cannot be checked here");
        }
        // These frames are compared with OpenSlide's bytes: the stored colours, without the
        // slide's ICC profile applied (engine.color checks the transform).
        iris::EngineConfig cfg;
        cfg.color.managed = false;
        e_ = createTestEngine(cfg);
        QVERIFY2(e_, describe(e_.error).c_str());
        const iris::DeviceInfo d = e_->device();
        qInfo("device: %s (%s), atlas slots %u", d.name.c_str(), d.driver.c_str(), d.atlasSlots);
    }

    void init() { e_.beginTest(); }

    void cleanup() {
        const std::string why = e_.endTest(); // good slides: no Error line
        QVERIFY2(why.empty(), why.c_str());
    }

    void cleanupTestCase() {
        refs_.clear();
        const std::string why = e_.finish();
        QVERIFY2(why.empty(), why.c_str());
    }

    // slideInfo() against OpenSlide's own figures, and the engine's 256×256 grid.
    void slideInfo_data() {
        QTest::addColumn<QString>("path");
        if (!addSlideRows([](const std::filesystem::path& p) {
                QTest::newRow(shortName(p).toUtf8().constData()) << QString::fromStdString(p.string());
            })) {
            QTest::newRow("no test data") << QString();
        }
    }
    void slideInfo() {
        QFETCH(QString, path);
        if (path.isEmpty()) QSKIP("no test data (set IRIS_TESTDATA or IRIS_TESTDATA_DEFAULT)");
        const std::filesystem::path p = path.toStdString();
        QVERIFY2(std::filesystem::exists(p), ("missing: " + p.string()).c_str());
        std::string err;
        OpenSlideRef* os = ref(p, &err);
        if (!os) QSKIP(("OpenSlide cannot read it, so it is not a pixel-test slide: " + err).c_str());
        QVERIFY2(prepare(p, 512, 384, &err), err.c_str());
        const auto info = e_->slideInfo();
        QVERIFY(info.has_value());
        QCOMPARE(info->width, os->levelWidth(0));
        QCOMPARE(info->height, os->levelHeight(0));
        QCOMPARE(QString::fromStdString(info->vendor), QString::fromStdString(os->vendor()));
        QCOMPARE(int(info->levels.size()), os->levelCount());
        for (int l = 0; l < os->levelCount(); ++l) {
            const iris::LevelInfo& li = info->levels[std::size_t(l)];
            QCOMPARE(li.width, os->levelWidth(l));
            QCOMPARE(li.height, os->levelHeight(l));
            QCOMPARE(li.downsample, os->levelDownsample(l));
            QCOMPARE(li.tilesX, (li.width + 255) / 256);
            QCOMPARE(li.tilesY, (li.height + 255) / 256);
        }
    }

    // The OpenSlide reader leaves out a level that is not coarser than the one before it (here
    // a second full-size directory) and must still read every level it keeps by OpenSlide's own
    // index of it: the 4× level drawn 1:1 is its directory's pixels (lossless, so exactly
    // syntheticPixel at 4× the level coordinates), not the left-out level's.
    void openSlideReaderLeavesOutALevel() {
        const auto path = testOutDir() / "pixel-exact-duplicate-level.tiff";
        std::string err;
        QVERIFY2(writeTiffPyramid(path, 2048, 1536, {{1}, {1}, {4}}, &err), err.c_str());
        iris::EngineConfig cfg;
        cfg.color.managed = false;
        cfg.source = iris::SourcePreference::OpenSlide;
        TestEngine os = createTestEngine(cfg);
        QVERIFY2(os, describe(os.error).c_str());
        constexpr uint32_t w = 333, h = 257;
        QVERIFY(os->bindOffscreen(w, h).ok());
        const iris::Result r = os->open(path.string());
        QVERIFY2(r.ok(), describe(r).c_str());
        const auto info = os->slideInfo();
        QVERIFY(info.has_value());
        QCOMPARE(int(info->levels.size()), 2);
        QCOMPARE(info->levels[1].width, int64_t(512));
        QCOMPARE(info->levels[1].downsample, 4.0);
        const int64_t kx = 100, ky = 70; // the frame's top-left level pixel; the frame stays inside the level
        auto frame = renderView(*os.engine, viewWithOrigin(double(kx) * 4, double(ky) * 4, 4.0, w, h), w, h, 30s, &err);
        QVERIFY2(frame.has_value(), err.c_str());
        iris::Image expected = makeImage(w, h);
        for (uint32_t j = 0; j < h; ++j)
            for (uint32_t i = 0; i < w; ++i) syntheticPixel((kx + i) * 4, (ky + j) * 4, pixel(expected, i, j));
        const DiffStats st = compareImages(frame->image, expected);
        if (st.differing) {
            QFAIL((st.summary() + "; " +
                   saveFailureArtefacts("pixel_exact.duplicate-level", frame->image, expected, nullptr))
                      .c_str());
        }
        const std::string why = os.finish();
        QVERIFY2(why.empty(), why.c_str());
    }

    // setBackground() at run time: the area outside the slide follows it (×255, rounded),
    // including EngineConfig's default 0.96 → 245. The view does not change, so the new
    // colour must show up without a view change (polled: no call promises which frame).
    void backgroundColour() {
        auto d = slidesDir("aperio");
        if (!d) QSKIP("no test data (set IRIS_TESTDATA or IRIS_TESTDATA_DEFAULT)");
        const auto path = *d / "small.svs"; // 16×16: almost all of the frame is background
        std::string err;
        QVERIFY2(prepare(path, 512, 384, &err), err.c_str());
        auto frame = renderView(*e_.engine, viewWithOrigin(-100, -100, 1.0, 512, 384), 512, 384, 30s, &err);
        QVERIFY2(frame.has_value(), err.c_str());
        Mask outside(512u * 384u, 1);
        for (uint32_t y = 90; y < 126; ++y) {
            for (uint32_t x = 90; x < 126; ++x) outside[y * 512u + x] = 0; // the slide and a margin
        }
        QCOMPARE(countNotColour(frame->image, backgroundBytes(), &outside), uint64_t(0));
        const std::array<float, 3> defaults = iris::EngineConfig{}.background;
        for (const auto& bg : {defaults, std::array<float, 3>{0.0f, 1.0f, 0.5f}, kBackground}) {
            e_->setBackground(bg[0], bg[1], bg[2]);
            const auto want = backgroundBytes(bg);
            QTRY_VERIFY_WITH_TIMEOUT(
                [&] {
                    auto f = e_->readFrame();
                    return f.ok() && countNotColour(f->image, want, &outside) == 0;
                }(),
                10000);
        }
        QCOMPARE(backgroundBytes(defaults), (std::array<uint8_t, 3>{245, 245, 245}));
    }

    // translate() and zoom(), the calls a pointer drives, keep the mapping exact: dragging by
    // (37, −11) target pixels at 1:1 shows the area 37 px further left and 11 px further
    // down, and zooming in and out around the same anchor returns to the same pixels.
    void translateAndZoom() {
        auto d = slidesDir("aperio");
        if (!d) QSKIP("no test data (set IRIS_TESTDATA or IRIS_TESTDATA_DEFAULT)");
        const auto path = *d / "CMU-1-Small-Region.svs";
        std::string err;
        QVERIFY2(prepare(path, 512, 384, &err), err.c_str());
        OpenSlideRef* os = ref(path, &err);
        QVERIFY2(os, err.c_str());
        const auto expectLevel0At = [&](int64_t x0, int64_t y0, const char* what) {
            const iris::Result w = e_->waitForFrame(30s);
            QVERIFY2(w.ok(), (std::string(what) + ": " + describe(w)).c_str());
            auto f = e_->readFrame();
            QVERIFY2(f.ok(), describe(f.error()).c_str());
            auto r = os->readLevel0(x0, y0, 512, 384, &err);
            QVERIFY2(r.has_value(), err.c_str());
            const DiffStats st = compareImages(f->image, *r);
            if (st.differing) {
                QFAIL((std::string(what) + ": " + st.summary() + "; " +
                       saveFailureArtefacts(std::string("pixel_exact.") + what, f->image, *r, nullptr))
                          .c_str());
            }
        };
        const iris::View start = viewWithOrigin(600, 900, 1.0, 512, 384);
        e_->setView(start);
        expectLevel0At(600, 900, "start");
        if (QTest::currentTestFailed()) return;

        e_->translate(37, -11);
        QCOMPARE(e_->view().centerX, start.centerX - 37);
        QCOMPARE(e_->view().centerY, start.centerY + 11);
        expectLevel0At(600 - 37, 900 + 11, "translated");
        if (QTest::currentTestFailed()) return;

        // The level-0 point under the anchor (continuous target coordinates) stays put.
        const iris::View before = e_->view();
        const double ax = 100.25, ay = 50.5;
        const auto under = [](const iris::View& v, double x, double y) {
            return std::pair{v.centerX + (x - 256.0) * v.downsample, v.centerY + (y - 192.0) * v.downsample};
        };
        e_->zoom(2.0, ax, ay);
        const iris::View zoomed = e_->view();
        QCOMPARE(zoomed.downsample, 0.5);
        QVERIFY(std::abs(under(zoomed, ax, ay).first - under(before, ax, ay).first) < 1e-9);
        QVERIFY(std::abs(under(zoomed, ax, ay).second - under(before, ax, ay).second) < 1e-9);
        QVERIFY2(e_->waitForFrame(30s).ok(), "no frame after zoom(2)");
        e_->zoom(0.5, ax, ay);
        const iris::View back = e_->view();
        QVERIFY(std::abs(back.centerX - before.centerX) < 1e-9 && std::abs(back.centerY - before.centerY) < 1e-9);
        QCOMPARE(back.downsample, 1.0);
        // Back at 1:1 on the same integer origin (up to 1e-9): the same bytes as before.
        expectLevel0At(600 - 37, 900 + 11, "zoomed in and out");
    }

    // The frame against read_region at `level`, with the view at that level's downsample.
    void matchesOpenSlide_data() {
        QTest::addColumn<QString>("path");
        QTest::addColumn<int>("level");
        QTest::addColumn<QString>("position");
        QTest::addColumn<uint>("width");
        QTest::addColumn<uint>("height");
        const bool any = addSlideRows([](const std::filesystem::path& p) {
            const QString name = shortName(p);
            const QString path = QString::fromStdString(p.string());
            for (const Position& pos : kLevel0Positions) {
                QTest::addRow("%s L0 %ux%u %s", name.toUtf8().constData(), pos.w, pos.h, pos.name)
                    << path << 0 << QString(pos.name) << uint(pos.w) << uint(pos.h);
            }
            // Coarser levels, as many as OpenSlide reports (data functions run when the suite
            // runs, after the sample_slide fixture has written the sample).
            std::string err;
            auto os = OpenSlideRef::open(p, &err);
            const int levels = os ? os->levelCount() : 1;
            for (int level = 1; level < levels; ++level) {
                for (const Position& pos : kLevelNPositions) {
                    QTest::addRow("%s L%d %ux%u %s", name.toUtf8().constData(), level, pos.w, pos.h, pos.name)
                        << path << level << QString(pos.name) << uint(pos.w) << uint(pos.h);
                }
            }
        });
        if (!any) QTest::newRow("no test data") << QString() << 0 << QString() << 0u << 0u;
    }
    void matchesOpenSlide() {
        QFETCH(QString, path);
        QFETCH(int, level);
        QFETCH(QString, position);
        QFETCH(uint, width);
        QFETCH(uint, height);
        if (path.isEmpty()) QSKIP("no test data (set IRIS_TESTDATA or IRIS_TESTDATA_DEFAULT)");
        const std::filesystem::path p = path.toStdString();
        QVERIFY2(std::filesystem::exists(p), ("missing: " + p.string()).c_str());
        std::string err;
        OpenSlideRef* os = ref(p, &err);
        if (!os) QSKIP(("OpenSlide cannot read it, so it is not a pixel-test slide: " + err).c_str());
        if (level >= os->levelCount()) QSKIP("the slide has no such level");

        QVERIFY2(prepare(p, width, height, &err), err.c_str());
        const auto info = e_->slideInfo();
        QVERIFY(info.has_value());
        QVERIFY(std::size_t(level) < info->levels.size());
        const iris::LevelInfo& li = info->levels[std::size_t(level)];
        QCOMPARE(li.width, os->levelWidth(level));
        QCOMPARE(li.height, os->levelHeight(level));

        const bool trusted = os->levelPixelsTrustworthy(level, &err);
        if (!trusted && position != "origin") QSKIP(("pixels not checked: " + err).c_str());

        // The frame's top-left output pixel is level pixel (kx, ky): origin = k · ds.
        const double ds = li.downsample;
        const auto [kx, ky] = originFor(position, li.width, li.height, width, height);
        const iris::View view = viewWithOrigin(double(kx) * ds, double(ky) * ds, ds, width, height);
        auto frame = renderView(*e_.engine, view, width, height, 30s, &err);
        QVERIFY2(frame.has_value(), err.c_str());
        const iris::Image& img = frame->image;
        QCOMPARE(countNotOpaque(img), uint64_t(0));

        auto refImg = os->readLevelRegion(level, kx, ky, width, height, &err);
        QVERIFY2(refImg.has_value(), err.c_str());

        // Expected frame and the masks of what is compared.
        //   inside:  the pixel's level pixel is in the level and its level-0 centre is in the
        //            slide → the level pixel's RGB, opaque;
        //   outside: the level-0 centre lies outside the slide and outside every level's
        //            extent (a coarse level can reach up to one of its pixels past the slide's
        //            level-0 edge, and may be drawn there) → the background colour;
        //   anything else (that sliver) is not compared.
        double extentW = double(info->width), extentH = double(info->height);
        for (const auto& l : info->levels) {
            extentW = std::max(extentW, double(l.width) * l.downsample);
            extentH = std::max(extentH, double(l.height) * l.downsample);
        }
        const auto bg = backgroundBytes();
        iris::Image expected = makeImage(width, height, {bg[0], bg[1], bg[2], 255});
        Mask inside(std::size_t(width) * height, 0), outside(std::size_t(width) * height, 0);
        uint64_t translucent = 0;
        for (uint32_t j = 0; j < height; ++j) {
            for (uint32_t i = 0; i < width; ++i) {
                const int64_t lx = kx + int64_t(i), ly = ky + int64_t(j);
                const double cx = (double(lx) + 0.5) * ds, cy = (double(ly) + 0.5) * ds;
                const bool inLevel = lx >= 0 && ly >= 0 && lx < li.width && ly < li.height;
                const bool inSlide = cx >= 0 && cy >= 0 && cx < double(info->width) && cy < double(info->height);
                const bool inAnyExtent = cx >= 0 && cy >= 0 && cx < extentW && cy < extentH;
                const std::size_t idx = std::size_t(j) * width + i;
                if (inLevel && inSlide) {
                    const uint8_t* s = pixel(*refImg, i, j);
                    if (s[3] != 255) {
                        // OpenSlide says "no data" (alpha 0) or translucent here; the engine's
                        // contract for such pixels is not pinned down, so they are not compared.
                        ++translucent;
                        continue;
                    }
                    std::memcpy(pixel(expected, i, j), s, 4);
                    inside[idx] = 1;
                } else if (!inSlide && !inAnyExtent) {
                    outside[idx] = 1;
                }
            }
        }
        if (translucent) qInfo("%llu reference pixels are not opaque and were not compared", (unsigned long long)translucent);

        const QString caseName = QString("pixel_exact.%1.L%2.%3x%4.%5")
                                     .arg(shortName(p)).arg(level).arg(width).arg(height).arg(position);
        const uint64_t badBackground = countNotColour(img, bg, &outside);
        if (!trusted) {
            // Dimensions were compared above; the engine must still draw a complete frame and
            // leave the outside of the slide alone.
            qInfo("level pixels not compared: %s", err.c_str());
            if (badBackground) {
                qWarning("%s", saveFailureArtefacts(caseName.toStdString(), img, expected, &outside).c_str());
            }
            QCOMPARE(badBackground, uint64_t(0));
            return;
        }

        const DiffStats st = compareImages(img, expected, &inside);
        if (st.differing != 0 || badBackground != 0) {
            Mask both(inside.size());
            for (std::size_t i = 0; i < both.size(); ++i) both[i] = inside[i] | outside[i];
            const std::string art = saveFailureArtefacts(caseName.toStdString(), img, expected, &both);
            const std::string msg = "inside the slide: " + st.summary() + "; outside the slide: " +
                                    std::to_string(badBackground) + " of " +
                                    std::to_string(std::count(outside.begin(), outside.end(), 1)) +
                                    " px not the background; " + art;
            QFAIL(msg.c_str());
        }
        QVERIFY2(st.compared > 0, "nothing of the slide was compared");
    }
};

QTEST_GUILESS_MAIN(TestPixelExact)
#include "tst_pixel_exact.moc"
