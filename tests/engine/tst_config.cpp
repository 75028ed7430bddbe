// Configuration, not environment (EngineConfig::tuning, iris/environment.h):
//
//   * tuningFromEnvironment maps each IRIS_* variable onto its EngineTuning field, leaves the
//     base's value where a variable is unset or empty, and rejects any other value with an
//     error naming the variable and the values it takes;
//   * the engine itself reads no environment: with every variable set to the opposite of what
//     the engine would choose, an engine created from a plain EngineConfig behaves as before;
//   * two engines in one process can be set up differently (the mip schedule, the device).
#include <QtTest>

#include <vector>

#include <mutex>

#include <cstdlib>
#include <map>
#include <optional>
#include <string>

#include <iris/environment.h>

#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;
using namespace std::chrono_literals;

namespace {

constexpr const char* kVariables[] = {"IRIS_PACE_FRAMES", "IRIS_DRAW_COVERED", "IRIS_MIP_SCHEDULE", "IRIS_DEVICE",
                                      "IRIS_QUEUES",      "IRIS_TILE_RESOLVE", "IRIS_COLOR_LOOKUP", "IRIS_EXACT_COPY",
                                      "IRIS_TILE_UPLOAD", "IRIS_JPEG_DECODE"};

// Sets the variables for its lifetime and puts back what was there before.
class ScopedEnvironment {
public:
    explicit ScopedEnvironment(const std::map<std::string, std::string>& values) {
        for (const char* name : kVariables) {
            const char* v = std::getenv(name);
            saved_[name] = v ? std::optional<std::string>(v) : std::nullopt;
            ::unsetenv(name);
        }
        for (const auto& [name, value] : values) ::setenv(name.c_str(), value.c_str(), 1);
    }
    ~ScopedEnvironment() {
        for (const auto& [name, value] : saved_) {
            if (value) ::setenv(name.c_str(), value->c_str(), 1);
            else ::unsetenv(name.c_str());
        }
    }
    ScopedEnvironment(const ScopedEnvironment&) = delete;
    ScopedEnvironment& operator=(const ScopedEnvironment&) = delete;

private:
    std::map<std::string, std::optional<std::string>> saved_;
};

// An engine from a plain EngineConfig (no environment mapping, unlike createTestEngine).
TestEngine createPlainEngine(const iris::EngineTuning& tuning) {
    TestEngine t;
    t.log = std::make_shared<LogSink>();
    iris::EngineConfig base;
    base.tuning = tuning;
    auto created = iris::Engine::create(testEngineConfig(t.log, base));
    if (created.ok()) t.engine = std::move(created.value());
    else t.error = created.error();
    return t;
}

} // namespace

class TstConfig : public QObject {
    Q_OBJECT

private slots:
    void eachVariableMapsOntoItsField() {
        using T = iris::EngineTuning;
        {
            ScopedEnvironment env(std::map<std::string, std::string>{});
            auto t = iris::tuningFromEnvironment();
            QVERIFY(t.ok());
            QVERIFY(t->pacing == T::Pacing::Auto);
            QVERIFY(!t->drawCovered);
            QVERIFY(t->mipSchedule == T::MipSchedule::Auto);
            QVERIFY(t->deviceName.empty());
            QVERIFY(!t->singleQueue);
            QVERIFY(t->exactCopy == T::ExactCopy::Auto);
            QVERIFY(t->tileUpload == T::TileUpload::Auto);
            QVERIFY(t->jpegDecode == T::JpegDecode::Auto);
        }
        {
            ScopedEnvironment env({{"IRIS_PACE_FRAMES", "1"},
                                   {"IRIS_DRAW_COVERED", "1"},
                                   {"IRIS_MIP_SCHEDULE", "serial"},
                                   {"IRIS_DEVICE", "llvmpipe"},
                                   {"IRIS_QUEUES", "single"},
                                   {"IRIS_TILE_RESOLVE", "quads"},
                                   {"IRIS_COLOR_LOOKUP", "nodes"},
                                   {"IRIS_EXACT_COPY", "1"},
                                   {"IRIS_TILE_UPLOAD", "host"},
                                   {"IRIS_JPEG_DECODE", "gpu"}});
            auto t = iris::tuningFromEnvironment();
            QVERIFY(t.ok());
            QVERIFY(t->exactCopy == T::ExactCopy::On);
            QVERIFY(t->tileUpload == T::TileUpload::Host);
            QVERIFY(t->jpegDecode == T::JpegDecode::Gpu);
            QVERIFY(t->tileResolve == T::TileResolve::Quads);
            QVERIFY(t->colorLookup == T::ColorLookup::Nodes);
            QVERIFY(t->pacing == T::Pacing::On);
            QVERIFY(t->drawCovered);
            QVERIFY(t->mipSchedule == T::MipSchedule::Serial);
            QCOMPARE(t->deviceName, std::string("llvmpipe"));
            QVERIFY(t->singleQueue);
        }
        {
            ScopedEnvironment env({{"IRIS_PACE_FRAMES", "0"},
                                   {"IRIS_MIP_SCHEDULE", "wide"},
                                   {"IRIS_QUEUES", "auto"},
                                   {"IRIS_DRAW_COVERED", "0"},
                                   {"IRIS_TILE_RESOLVE", "compute"},
                                   {"IRIS_COLOR_LOOKUP", "sampler"},
                                   {"IRIS_EXACT_COPY", "0"},
                                   {"IRIS_TILE_UPLOAD", "queue"},
                                   {"IRIS_JPEG_DECODE", "cpu"}});
            T base;
            base.singleQueue = true;
            base.drawCovered = true;
            auto t = iris::tuningFromEnvironment(base);
            QVERIFY(t.ok());
            QVERIFY(t->pacing == T::Pacing::Off);
            QVERIFY(t->mipSchedule == T::MipSchedule::Wide);
            QVERIFY(!t->singleQueue);
            QVERIFY(!t->drawCovered);
            QVERIFY(t->tileResolve == T::TileResolve::Compute);
            QVERIFY(t->colorLookup == T::ColorLookup::Sampler);
            QVERIFY(t->exactCopy == T::ExactCopy::Off);
            QVERIFY(t->tileUpload == T::TileUpload::Queue);
            QVERIFY(t->jpegDecode == T::JpegDecode::Cpu);
        }
        {
            ScopedEnvironment env(std::map<std::string, std::string>{{"IRIS_MIP_SCHEDULE", "host"}});
            auto t = iris::tuningFromEnvironment();
            QVERIFY(t.ok());
            QVERIFY(t->mipSchedule == T::MipSchedule::Host);
        }
    }

    void unsetOrEmptyKeepsTheBase() {
        iris::EngineTuning base;
        base.pacing = iris::EngineTuning::Pacing::On;
        base.drawCovered = true;
        base.mipSchedule = iris::EngineTuning::MipSchedule::Wide;
        base.deviceName = "NVIDIA";
        base.singleQueue = true;
        ScopedEnvironment env({{"IRIS_PACE_FRAMES", ""}, {"IRIS_DEVICE", ""}});
        auto t = iris::tuningFromEnvironment(base);
        QVERIFY(t.ok());
        QVERIFY(t->pacing == base.pacing);
        QCOMPARE(t->drawCovered, true);
        QVERIFY(t->mipSchedule == base.mipSchedule);
        QCOMPARE(t->deviceName, std::string("NVIDIA"));
        QCOMPARE(t->singleQueue, true);
    }

    void badValuesAreErrorsNamingTheVariable_data() {
        QTest::addColumn<QString>("name");
        QTest::addColumn<QString>("value");
        QTest::addColumn<QString>("allowed");
        QTest::newRow("pacing yes") << "IRIS_PACE_FRAMES" << "yes" << "0, 1";
        QTest::newRow("pacing 2") << "IRIS_PACE_FRAMES" << "2" << "0, 1";
        QTest::newRow("covered true") << "IRIS_DRAW_COVERED" << "true" << "0, 1";
        QTest::newRow("schedule Wide") << "IRIS_MIP_SCHEDULE" << "Wide" << "wide, serial";
        QTest::newRow("queues one") << "IRIS_QUEUES" << "one" << "single, auto";
        QTest::newRow("resolve pixels") << "IRIS_TILE_RESOLVE" << "pixels" << "auto, quads, compute";
        QTest::newRow("lookup Sampler") << "IRIS_COLOR_LOOKUP" << "Sampler" << "auto, sampler, nodes";
        QTest::newRow("exact copy on") << "IRIS_EXACT_COPY" << "on" << "auto, 0, 1";
    }
    void badValuesAreErrorsNamingTheVariable() {
        QFETCH(QString, name);
        QFETCH(QString, value);
        QFETCH(QString, allowed);
        ScopedEnvironment env(std::map<std::string, std::string>{{name.toStdString(), value.toStdString()}});
        auto t = iris::tuningFromEnvironment();
        QVERIFY(!t.ok());
        QCOMPARE(t.error().status(), iris::Status::InvalidArgument);
        const QString message = QString::fromStdString(t.error().message());
        QVERIFY2(message.contains(name) && message.contains("'" + value + "'") && message.contains(allowed),
                 qPrintable(message));
        // createTestEngine reports it as the creation error rather than ignoring it.
        TestEngine e = createTestEngine();
        QVERIFY(!e);
        QCOMPARE(e.error.status(), iris::Status::InvalidArgument);
    }

    // The engine reads no environment: every variable set against what the engine chooses on
    // its own changes nothing in an engine made from a plain EngineConfig.
    void theEngineIgnoresTheEnvironment() {
        std::string schedule, device;
        {
            ScopedEnvironment env(std::map<std::string, std::string>{});
            TestEngine plain = createPlainEngine({});
            QVERIFY2(plain, describe(plain.error).c_str());
            schedule = plain->device().mipSchedule;
            device = plain->device().name;
        }
        QVERIFY(schedule == "wide" || schedule == "serial" || schedule == "host");
        ScopedEnvironment env({{"IRIS_MIP_SCHEDULE", schedule == "wide" ? "serial" : "wide"},
                               {"IRIS_DEVICE", "no device is called this"},
                               {"IRIS_QUEUES", "bogus"},
                               {"IRIS_PACE_FRAMES", "bogus"}});
        TestEngine e = createPlainEngine({});
        QVERIFY2(e, describe(e.error).c_str());
        QCOMPARE(e->device().mipSchedule, schedule);
        QCOMPARE(e->device().name, device);
        QCOMPARE(e->validationMessageCount(), uint64_t(0));
    }

    // Two engines in one process, set up differently.
    void twoEnginesDiffer() {
        ScopedEnvironment env(std::map<std::string, std::string>{});
        iris::EngineTuning wide, serial;
        wide.mipSchedule = iris::EngineTuning::MipSchedule::Wide;
        serial.mipSchedule = iris::EngineTuning::MipSchedule::Serial;
        TestEngine a = createPlainEngine(wide);
        QVERIFY2(a, describe(a.error).c_str());
        TestEngine b = createPlainEngine(serial);
        QVERIFY2(b, describe(b.error).c_str());
        QCOMPARE(a->device().mipSchedule, std::string("wide"));
        QCOMPARE(b->device().mipSchedule, std::string("serial"));

        // A device filter: the device's own name picks it; a name no device has fails clearly.
        iris::EngineTuning named;
        named.deviceName = a->device().name;
        TestEngine c = createPlainEngine(named);
        QVERIFY2(c, describe(c.error).c_str());
        QCOMPARE(c->device().name, a->device().name);
        iris::EngineTuning nowhere;
        nowhere.deviceName = "no device is called this";
        TestEngine d = createPlainEngine(nowhere);
        QVERIFY(!d);
        QVERIFY2(d.error.message().find("no device is called this") != std::string::npos,
                 describe(d.error).c_str());
        for (TestEngine* t : {&a, &b, &c}) QCOMPARE((*t)->validationMessageCount(), uint64_t(0));
    }

    // Issue 14: a VRAM budget the device cannot allocate (VK_ERROR_OUT_OF_DEVICE_MEMORY,
    // injected through EngineTuning::deviceAllocationLimit) gives a smaller atlas, a logged
    // warning naming both sizes, and the same frames; a device that cannot hold even the
    // smallest atlas is a clear creation error.
    void atlasFallsBackWhenTheDeviceRunsOut() {
        ScopedEnvironment env(std::map<std::string, std::string>{});
        const auto sample = sampleSlidePath();
        if (!sample) QSKIP("no sample slide");
        struct Warnings {
            std::mutex m;
            std::vector<std::string> lines;
        };
        auto warnings = std::make_shared<Warnings>();
        const auto make = [&](uint64_t limit) {
            iris::EngineConfig cfg;
            cfg.vramBudgetBytes = 256ull << 20;
            cfg.tuning.deviceAllocationLimit = limit;
            auto log = std::make_shared<LogSink>();
            cfg = testEngineConfig(log, cfg);
            auto inner = cfg.log;
            cfg.log = [inner, warnings](iris::LogLevel level, std::string_view line) {
                if (level == iris::LogLevel::Warning) {
                    std::lock_guard lock(warnings->m);
                    warnings->lines.emplace_back(line);
                }
                if (inner) inner(level, line);
            };
            return iris::Engine::create(cfg);
        };
        auto full = make(0);
        QVERIFY2(full.ok(), describe(full.error()).c_str());
        {
            std::lock_guard lock(warnings->m);
            QVERIFY(warnings->lines.empty());
        }
        auto small = make(40ull << 20);
        QVERIFY2(small.ok(), describe(small.error()).c_str());
        const iris::MemoryStats fs = (*full)->memoryStats(), ss = (*small)->memoryStats();
        QVERIFY2(ss.atlasSlots < fs.atlasSlots && ss.atlasSlots >= 64,
                 (std::to_string(ss.atlasSlots) + " vs " + std::to_string(fs.atlasSlots)).c_str());
        QVERIFY(ss.vramAtlasBytes <= (40ull << 20));
        {
            std::lock_guard lock(warnings->m);
            QCOMPARE(warnings->lines.size(), size_t(1));
            const std::string& w = warnings->lines.front();
            QVERIFY2(w.find("could not allocate") != std::string::npos &&
                         w.find(std::to_string(fs.atlasSlots) + " slots") != std::string::npos &&
                         w.find(std::to_string(ss.atlasSlots) + " slots") != std::string::npos,
                     w.c_str());
        }
        // The same frames from both.
        for (auto* e : {full->get(), small->get()}) {
            QVERIFY(e->bindOffscreen(320, 240).ok());
            QVERIFY(e->open(sample->string()).ok());
        }
        for (const iris::View v : {iris::View{3000, 2000, 1.0}, iris::View{1500, 1000, 4.0}, iris::View{4500, 3000, 2.0}}) {
            std::string why;
            auto a = renderView(**full, v, 320, 240, 20s, &why);
            QVERIFY2(a, why.c_str());
            auto b = renderView(**small, v, 320, 240, 20s, &why);
            QVERIFY2(b, why.c_str());
            QVERIFY(a->image.rgba == b->image.rgba);
        }
        QCOMPARE((*small)->validationMessageCount(), uint64_t(0));
        // Not even 64 slots: creation fails, saying why.
        auto none = make(1ull << 20);
        QVERIFY(!none.ok());
        QCOMPARE(none.error().status(), iris::Status::OutOfMemory);
        QVERIFY2(none.error().message().find("OUT_OF_DEVICE_MEMORY") != std::string::npos,
                 describe(none.error()).c_str());
    }
};

QTEST_GUILESS_MAIN(TstConfig)
#include "tst_config.moc"
