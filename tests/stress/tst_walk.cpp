// Long walks over very large slides: memory stays bounded, and after rapid moves the final
// field is complete and exactly right (no stale tile of an earlier position visible).
#include <QtTest>

#include <fstream>
#include <cmath>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <random>
#include <string>

#include <openslide.h>

#include "iris/engine.h"
#include "iris/environment.h"

namespace {

// The synthetic slide's level-0 pixel, written out independently of the engine's source.
void expectedSynthetic(int64_t x, int64_t y, uint8_t* p) {
    const bool checker = ((x >> 8) + (y >> 8)) & 1;
    p[0] = uint8_t((x * 255) / 4096 % 256);
    p[1] = uint8_t((y * 255) / 4096 % 256);
    p[2] = uint8_t(checker ? 200 : 60) ^ uint8_t(((x + y) & 7) << 2);
}

uint64_t residentBytes() {
    std::ifstream f("/proc/self/status");
    std::string line;
    while (std::getline(f, line))
        if (line.rfind("VmRSS:", 0) == 0) return std::stoull(line.substr(6)) * 1024;
    return 0;
}

std::unique_ptr<iris::Engine> makeEngine(uint64_t ram, uint64_t vram) {
    iris::EngineConfig cfg;
    cfg.validation = true;
    cfg.loaderThreads = 2;
    cfg.ramBudgetBytes = ram;
    cfg.vramBudgetBytes = vram;
    auto tuning = iris::tuningFromEnvironment();
    if (!tuning) qFatal("%s", tuning.error().message().c_str());
    cfg.tuning = *tuning;
    auto e = iris::Engine::create(cfg);
    if (!e) qFatal("engine: %s", e.error().message().c_str());
    return std::move(e.value());
}

} // namespace

class TestWalk : public QObject {
    Q_OBJECT
private slots:
    void memoryStaysBounded();
    void rapidMovesEndExact_synthetic();
    void rapidMovesEndExact_openslide();
};

void TestWalk::memoryStaysBounded() {
    // Budgets deliberately far below what the walk touches, so eviction is exercised.
    constexpr uint64_t kRam = 48ull << 20, kVram = 32ull << 20;
    auto e = makeEngine(kRam, kVram);
    QVERIFY(e->bindOffscreen(640, 480).ok());
    QVERIFY(e->open("synthetic:200000x200000").ok());
    const iris::MemoryStats start = e->memoryStats();
    QVERIFY(start.vramAtlasBytes > 0);
    // Stated fixed overhead beyond the budget: 64 recycled tile buffers plus one buffer per
    // loader (256 KiB each), plus allocator slack for the walk's bookkeeping.
    const uint64_t kTile = 256 * 256 * 4;
    const uint64_t kOverhead = (64 + 2) * kTile;
    e->setView({100000, 100000, 1});
    QVERIFY(e->waitForFrame(std::chrono::seconds(60)).ok());
    const uint64_t rssStart = residentBytes();
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(0, 1);
    uint64_t maxRam = 0, maxRss = 0;
    for (int step = 0; step < 120; ++step) {
        const double ds = step % 3 == 0 ? 1.0 : std::pow(2.0, u(rng) * 7); // 1 … 128
        e->setView({u(rng) * 200000, u(rng) * 200000, ds});
        const iris::Result r = e->waitForFrame(std::chrono::seconds(60));
        QVERIFY2(r.ok(), r.message().c_str());
        const iris::MemoryStats m = e->memoryStats();
        maxRam = std::max(maxRam, m.ramCacheBytes);
        maxRss = std::max(maxRss, residentBytes());
        QCOMPARE(m.vramAtlasBytes, start.vramAtlasBytes); // the atlas never grows
        QCOMPARE(m.atlasSlots, start.atlasSlots);
        QVERIFY2(m.ramCacheBytes <= m.ramBudgetBytes + kOverhead,
                 qPrintable(QString("RAM cache %1 MiB over budget %2 MiB").arg(m.ramCacheBytes >> 20).arg(m.ramBudgetBytes >> 20)));
    }
    // The process as a whole: what it held once warm, plus at most the cache budget and the
    // overhead (the cache may have been far from full when rssStart was taken), plus 32 MiB of
    // allocator and driver slack.
    QVERIFY2(maxRss <= rssStart + kRam + kOverhead + (32ull << 20),
             qPrintable(QString("RSS grew from %1 to %2 MiB").arg(rssStart >> 20).arg(maxRss >> 20)));
    qInfo("RAM cache peak %llu MiB (budget %llu MiB); RSS %llu → peak %llu MiB", (unsigned long long)(maxRam >> 20),
          (unsigned long long)(kRam >> 20), (unsigned long long)(rssStart >> 20), (unsigned long long)(maxRss >> 20));
    QCOMPARE(e->validationMessageCount(), 0u);
}

void TestWalk::rapidMovesEndExact_synthetic() {
    auto e = makeEngine(64ull << 20, 48ull << 20);
    constexpr uint32_t W = 400, H = 300;
    QVERIFY(e->bindOffscreen(W, H).ok());
    QVERIFY(e->open("synthetic:200000x200000").ok());
    // The view of the last frame drawn, for the moves below that wait for one of theirs.
    struct Drawn {
        std::mutex mutex;
        std::condition_variable cv;
        iris::View view;
    };
    const auto drawn = std::make_shared<Drawn>(); // the callback may outlive this function
    e->setFrameCallback([drawn](const iris::FrameStats& s) {
        {
            std::lock_guard lock(drawn->mutex);
            drawn->view = s.view;
        }
        drawn->cv.notify_all();
    });
    std::mt19937_64 rng(11);
    // Forty moves to unrelated fields and zooms. Most follow each other at once; every 20th
    // waits until a frame of its field was drawn (its tiles asked for, some perhaps arriving),
    // so that tiles of earlier fields are in flight or resident at the end. (A frame takes tens
    // of milliseconds on lavapipe: waiting after every move would make this case slow.)
    for (int i = 0; i < 40; ++i) {
        e->setView({double(rng() % 190000) + 5000, double(rng() % 190000) + 5000, double(1 + rng() % 64)});
        if (i % 3 == 0) e->translate(double(rng() % 400), double(rng() % 300));
        if (i % 20 != 19) continue;
        const iris::View now = e->view();
        std::unique_lock lock(drawn->mutex);
        QVERIFY2(drawn->cv.wait_for(lock, std::chrono::seconds(10), [&] { return drawn->view == now; }),
                 qPrintable(QString("no frame of move %1 within 10 s").arg(i)));
    }
    e->setFrameCallback(nullptr);
    // The last field, integer-aligned at 1:1.
    const int64_t x0 = 123456, y0 = 65432;
    e->setView({x0 + W / 2.0, y0 + H / 2.0, 1});
    QVERIFY(e->waitForFrame(std::chrono::seconds(60)).ok());
    auto f = e->readFrame();
    QVERIFY(f.ok());
    QVERIFY(f->complete);
    int wrong = 0;
    for (uint32_t y = 0; y < H; ++y) {
        for (uint32_t x = 0; x < W; ++x) {
            uint8_t want[3];
            expectedSynthetic(x0 + x, y0 + y, want);
            const uint8_t* got = f->image.rgba.data() + (size_t(y) * W + x) * 4;
            if (got[0] != want[0] || got[1] != want[1] || got[2] != want[2]) ++wrong;
        }
    }
    QCOMPARE(wrong, 0);
    QCOMPARE(e->validationMessageCount(), 0u);
}

void TestWalk::rapidMovesEndExact_openslide() {
    const QString sample = qEnvironmentVariable("IRIS_TEST_SAMPLE");
    QVERIFY2(QFile::exists(sample), "the sample slide fixture is missing");
    auto e = makeEngine(64ull << 20, 48ull << 20);
    constexpr uint32_t W = 320, H = 240;
    QVERIFY(e->bindOffscreen(W, H).ok());
    QVERIFY(e->open(sample.toStdString()).ok());
    std::mt19937_64 rng(5);
    for (int i = 0; i < 30; ++i) {
        e->setView({double(rng() % 6000), double(rng() % 4000), 0.5 + double(rng() % 20)});
        e->translate(double(rng() % 200) - 100, double(rng() % 200) - 100);
    }
    const int64_t x0 = 2901, y0 = 1703;
    e->setView({x0 + W / 2.0, y0 + H / 2.0, 1});
    QVERIFY(e->waitForFrame(std::chrono::seconds(60)).ok());
    auto f = e->readFrame();
    QVERIFY(f.ok());
    openslide_t* osr = openslide_open(sample.toLocal8Bit().constData());
    QVERIFY(osr);
    std::vector<uint32_t> ref(size_t(W) * H);
    openslide_read_region(osr, ref.data(), x0, y0, 0, W, H);
    QVERIFY(!openslide_get_error(osr));
    openslide_close(osr);
    int wrong = 0;
    for (size_t i = 0; i < ref.size(); ++i) {
        const uint8_t* got = f->image.rgba.data() + i * 4;
        const uint32_t p = ref[i];
        if (got[0] != uint8_t(p >> 16) || got[1] != uint8_t(p >> 8) || got[2] != uint8_t(p)) ++wrong;
    }
    QCOMPARE(wrong, 0);
}

QTEST_GUILESS_MAIN(TestWalk)
#include "tst_walk.moc"
