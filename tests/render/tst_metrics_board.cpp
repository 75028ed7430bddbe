// The render thread's field timing (metrics/field_metrics: MetricsBoard) on scripted frames,
// without a device: which moves are timed, and with what.
//
//   * a field whose first frame is already whole, every tile of it uploaded before the move,
//     is a revisit: not timed;
//   * a field whose first frame is whole with tiles uploaded after the move loaded before the
//     render thread drew it (a few tiles on a fast GPU on one queue): timed, with its uploads;
//   * a field that completes over several frames: LR-TeFOV at the first frame with LR whole,
//     HR-TeFOV and TPT at the first complete one.
#include <QtTest>

#include <atomic>
#include <cmath>
#include <thread>
#include <vector>

#include "metrics/field_metrics.h"

using iris::Snapshot;
using iris::UploadCounters;
using iris::metrics::FieldProgress;
using iris::metrics::MetricsBoard;

namespace {

Snapshot field(uint64_t id, uint64_t tilesAtStart) {
    Snapshot s;
    s.fieldId = id;
    s.fieldStart = std::chrono::steady_clock::now() - std::chrono::milliseconds(20);
    s.fieldTilesAtStart = tilesAtStart;
    s.viewport.view = {1000.0 * double(id), 500, 1};
    return s;
}

FieldProgress progress(bool lr, bool hr, uint64_t newestUpload) {
    return {
        .hasLr = true, .lrComplete = lr, .hrComplete = hr, .lrTiles = 1, .hrTiles = 4, .newestUpload = newestUpload};
}

} // namespace

class TestMetricsBoard : public QObject {
    Q_OBJECT
private slots:
    // The stage log: a field's stage times are the events between its move and its end, as
    // offsets from the move (first, median, last, count); events before the move (the last
    // field's) are left out; a stage with no event has none.
    void stageTimesOfAField() {
        using namespace std::chrono_literals;
        UploadCounters counters;
        iris::StageLog log;
        MetricsBoard board(counters, &log);
        Snapshot s = field(1, 0);
        const auto t0 = s.fieldStart; // 20 ms ago
        log.stamp(iris::TileStage::DecodeStart, 5, t0 - 5ms); // the previous field's
        log.stamp(iris::TileStage::DecodeStart, 1, t0 + 1ms);
        log.stamp(iris::TileStage::DecodeStart, 1, t0 + 2ms);
        log.stamp(iris::TileStage::DecodeStart, 1, t0 + 4ms);
        log.stamp(iris::TileStage::Submitted, 3, t0 + 10ms); // a transaction of three tiles
        board.frameDrawn(s, progress(true, true, 3));
        QCOMPARE(board.read().fields.size(), size_t(0)); // published by frameFinished
        (void)board.frameFinished(s, 1, true, 4, 0.1, 0.1);
        QCOMPARE(board.read().fields.size(), size_t(1));
        const iris::FieldStats f = board.read().fields.back();
        const iris::StageTimes d = f.stages[size_t(iris::TileStage::DecodeStart)];
        QCOMPARE(d.tiles, 3u);
        QVERIFY(std::abs(d.firstMs - 1) < 1e-6 && std::abs(d.medianMs - 2) < 1e-6 && std::abs(d.lastMs - 4) < 1e-6);
        const iris::StageTimes sub = f.stages[size_t(iris::TileStage::Submitted)];
        QCOMPARE(sub.tiles, 3u);
        QVERIFY(std::abs(sub.firstMs - 10) < 1e-6 && std::abs(sub.lastMs - 10) < 1e-6);
        const iris::StageTimes none = f.stages[size_t(iris::TileStage::Shown)];
        QCOMPARE(none.tiles, 0u);
        QCOMPARE(none.firstMs, -1.0);
        QCOMPARE(std::string(iris::tileStageName(iris::TileStage::GpuDone)), std::string("gpu_done"));

        // The ring keeps the newest kSlots events of a stage.
        for (size_t i = 0; i < iris::StageLog::kSlots + 10; ++i) log.stamp(iris::TileStage::Staged, 1, t0 + 3ms);
        QCOMPARE(log.summarise(iris::TileStage::Staged, t0, t0 + 1s).tiles, uint32_t(iris::StageLog::kSlots));
    }

    // Tiles being read at once over a field (FieldStats::decodesInFlight): the time each spent
    // between DecodeStart and Decoded within the field, summed, over the time to the last
    // Decoded. One tile begun before the move counts from the move.
    void decodesInFlightOfAField() {
        using namespace std::chrono_literals;
        UploadCounters counters;
        iris::StageLog log;
        MetricsBoard board(counters, &log);
        Snapshot s = field(1, 0);
        const auto t0 = s.fieldStart; // 20 ms ago
        log.stamp(iris::TileStage::DecodeStart, 1, t0 - 1ms); // the previous field's: [0, 2] in this one
        log.stamp(iris::TileStage::DecodeStart, 2, t0);        // [0, 4] and [0, 6]
        log.stamp(iris::TileStage::DecodeStart, 1, t0 + 2ms);  // [2, 8]
        log.stamp(iris::TileStage::Decoded, 1, t0 + 2ms);
        log.stamp(iris::TileStage::Decoded, 1, t0 + 4ms);
        log.stamp(iris::TileStage::Decoded, 1, t0 + 6ms);
        log.stamp(iris::TileStage::Decoded, 1, t0 + 8ms);
        // (2 + 4 + 6 + 6) ms of reading over 8 ms.
        QVERIFY(std::abs(log.meanBetween(iris::TileStage::DecodeStart, iris::TileStage::Decoded, t0, t0 + 1s) - 2.25) < 1e-9);
        board.frameDrawn(s, progress(true, true, 3));
        (void)board.frameFinished(s, 1, true, 4, 0.1, 0.1);
        QCOMPARE(board.read().fields.size(), size_t(1));
        QVERIFY(std::abs(board.read().fields.back().decodesInFlight - 2.25) < 1e-9);
        // No tile read: none.
        iris::StageLog quiet;
        QCOMPARE(quiet.meanBetween(iris::TileStage::DecodeStart, iris::TileStage::Decoded, t0, t0 + 1s), -1.0);
    }

    void revisitsAndFastFields() {
        UploadCounters counters;
        counters.tiles = 100;
        MetricsBoard board(counters);
        uint64_t serial = 0;
        const auto frame = [&](const Snapshot& s, const FieldProgress& p) {
            board.frameDrawn(s, p);
            (void)board.frameFinished(s, ++serial, p.hrComplete, p.hrTiles, 0.1, 0.1);
        };

        // A revisit: whole at once, nothing uploaded since the move.
        frame(field(1, 100), progress(true, true, 97));
        QCOMPARE(board.read().fields.size(), size_t(0));

        // Loaded before its first frame: 5 tiles uploaded since the move (101-105).
        counters.tiles = 105;
        frame(field(2, 100), progress(true, true, 105));
        QCOMPARE(board.read().fields.size(), size_t(1));
        const iris::FieldStats fast = board.read().fields.back();
        QCOMPARE(fast.tilesBuffered, 5u);
        QVERIFY(fast.hrTeFovMs >= 20 && fast.lrTeFovMs >= 20);
        QCOMPARE(fast.view.centerX, 2000.0);

        // Over three frames: nothing, then LR, then HR.
        const Snapshot third = field(3, 105);
        frame(third, progress(false, false, 0));
        counters.tiles = 106;
        frame(third, progress(true, false, 106));
        QCOMPARE(board.read().fields.size(), size_t(1));
        counters.tiles = 110;
        frame(third, progress(true, true, 110));
        QCOMPARE(board.read().fields.size(), size_t(2));
        const iris::FieldStats slow = board.read().fields.back();
        QCOMPARE(slow.tilesBuffered, 5u);
        QVERIFY(slow.lrTeFovMs > 0 && slow.lrTeFovMs <= slow.hrTeFovMs);
        QVERIFY(std::abs(slow.hrTptUs - slow.hrTeFovMs * 1000.0 / 5) < 1e-6);
    }

    // The loaders' sums read while loaders count passes: a pass's parts never show without
    // its whole (StageLog::addDecodedPass, and the board reading parts first). The passes have
    // no time beyond one part, so that part counted ahead of its whole, or the whole read before
    // the parts, shows as a part larger than the whole: two loaders count passes while the
    // render thread's side publishes 100000 boards, once with passes all read and decode, once
    // with passes all getting a buffer.
    void loaderSumsWhileCounted_data() {
        QTest::addColumn<bool>("decodePart");
        QTest::newRow("read and decode") << true;
        QTest::newRow("getting a buffer") << false;
    }
    void loaderSumsWhileCounted() {
        QFETCH(bool, decodePart);
        using D = iris::StageLog::Clock::duration;
        const D none(0), part(5);
        UploadCounters counters;
        iris::StageLog log;
        MetricsBoard board(counters, &log);
        std::atomic<bool> stop{false};
        std::atomic<int> running{0};
        std::vector<std::thread> loaders;
        for (int i = 0; i < 2; ++i)
            loaders.emplace_back([&] {
                running.fetch_add(1);
                while (!stop.load(std::memory_order_relaxed))
                    log.addDecodedPass(part, decodePart ? none : part, decodePart ? part : none);
            });
        while (running.load() < 2) std::this_thread::yield();
        const Snapshot s = field(1, 0);
        size_t bad = 0;
        uint64_t serial = 0;
        for (int reads = 0; reads < 100000; ++reads) {
            (void)board.frameFinished(s, ++serial, true, 1, 0.1, 0.1);
            const iris::EngineMetrics m = board.read();
            if ((decodePart ? m.decodeMs : m.loaderAcquireMs) > m.loaderWorkMs) ++bad;
        }
        stop = true;
        for (std::thread& t : loaders) t.join();
        (void)board.frameFinished(s, ++serial, true, 1, 0.1, 0.1);
        const iris::EngineMetrics m = board.read();
        QVERIFY2(bad == 0, QByteArray::number(qulonglong(bad)) + " of 100000 boards had a part over the whole");
        QVERIFY(m.decodeTiles > 0);
        // Every pass counted: the whole is its parts.
        QCOMPARE(qint64(std::llround(m.loaderWorkMs * 1e6)), qint64(std::llround((m.decodeMs + m.loaderAcquireMs) * 1e6)));
    }
};

QTEST_APPLESS_MAIN(TestMetricsBoard)
#include "tst_metrics_board.moc"
