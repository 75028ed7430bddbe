// Tiles written into the atlas from the host (EngineTuning::tileUpload; gpu/tile_atlas.h,
// buffer/buffer_thread.h): on a CPU device the atlas is a linear image in host-visible memory
// and the buffer thread writes each tile's nine levels into it, with no upload on the queue.
// That must change nothing but when a tile becomes drawable:
//
//   * an engine that writes from the host and one that uploads by queue copies draw the same
//     settled frames, byte for byte, along a walk of exact, filtered, turned and coarse views,
//     with the reduction-enhancement on and off (the host-made levels differ between the two);
//   * both atlases are the smallest there is (64 slots) and the walk needs several times that
//     many tiles, so slots are reclaimed and written again while earlier frames were drawn from
//     them; the walk's first view, drawn again at the end from rewritten slots, is the same;
//   * tiles written for a view that reads them at level 0 alone get their other levels later;
//     a shrunk view of the same place right after draws them only once those are made, and
//     then equal to the engine that uploaded every level at once;
//   * on a CPU device Auto chooses host writes and the engine says so (DeviceInfo::tileUpload);
//     a GPU may or may not allow a linear atlas (the engine then logs why and uploads by copy).
#include <QtTest>

#include <cmath>
#include <cstdlib>

#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;

namespace {

constexpr uint32_t kW = 640, kH = 480;

} // namespace

class TstTileUpload : public QObject {
    Q_OBJECT

    TestEngine host_, queue_;

private slots:
    void initTestCase() {
        ::unsetenv("IRIS_TILE_UPLOAD"); // the engines' tuning is this suite's, not the shell's
        ::unsetenv("IRIS_MIP_SCHEDULE");
        iris::EngineConfig h, q;
        h.tuning.tileUpload = iris::EngineTuning::TileUpload::Host;
        q.tuning.tileUpload = iris::EngineTuning::TileUpload::Queue;
        // Host writes need the levels made on the host; both engines make them so, so that the
        // two differ only in how tiles reach the atlas (on a GPU too).
        h.tuning.mipSchedule = q.tuning.mipSchedule = iris::EngineTuning::MipSchedule::Host;
        // And both draw quads: the resolve on the host (render/host_resolve.h), which only a
        // host-written atlas allows, is compared with the quads by engine.host_resolve.
        ::unsetenv("IRIS_TILE_RESOLVE");
        h.tuning.tileResolve = q.tuning.tileResolve = iris::EngineTuning::TileResolve::Quads;
        h.vramBudgetBytes = q.vramBudgetBytes = 1; // the atlas's floor: 64 slots
        host_ = createTestEngine(h);
        QVERIFY2(host_, describe(host_.error).c_str());
        queue_ = createTestEngine(q);
        QVERIFY2(queue_, describe(queue_.error).c_str());
        QVERIFY(host_->bindOffscreen(kW, kH).ok());
        QVERIFY(queue_->bindOffscreen(kW, kH).ok());
        const iris::DeviceInfo hd = host_->device(), qd = queue_->device();
        qInfo("device %s: host-write engine uploads by '%s', the other by '%s'; %u and %u atlas slots", hd.name.c_str(),
              hd.tileUpload.c_str(), qd.tileUpload.c_str(), hd.atlasSlots, qd.atlasSlots);
        QCOMPARE(qd.tileUpload, std::string("queue"));
        QCOMPARE(hd.atlasSlots, 64u);
        QCOMPARE(qd.atlasSlots, 64u);
        if (isCpuDevice(hd.name)) QCOMPARE(hd.tileUpload, std::string("host"));
        // An Auto engine on a CPU device writes from the host too.
        TestEngine autoEngine = createTestEngine();
        QVERIFY2(autoEngine, describe(autoEngine.error).c_str());
        if (isCpuDevice(hd.name))
            QCOMPARE(autoEngine->device().tileUpload, std::string("host"));
        else
            QCOMPARE(autoEngine->device().tileUpload, std::string("queue"));
        const std::string done = autoEngine.finish();
        QVERIFY2(done.empty(), done.c_str());
    }

    void cleanupTestCase() {
        for (TestEngine* e : {&host_, &queue_}) {
            const std::string during = e->endTest(); // the whole suite's: no beginTest
            QVERIFY2(during.empty(), during.c_str());
            const std::string finished = e->finish();
            QVERIFY2(finished.empty(), finished.c_str());
        }
    }

    void sameFramesAlongAWalk() {
        const auto path = sampleSlidePath();
        if (!path) QSKIP("the sample slide is not built");
        QVERIFY(host_->open(path->string()).ok());
        QVERIFY(queue_->open(path->string()).ok());
        const iris::SlideInfo info = *host_->slideInfo();
        QVERIFY(info.levels.size() >= 2);
        const double w = double(info.width), h = double(info.height);
        const double ds1 = info.levels[1].downsample;
        struct Step {
            const char* what;
            iris::View view;
            bool enhance;
        };
        const iris::View first{std::round(w * 0.2), std::round(h * 0.25), 1.0};
        // Fields far apart at 1:1: each needs about 30 tiles with its perimeter, so the walk
        // needs several times the 64 slots and reclaims most of them more than once.
        const Step steps[] = {
            {"1:1, first field", first, true},
            // Tiles uploaded for a level's own scale wait for their levels (BufferThread::
            // levelsWaitFor); shrunk at once, the same place needs them made.
            {"downsample 1.6 at the first field", {first.centerX, first.centerY, 1.6}, true},
            {"1:1, second field", {std::round(w * 0.7), std::round(h * 0.25), 1.0}, true},
            {"1:1 a quarter pixel off: filtered", {std::round(w * 0.45) + 0.25, std::round(h * 0.6), 1.0}, true},
            {"turned 30 degrees", turnedViewAt(int64_t(w * 0.3), int64_t(h * 0.7), 1.0, 30, false, false, kW, kH),
             true},
            {"downsample 1.37", {w * 0.8 + 0.37, h * 0.8 + 0.61, 1.37}, true},
            {"level 1 at its own scale", {std::round(w / 2 / ds1) * ds1, std::round(h / 3 / ds1) * ds1, ds1}, true},
            {"level 1 shrunk by 1.3 there",
             {std::round(w / 2 / ds1) * ds1, std::round(h / 3 / ds1) * ds1, ds1 * 1.3},
             true},
            {"1:1, enhancement off", {std::round(w * 0.55), std::round(h * 0.45), 1.0}, false},
            {"downsample 2.6, enhancement off", {w * 0.35, h * 0.4, 2.6}, false},
            {"1:1, third field", {std::round(w * 0.85), std::round(h * 0.55), 1.0}, true},
            {"the first field again, from reclaimed slots", first, true},
        };
        std::optional<iris::Image> firstFrame;
        for (const Step& s : steps) {
            host_->setEnhance(s.enhance);
            queue_->setEnhance(s.enhance);
            std::string why;
            auto a = renderSettled(*host_.engine, s.view, kW, kH, 60s, &why);
            QVERIFY2(a, (std::string(s.what) + " (host writes): " + why).c_str());
            auto b = renderSettled(*queue_.engine, s.view, kW, kH, 60s, &why);
            QVERIFY2(b, (std::string(s.what) + " (queue copies): " + why).c_str());
            const DiffStats d = compareImages(a->image, b->image, nullptr, 4);
            qInfo("%s: %s; tiles drawn %u, atlas slots active %u", s.what, d.summary().c_str(),
                  host_->metrics().lastFrame.tilesDrawn, host_->memoryStats().atlasActive);
            if (d.differing)
                qWarning(
                    "%s",
                    saveFailureArtefacts(std::string("tile_upload.") + s.what, a->image, b->image, nullptr).c_str());
            QVERIFY2(d.differing == 0, s.what);
            if (!firstFrame) {
                firstFrame = a->image;
            } else if (&s == &steps[std::size(steps) - 1]) {
                const DiffStats again = compareImages(a->image, *firstFrame, nullptr, 4);
                QVERIFY2(again.differing == 0, ("the first field drawn again differs: " + again.summary()).c_str());
            }
        }
    }

private:
    static bool isCpuDevice(const std::string& name) { return name.find("llvmpipe") != std::string::npos; }
};

QTEST_GUILESS_MAIN(TstTileUpload)
#include "tst_tile_upload.moc"
