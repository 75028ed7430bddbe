// Large raster layers streamed from their files (issue 19): a map whose levels stay in its file
// (iris::RasterLoadOptions::streamAbove) is drawn by the engine through its layer streamer, off
// the render thread, a chunk at a time.
//
//   streamedEqualsHeld   a label map and a float map, each loaded streamed and held: every
//                        view's frame with the streamed layer equals the frame with the held
//                        one byte for byte (the held path is checked against the CPU reference
//                        by engine.layers_render), at 1:1, zoomed in, between levels, turned,
//                        and the fit view;
//   slowSourceDoesNotBlock  a host's streamed level whose reads wait on the test: frames keep
//                        coming (incomplete) while a read waits, a view change is drawn, and
//                        once the reads go on the frame completes and equals the held map's;
//   fileTruncatedWhileShown  the map's file cut short after the load: the chunks that can no
//                        longer be read are left out (the frame equals the one without the
//                        layer there), the frame completes, a warning names the file, and the
//                        engine goes on drawing.
#include <QtTest>

#include <tiffio.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <condition_variable>
#include <filesystem>
#include <mutex>

#include "iris/layers.h"
#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;

namespace {

constexpr uint32_t kW = 320, kH = 240;

// The label at map pixel (x, y): squares of 40 of ids 1..3, a diagonal band of id 4 and
// scattered single pixels of 5, so that every reduction rule and edge shows.
uint16_t labelAt(uint32_t x, uint32_t y) {
    if ((x * 7 + y * 13) % 97 == 0) return 5;
    if ((x + y) / 9 % 31 == 0) return 4;
    return uint16_t(1 + (x / 40 + 2 * (y / 40)) % 3);
}
float valueAt(uint32_t x, uint32_t y) {
    if ((x / 17 + y / 23) % 11 == 0) return std::numeric_limits<float>::quiet_NaN();
    return float(0.5 + 0.5 * std::sin(x * 0.013) * std::cos(y * 0.021));
}

// A tiled (256), deflated, single-level TIFF of `w` × `h` labels (uint16) or values (float32),
// written a tile at a time.
bool writeTiff(const std::string& path, uint32_t w, uint32_t h, bool labels) {
    TIFF* t = TIFFOpen(path.c_str(), "w8");
    if (!t) return false;
    TIFFSetField(t, TIFFTAG_IMAGEWIDTH, w);
    TIFFSetField(t, TIFFTAG_IMAGELENGTH, h);
    TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, 1);
    TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, labels ? 16 : 32);
    TIFFSetField(t, TIFFTAG_SAMPLEFORMAT, labels ? SAMPLEFORMAT_UINT : SAMPLEFORMAT_IEEEFP);
    TIFFSetField(t, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
    TIFFSetField(t, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
    TIFFSetField(t, TIFFTAG_COMPRESSION, COMPRESSION_ADOBE_DEFLATE);
    TIFFSetField(t, TIFFTAG_TILEWIDTH, 256);
    TIFFSetField(t, TIFFTAG_TILELENGTH, 256);
    const size_t bpp = labels ? 2 : 4;
    std::vector<uint8_t> tile(256 * 256 * bpp);
    bool ok = true;
    for (uint32_t ty = 0; ty < h && ok; ty += 256)
        for (uint32_t tx = 0; tx < w && ok; tx += 256) {
            std::fill(tile.begin(), tile.end(), 0);
            for (uint32_t y = ty; y < std::min(h, ty + 256); ++y)
                for (uint32_t x = tx; x < std::min(w, tx + 256); ++x) {
                    uint8_t* p = tile.data() + (size_t(y - ty) * 256 + (x - tx)) * bpp;
                    if (labels) {
                        const uint16_t v = labelAt(x, y);
                        std::memcpy(p, &v, 2);
                    } else {
                        const float v = valueAt(x, y);
                        std::memcpy(p, &v, 4);
                    }
                }
            ok = TIFFWriteTile(t, tile.data(), tx, ty, 0, 0) >= 0;
        }
    TIFFClose(t);
    return ok;
}

// A host's level whose reads wait while the gate is closed (at most 20 s: a test that forgets
// to open it fails instead of hanging), counting them.
class GatedSource final : public iris::RasterPixelSource {
public:
    GatedSource(int32_t w, int32_t h) : w_(w), h_(h) {}
    iris::Result read(int32_t x, int32_t y, int32_t w, int32_t h, void* out) const override {
        {
            std::unique_lock lock(m_);
            ++waiting_;
            cv_.notify_all();
            if (!cv_.wait_for(lock, 20s, [&] { return open_; }))
                return iris::Result(iris::Status::Timeout, "the test never opened the gate");
            --waiting_;
        }
        reads_.fetch_add(1);
        auto* o = static_cast<uint16_t*>(out);
        for (int32_t r = 0; r < h; ++r)
            for (int32_t c = 0; c < w; ++c) o[size_t(r) * size_t(w) + size_t(c)] = labelAt(uint32_t(x + c), uint32_t(y + r));
        return {};
    }
    void setOpen(bool open) {
        std::lock_guard lock(m_);
        open_ = open;
        cv_.notify_all();
    }
    // Waits until a read waits at the closed gate.
    bool awaitWaiter(std::chrono::milliseconds timeout) const {
        std::unique_lock lock(m_);
        return cv_.wait_for(lock, timeout, [&] { return waiting_ > 0; });
    }
    int32_t w_, h_;
    mutable std::atomic<int> reads_{0};

private:
    mutable std::mutex m_;
    mutable std::condition_variable cv_;
    mutable int waiting_ = 0;
    bool open_ = true;
};

} // namespace

class TestLayersStream : public QObject {
    Q_OBJECT

    TestEngine e_;
    iris::SlideInfo info_;
    QTemporaryDir dir_;

    std::optional<iris::Frame> frameOf(const iris::View& view, std::string* why) {
        return renderView(*e_.engine, view, kW, kH, 60s, why);
    }

    std::vector<iris::View> views() const {
        const double w = info_.width, h = info_.height;
        std::vector<iris::View> v{
            viewWithOrigin(w * 0.1, h * 0.1, 1.0, kW, kH),   // 1:1, the top left
            viewWithOrigin(w * 0.62, h * 0.55, 1.0, kW, kH), // 1:1 elsewhere
            viewWithOrigin(w * 0.45, h * 0.2, 0.37, kW, kH), // zoomed in
            iris::View{w * 0.5, h * 0.5, 1.7},               // between levels
            iris::View{w * 0.3, h * 0.6, 4.0},
            iris::View{w * 0.6, h * 0.4, 2.3, 30.0},         // turned
        };
        v.push_back(e_->fitView());
        return v;
    }

    // Every view's frame with `streamed` shown equals the frame with `held` shown.
    void compareStreamedWithHeld(std::shared_ptr<const iris::RasterMap> streamed,
                                 std::shared_ptr<const iris::RasterMap> held, const iris::LayerStyle& style,
                                 const std::string& what) {
        std::string why;
        for (const iris::View& v : views()) {
            e_->clearLayers();
            QVERIFY(e_->addLayer(held, style).ok());
            auto a = frameOf(v, &why);
            QVERIFY2(a, why.c_str());
            e_->clearLayers();
            QVERIFY(e_->addLayer(streamed, style).ok());
            auto b = frameOf(v, &why);
            QVERIFY2(b, why.c_str());
            e_->clearLayers();
            auto base = frameOf(v, &why);
            QVERIFY2(base, why.c_str());
            QVERIFY2(a->image.rgba != base->image.rgba, (what + ": the layer shows nowhere in this view").c_str());
            if (b->image.rgba != a->image.rgba) {
                uint64_t differ = 0;
                for (size_t i = 0; i < a->image.rgba.size(); ++i) differ += a->image.rgba[i] != b->image.rgba[i];
                const std::string where = saveFailureArtefacts("layers-stream-" + what, b->image, a->image, nullptr);
                QFAIL((what + ": the streamed layer's frame differs from the held one's in " + std::to_string(differ) +
                       " bytes at downsample " + std::to_string(v.downsample) + "; " + where)
                          .c_str());
            }
        }
    }

private Q_SLOTS:
    void initTestCase() {
        e_ = createTestEngine();
        QVERIFY2(e_, describe(e_.error).c_str());
        const auto sample = sampleSlidePath();
        if (!sample) QSKIP("no sample slide");
        QVERIFY(dir_.isValid());
        QVERIFY(e_->bindOffscreen(kW, kH).ok());
        QVERIFY(e_->open(sample->string()).ok());
        info_ = *e_->slideInfo();
    }
    void init() { e_.beginTest(); }
    void cleanup() {
        e_->clearLayers();
        const std::string why = e_.endTest();
        QVERIFY2(why.empty(), why.c_str());
    }
    void cleanupTestCase() {
        const std::string why = e_.finish();
        QVERIFY2(why.empty(), why.c_str());
    }

    void streamedEqualsHeld() {
        // A label map at half the slide's resolution (3000 × 2000: 12 MB decoded) and a float
        // map at a quarter of it, both spanning the slide. Streamed above 4 MiB: levels over
        // 512 KiB stay in the file or are made on demand, the coarsest are held.
        struct Case {
            std::string name;
            uint32_t w, h;
            bool labels;
        };
        for (const Case& c : {Case{"labels", uint32_t(info_.width / 2), uint32_t(info_.height / 2), true},
                              Case{"values", uint32_t(info_.width / 4), uint32_t(info_.height / 4), false}}) {
            const std::string path = dir_.filePath(QString::fromStdString(c.name + ".tif")).toStdString();
            QVERIFY(writeTiff(path, c.w, c.h, c.labels));
            iris::RasterLoadOptions streamedOpts;
            streamedOpts.asLabels = c.labels;
            streamedOpts.streamAbove = 4u << 20;
            auto streamed = iris::loadRasterMap(path, streamedOpts);
            QVERIFY2(streamed, describe(streamed.error()).c_str());
            QVERIFY(streamed->streamed());
            QVERIFY(streamed->levels.front().streamed());
            QVERIFY(!streamed->levels.back().streamed());
            QVERIFY(streamed->residentBytes() <= 4u << 20);
            iris::RasterLoadOptions heldOpts;
            heldOpts.asLabels = c.labels;
            auto held = iris::loadRasterMap(path, heldOpts);
            QVERIFY2(held, describe(held.error()).c_str());
            QVERIFY(!held->streamed());
            QCOMPARE(streamed->minValue, held->minValue);
            QCOMPARE(streamed->maxValue, held->maxValue);
            iris::LayerStyle style;
            style.opacity = 0.7;
            if (c.labels) {
                style.classes = iris::defaultLabelClasses(6);
            } else {
                style.threshold = 0.15;
                style.colorMap = iris::ColorMap::magma();
            }
            compareStreamedWithHeld(std::make_shared<const iris::RasterMap>(std::move(*streamed)),
                                    std::make_shared<const iris::RasterMap>(std::move(*held)), style, c.name);
            if (QTest::currentTestFailed()) return;
        }
    }

    void slowSourceDoesNotBlock() {
        const int32_t w = int32_t(info_.width), h = int32_t(info_.height);
        auto source = std::make_shared<GatedSource>(w, h);
        iris::RasterLevel level;
        level.width = w, level.height = h;
        level.source = source;
        std::vector<iris::RasterLevel> levels;
        levels.push_back(level);
        auto made = iris::fromHostMemory(iris::RasterKind::Label, std::move(levels), "gated");
        QVERIFY2(made, describe(made.error()).c_str());
        QCOMPARE(made->minValue, 1.0);
        QCOMPARE(made->maxValue, 5.0);
        auto map = std::make_shared<const iris::RasterMap>(std::move(*made));
        // The held twin: the same labels in memory.
        std::vector<uint16_t> ids(size_t(w) * size_t(h));
        for (int32_t y = 0; y < h; ++y)
            for (int32_t x = 0; x < w; ++x) ids[size_t(y) * size_t(w) + size_t(x)] = labelAt(uint32_t(x), uint32_t(y));
        auto twin = iris::fromHostMemory(std::span<const uint16_t>(ids), w, h, "held");
        QVERIFY(twin);

        iris::LayerStyle style;
        style.opacity = 0.6;
        style.classes = iris::defaultLabelClasses(6);
        QVERIFY(e_->addLayer(map, style).ok()); // its coarser levels are made here, the gate open
        std::atomic<uint64_t> frames{0};
        e_->setFrameCallback([&](const iris::FrameStats&) { frames.fetch_add(1); });
        source->setOpen(false);
        const iris::View first = viewWithOrigin(w * 0.2, h * 0.3, 1.0, kW, kH);
        e_->setView(first);
        QVERIFY2(source->awaitWaiter(10s), "the engine never read the streamed level");
        // A read waits: the render thread must not. A new view is drawn (incomplete).
        const uint64_t before = frames.load();
        const iris::View second = viewWithOrigin(w * 0.5, h * 0.5, 1.0, kW, kH);
        e_->setView(second);
        QTRY_VERIFY_WITH_TIMEOUT(frames.load() > before, 10000);
        auto last = e_->readFrame();
        QVERIFY(last);
        QVERIFY2(!last->complete || last->view.centerX != second.centerX,
                 "a frame of the new view was complete while the level's reads waited");
        source->setOpen(true);
        e_->setFrameCallback(nullptr);
        std::string why;
        auto streamedFrame = frameOf(second, &why);
        QVERIFY2(streamedFrame, why.c_str());
        QVERIFY(source->reads_.load() > 0);
        e_->clearLayers();
        QVERIFY(e_->addLayer(std::make_shared<const iris::RasterMap>(std::move(*twin)), style).ok());
        auto heldFrame = frameOf(second, &why);
        QVERIFY2(heldFrame, why.c_str());
        QVERIFY(streamedFrame->image.rgba == heldFrame->image.rgba);
    }

    void fileTruncatedWhileShown() {
        // Labels at half the slide's resolution (12 MB decoded): eight times the file level's
        // block cache, so the blocks read first at the load are out of it by its end.
        const std::string path = dir_.filePath("cut.tif").toStdString();
        QVERIFY(writeTiff(path, uint32_t(info_.width / 2), uint32_t(info_.height / 2), true));
        iris::RasterLoadOptions opts;
        opts.asLabels = true;
        opts.streamAbove = 4u << 20;
        auto loaded = iris::loadRasterMap(path, opts);
        QVERIFY2(loaded, describe(loaded.error()).c_str());
        auto map = std::make_shared<const iris::RasterMap>(std::move(*loaded));
        QVERIFY(::truncate(path.c_str(), 4096) == 0); // the header and the first tiles' offsets stay
        iris::LayerStyle style;
        style.opacity = 0.6;
        style.classes = iris::defaultLabelClasses(6);
        // Counted before the layer is added: the engine warns once a map, at the first chunk it
        // cannot read, which may be one the view before asks for, as soon as the layer is there.
        const size_t warningsBefore = e_.log->warningsContaining("cut.tif");
        QVERIFY(e_->addLayer(map, style).ok());
        // 1:1 at the top left: level 0 of the map (a map pixel is two screen pixels), whose
        // tiles there are gone from the file. Nothing of the layer is left to draw there.
        const iris::View v = viewWithOrigin(0, 0, 1.0, kW, kH);
        std::string why;
        auto with = frameOf(v, &why);
        QVERIFY2(with, why.c_str());
        QVERIFY2(e_.log->warningsContaining("cut.tif") > warningsBefore, "no warning named the file");
        e_->clearLayers();
        auto without = frameOf(v, &why);
        QVERIFY2(without, why.c_str());
        QVERIFY(with->image.rgba == without->image.rgba);
        // The fit view draws from the held coarse levels: the layer shows there.
        QVERIFY(e_->addLayer(map, style).ok());
        auto fit = frameOf(e_->fitView(), &why);
        QVERIFY2(fit, why.c_str());
        e_->clearLayers();
        auto fitWithout = frameOf(e_->fitView(), &why);
        QVERIFY2(fitWithout, why.c_str());
        QVERIFY(fit->image.rgba != fitWithout->image.rgba);
    }
};

QTEST_GUILESS_MAIN(TestLayersStream)
#include "tst_layers_stream.moc"
