// unit.mip_chain: the host mip schedule's kernel (mipkernel::reduceChain8, what the buffer
// thread runs where the device is the CPU) against the CPU reference (reduceLevel8, level by
// level from the base): every byte of every level 1..8 equal, with the enhancement on and off,
// on tiles that reach the kernel's corners — random noise, flat tiles of 0 and 255, a
// one-texel checker of 0 and 255 (the largest |A − G|, so the clamp at 0 and 1 is taken),
// steps and lines at block and tile edges (the blur's index clamp), and real tissue from the
// sample slide's generator — and at other gains λ. Also under ASan (its scratch is per thread;
// two threads run it at once).
#include <QtTest>

#include <chrono>
#include <cstring>
#include <random>
#include <thread>

#include "gpu/mip_kernel.h"
#include "test_support.h"

namespace mk = iris::gpu::mipkernel;

namespace {

using Tile = std::vector<uint8_t>;
constexpr int kTile = mk::kTile;

Tile makeTile(const std::function<void(int, int, uint8_t*)>& f) {
    Tile t(size_t(kTile) * kTile * 4);
    for (int y = 0; y < kTile; ++y)
        for (int x = 0; x < kTile; ++x) f(x, y, &t[(size_t(y) * kTile + x) * 4]);
    return t;
}

// The first difference between the chain and the reference, or empty.
QString differs(const Tile& t, bool enhance, float lambda) {
    std::vector<uint8_t> chain(mk::kChainBytes, 0xA5);
    mk::reduceChain8(t.data(), chain.data(), enhance, lambda);
    for (int k = 1; k <= mk::kLevels; ++k) {
        const std::vector<uint8_t> ref = mk::reduceLevel8(t.data(), k, enhance, lambda);
        const uint8_t* got = chain.data() + mk::chainOffset(k);
        for (size_t i = 0; i < ref.size(); ++i)
            if (got[i] != ref[i]) {
                const int n = kTile >> k;
                return QString("level %1 texel (%2, %3) channel %4: chain %5, reference %6")
                    .arg(k).arg((i / 4) % n).arg((i / 4) / n).arg(i % 4).arg(got[i]).arg(ref[i]);
            }
    }
    return {};
}

} // namespace

class TestMipChain : public QObject {
    Q_OBJECT
private slots:
    void layout() {
        QCOMPARE(mk::chainOffset(1), size_t(0));
        QCOMPARE(mk::chainOffset(2), size_t(128 * 128 * 4));
        QCOMPARE(mk::chainOffset(8), size_t(4 * (16384 + 4096 + 1024 + 256 + 64 + 16 + 4)));
        QCOMPARE(mk::kChainBytes, size_t(87380));
    }

    void equalsReference_data() {
        QTest::addColumn<int>("kind");
        QTest::addColumn<bool>("enhance");
        QTest::addColumn<float>("lambda");
        const char* kinds[] = {"noise", "black", "white", "checker", "steps", "lines", "tissue", "alpha"};
        for (int k = 0; k < 8; ++k)
            for (bool enhance : {false, true})
                for (float lambda : {mk::kLambda, 1.0f, 0.125f}) {
                    if (!enhance && lambda != mk::kLambda) continue;
                    QTest::addRow("%s enhance=%d lambda=%g", kinds[k], int(enhance), double(lambda))
                        << k << enhance << lambda;
                }
    }
    void equalsReference() {
        QFETCH(int, kind);
        QFETCH(bool, enhance);
        QFETCH(float, lambda);
        std::mt19937 rng(uint32_t(1234 + kind));
        Tile t;
        switch (kind) {
        case 0: t = makeTile([&](int, int, uint8_t* p) { for (int c = 0; c < 4; ++c) p[c] = uint8_t(rng()); }); break;
        case 1: t = makeTile([](int, int, uint8_t* p) { std::memset(p, 0, 4); }); break;
        case 2: t = makeTile([](int, int, uint8_t* p) { std::memset(p, 255, 4); }); break;
        case 3: t = makeTile([](int x, int y, uint8_t* p) { std::memset(p, ((x ^ y) & 1) ? 255 : 0, 4); }); break;
        case 4: // steps at 2^k block edges and off them
            t = makeTile([](int x, int y, uint8_t* p) {
                p[0] = x < 128 ? 0 : 255;
                p[1] = y < 77 ? 255 : 3;
                p[2] = (x + y) < 200 ? 10 : 250;
                p[3] = 255;
            });
            break;
        case 5: // one-texel lines on the tile's edges and in the middle
            t = makeTile([](int x, int y, uint8_t* p) {
                const bool line = x == 0 || y == 0 || x == kTile - 1 || y == kTile - 1 || x == 129 || y == 64;
                std::memset(p, line ? 0 : 255, 3);
                p[3] = 255;
            });
            break;
        case 6: // the sample slide's synthetic tissue
            t = makeTile([](int x, int y, uint8_t* p) { iristest::syntheticPixel(int64_t(x) + 3 * kTile, int64_t(y) + 5 * kTile, p); });
            break;
        case 7: // noise in alpha too, with sharp edges between opaque and clear
            t = makeTile([&](int x, int, uint8_t* p) {
                for (int c = 0; c < 3; ++c) p[c] = uint8_t(rng());
                p[3] = x % 3 ? 255 : 0;
            });
            break;
        }
        const QString why = differs(t, enhance, lambda);
        QVERIFY2(why.isEmpty(), qPrintable(why));
    }

    // The scratch is per thread: two threads at once give each its own tile's levels.
    void twoThreads() {
        const Tile a = makeTile([](int x, int y, uint8_t* p) { std::memset(p, uint8_t(x + 2 * y), 4); });
        const Tile b = makeTile([](int x, int y, uint8_t* p) { std::memset(p, uint8_t(255 - x * y), 4); });
        std::atomic<int> bad{0};
        auto run = [&](const Tile& t) {
            for (int i = 0; i < 20; ++i)
                if (!differs(t, true, mk::kLambda).isEmpty()) ++bad;
        };
        std::thread ta(run, std::cref(a)), tb(run, std::cref(b));
        ta.join();
        tb.join();
        QCOMPARE(bad.load(), 0);
    }

    // Not a timed test: says what one tile's levels cost here, beside the reference's.
    void cost() {
        std::mt19937 rng(7);
        const Tile t = makeTile([&](int, int, uint8_t* p) { for (int c = 0; c < 4; ++c) p[c] = uint8_t(rng()); });
        std::vector<uint8_t> chain(mk::kChainBytes);
        using Clock = std::chrono::steady_clock;
        constexpr int kRuns = 20;
        const auto t0 = Clock::now();
        for (int i = 0; i < kRuns; ++i) mk::reduceChain8(t.data(), chain.data(), true);
        const auto t1 = Clock::now();
        for (int k = 1; k <= mk::kLevels; ++k) (void)mk::reduceLevel8(t.data(), k, true);
        const auto t2 = Clock::now();
        qInfo("one tile's 8 levels: chain %.1f us, reference %.1f us",
              std::chrono::duration<double, std::micro>(t1 - t0).count() / kRuns,
              std::chrono::duration<double, std::micro>(t2 - t1).count());
    }
};

QTEST_GUILESS_MAIN(TestMipChain)
#include "tst_mip_chain.moc"
