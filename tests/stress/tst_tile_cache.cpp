// The RAM tile cache (cache/tile_cache): claims, publication, eviction within the budget, and
// copyOut, which copies a 256 KiB tile without the cache's lock. While a copy runs, the tile may
// be evicted or dropped with its generation and its buffer handed back: the copy must still
// read the tile it started on, never a buffer a loader is already refilling. Two copier threads
// race a publisher that refills recycled buffers and evicts, and a dropper; every copy must be
// one tile's pattern whole (run under ASan and TSan too).
#include <QtTest>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <thread>
#include <vector>

#include "cache/tile_cache.h"
#include "slide/slide_source.h"

namespace {

uint64_t keyOf(uint32_t generation, uint32_t n) { return (uint64_t(generation & 0xFFFF) << 48) | n; }

// A tile's pixels: every byte names the tile, so a copy of a buffer refilled mid-copy shows.
void fill(uint8_t* p, uint64_t key) {
    const uint8_t b = uint8_t((key * 0x9E3779B97F4A7C15ull) >> 56) | 1;
    std::memset(p, b, iris::kTileBytes);
}
bool isWhole(const uint8_t* p, uint64_t key) {
    std::vector<uint8_t> want(iris::kTileBytes);
    fill(want.data(), key);
    return std::memcmp(p, want.data(), iris::kTileBytes) == 0;
}

} // namespace

class TestTileCache : public QObject {
    Q_OBJECT
private slots:
    void claimPublishCopy() {
        iris::TileCache cache(uint64_t(iris::kTileBytes) * 16);
        const uint64_t k = keyOf(1, 7);
        QVERIFY(cache.tryClaim(k));
        QVERIFY(!cache.tryClaim(k)); // being decoded
        QVERIFY(!cache.isReady(k));
        auto buf = cache.acquireBuffer();
        fill(buf.get(), k);
        cache.publish(k, std::move(buf), false);
        QVERIFY(cache.isReady(k));
        std::vector<uint8_t> out(iris::kTileBytes);
        bool failed = true;
        QVERIFY(cache.copyOut(k, out.data(), &failed));
        QVERIFY(!failed);
        QVERIFY(isWhole(out.data(), k));
        QVERIFY(!cache.copyOut(keyOf(1, 8), out.data(), nullptr));
        // Over the budget the least recently copied tile goes.
        for (uint32_t n = 100; n < 116; ++n) {
            QVERIFY(cache.tryClaim(keyOf(1, n)));
            auto b = cache.acquireBuffer();
            fill(b.get(), keyOf(1, n));
            cache.publish(keyOf(1, n), std::move(b), false);
        }
        QVERIFY(!cache.isReady(k));
        QVERIFY(cache.bytesUsed() <= cache.budgetBytes() + 64ull * iris::kTileBytes);
        cache.dropOtherGenerations(2);
        QVERIFY(!cache.isReady(keyOf(1, 115)));
    }

    // Idle loaders make buffers ahead of need (TileCache::replenish): never more free ones than
    // the reserve, never more in all than the budget holds, zeroed, and taken before any new one.
    void reserveStaysWithinTheBudget() {
        iris::TileCache cache(uint64_t(iris::kTileBytes) * 64);
        const size_t target = cache.reserveTarget();
        QCOMPARE(target, size_t(8)); // 1/8 of the budget
        QVERIFY(cache.replenish(3));
        QCOMPARE(cache.bytesUsed(), 3ull * iris::kTileBytes);
        {
            // Loaders replenishing at once (each counts what the others are making) stop at the
            // reserve, never past it.
            std::vector<std::thread> loaders;
            for (int i = 0; i < 4; ++i)
                loaders.emplace_back([&] {
                    while (cache.replenish(2)) {
                    }
                });
            for (auto& t : loaders) t.join();
        }
        QCOMPARE(cache.bytesUsed(), uint64_t(target) * iris::kTileBytes);
        QVERIFY(!cache.replenish(8));
        // Taken from the reserve: zeroed, and nothing new allocated meanwhile.
        std::vector<std::unique_ptr<uint8_t[]>> taken;
        for (size_t i = 0; i < target; ++i) {
            taken.push_back(cache.acquireBuffer());
            const uint8_t* b = taken.back().get();
            QVERIFY(std::all_of(b, b + iris::kTileBytes, [](uint8_t v) { return v == 0; }));
        }
        QCOMPARE(cache.bytesUsed(), uint64_t(0));
        // Near the budget the reserve is what the budget leaves: 60 tiles ready, 4 more buffers.
        for (uint32_t n = 0; n < 60; ++n) {
            QVERIFY(cache.tryClaim(keyOf(1, n)));
            auto b = n < taken.size() ? std::move(taken[n]) : cache.acquireBuffer();
            fill(b.get(), keyOf(1, n));
            cache.publish(keyOf(1, n), std::move(b), false);
        }
        while (cache.replenish(3)) {
        }
        QCOMPARE(cache.bytesUsed(), 64ull * iris::kTileBytes);
        for (uint32_t n = 0; n < 60; ++n) QVERIFY(cache.isReady(keyOf(1, n)));
    }

    void copiesRaceEvictionAndDrops() {
        iris::TileCache cache(uint64_t(iris::kTileBytes) * 16); // tiny: constant eviction
        std::atomic<bool> stop{false};
        std::atomic<uint32_t> generation{1};
        std::atomic<uint64_t> copies{0}, torn{0};
        constexpr uint32_t kKeys = 40;
        std::thread publisher([&] {
            for (uint32_t round = 0; !stop.load(); ++round) {
                const uint32_t g = generation.load();
                const uint64_t k = keyOf(g, round % kKeys);
                if (!cache.tryClaim(k)) continue;
                auto b = cache.acquireBuffer(); // often one just evicted or dropped
                fill(b.get(), k);
                cache.publish(k, std::move(b), false);
            }
        });
        std::thread dropper([&] {
            while (!stop.load()) {
                std::this_thread::yield();
                if (copies.load() % 97 == 0) cache.dropOtherGenerations(generation.fetch_add(1) + 1);
            }
        });
        std::vector<std::thread> copiers;
        for (int c = 0; c < 2; ++c)
            copiers.emplace_back([&, c] {
                std::vector<uint8_t> out(iris::kTileBytes);
                for (uint32_t i = 0; !stop.load(); ++i) {
                    const uint64_t k = keyOf(generation.load(), (i * 7 + uint32_t(c)) % kKeys);
                    if (!cache.copyOut(k, out.data(), nullptr)) continue;
                    copies.fetch_add(1);
                    if (!isWhole(out.data(), k)) torn.fetch_add(1);
                }
            });
        // Until enough copies were made (bounded: 20 s at most, also under TSan).
        QTRY_VERIFY_WITH_TIMEOUT(copies.load() >= 3000, 20000);
        stop = true;
        publisher.join();
        dropper.join();
        for (auto& t : copiers) t.join();
        QCOMPARE(torn.load(), uint64_t(0));
        QVERIFY(cache.bytesUsed() <= cache.budgetBytes() + 64ull * iris::kTileBytes);
    }
};

QTEST_GUILESS_MAIN(TestTileCache)
#include "tst_tile_cache.moc"
