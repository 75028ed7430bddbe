// The metric definitions on a scripted sequence: a move to an entirely new field produces
// exactly one TeFOV sample with the right tile counts; a revisit and an overlapping move
// produce none; frame figures are filled in.
//
// And frame pacing (on by default on CPU devices, forced on here): while a new field's tiles
// arrive, a frame that only adds tiles to the view on screen comes at least 2× the previous
// frame's GPU time after it, except the frames that show the LR and the HR layer whole.
//
// And waitForSettled: once it returns, the perimeter is resident too, so a pan within it is
// complete in its very first frame; it reports NoSlide, NotBound and Timeout.
#include <QtTest>

#include <condition_variable>
#include <mutex>
#include <optional>
#include <vector>

#include "iris/engine.h"
#include "test_support.h"

class TestMetrics : public QObject {
    Q_OBJECT
private slots:
    void scriptedMoves();
    void pacedFrames();
    void settledMeansPerimeterResident();
};

void TestMetrics::scriptedMoves() {
    iris::EngineConfig cfg;
    cfg.perimeterTiles = 0; // the buffered set is then exactly the visible tiles
    cfg.vramBudgetBytes = 64ull << 20;
    // One loader: it reads the field's LR tile first (the buffer region's order), so the tile
    // is uploaded before the HR tiles complete the field and is counted in it. Several loaders
    // read in parallel, and on a loaded machine the four HR tiles can all land first; the field
    // is then whole at HR without its LR tile, correctly counting four (seen once in CI).
    cfg.loaderThreads = 1;
    iristest::TestEngine created = iristest::createTestEngine(cfg);
    QVERIFY2(created, iristest::describe(created.error).c_str());
    iris::Engine& e = *created.engine;
    QVERIFY(e.bindOffscreen(512, 512).ok());
    QVERIFY(e.open("synthetic:100000x100000").ok());
    // Field A: level-0 [20480, 20992)², tile-aligned at downsample 1 → HR (level 0) tiles
    // 80..81 on each axis (4), LR (level 1) one tile (40,40).
    const iris::View a{20480 + 256, 20480 + 256, 1};
    e.setView(a);
    QVERIFY(e.waitForFrame(std::chrono::seconds(60)).ok());
    e.resetMetrics();

    // Field B: far away and aligned the same way: exactly one new field.
    const iris::View b{61440 + 256, 40960 + 256, 1};
    e.setView(b);
    QVERIFY(e.waitForFrame(std::chrono::seconds(60)).ok());
    QTRY_COMPARE_WITH_TIMEOUT(e.metrics().fields.size(), size_t(1), 5000);
    const iris::FieldStats f = e.metrics().fields[0];
    QCOMPARE(f.hrTiles, 4u);
    QCOMPARE(f.lrTiles, 1u);
    QCOMPARE(f.tilesBuffered, 5u); // 4 HR + 1 LR; the base level was resident already
    QVERIFY(f.hrTeFovMs > 0);
    QVERIFY(f.lrTeFovMs > 0 && f.lrTeFovMs <= f.hrTeFovMs);
    QVERIFY(std::abs(f.hrTptUs - f.hrTeFovMs * 1000.0 / 5) < 1e-6);
    QCOMPARE(f.view.centerX, b.centerX);
    // Its tiles' way, stage by stage (issue 20's timeline): every stage saw them, in order,
    // within the field's time; the five uploads completed, and the four HR tiles were shown
    // (the LR tile only when a frame drew it before the HR tiles covered it: with tiles written
    // from the host, the default on CPU devices, they can all be drawable before any frame).
    for (int s = 0; s < iris::kTileStageCount; ++s) {
        const iris::StageTimes& t = f.stages[size_t(s)];
        const QByteArray name = iris::tileStageName(iris::TileStage(s));
        QVERIFY2(t.tiles >= 1, name);
        QVERIFY2(0 <= t.firstMs && t.firstMs <= t.medianMs && t.medianMs <= t.lastMs, name);
        QVERIFY2(t.lastMs <= f.hrTeFovMs + 1e-3, name);
        if (s > 0) QVERIFY2(t.lastMs + 1e-3 >= f.stages[size_t(s - 1)].firstMs, name);
    }
    QCOMPARE(f.stages[size_t(iris::TileStage::GpuDone)].tiles, 5u);
    QVERIFY(f.stages[size_t(iris::TileStage::Shown)].tiles >= f.hrTiles);
    // Loaders read its five tiles: at least one at a time, never more than tiles were read.
    QVERIFY2(f.decodesInFlight > 0 && f.decodesInFlight <= 5.0 + 1e-9, QByteArray::number(f.decodesInFlight));
    {
        // The loaders' time: reads within the passes that decoded, buffers within those too.
        const iris::EngineMetrics m = e.metrics();
        QVERIFY(m.decodeTiles >= 5);
        QVERIFY(m.decodeMs > 0);
        QVERIFY(m.loaderWorkMs >= m.decodeMs);
        QVERIFY(m.loaderWorkMs >= m.loaderAcquireMs && m.loaderAcquireMs >= 0);
        // A sleep counts when it ends, and the loaders may not have slept and woken yet (their
        // first sleep can be the one after these tiles): no lower bound beyond zero.
        QVERIFY(m.loaderSearchMs >= 0 && m.loaderReplenishMs >= 0 && m.loaderAsleepMs >= 0);
        // A tile a loader copied into staging (GPUs) was taken from there by the buffer thread.
        QVERIFY(m.stagedPickupTiles <= m.prestageTiles);
        if (m.stagedPickupTiles > 0) QVERIFY(m.stagedPickupMs > 0 && m.prestageCopyMs > 0);
        if (m.uploadTransactions > 0) QVERIFY(m.uploadMs > 0);
    }

    // Back to A: its tiles are still resident (a revisit): no new sample.
    e.setView(a);
    QVERIFY(e.waitForFrame(std::chrono::seconds(60)).ok());
    // An overlapping move (half a field): no new sample either.
    e.translate(200, 0);
    QVERIFY(e.waitForFrame(std::chrono::seconds(60)).ok());
    QVERIFY(e.waitForSettled(std::chrono::seconds(60)).ok()); // every frame this view will get
    QCOMPARE(e.metrics().fields.size(), size_t(1));

    // A walk of adjacent fields at a downsample that is not a dyadic fraction: the shared edge
    // comes out of two different centres and differs by a rounding error. Touching fields
    // share no pixel, so each step is a new field (iris-bench walks exactly like this).
    // (At ds = 10/3 the right edge of field 20, 20.5·fw + 256·ds, exceeds the left edge of
    // field 21, 21.5·fw − 256·ds, by 1.2e-10 in doubles; likewise for 21 → 22.)
    const double ds = 10.0 / 3.0;
    const double fw = 512 * ds;
    for (int c = 20; c <= 22; ++c) {
        const size_t before = e.metrics().fields.size();
        e.setView({(c + 0.5) * fw, 30000.5, ds});
        QVERIFY(e.waitForFrame(std::chrono::seconds(60)).ok());
        if (c > 20) QTRY_COMPARE_WITH_TIMEOUT(e.metrics().fields.size(), before + 1, 5000);
    }

    const iris::EngineMetrics m = e.metrics();
    QVERIFY(m.frames > 0);
    QVERIFY(m.tilesBuffered >= 5);
    QVERIFY(m.lastFrame.cpuMs > 0);
    QVERIFY(m.lastFrame.gpuMs >= 0); // lavapipe and NVIDIA both have timestamps
    QCOMPARE(e.validationMessageCount(), 0u);
}

void TestMetrics::pacedFrames() {
    // Pacing on whatever the device; IRIS_PACE_FRAMES=0 turns it off, and then this test must
    // fail (it did: every field had tile-only frames closer together than that).
    iris::EngineConfig cfg;
    cfg.tuning.pacing = iris::EngineTuning::Pacing::On; // the environment may still override it
    iristest::TestEngine created = iristest::createTestEngine(cfg);
    QVERIFY2(created, iristest::describe(created.error).c_str());
    iris::Engine& e = *created.engine;
    QVERIFY(e.bindOffscreen(1024, 768).ok());
    QVERIFY(e.open("synthetic:200000x200000").ok());
    QVERIFY(e.waitForFrame(std::chrono::seconds(60)).ok());

    std::mutex m;
    std::vector<iris::FrameStats> frames;
    e.setFrameCallback([&](const iris::FrameStats& f) {
        std::lock_guard lock(m);
        frames.push_back(f);
    });
    for (int i = 0; i < 4; ++i) {
        e.setView({30000.0 + i * 40000.0, 50000.0 + i * 30000.0, 1.0}); // an entirely new field each time
        QVERIFY(e.waitForFrame(std::chrono::seconds(60)).ok());
        QVERIFY(e.waitForSettled(std::chrono::seconds(60)).ok()); // the perimeter's frames
    }
    e.setFrameCallback({});

    std::lock_guard lock(m);
    int checked = 0, early = 0, fields = 0;
    for (size_t i = 1; i < frames.size(); ++i) {
        const iris::FrameStats& prev = frames[i - 1];
        const iris::FrameStats& f = frames[i];
        const bool sameView = f.view.centerX == prev.view.centerX && f.view.centerY == prev.view.centerY &&
                              f.view.downsample == prev.view.downsample;
        if (!sameView) {
            ++fields;
            continue;
        }
        if (f.complete && !prev.complete) continue; // the frame that shows HR whole
        if (prev.gpuMs <= 0) continue;
        ++checked;
        if (f.intervalMs < 0.95 * 2.0 * prev.gpuMs) {
            ++early;
            qInfo("frame %llu: %.2f ms after the previous one, whose predecessor took %.2f ms of GPU time",
                  static_cast<unsigned long long>(f.serial), f.intervalMs, prev.gpuMs);
        }
    }
    qInfo("%zu frames, %d tile-only frames checked, %d early (at most one a field: the one showing LR whole)",
          frames.size(), checked, early);
    QVERIFY(checked > 0);
    QVERIFY2(early <= fields, (std::to_string(early) + " early frames over " + std::to_string(fields) + " fields").c_str());
    QCOMPARE(e.validationMessageCount(), 0u);
}

void TestMetrics::settledMeansPerimeterResident() {
    iris::EngineConfig cfg;
    cfg.perimeterTiles = 2;
    iristest::TestEngine created = iristest::createTestEngine(cfg);
    QVERIFY2(created, iristest::describe(created.error).c_str());
    iris::Engine& e = *created.engine;
    QCOMPARE(e.waitForSettled(std::chrono::seconds(1)).status(), iris::Status::NoSlide);
    QVERIFY(e.open("synthetic:100000x100000").ok());
    QCOMPARE(e.waitForSettled(std::chrono::seconds(1)).status(), iris::Status::NotBound);
    QVERIFY(e.bindOffscreen(512, 384).ok());
    // Three views, each an entirely new field: settle, then pan by less than the perimeter
    // (two tiles, 512 level-0 pixels at downsample 1) in each direction.
    for (int i = 0; i < 3; ++i) {
        const iris::View v{20000.0 + i * 25000.0, 30000.0 + i * 17000.0, 1.0};
        e.setView(v);
        QVERIFY(e.waitForSettled(std::chrono::seconds(60)).ok());
        const auto frame = e.readFrame();
        QVERIFY(frame.ok());
        QVERIFY(frame.value().complete);
        QCOMPARE(frame.value().view.centerX, v.centerX);

        // The first frame of the panned view, as the frame callback reports it (waitForFrame
        // may return before the callback of the frame that completed the view has run).
        const iris::View panned{v.centerX + 400, v.centerY - 300, 1.0};
        std::mutex m;
        std::condition_variable cv;
        std::optional<iris::FrameStats> first;
        e.setFrameCallback([&](const iris::FrameStats& f) {
            std::lock_guard lock(m);
            if (!first && f.view.centerX == panned.centerX && f.view.centerY == panned.centerY) first = f;
            cv.notify_all();
        });
        e.setView(panned);
        std::unique_lock lock(m);
        const bool seen = cv.wait_for(lock, std::chrono::seconds(60), [&] { return first.has_value(); });
        lock.unlock();
        e.setFrameCallback({});
        QVERIFY(seen);
        QVERIFY2(first->complete, "the first frame after a pan within the settled perimeter lacked tiles");
    }
    // A view whose region cannot settle in the time given: a fresh field, 1 ms.
    e.setView({90000, 90000, 1.0});
    const iris::Result r = e.waitForSettled(std::chrono::milliseconds(1));
    QVERIFY(r.ok() || r.status() == iris::Status::Timeout); // a fast machine may settle in 1 ms
}

QTEST_GUILESS_MAIN(TestMetrics)
#include "tst_metrics.moc"
