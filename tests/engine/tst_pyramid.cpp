// Synthetic levels (engine/src/slide/pyramid_source.h): a slide whose coarsest stored level is
// too large to keep resident (more than 256 of the engine's tiles; a slide without reduced
// levels, for example) gets levels at 2×, 4×, … that level's downsample, computed by the engine,
// until one fits. They are what keeps such a slide's screen from going empty and its overview
// map whole.
//
//   * the levels: which slides get them, their sizes (rounded up), downsamples, mpp,
//     magnification and the synthetic flag; slides with a small enough coarsest level keep
//     exactly the levels they store;
//   * their pixels: a frame drawn 1:1 from a synthetic level equals, byte for byte, the area
//     average (rounded to nearest) of the 2^k × 2^k blocks of level-0 pixels under each pixel,
//     computed here from the synthetic slide's pixel formula — also along the right and bottom
//     edges, where the blocks are cut by the slide's edge and average fewer pixels;
//   * the overview map of such a slide shows the whole slide while the view is zoomed in at
//     1:1 on level 0: no pixel of the thumbnail shows the background, and the thumbnail is
//     close to an area average of the slide at its downsample;
//   * a zoomed-out view is drawn from the synthetic levels, so it completes without reading
//     every level-0 tile into the atlas;
//   * a stored tile that fails to decode costs a synthetic tile only that tile's area (shown as
//     the failed-tile placeholder), and the error names the synthetic tile;
//   * a synthetic tile that takes long (thousands of stored tiles) stops when the engine lets
//     go of its slide: the next slide draws, and the engine is destroyed, without waiting;
//   * and while such tiles are computed one loader stays free, so a move to a view drawn from
//     stored tiles does not wait for them.
//
// The slides are "synthetic:WxH:1" (engine/src/slide/synthetic_source.h): procedural pixels,
// one stored level.
#include <QtTest>

#include <cmath>
#include <thread>

#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;

namespace {

// Pixel (i, j) of the level that averages 2^k × 2^k blocks of a W × H level 0: the rounded
// mean of the block's pixels inside the slide.
void blockAverage(int64_t i, int64_t j, int k, int64_t w, int64_t h, uint8_t* out) {
    const int64_t f = int64_t(1) << k;
    uint64_t sum[4] = {0, 0, 0, 0};
    uint64_t n = 0;
    for (int64_t y = j * f; y < std::min(h, (j + 1) * f); ++y) {
        for (int64_t x = i * f; x < std::min(w, (i + 1) * f); ++x) {
            uint8_t p[4];
            syntheticPixel(x, y, p);
            for (int c = 0; c < 4; ++c) sum[c] += p[c];
            ++n;
        }
    }
    for (int c = 0; c < 4; ++c) out[c] = uint8_t((sum[c] + n / 2) / n);
}

// The mean of level-0 pixels over the box [x0, x1) × [y0, y1) (level-0 units, clipped to the
// slide), fractional edge pixels weighted by their overlap.
std::array<double, 3> areaAverage(double x0, double y0, double x1, double y1, int64_t w, int64_t h) {
    x0 = std::max(0.0, x0), y0 = std::max(0.0, y0), x1 = std::min(double(w), x1), y1 = std::min(double(h), y1);
    std::array<double, 3> sum{0, 0, 0};
    double weight = 0;
    for (int64_t y = int64_t(std::floor(y0)); double(y) < y1; ++y) {
        const double wy = std::min(y1, double(y + 1)) - std::max(y0, double(y));
        for (int64_t x = int64_t(std::floor(x0)); double(x) < x1; ++x) {
            const double wx = std::min(x1, double(x + 1)) - std::max(x0, double(x));
            uint8_t p[4];
            syntheticPixel(x, y, p);
            for (int c = 0; c < 3; ++c) sum[size_t(c)] += wx * wy * p[c];
            weight += wx * wy;
        }
    }
    for (double& s : sum) s /= weight;
    return sum;
}


// Whether a loader got inside a tile read within `limit` (Engine::metrics' count of reads in
// progress; polled, since a read's start has no event of its own).
bool readStarted(iris::Engine& e, std::chrono::milliseconds limit = std::chrono::seconds(10)) {
    const auto end = std::chrono::steady_clock::now() + limit;
    while (e.metrics().tileReadsInProgress == 0) {
        if (std::chrono::steady_clock::now() > end) return false;
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return true;
}

} // namespace

class TstPyramid : public QObject {
    Q_OBJECT

    TestEngine e_;

    std::optional<iris::Frame> render(const iris::View& view, uint32_t w, uint32_t h) {
        if (const iris::Result r = e_->bindOffscreen(w, h); !r.ok()) {
            qWarning("bindOffscreen: %s", describe(r).c_str());
            return std::nullopt;
        }
        std::string why;
        auto f = renderView(*e_.engine, view, w, h, 120s, &why);
        if (!f) qWarning("%s", why.c_str());
        return f;
    }

    // A frame 1:1 with level `level` (downsample 2^k of a one-level slide) whose top-left corner
    // is that level's pixel (ox, oy), against the block averages (background past the edge).
    void checkOneToOne(const std::string& slide, int64_t w, int64_t h, int k, int64_t ox, int64_t oy, uint32_t fw,
                       uint32_t fh) {
        const double ds = double(int64_t(1) << k);
        auto f = render(viewWithOrigin(double(ox) * ds, double(oy) * ds, ds, fw, fh), fw, fh);
        QVERIFY(f);
        const int64_t lw = (w + (int64_t(1) << k) - 1) >> k, lh = (h + (int64_t(1) << k) - 1) >> k;
        iris::Image ref = makeImage(fw, fh);
        const std::array<uint8_t, 3> bg = backgroundBytes();
        for (uint32_t y = 0; y < fh; ++y) {
            for (uint32_t x = 0; x < fw; ++x) {
                uint8_t* p = pixel(ref, x, y);
                const int64_t i = ox + x, j = oy + y;
                if (i < lw && j < lh) {
                    blockAverage(i, j, k, w, h, p);
                } else {
                    p[0] = bg[0], p[1] = bg[1], p[2] = bg[2], p[3] = 255;
                }
            }
        }
        const DiffStats d = compareImages(f->image, ref);
        const std::string what = slide + " at downsample " + std::to_string(int(ds)) + ", origin (" +
                                 std::to_string(ox) + ", " + std::to_string(oy) + ")";
        qInfo("%s: %s", what.c_str(), d.summary().c_str());
        if (d.differing != 0) {
            qWarning("%s", saveFailureArtefacts("pyramid." + what, f->image, ref, nullptr).c_str());
        }
        QVERIFY2(d.differing == 0, (what + ": " + d.summary()).c_str());
    }

private slots:
    void initTestCase() {
        e_ = createTestEngine();
        QVERIFY2(e_, describe(e_.error).c_str());
    }

    void init() { e_.beginTest(); }

    void cleanup() {
        if (e_) e_->setOverlayVisible(iris::Overlay::Overview, false);
        const std::string why = e_.endTest();
        QVERIFY2(why.empty(), why.c_str());
    }

    void cleanupTestCase() {
        const std::string why = e_.finish();
        QVERIFY2(why.empty(), why.c_str());
    }

    // Which slides get synthetic levels, and what those levels are.
    void levels() {
        // Stored pyramids whose coarsest level fits: exactly the stored levels.
        for (const char* path : {"synthetic:60000x40000", "synthetic:4096x4096:1"}) {
            QVERIFY2(e_->open(path).ok(), path);
            const auto info = e_->slideInfo();
            QVERIFY(info.has_value());
            for (const iris::LevelInfo& l : info->levels) QVERIFY2(!l.synthetic, path);
        }
        if (const auto sample = sampleSlidePath()) {
            QVERIFY(e_->open(sample->string()).ok());
            const auto sampleInfo = e_->slideInfo(); // (a range-for over a temporary's member dangles)
            QVERIFY(sampleInfo.has_value());
            for (const iris::LevelInfo& l : sampleInfo->levels) QVERIFY(!l.synthetic);
        }

        // 4097 × 4096: 17 × 16 = 272 tiles > 256, so one level at 2× (2049 × 2048, 9 × 8 tiles).
        QVERIFY(e_->open("synthetic:4097x4096:1").ok());
        auto info = e_->slideInfo();
        QCOMPARE(info->levels.size(), size_t(2));
        QVERIFY(!info->levels[0].synthetic);
        QVERIFY(info->levels[1].synthetic);
        QCOMPARE(info->levels[1].width, int64_t(2049));
        QCOMPARE(info->levels[1].height, int64_t(2048));
        QCOMPARE(info->levels[1].downsample, 2.0);
        QCOMPARE(info->levels[1].tilesX, int64_t(9));
        QCOMPARE(info->levels[1].tilesY, int64_t(8));
        QCOMPARE(info->levels[1].mppX, 0.5); // the synthetic slide's 0.25 µm/px × 2
        QCOMPARE(info->levels[1].magnification, 20.0); // its 40× ÷ 2

        // 9000 × 9000 (1296 tiles): 4500² has 324 tiles, still too many; 2250² has 81.
        QVERIFY(e_->open("synthetic:9000x9000:1").ok());
        info = e_->slideInfo();
        QCOMPARE(info->levels.size(), size_t(3));
        QVERIFY(!info->levels[0].synthetic && info->levels[1].synthetic && info->levels[2].synthetic);
        QCOMPARE(info->levels[1].width, int64_t(4500));
        QCOMPARE(info->levels[2].width, int64_t(2250));
        QCOMPARE(info->levels[2].downsample, 4.0);
        QCOMPARE(info->levels[2].tilesX * info->levels[2].tilesY, int64_t(81));

        // A stored pyramid that stops early: synthetic levels continue from its coarsest level.
        // 20000 × 20000 with 2 stored levels: 10000² (1600 tiles) → 5000², 2500² (100 tiles).
        QVERIFY(e_->open("synthetic:20000x20000:2").ok());
        info = e_->slideInfo();
        QCOMPARE(info->levels.size(), size_t(4));
        QVERIFY(!info->levels[1].synthetic && info->levels[2].synthetic && info->levels[3].synthetic);
        QCOMPARE(info->levels[2].downsample, 4.0);
        QCOMPARE(info->levels[3].downsample, 8.0);
        QCOMPARE(info->levels[3].width, int64_t(2500));
        e_->close();
    }

    // Drawn 1:1, a synthetic level is exactly the area average of the stored level.
    void pixelsAreBlockAverages() {
        // Odd sizes: the last column and row of the 2× level average 1 × 2, 2 × 1 and 1 × 1
        // blocks. 4353 × 4101 has 18 × 17 tiles, so one synthetic level (2177 × 2051).
        QVERIFY(e_->open("synthetic:4353x4101:1").ok());
        QCOMPARE(e_->slideInfo()->levels.size(), size_t(2));
        checkOneToOne("synthetic:4353x4101:1", 4353, 4101, 1, 0, 0, 512, 384);
        checkOneToOne("synthetic:4353x4101:1", 4353, 4101, 1, 300, 700, 512, 384); // across tile seams
        checkOneToOne("synthetic:4353x4101:1", 4353, 4101, 1, 1800, 1800, 512, 384); // the corner, and past it
        // Two synthetic levels: the 4× one averages 4 × 4 blocks of level 0 (not of the 2× level).
        QVERIFY(e_->open("synthetic:9000x9000:1").ok());
        checkOneToOne("synthetic:9000x9000:1", 9000, 9000, 2, 1000, 1100, 512, 384);
        checkOneToOne("synthetic:9000x9000:1", 9000, 9000, 2, 2000, 2000, 512, 384);
        e_->close();
    }

    // Zoomed in at 1:1 on level 0, the overview map still shows the whole slide.
    void overviewShowsTheWholeSlide() {
        const uint32_t w = 640, h = 480;
        const int64_t sw = 9000, sh = 9000;
        QVERIFY(e_->open("synthetic:9000x9000:1").ok());
        e_->setOverlayVisible(iris::Overlay::Overview, true);
        auto f = render(viewWithOrigin(5000, 3000, 1.0, w, h), w, h);
        QVERIFY(f);
        const iris::PixelRect img = f->overlays.overviewImage;
        const double ds = f->overlays.overviewDownsample;
        QVERIFY(!img.empty() && ds > 0);
        qInfo("thumbnail %dx%d at (%d, %d), downsample %.3f", img.width, img.height, img.x, img.y, ds);
        // Compare inside the thumbnail, a pixel in from its edge (its border is the plate's
        // antialiased edge), away from the field's outline (the view is a few pixels wide there).
        const auto& field = f->overlays.overviewField;
        Mask mask(size_t(w) * h, 0);
        iris::Image ref = makeImage(w, h);
        uint64_t masked = 0;
        for (int y = img.y + 1; y < img.y + img.height - 1; ++y) {
            for (int x = img.x + 1; x < img.x + img.width - 1; ++x) {
                if (x >= field[0] - 3 && x <= field[2] + 3 && y >= field[1] - 3 && y <= field[3] + 3) continue;
                mask[size_t(y) * w + size_t(x)] = 1;
                ++masked;
                const double sx = (x - img.x) * ds, sy = (y - img.y) * ds;
                const auto avg = areaAverage(sx, sy, sx + ds, sy + ds, sw, sh);
                uint8_t* p = pixel(ref, uint32_t(x), uint32_t(y));
                for (int c = 0; c < 3; ++c) p[c] = uint8_t(std::lround(avg[size_t(c)]));
                p[3] = 255;
            }
        }
        QVERIFY(masked > uint64_t(img.width) * img.height / 2);
        // Every compared pixel shows the slide: none is the background (a missing tile).
        uint64_t background = 0;
        const std::array<uint8_t, 3> bg = backgroundBytes();
        for (size_t i = 0; i < mask.size(); ++i) {
            const uint8_t* p = f->image.rgba.data() + i * 4;
            if (mask[i] && p[0] == bg[0] && p[1] == bg[1] && p[2] == bg[2]) ++background;
        }
        const DiffStats d = compareImages(f->image, ref, &mask);
        qInfo("thumbnail vs the area average at downsample %.3f: %s; background pixels %llu", ds, d.summary().c_str(),
              static_cast<unsigned long long>(background));
        if (background != 0 || d.meanAbs > kThumbnailMeanBound)
            qWarning("%s", saveFailureArtefacts("pyramid.overview", f->image, ref, &mask).c_str());
        QCOMPARE(background, uint64_t(0));
        // The thumbnail is the 4× synthetic level drawn through its (sharpened) mips at about
        // 12×: mean differences of a few levels against an exact area average, most of them
        // along the 256-px checker's edges. A missing or misplaced part is tens of levels.
        QVERIFY2(d.meanAbs <= kThumbnailMeanBound, d.summary().c_str());
        e_->close();
    }

    // A fitted view of a large one-level slide is drawn from the synthetic levels: it completes
    // with a few dozen tiles in the atlas instead of every level-0 tile.
    void fittedViewUsesSyntheticLevels() {
        const uint64_t before = e_->metrics().tilesBuffered;
        QVERIFY(e_->open("synthetic:9000x9000:1").ok());
        const iris::View fit = iris::View{4500, 4500, 9000.0 / 384};
        auto f = render(fit, 512, 384);
        QVERIFY(f);
        const uint64_t buffered = e_->metrics().tilesBuffered - before;
        qInfo("fitted: %llu tiles buffered", static_cast<unsigned long long>(buffered));
        // The 81 tiles of the 4× level; drawing from level 0 would need all 1296.
        QVERIFY2(buffered >= 81 && buffered < 300, std::to_string(buffered).c_str());
        e_->close();
    }

    // A stored tile that cannot be decoded costs a synthetic tile only its own area: the rest
    // of the synthetic tile is exact, the broken area shows the failed-tile placeholder (grey
    // and red), and the error is reported with the synthetic tile it touched.
    void brokenStoredTileCostsOnlyItsArea() {
        // 18 × 18 stored tiles (too many to keep resident): one synthetic level at 2×, 9 × 9.
        const fs::path path = testOutDir() / "one-level-broken-tile.tiff";
        std::string why;
        QVERIFY2(writeOneLevelTiff(path, 4608, 4608, {{5, 7}}, &why), why.c_str());
        QVERIFY(e_->open(path.string()).ok());
        QCOMPARE(e_->slideInfo()->levels.size(), size_t(2));
        QVERIFY(e_->slideInfo()->levels[1].synthetic);

        // Synthetic tile (2, 3) 1:1: level-1 pixels [512, 768) × [768, 1024). Stored tile
        // (5, 7) is its bottom-right quarter.
        auto f = render(viewWithOrigin(512 * 2.0, 768 * 2.0, 2.0, 256, 256), 256, 256);
        QVERIFY(f);
        iris::Image ref = makeImage(256, 256);
        Mask outside(size_t(256) * 256, 1);
        uint64_t placeholderLike = 0, brokenArea = 0;
        for (uint32_t y = 0; y < 256; ++y) {
            for (uint32_t x = 0; x < 256; ++x) {
                blockAverage(512 + x, 768 + y, 1, 4608, 4608, pixel(ref, x, y));
                if (x < 128 || y < 128) continue;
                outside[size_t(y) * 256 + x] = 0;
                const uint8_t* p = pixel(f->image, x, y);
                ++brokenArea;
                if (p[1] == p[2] && p[0] >= p[1] && p[1] >= 40) ++placeholderLike; // grey, red or a mix
            }
        }
        const DiffStats d = compareImages(f->image, ref, &outside);
        qInfo("outside the broken stored tile: %s; inside, %llu of %llu pixels are the placeholder's",
              d.summary().c_str(), static_cast<unsigned long long>(placeholderLike),
              static_cast<unsigned long long>(brokenArea));
        if (d.differing != 0) qWarning("%s", saveFailureArtefacts("pyramid.broken", f->image, ref, &outside).c_str());
        QVERIFY2(d.differing == 0, d.summary().c_str());
        QCOMPARE(placeholderLike, brokenArea);

        const auto errors = e_.log->takeErrors();
        QVERIFY(!errors.empty());
        bool named = false;
        for (const auto& line : errors) named = named || line.find("level 1 tile 2,3 shows 1 of its 4 stored tiles") != std::string::npos;
        QVERIFY2(named, errors.front().c_str());
        QVERIFY(!e_->error().ok());
        e_->close();
    }

    // A synthetic tile of a huge one-level slide reads thousands of stored tiles (here 65536,
    // tens of seconds). Opening another slide, or destroying the engine, must not wait for it.
    void lettingGoStopsLongReads() {
        TestEngine e = createTestEngine();
        QVERIFY2(e, describe(e.error).c_str());
        QVERIFY(e->bindOffscreen(256, 256).ok());
        // 1000000² (3907² tiles): synthetic levels down to 2^8 (3907², 16 × 16 tiles).
        QVERIFY(e->open("synthetic:1000000x1000000:1").ok());
        QCOMPARE(e->slideInfo()->levels.back().downsample, 256.0);
        // A loader inside a synthetic tile's reads (every tile of this view is synthetic).
        QVERIFY2(readStarted(*e.engine), "no tile read started within 10 s");
        QVERIFY(e->open("synthetic:2000x2000").ok());
        std::string why;
        const auto t0 = std::chrono::steady_clock::now();
        auto f = renderView(*e.engine, e->view(), 256, 256, 10s, &why);
        QVERIFY2(f, why.c_str());
        const double switchS = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

        QVERIFY(e->open("synthetic:1000000x1000000:1").ok());
        QVERIFY2(readStarted(*e.engine), "no tile read started within 10 s");
        const auto t1 = std::chrono::steady_clock::now();
        e.engine.reset();
        const double destroyS = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
        qInfo("next slide drawn %.2f s after the switch; engine destroyed in %.2f s", switchS, destroyS);
        QVERIFY2(destroyS < 5, std::to_string(destroyS).c_str());
        const auto errors = e.log->takeErrors();
        for (const auto& line : errors) qWarning("engine logged an error: %s", line.c_str());
        QVERIFY2(errors.empty(), "an abandoned read is not an error");
    }

    // While loaders compute synthetic tiles, one of them stays free: a move to a view drawn from
    // stored tiles is drawn at once, not after the synthetic tiles in progress (here 65536
    // stored reads each, tens of seconds).
    void aMoveDoesNotWaitForSyntheticTiles() {
        TestEngine e = createTestEngine(); // two loaders
        QVERIFY2(e, describe(e.error).c_str());
        QVERIFY(e->bindOffscreen(256, 256).ok());
        QVERIFY(e->open("synthetic:1000000x1000000:1").ok()); // fitted: drawn from the 2^8 level
        QVERIFY2(readStarted(*e.engine), "no tile read started within 10 s");
        std::string why;
        const auto t0 = std::chrono::steady_clock::now();
        auto f = renderView(*e.engine, iris::View{500000.5, 500000.5, 1.0}, 256, 256, 10s, &why);
        QVERIFY2(f, why.c_str());
        qInfo("1:1 view drawn %.2f s after the move",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        e.engine.reset(); // abandons the synthetic read still going
        const auto errors = e.log->takeErrors();
        for (const auto& line : errors) qWarning("engine logged an error: %s", line.c_str());
        QVERIFY(errors.empty());
    }

private:
    static constexpr double kThumbnailMeanBound = 8.0;
};

QTEST_GUILESS_MAIN(TstPyramid)
#include "tst_pyramid.moc"
