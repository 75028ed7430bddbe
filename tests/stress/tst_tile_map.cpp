// Unit tests of the lock-free tile map (concurrent pin/unpin against allocate/reclaim) and of
// the view model's priority order.
#include <QtTest>

#include <atomic>
#include <random>
#include <thread>
#include <unordered_set>

#include "core/tile_map.h"
#include "view/view_model.h"

using iris::TileMap;

class TestTileMap : public QObject {
    Q_OBJECT
private slots:
    void insertLookupActivate();
    void reclaimSkipsPinnedAndKept();
    void tombstoneRebuildKeepsEntries();
    void concurrentPinAndReclaim();
    void priorityOrder();
    void levelChoice();
    void syntheticBaseAfterVisible();
};

void TestTileMap::insertLookupActivate() {
    TileMap m(16);
    const auto none = [](uint64_t) { return false; };
    const int s = m.allocate(42, none);
    QVERIFY(s >= 0);
    QVERIFY(m.contains(42));
    QCOMPARE(m.pin(42, 1), -1); // FILLING is never drawn
    QCOMPARE(m.statusOf(42), TileMap::Status::Filling);
    m.activate(s);
    QCOMPARE(m.pin(42, 1), s);
    QCOMPARE(m.statusOf(42), TileMap::Status::Active);
    m.unpin(s);
    QCOMPARE(m.pin(43, 1), -1);
    m.abandon(s);
    QVERIFY(!m.contains(42));
    QCOMPARE(m.statusOf(42), TileMap::Status::Free);
}

void TestTileMap::reclaimSkipsPinnedAndKept() {
    TileMap m(4);
    const auto none = [](uint64_t) { return false; };
    for (uint64_t k = 1; k <= 4; ++k) m.activate(m.allocate(k, none));
    QCOMPARE(m.countActive(), 4u);
    // Pin 1 and 2, keep 3: only 4 can be reclaimed.
    const int p1 = m.pin(1, 10), p2 = m.pin(2, 10);
    QVERIFY(p1 >= 0 && p2 >= 0);
    const auto keep3 = [](uint64_t k) { return k == 3; };
    const int s = m.allocate(5, keep3);
    QVERIFY(s >= 0);
    QVERIFY(!m.contains(4));
    QVERIFY(m.contains(5));
    // Nothing left to reclaim while 1, 2 are pinned, 3 kept and 5 filling.
    QCOMPARE(m.allocate(6, keep3), -1);
    m.unpin(p1);
    const int s6 = m.allocate(6, keep3);
    QCOMPARE(s6, p1);
    QVERIFY(!m.contains(1));
    m.unpin(p2);
}

void TestTileMap::tombstoneRebuildKeepsEntries() {
    // Churn many more keys than there are slots: every allocation reclaims a slot, erasing a
    // key (a tombstone), so the index is rebuilt many times. Afterwards exactly the live keys
    // must be found, and no erased one.
    TileMap m(64);
    const auto none = [](uint64_t) { return false; };
    std::vector<uint64_t> inserted;
    std::mt19937_64 rng(1);
    std::unordered_set<uint64_t> seen;
    for (int i = 0; i < 20000; ++i) {
        const uint64_t k = (rng() | 1) & ~(uint64_t(1) << 63);
        if (!seen.insert(k).second) continue;
        const int s = m.allocate(k, none);
        QVERIFY(s >= 0);
        m.activate(s);
        inserted.push_back(k);
    }
    int active = 0;
    for (uint64_t k : inserted) active += m.statusOf(k) == TileMap::Status::Active;
    QCOMPARE(active, 64);
    QCOMPARE(m.countActive(), 64u);
    // The most recent key is certainly live.
    QCOMPARE(m.statusOf(inserted.back()), TileMap::Status::Active);
}

void TestTileMap::concurrentPinAndReclaim() {
    // One writer reclaims and refills slots as fast as it can while readers pin, check the
    // slot's identity and unpin. A reader must never hold a pin on a slot that the writer
    // refilled: the writer marks each fill with a "generation" in a shadow array and readers
    // check it did not change while pinned. The readers stop after kPinsEach pins each (a pin
    // succeeds for about one probe in 128: 32 of 4096 keys are resident) once the writer has
    // refilled the slots 100 times over, the writer when they are done.
    constexpr uint32_t kSlots = 32;
    constexpr uint64_t kPinsEach = 500;
    TileMap m(kSlots);
    std::atomic<uint64_t> shadow[kSlots];
    for (auto& s : shadow) s.store(0);
    std::atomic<bool> stop{false};
    std::atomic<uint64_t> pins{0}, violations{0}, fills{0};
    std::thread writer([&] {
        std::mt19937_64 rng(7);
        uint64_t key = 1;
        while (!stop.load(std::memory_order_relaxed)) {
            const int s = m.allocate(key, [&](uint64_t k) { return (k % 7) == 0 && (rng() & 1); });
            if (s >= 0) {
                shadow[s].store(key, std::memory_order_relaxed); // "overwrite the texels"
                m.activate(s);
                fills.fetch_add(1, std::memory_order_relaxed);
            }
            ++key;
        }
    });
    std::vector<std::thread> readers;
    for (int r = 0; r < 3; ++r) {
        readers.emplace_back([&, r] {
            std::mt19937_64 rng(100 + r);
            uint64_t frame = 0;
            // Until both: this reader's pins, and the writer's refills of every slot many times
            // over (on a loaded machine the readers can finish their pins before the writer
            // has been scheduled much). Bounded: a writer that makes no progress fails below.
            const auto limit = std::chrono::steady_clock::now() + std::chrono::seconds(60);
            for (uint64_t mine = 0;
                 (mine < kPinsEach || fills.load(std::memory_order_relaxed) <= kSlots * 100) &&
                 std::chrono::steady_clock::now() < limit;) {
                const uint64_t probe = 1 + rng() % 4096;
                const int s = m.pin(probe, ++frame);
                if (s < 0) continue;
                ++mine;
                pins.fetch_add(1, std::memory_order_relaxed);
                // While pinned, the slot's content must stay the tile we pinned.
                for (int i = 0; i < 50; ++i) {
                    const uint64_t v = shadow[s].load(std::memory_order_relaxed);
                    if (v != probe) violations.fetch_add(1, std::memory_order_relaxed);
                }
                m.unpin(s);
            }
        });
    }
    const auto t0 = std::chrono::steady_clock::now();
    for (auto& t : readers) t.join();
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    const uint64_t filled = fills.load(); // by the time the last reader finished
    stop = true;
    writer.join();
    qInfo("%llu pins against %llu fills in %.0f ms", static_cast<unsigned long long>(pins.load()),
          static_cast<unsigned long long>(filled), ms);
    QCOMPARE(violations.load(), 0u);
    // The writer kept refilling the slots while the readers pinned them.
    QVERIFY2(filled > kSlots * 100, qPrintable(QString("only %1 fills").arg(filled)));
}

void TestTileMap::priorityOrder() {
    // Three levels: 4096², 1024², 256² (downsamples 1, 4, 16).
    iris::SlideInfo info;
    info.width = info.height = 4096;
    for (auto [w, d] : {std::pair{4096, 1.0}, {1024, 4.0}, {256, 16.0}}) {
        iris::LevelInfo l{w, w, d, 0, 0};
        l.tilesX = (w + 255) / 256;
        l.tilesY = l.tilesX;
        info.levels.push_back(l);
    }
    iris::Viewport vp{{2048, 2048, 2.0}, 512, 512};
    const auto region = iris::bufferRegion(info, 1, vp, 1);
    QVERIFY(!region.empty());
    // Roles appear in the required order: base, LR visible, HR visible, LR perimeter, HR perimeter.
    int lastRole = -1;
    for (const auto& t : region) {
        QVERIFY2(int(t.role) >= lastRole, "roles out of priority order");
        lastRole = int(t.role);
    }
    QCOMPARE(region.front().role, iris::TileRole::Base);
    QCOMPARE(region.front().level, 2);
    // Within HR visible, nearest the view centre first.
    double lastD = -1;
    for (const auto& t : region) {
        if (t.role != iris::TileRole::HRVisible) continue;
        QCOMPARE(t.level, 0);
        const double dx = (t.tx + 0.5) * 256 - 2048, dy = (t.ty + 0.5) * 256 - 2048;
        const double d = dx * dx + dy * dy;
        QVERIFY(d >= lastD - 1e-9);
        lastD = d;
    }
    // At downsample 2 the 512-px target spans level-0 [1536, 2560) on each axis: HR (level 0)
    // tiles 6..9, so 4×4 visible, and one ring of perimeter around them.
    int hrVisible = 0, hrPerimeter = 0;
    for (const auto& t : region) {
        hrVisible += t.role == iris::TileRole::HRVisible;
        hrPerimeter += t.role == iris::TileRole::HRPerimeter;
    }
    QCOMPARE(hrVisible, 16);
    QCOMPARE(hrPerimeter, 6 * 6 - 16);
}

void TestTileMap::levelChoice() {
    iris::SlideInfo info;
    for (double d : {1.0, 4.0, 16.0}) info.levels.push_back({1000, 1000, d, 4, 4});
    QCOMPARE(iris::chooseLevels(info, 0.5).hr, 0); // zoomed in past 1:1: level 0
    QCOMPARE(iris::chooseLevels(info, 1.0).hr, 0);
    QCOMPARE(iris::chooseLevels(info, 1.0).lr, 1);
    QCOMPARE(iris::chooseLevels(info, 3.9).hr, 0);
    QCOMPARE(iris::chooseLevels(info, 4.0).hr, 1); // exactly a level's downsample picks it
    QCOMPARE(iris::chooseLevels(info, 100).hr, 2);
    QCOMPARE(iris::chooseLevels(info, 100).lr, -1);
    QCOMPARE(iris::chooseLevels(info, 100).base, 2);
}

void TestTileMap::syntheticBaseAfterVisible() {
    // A one-level 8192² slide (1024 tiles) and the synthetic levels the engine adds to it
    // (slide/pyramid_source.h): 4096² (256 tiles, kept whole) at downsample 2.
    iris::SlideInfo info;
    info.width = info.height = 8192;
    for (auto [w, d] : {std::pair{8192, 1.0}, {4096, 2.0}}) {
        iris::LevelInfo l{w, w, d, 0, 0};
        l.tilesX = l.tilesY = (w + 255) / 256;
        l.synthetic = d > 1;
        info.levels.push_back(l);
    }
    // Zoomed in on the stored level: its visible and perimeter tiles (one stored read each)
    // come before the synthetic base (four stored reads per tile), which is still asked for whole.
    iris::Viewport vp{{4096, 4096, 1.0}, 512, 512};
    auto region = iris::bufferRegion(info, 1, vp, 1);
    QVERIFY(!region.empty());
    QCOMPARE(region.front().role, iris::TileRole::LRVisible);
    size_t lastOther = 0, firstBase = region.size(), base = 0, perimeter = 0;
    for (size_t i = 0; i < region.size(); ++i) {
        if (region[i].role == iris::TileRole::Base) {
            firstBase = std::min(firstBase, i);
            ++base;
        } else {
            lastOther = i;
        }
        perimeter += region[i].role == iris::TileRole::HRPerimeter || region[i].role == iris::TileRole::LRPerimeter;
    }
    QVERIFY(perimeter > 0);
    QVERIFY(lastOther < firstBase);
    // All of it but the tiles already asked for as LR (visible and perimeter: 4 × 4 around the view).
    QCOMPARE(base, size_t(256) - 16);
    // Zoomed out onto the synthetic level itself: it is HR, and nothing waits for it.
    vp.view.downsample = 8;
    region = iris::bufferRegion(info, 1, vp, 1);
    QCOMPARE(region.front().role, iris::TileRole::Base);
    QCOMPARE(region.front().level, 1);
}

QTEST_GUILESS_MAIN(TestTileMap)
#include "tst_tile_map.moc"
