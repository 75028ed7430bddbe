// Lifecycle churn (issue 2, "Tests"): open/close/reopen many times, rendering each time;
// create and destroy whole engines; rebind and resize the offscreen target while a slide
// is open. Nothing may crash, leak validation messages, or render a wrong frame. Under the
// asan preset LeakSanitizer reports any leak when the process exits; the test only has to
// exercise the paths.
#include <QtTest>

#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;

namespace {

#define CHECKED(call)                                                                               \
    do {                                                                                            \
        call;                                                                                       \
        if (QTest::currentTestFailed()) return;                                                     \
    } while (0)

std::vector<std::filesystem::path> churnSlides() {
    std::vector<std::filesystem::path> out;
    if (auto d = slidesDir("aperio")) {
        out.push_back(*d / "CMU-1-Small-Region.svs");
        out.push_back(*d / "small.svs");
    }
    if (auto s = sampleSlidePath()) out.push_back(*s);
    if (auto d = slidesDir("generic-tiff")) out.push_back(*d / "boxes.tiff");
    return out;
}

} // namespace

class TestLifecycle : public QObject {
    Q_OBJECT

    TestEngine e_;

    // Renders a 1:1 patch at level-0 (x0, y0) of the open slide and compares it with
    // read_region over the part inside the slide (the rest must be background).
    void checkOneToOne(iris::Engine& engine, const std::filesystem::path& path, int64_t x0, int64_t y0, uint32_t w,
                       uint32_t h, const char* what) {
        std::string err;
        auto frame = renderView(engine, viewWithOrigin(double(x0), double(y0), 1.0, w, h), w, h, 30s, &err);
        QVERIFY2(frame.has_value(), (std::string(what) + ": " + err).c_str());
        auto os = OpenSlideRef::open(path, &err);
        QVERIFY2(os, err.c_str());
        auto ref = os->readLevel0(x0, y0, w, h, &err);
        QVERIFY2(ref.has_value(), err.c_str());
        Mask inside(std::size_t(w) * h, 0), outside(std::size_t(w) * h, 0);
        for (uint32_t j = 0; j < h; ++j) {
            for (uint32_t i = 0; i < w; ++i) {
                const int64_t x = x0 + i, y = y0 + j;
                const bool in = x >= 0 && y >= 0 && x < os->levelWidth(0) && y < os->levelHeight(0);
                // A coarse level may reach up to one of its pixels past the slide: skip a band.
                const bool far = x < -64 || y < -64 || x >= os->levelWidth(0) + 64 || y >= os->levelHeight(0) + 64;
                if (in && pixel(*ref, i, j)[3] == 255) inside[std::size_t(j) * w + i] = 1;
                if (far) outside[std::size_t(j) * w + i] = 1;
            }
        }
        const DiffStats st = compareImages(frame->image, *ref, &inside);
        const uint64_t badBg = countNotColour(frame->image, backgroundBytes(), &outside);
        if (st.differing || badBg) {
            const std::string art = saveFailureArtefacts(std::string("lifecycle.") + what, frame->image, *ref, &inside);
            QFAIL((std::string(what) + ": " + st.summary() + "; " + std::to_string(badBg) +
                   " background px wrong; " + art)
                      .c_str());
        }
    }

private slots:
    void initTestCase() {
        e_ = createTestEngine();
        QVERIFY2(e_, describe(e_.error).c_str());
    }

    void init() { e_.beginTest(); }

    void cleanup() {
        const std::string why = e_.endTest();
        QVERIFY2(why.empty(), why.c_str());
    }

    void cleanupTestCase() {
        const std::string why = e_.finish();
        QVERIFY2(why.empty(), why.c_str());
    }

    // 30 opens, alternating slides; every other one without close() first (open replaces).
    void openCloseReopen() {
        const auto slides = churnSlides();
        if (slides.size() < 2) QSKIP("no test data");
        for (const auto& s : slides) QVERIFY2(std::filesystem::exists(s), ("missing: " + s.string()).c_str());
        constexpr uint32_t w = 192, h = 144;
        QVERIFY(e_->bindOffscreen(w, h).ok());
        uint64_t lastSerial = 0;
        for (int i = 0; i < 30; ++i) {
            const auto& path = slides[std::size_t(i) % slides.size()];
            const std::string what = "round " + std::to_string(i) + " " + path.filename().string();
            if (i % 2 == 0) e_->close();
            const iris::Result r = e_->open(path.string());
            QVERIFY2(r.ok(), (what + ": " + describe(r)).c_str());
            const auto info = e_->slideInfo();
            QVERIFY(info.has_value());
            QCOMPARE(QString::fromStdString(info->path), QString::fromStdString(path.string()));
            // Alternate between the fitted view (whole slide) and a 1:1 patch checked exactly.
            if (i % 3 == 0) {
                const iris::Result wr = e_->waitForFrame(30s);
                QVERIFY2(wr.ok(), (what + ": " + describe(wr)).c_str());
                auto f = e_->readFrame();
                QVERIFY2(f.ok(), describe(f.error()).c_str());
                QVERIFY(f->complete);
                QCOMPARE(f->image.width, w);
                QVERIFY2(f->serial > lastSerial, "frame serial did not increase");
                lastSerial = f->serial;
                QCOMPARE(countNotOpaque(f->image), uint64_t(0));
            } else {
                const int64_t x0 = info->width / 3, y0 = info->height / 4;
                CHECKED(checkOneToOne(*e_.engine, path, x0, y0, w, h, what.c_str()));
                auto f = e_->readFrame();
                QVERIFY(f.ok());
                QVERIFY2(f->serial > lastSerial, "frame serial did not increase");
                lastSerial = f->serial;
            }
        }
        e_->close();
        QVERIFY(!e_->slideInfo().has_value());
        QCOMPARE(QString(iris::statusName(e_->waitForFrame(50ms).status())), QString(iris::statusName(iris::Status::NoSlide)));
    }

    // Five whole engines, each opening, rendering and being destroyed with the slide open
    // (the destructor must stop the threads and free the device in the right order).
    void createDestroyEngines() {
        const auto slides = churnSlides();
        if (slides.empty()) QSKIP("no test data");
        for (int i = 0; i < 5; ++i) {
            TestEngine t = createTestEngine();
            QVERIFY2(t, describe(t.error).c_str());
            QVERIFY(t->bindOffscreen(128 + 16 * uint32_t(i), 96).ok());
            const auto& path = slides[std::size_t(i) % slides.size()];
            const iris::Result r = t->open(path.string());
            QVERIFY2(r.ok(), describe(r).c_str());
            if (i == 4) {
                // The last one is destroyed while its first frame may still be loading.
                t->setView(iris::View{100, 100, 0.7});
            } else {
                const iris::Result w = t->waitForFrame(30s);
                QVERIFY2(w.ok(), describe(w).c_str());
            }
            QCOMPARE(t->validationMessageCount(), uint64_t(0));
            const auto errors = t.log->errors();
            for (const auto& line : errors) qWarning("engine %d logged an error: %s", i, line.c_str());
            QVERIFY(errors.empty());
        }
    }

    // Rebinding at another size, and resize(), with a slide open: the next frame has the
    // new size and is still exact at 1:1.
    void rebindWhileOpen() {
        const auto slides = churnSlides();
        if (slides.empty()) QSKIP("no test data");
        const auto& path = slides[0]; // CMU-1-Small-Region.svs
        QVERIFY(e_->bindOffscreen(300, 200).ok());
        QVERIFY(e_->open(path.string()).ok());
        CHECKED(checkOneToOne(*e_.engine, path, 500, 700, 300, 200, "bound 300x200"));
        QVERIFY(e_->bindOffscreen(421, 173).ok());
        QCOMPARE(e_->targetSize(), std::make_pair(421u, 173u));
        CHECKED(checkOneToOne(*e_.engine, path, 1900, 2850, 421, 173, "rebound 421x173"));
        e_->resize(257, 311);
        QCOMPARE(e_->targetSize(), std::make_pair(257u, 311u));
        CHECKED(checkOneToOne(*e_.engine, path, 37, 11, 257, 311, "resized 257x311"));
        // Back and forth quickly, then a frame at the last size.
        for (uint32_t k = 0; k < 6; ++k) {
            QVERIFY(e_->bindOffscreen(100 + 37 * k, 80 + 11 * k).ok());
            e_->translate(3.0, -2.0);
        }
        CHECKED(checkOneToOne(*e_.engine, path, 1200, 1300, 100 + 37 * 5, 80 + 11 * 5, "after rebind storm"));
        e_->close();
    }
};

QTEST_GUILESS_MAIN(TestLifecycle)
#include "tst_lifecycle.moc"
