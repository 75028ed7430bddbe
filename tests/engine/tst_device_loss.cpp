// Device loss (issue 14, "Faults the engine survives"): VK_ERROR_DEVICE_LOST from a frame
// submission, an upload submission (an engine uploading by queue copies: a host-written atlas,
// the default on CPU devices, submits none) or a frame's fence wait, injected with
// Engine::injectFault, is recovered by the engine alone. After each loss the engine reports
// it (error(), the fault callback, an Error line), recreates its device, atlas and pipelines,
// and draws the view again from the RAM cache: the frames after a recovery equal byte for byte
// the frames the same views gave before any fault. The host's calls made while the device is
// being recreated (a new view, a new target size) are kept. Runs in the dev build and under
// ASan (label asan), where LeakSanitizer checks that the rebuilt objects leak nothing.
#include <QtTest>

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;

namespace {

using Fault = iris::Engine::InjectedFault;

const char* faultName(Fault f) {
    switch (f) {
    case Fault::DeviceLostAtFrameSubmit: return "frame submit";
    case Fault::DeviceLostAtUploadSubmit: return "upload submit";
    case Fault::DeviceLostAtFrameWait: return "frame wait";
    case Fault::DeviceLostAtPresent: return "present";
    case Fault::SurfaceLostAtPresent: return "surface lost at present";
    }
    return "?";
}

// What the fault callback was told, in order.
struct FaultLog {
    std::mutex m;
    std::vector<iris::Result> events;
    void add(const iris::Result& r) {
        std::lock_guard lock(m);
        events.push_back(r);
    }
    std::vector<iris::Result> take() {
        std::lock_guard lock(m);
        return std::exchange(events, {});
    }
};

// Error lines a recovery logs: the loss, and the engine saying what it does about it.
bool expectedLossLine(const std::string& line) {
    return line.find("Vulkan device lost") != std::string::npos ||
           line.find("The GPU device was lost") != std::string::npos;
}

} // namespace

class TestDeviceLoss : public QObject {
    Q_OBJECT

    TestEngine e_;
    std::shared_ptr<FaultLog> faults_ = std::make_shared<FaultLog>();
    static constexpr uint32_t kW = 320, kH = 240;
    // Views spread over the sample slide: three downsamples × three places, and one between
    // levels. Consecutive ones are at different places, so that each needs tiles the one
    // before did not (an upload fault needs an upload to happen).
    std::vector<iris::View> views_;
    std::vector<iris::Frame> reference_; // the frame of views_[i] before any fault

    // Every Error line since the last call must be one a device loss logs.
    void checkErrorLines() {
        for (const std::string& line : e_.log->takeErrors())
            QVERIFY2(expectedLossLine(line), ("unexpected Error line: " + line).c_str());
    }

    // One injected loss: arm `fault`, show views_[i], and expect a complete frame equal to the
    // reference, one more recovery, the loss in error() and the callback told of the loss and
    // then of the recovery. On `engine` (the suite's engine when null), whose fault callback
    // writes into `faults` (faults_ when null).
    void lossThenView(Fault fault, size_t i, const char* round, TestEngine* engine = nullptr,
                      FaultLog* faults = nullptr) {
        TestEngine& e = engine ? *engine : e_;
        FaultLog& log = faults ? *faults : *faults_;
        const std::string what = std::string(faultName(fault)) + ", " + round + ", view " + std::to_string(i) +
                                 ", uploads by " + e->device().tileUpload;
        const uint32_t before = e->device().recoveries;
        e->clearError();
        e->injectFault(fault);
        std::string why;
        auto frame = renderView(*e.engine, views_[i], kW, kH, 120s, &why);
        QVERIFY2(frame.has_value(), (what + ": " + why).c_str());
        const iris::DeviceInfo d = e->device();
        QVERIFY2(d.recoveries == before + 1,
                 (what + ": " + std::to_string(d.recoveries - before) + " recoveries, expected 1").c_str());
        QVERIFY(!d.lost);
        QCOMPARE(e->error().status(), iris::Status::DeviceLost);
        e->clearError();
        const auto events = log.take();
        QVERIFY2(events.size() == 2, (what + ": " + std::to_string(events.size()) + " fault callbacks, expected 2").c_str());
        QCOMPARE(events[0].status(), iris::Status::DeviceLost);
        QCOMPARE(events[1].status(), iris::Status::Ok);
        QVERIFY2(events[1].message().find("recreated") != std::string::npos, events[1].message().c_str());
        const DiffStats diff = compareImages(frame->image, reference_[i].image, nullptr, 4);
        if (diff.differing != 0) {
            const std::string where = saveFailureArtefacts("device_loss", frame->image, reference_[i].image, nullptr);
            QFAIL((what + ": the frame after recovery differs from the one before: " + diff.summary() + "; " + where)
                      .c_str());
        }
        for (const std::string& line : e.log->takeErrors())
            QVERIFY2(expectedLossLine(line), ("unexpected Error line: " + line).c_str());
    }

    // The upload fault needs uploads on the queue: where the suite's engine writes tiles into a
    // host-written atlas (CPU devices), an engine that uploads by queue copies takes it.
    static iris::EngineConfig uploadingBy(Fault fault) {
        iris::EngineConfig c;
        if (fault == Fault::DeviceLostAtUploadSubmit) c.tuning.tileUpload = iris::EngineTuning::TileUpload::Queue;
        return c;
    }
    bool hostWrites() const { return e_->device().tileUpload == "host"; }

private Q_SLOTS:
    void initTestCase() {
        e_ = createTestEngine();
        QVERIFY2(e_, describe(e_.error).c_str());
        const auto sample = sampleSlidePath();
        if (!sample) QSKIP("no sample slide");
        e_->setFaultCallback([log = faults_](const iris::Result& r) { log->add(r); });
        QVERIFY(e_->bindOffscreen(kW, kH).ok());
        QVERIFY2(e_->open(sample->string()).ok(), describe(e_->error()).c_str());
        const iris::SlideInfo info = *e_->slideInfo();
        const double w = double(info.width), h = double(info.height);
        for (double ds : {1.0, 2.0, 4.0})
            for (double fx : {0.2, 0.5, 0.8})
                views_.push_back(iris::View{w * fx, h * (1.0 - fx * 0.8), ds});
        views_.push_back(iris::View{w * 0.35, h * 0.4, 1.5}); // between levels
        for (const iris::View& v : views_) {
            std::string why;
            auto frame = renderView(*e_.engine, v, kW, kH, 60s, &why);
            QVERIFY2(frame.has_value(), why.c_str());
            reference_.push_back(std::move(*frame));
        }
        QVERIFY(faults_->take().empty());
        QCOMPARE(e_->device().recoveries, 0u);
    }
    void init() { e_.beginTest(); }
    void cleanup() {
        checkErrorLines();
        const std::string why = e_.endTest();
        QVERIFY2(why.empty(), why.c_str());
    }
    void cleanupTestCase() {
        const std::string why = e_.finish();
        QVERIFY2(why.empty(), why.c_str());
    }

    // Each kind of loss, again and again: every recovery gives the same frames as before.
    void recoversFromEachFaultRepeatedly() {
        const int rounds = qEnvironmentVariableIsSet("IRIS_DEVICE_LOSS_ROUNDS")
                               ? qEnvironmentVariableIntValue("IRIS_DEVICE_LOSS_ROUNDS")
                               : 3;
        // The suite's engine (where it writes tiles from the host it submits no uploads: its
        // upload faults are skipped), and then an engine that uploads by queue copies, which
        // takes every kind (its frames are the same: engine.tile_upload). Each loss empties the
        // atlas, so every view after one needs uploads again.
        const auto walk = [&](TestEngine* engine, FaultLog* faults, bool uploads) {
            size_t next = 0;
            for (int round = 0; round < rounds; ++round) {
                for (Fault f :
                     {Fault::DeviceLostAtFrameSubmit, Fault::DeviceLostAtUploadSubmit, Fault::DeviceLostAtFrameWait}) {
                    if (f == Fault::DeviceLostAtUploadSubmit && !uploads) continue;
                    lossThenView(f, next % views_.size(), ("round " + std::to_string(round)).c_str(), engine, faults);
                    if (QTest::currentTestFailed()) return;
                    ++next;
                }
            }
        };
        walk(nullptr, nullptr, !hostWrites());
        if (QTest::currentTestFailed() || !hostWrites()) return;
        TestEngine uploader = createTestEngine(uploadingBy(Fault::DeviceLostAtUploadSubmit));
        QVERIFY2(uploader, describe(uploader.error).c_str());
        QCOMPARE(uploader->device().tileUpload, std::string("queue"));
        auto uploaderFaults = std::make_shared<FaultLog>();
        uploader->setFaultCallback([log = uploaderFaults](const iris::Result& r) { log->add(r); });
        QVERIFY(uploader->bindOffscreen(kW, kH).ok());
        QVERIFY(uploader->open(sampleSlidePath()->string()).ok());
        walk(&uploader, uploaderFaults.get(), true);
        const std::string why = uploader.finish();
        QVERIFY2(why.empty(), why.c_str());
    }

    // The host's calls while the device is being recreated are kept: a view and a new target
    // size given right after the loss are what the next complete frame shows.
    void callsDuringRecoveryAreKept() {
        const uint32_t before = e_->device().recoveries;
        e_->clearError();
        e_->injectFault(Fault::DeviceLostAtFrameSubmit);
        e_->setView(views_[1]); // the frame that hits the fault
        // Meanwhile (the render thread is noticing the loss or rebuilding): a new size and view.
        QVERIFY(e_->bindOffscreen(kW * 2, kH * 2).ok());
        const iris::View target{views_[2].centerX, views_[2].centerY, views_[2].downsample};
        std::string why;
        auto big = renderView(*e_.engine, target, kW * 2, kH * 2, 120s, &why);
        QVERIFY2(big.has_value(), why.c_str());
        QCOMPARE(e_->device().recoveries, before + 1);
        e_->clearError();
        faults_->take();
        // The same view at the old size again equals its reference.
        QVERIFY(e_->bindOffscreen(kW, kH).ok());
        auto small = renderView(*e_.engine, views_[2], kW, kH, 60s, &why);
        QVERIFY2(small.has_value(), why.c_str());
        QCOMPARE(compareImages(small->image, reference_[2].image, nullptr, 4).differing, uint64_t(0));
    }

    // API readers on other threads while losses are recovered: memoryStats(), device(),
    // metrics() and views never see a half-built atlas (ASan and the race-free reads).
    void readersDuringRecovery() {
        std::atomic<bool> stop{false};
        std::vector<std::thread> readers;
        for (int t = 0; t < 3; ++t) {
            readers.emplace_back([&, t] {
                uint64_t sink = 0;
                while (!stop.load()) {
                    const iris::MemoryStats m = e_->memoryStats();
                    const iris::DeviceInfo d = e_->device();
                    sink += m.atlasSlots + m.atlasActive + d.atlasSlots + e_->metrics().frames;
                    if (t == 0) e_->redraw();
                    std::this_thread::yield();
                }
                QVERIFY(sink > 0);
            });
        }
        for (size_t i = 0; i < 4 && !QTest::currentTestFailed(); ++i) {
            // (a host-written atlas submits no uploads: its buffer thread's part is the rebuild)
            const Fault odd = hostWrites() ? Fault::DeviceLostAtFrameWait : Fault::DeviceLostAtUploadSubmit;
            lossThenView(i % 2 ? odd : Fault::DeviceLostAtFrameSubmit, (i * 4 + 1) % views_.size(), "readers");
        }
        stop = true;
        for (auto& r : readers) r.join();
    }

    // An engine destroyed just after a loss was armed, or while it recovers (told by the fault
    // callback that the loss was noticed), goes away cleanly: no hang, no leak, no use of
    // what the rebuild replaced.
    void destroyedDuringRecovery() {
        const auto sample = sampleSlidePath();
        for (int i = 0; i < 6; ++i) {
            const Fault fault = i % 2 ? Fault::DeviceLostAtUploadSubmit : Fault::DeviceLostAtFrameSubmit;
            TestEngine t = createTestEngine(uploadingBy(fault));
            QVERIFY2(t, describe(t.error).c_str());
            struct Noticed {
                std::mutex m;
                std::condition_variable cv;
                bool lost = false;
            };
            auto noticed = std::make_shared<Noticed>();
            t->setFaultCallback([noticed](const iris::Result& r) {
                if (r.status() != iris::Status::DeviceLost) return;
                std::lock_guard lock(noticed->m);
                noticed->lost = true;
                noticed->cv.notify_all();
            });
            QVERIFY(t->bindOffscreen(kW, kH).ok());
            QVERIFY(t->open(sample->string()).ok());
            std::string why;
            QVERIFY2(renderView(*t.engine, views_[0], kW, kH, 60s, &why).has_value(), why.c_str());
            t->injectFault(fault);
            t->setView(views_[3 + i % 3]);
            if (i >= 2) { // else: destroyed before the fault may even have been hit
                std::unique_lock lock(noticed->m);
                QVERIFY2(noticed->cv.wait_for(lock, 60s, [&] { return noticed->lost; }), "the loss was not reported");
            }
            for (const std::string& line : t.log->takeErrors())
                QVERIFY2(expectedLossLine(line), ("unexpected Error line: " + line).c_str());
            const std::string fin = t.finish();
            QVERIFY2(fin.empty(), fin.c_str());
        }
    }
};

QTEST_GUILESS_MAIN(TestDeviceLoss)
#include "tst_device_loss.moc"
