// mips.enhancement (issue 6): the single-dispatch mip reduction against its CPU reference
// (engine/src/gpu/mip_kernel.cpp, compiled into this test). CTest runs it once per schedule
// (IRIS_MIP_SCHEDULE=wide: shaders/mip_reduce.comp, 16 workgroups per tile; =serial:
// shaders/mip_reduce_serial.comp; =host: the buffer thread's mipkernel::reduceChain8, uploaded
// with the base level), and the test checks the engine really uses that schedule.
//
// Reading GPU mips back. There is no engine hook; instead a slide whose only level is level 0
// (synthetic:512x512, and CMU-1-Small-Region.svs, both single-level) is rendered at downsample
// 2^k with the frame's origin at the slide's (0, 0): the renderer then samples mip k (LOD
// log2(2^k / 1) = k exactly) at texel centres, so every frame pixel is one mip-k texel of one
// level-0 tile, byte for byte (linear filtering with zero weights). Only tiles wholly inside
// the slide are compared (edge tiles hold padding).
//
// Cases: GPU = CPU reference within 1/255 at every level 1..8 (the host schedule: equal), enhancement on and off, on
// synthetic and real tiles; enhancement off = an independent area average within 1/255; a
// flat tile stays flat; a tile's mips do not depend on its neighbours; sharpness on tissue at
// downsample 8 (mean squared Laplacian of luma) and a step edge's overshoot within λ/4.
#include <QtTest>

#include <algorithm>
#include <cmath>

#include "gpu/mip_kernel.h"
#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;
namespace mk = iris::gpu::mipkernel;

namespace {

constexpr uint32_t kFrame = 256;
constexpr int kTile = 256;
using Tile = std::vector<uint8_t>; // 256×256 RGBA8

Tile syntheticTile(int tx, int ty) {
    Tile t(size_t(kTile) * kTile * 4);
    for (int y = 0; y < kTile; ++y)
        for (int x = 0; x < kTile; ++x)
            syntheticPixel(int64_t(tx) * kTile + x, int64_t(ty) * kTile + y, &t[(size_t(y) * kTile + x) * 4]);
    return t;
}

// An area average written independently of the kernel (for "enhancement off").
std::vector<uint8_t> areaAverage(const Tile& t, int level) {
    const int r = 1 << level, n = kTile >> level;
    std::vector<uint8_t> out(size_t(n) * n * 4);
    for (int py = 0; py < n; ++py)
        for (int px = 0; px < n; ++px)
            for (int c = 0; c < 4; ++c) {
                double s = 0;
                for (int y = 0; y < r; ++y)
                    for (int x = 0; x < r; ++x) s += t[(size_t(py * r + y) * kTile + size_t(px * r + x)) * 4 + c];
                out[(size_t(py) * n + px) * 4 + c] = uint8_t(std::lround(s / (r * r)));
            }
    return out;
}

// The engine limits zooming out to a few times the fit view, so the frame shrinks with k:
// ceil(longest side / 2^k) pixels (at most 256), which shows the whole slide.
std::optional<iris::Frame> renderMip(iris::Engine& e, int k, std::string* why) {
    const double ds = double(1 << k);
    const auto info = e.slideInfo();
    const int64_t side = info ? std::max(info->width, info->height) : 512;
    const uint32_t f = uint32_t(std::clamp<int64_t>((side + (int64_t(1) << k) - 1) >> k, 2, kFrame));
    if (iris::Result r = e.bindOffscreen(f, f); !r.ok()) {
        *why = describe(r);
        return std::nullopt;
    }
    return renderView(e, viewWithOrigin(0, 0, ds, f, f), f, f, 60s, why);
}

// Largest RGB difference between the frame's region of tile (tx, ty) at level k and `ref`.
int tileDiff(const iris::Image& frame, int tx, int ty, int k, const std::vector<uint8_t>& ref) {
    const int n = kTile >> k;
    int worst = 0;
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            const uint8_t* f = pixel(frame, uint32_t(tx * n + x), uint32_t(ty * n + y));
            const uint8_t* r = &ref[(size_t(y) * n + x) * 4];
            for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(int(f[c]) - int(r[c])));
        }
    return worst;
}

std::optional<std::filesystem::path> cmuPath() {
    auto dir = slidesDir("aperio");
    if (!dir) return std::nullopt;
    auto p = *dir / "CMU-1-Small-Region.svs";
    if (!std::filesystem::exists(p)) return std::nullopt;
    return p;
}

double luma(const uint8_t* p) { return 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2]; }

// Mean squared 4-neighbour Laplacian of luma over the interior (the high-frequency energy).
double laplacianEnergy(const iris::Image& img) {
    double sum = 0;
    uint64_t count = 0;
    for (uint32_t y = 1; y + 1 < img.height; ++y)
        for (uint32_t x = 1; x + 1 < img.width; ++x) {
            const double l = luma(pixel(img, x - 1, y)) + luma(pixel(img, x + 1, y)) + luma(pixel(img, x, y - 1)) +
                             luma(pixel(img, x, y + 1)) - 4 * luma(pixel(img, x, y));
            sum += l * l;
            ++count;
        }
    return sum / double(count);
}

double meanLuma(const iris::Image& img) {
    double s = 0;
    for (uint32_t y = 0; y < img.height; ++y)
        for (uint32_t x = 0; x < img.width; ++x) s += luma(pixel(img, x, y));
    return s / (double(img.width) * img.height);
}

} // namespace

class TestMips : public QObject {
    Q_OBJECT

    TestEngine engine_;

    void openWith(const std::string& path, bool enhance) {
        engine_->setEnhance(enhance);
        const iris::Result r = engine_->open(path); // a fresh generation: no tile of the other setting
        QVERIFY2(r.ok(), describe(r).c_str());
    }

    // Compares every level 1..8 of tiles [0, cols) × [0, rows) with the kernel (and, with
    // enhancement off, with an independent area average); `tile` gives the level-0 tiles.
    void compareLevels(const std::string& path, bool enhance, int cols, int rows,
                       const std::function<Tile(int, int)>& tile) {
        openWith(path, enhance);
        std::vector<Tile> tiles;
        for (int ty = 0; ty < rows; ++ty)
            for (int tx = 0; tx < cols; ++tx) tiles.push_back(tile(tx, ty));
        for (int k = 1; k <= mk::kLevels; ++k) {
            std::string why;
            const auto frame = renderMip(*engine_.engine, k, &why);
            QVERIFY2(frame, why.c_str());
            const int n = kTile >> k;
            int worst = 0, worstArea = 0, compared = 0;
            for (int ty = 0; ty < rows; ++ty)
                for (int tx = 0; tx < cols; ++tx) {
                    if ((tx + 1) * n > int(frame->image.width) || (ty + 1) * n > int(frame->image.height)) continue;
                    const Tile& t = tiles[size_t(ty * cols + tx)];
                    worst = std::max(worst, tileDiff(frame->image, tx, ty, k, mk::reduceLevel8(t.data(), k, enhance)));
                    if (!enhance) worstArea = std::max(worstArea, tileDiff(frame->image, tx, ty, k, areaAverage(t, k)));
                    ++compared;
                }
            qInfo("%s enhance=%d level %d: %d tiles, max |GPU - CPU| = %d%s", path.c_str(), int(enhance), k, compared,
                  worst, enhance ? "" : qPrintable(QString(", max |GPU - area average| = %1").arg(worstArea)));
            QVERIFY(compared > 0);
            // The shaders' float steps may round a value the other way; the host schedule runs the
            // reference's own expressions, so its levels are the reference's bytes.
            const int allowed = engine_->device().mipSchedule == "host" ? 0 : 1;
            QVERIFY2(worst <= allowed,
                     qPrintable(QString("level %1: GPU differs from the CPU reference by %2").arg(k).arg(worst)));
            QVERIFY2(worstArea <= 1, qPrintable(QString("level %1: not the area average (%2)").arg(k).arg(worstArea)));
        }
    }

private slots:
    void initTestCase() {
        engine_ = createTestEngine();
        QVERIFY2(engine_, describe(engine_.error).c_str());
        if (!validationLayerInstalled()) qWarning("validation layer not installed: validationMessageCount proves nothing");
        QVERIFY(engine_->bindOffscreen(kFrame, kFrame).ok());
        const QByteArray schedule = qgetenv("IRIS_MIP_SCHEDULE");
        qInfo("mip schedule: %s", engine_->device().mipSchedule.c_str());
        if (!schedule.isEmpty()) QCOMPARE(QString::fromStdString(engine_->device().mipSchedule), QString(schedule));
    }
    void cleanupTestCase() {
        if (engine_) QCOMPARE(engine_->validationMessageCount(), uint64_t(0));
        engine_ = {};
    }

    void gpuMatchesCpu_synthetic_data() {
        QTest::addColumn<bool>("enhance");
        QTest::newRow("enhanced") << true;
        QTest::newRow("plain") << false;
    }
    void gpuMatchesCpu_synthetic() {
        QFETCH(bool, enhance);
        compareLevels("synthetic:512x512", enhance, 2, 2, syntheticTile);
        QCOMPARE(engine_->validationMessageCount(), uint64_t(0));
    }

    void gpuMatchesCpu_real_data() { gpuMatchesCpu_synthetic_data(); }
    void gpuMatchesCpu_real() {
        QFETCH(bool, enhance);
        const auto path = cmuPath();
        if (!path) QSKIP("CMU-1-Small-Region.svs not found ($IRIS_TESTDATA)");
        std::string err;
        auto ref = OpenSlideRef::open(*path, &err);
        QVERIFY2(ref, err.c_str());
        QCOMPARE(ref->levelCount(), 1); // level 0 is the HR level at every downsample
        const int cols = int(ref->levelWidth(0) / kTile), rows = int(ref->levelHeight(0) / kTile);
        compareLevels(path->string(), enhance, cols, rows, [&](int tx, int ty) {
            auto img = ref->readLevel0(int64_t(tx) * kTile, int64_t(ty) * kTile, kTile, kTile, &err);
            return img ? img->rgba : Tile(size_t(kTile) * kTile * 4, 0);
        });
        QCOMPARE(engine_->validationMessageCount(), uint64_t(0));
    }

    // A flat tile keeps its exact value at every level, both settings (kernel weights sum to 1).
    void flatTileStaysFlat() {
        for (int v : {0, 1, 37, 128, 254, 255}) {
            const Tile t(size_t(kTile) * kTile * 4, uint8_t(v));
            for (bool enhance : {false, true})
                for (int k = 1; k <= mk::kLevels; ++k) {
                    const std::vector<float> f = mk::reduceLevel(t.data(), k, enhance);
                    for (float x : f)
                        QVERIFY2(x == float(v) / 255.0f, qPrintable(QString("value %1 level %2 enhance %3: %4")
                                                                       .arg(v).arg(k).arg(enhance).arg(double(x) * 255)));
                }
        }
    }

    // The GPU kernel reads only inside the tile: tile (0, 0) of a 256×256 slide (no neighbours)
    // and of a 512×512 slide (three neighbours) give identical bytes at every level.
    void independentOfNeighbours() {
        std::vector<iris::Image> alone, withNeighbours;
        for (const char* path : {"synthetic:256x256", "synthetic:512x512"}) {
            openWith(path, true);
            for (int k = 1; k <= mk::kLevels; ++k) {
                std::string why;
                const auto frame = renderMip(*engine_.engine, k, &why);
                QVERIFY2(frame, why.c_str());
                (std::string(path) == "synthetic:256x256" ? alone : withNeighbours).push_back(frame->image);
            }
        }
        for (int k = 1; k <= mk::kLevels; ++k) {
            const int n = kTile >> k;
            int worst = 0;
            for (int y = 0; y < n; ++y)
                for (int x = 0; x < n; ++x)
                    for (int c = 0; c < 4; ++c)
                        worst = std::max(worst, std::abs(int(pixel(alone[size_t(k - 1)], uint32_t(x), uint32_t(y))[c]) -
                                                         int(pixel(withNeighbours[size_t(k - 1)], uint32_t(x), uint32_t(y))[c])));
            QVERIFY2(worst == 0, qPrintable(QString("level %1: tile (0,0) depends on its neighbours (%2)").arg(k).arg(worst)));
        }
        QCOMPARE(engine_->validationMessageCount(), uint64_t(0));
    }

    // Real tissue at downsample 8: the enhanced frame has a higher mean squared Laplacian of
    // luma than the plain one; mean luma is unchanged (normalised kernel). Also checks that
    // Engine::setEnhance alone (no re-open) re-buffers the visible tiles.
    void sharperOnTissue() {
        const auto path = cmuPath();
        if (!path) QSKIP("CMU-1-Small-Region.svs not found ($IRIS_TESTDATA)");
        openWith(path->string(), false);
        QVERIFY(engine_->bindOffscreen(kFrame, kFrame).ok());
        const iris::View v = viewWithOrigin(8.0 * 8, 8.0 * 8, 8.0, kFrame, kFrame);
        std::string why;
        const auto plain = renderView(*engine_.engine, v, kFrame, kFrame, 60s, &why);
        QVERIFY2(plain, why.c_str());
        engine_->setEnhance(true); // the toggle alone must re-make the mips
        const auto sharp = renderView(*engine_.engine, v, kFrame, kFrame, 60s, &why);
        QVERIFY2(sharp, why.c_str());
        const iris::Image a = plain->image, b = sharp->image;
        const double ea = laplacianEnergy(a), eb = laplacianEnergy(b);
        const double ma = meanLuma(a), mb = meanLuma(b);
        qInfo("downsample 8: mean squared Laplacian of luma plain %.2f, enhanced %.2f (x%.2f); mean luma %.3f / %.3f",
              ea, eb, eb / ea, ma, mb);
        writePng(testOutDir() / "mips-ds8-plain.png", a);
        writePng(testOutDir() / "mips-ds8-enhanced.png", b);
        QVERIFY2(eb > 1.5 * ea, "enhancement does not raise the high-frequency energy by 1.5x");
        QVERIFY2(std::abs(ma - mb) < 0.5, "enhancement changes the mean brightness");
        QCOMPARE(engine_->validationMessageCount(), uint64_t(0));
    }

    // A vertical step edge (low → high, at several positions): no level over- or undershoots by
    // more than λ/4 of the step height (the kernel's negative lobe), plus rounding; and the
    // enhancement does steepen it (some overshoot > 0 somewhere).
    void stepEdgeOvershoot() {
        const int low = 51, high = 204;
        double most = 0;
        for (int edge : {1, 37, 100, 128, 129, 200}) {
            Tile t(size_t(kTile) * kTile * 4);
            for (int y = 0; y < kTile; ++y)
                for (int x = 0; x < kTile; ++x)
                    for (int c = 0; c < 4; ++c) t[(size_t(y) * kTile + x) * 4 + c] = uint8_t(c == 3 ? 255 : x < edge ? low : high);
            for (int k = 1; k <= mk::kLevels; ++k) {
                const std::vector<float> f = mk::reduceLevel(t.data(), k, true);
                for (size_t i = 0; i < f.size(); i += 4) {
                    const double v = f[i] * 255.0;
                    const double over = std::max(v - high, low - v) / (high - low);
                    most = std::max(most, over);
                }
            }
        }
        qInfo("step edge: largest overshoot %.4f of the step height (bound %.4f)", most, double(mk::kOvershootBound));
        QVERIFY(most > 0.01);
        QVERIFY(most <= double(mk::kOvershootBound) + 1e-5);
    }
};

QTEST_GUILESS_MAIN(TestMips)
#include "tst_mips.moc"
