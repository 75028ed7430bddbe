// tst_overlay: the engine's overlays (scale bar, magnification readout, overview map) on the
// offscreen target, on lavapipe with the validation layers on. Everything is measured from
// the rendered frames against the view's own numbers:
//
//   * the scale bar's white bar is as long as its label says at the view's mpp × downsample
//     (within a pixel), its length is 1, 2 or 5 × 10^n µm and 80–200 pixels;
//   * a frame with overlays differs from the same frame without them only inside the
//     rectangles the engine reports (and inside each of them somewhere);
//   * the overview's outline is the view's field mapped into the thumbnail, after moves and
//     zooms, and a point of the thumbnail maps back to the slide (overviewHit);
//   * at device pixel ratio 2 the layout is exactly twice the layout at 1 and the label is the
//     same text rasterised at twice the pixel size (not an enlarged bitmap);
//   * each overlay in each corner, alone and stacked; nothing without a slide; no scale bar
//     without mpp; bad fonts and a system without fonts leave the labels out, nothing else;
//   * churn: engines created and destroyed, slides opened and closed, overlays toggled from
//     other threads while frames render (the asan preset runs this case for leaks).
//
// Failure artefacts go to $IRIS_TEST_OUT/failures (IRIS_TEST_SAVE_FRAMES=1: always).
#include <QtTest>

#include <cstdio>

#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <mutex>
#include <thread>

#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;
using iris::Corner;
using iris::Overlay;
using iris::PixelRect;

namespace {

constexpr uint32_t kW = 640, kH = 480;
constexpr auto kTimeout = 60s;
// mpp 0.25, objective 40×; big enough for every magnification the tests visit.
const std::string kSlide = "synthetic:60000x40000";
constexpr double kSlideW = 60000, kSlideH = 40000, kSlideMpp = 0.25;
constexpr int kMargin = 10; // the engine's corner margin, logical pixels (overlay/overlay_layout.h)
constexpr int kGap = 6;     // between overlays stacked in one corner
constexpr std::array<uint8_t, 3> kWhite{255, 255, 255};
constexpr std::array<uint8_t, 3> kFieldCyan{0, 255, 255};

constexpr std::array<Overlay, 3> kOverlays{Overlay::ScaleBar, Overlay::Magnification, Overlay::Overview};
constexpr std::array<Corner, 4> kCorners{Corner::TopLeft, Corner::TopRight, Corner::BottomLeft, Corner::BottomRight};

const char* name(Overlay o) {
    switch (o) {
    case Overlay::ScaleBar: return "scale bar";
    case Overlay::Magnification: return "magnification";
    case Overlay::Overview: return "overview";
    case Overlay::Legend: return "legend"; // (tst_legend tests it)
    }
    return "?";
}
const char* name(Corner c) {
    switch (c) {
    case Corner::TopLeft: return "top left";
    case Corner::TopRight: return "top right";
    case Corner::BottomLeft: return "bottom left";
    case Corner::BottomRight: return "bottom right";
    }
    return "?";
}

std::string str(const PixelRect& r) {
    // (snprintf, not operator+ chains: GCC 12's -Wrestrict misfires on those at -O2)
    char buf[96];
    std::snprintf(buf, sizeof buf, "[%d, %d %dx%d]", int(r.x), int(r.y), int(r.width), int(r.height));
    return buf;
}

bool same(const uint8_t* p, std::array<uint8_t, 3> c) { return p[0] == c[0] && p[1] == c[1] && p[2] == c[2]; }

void setAll(iris::Engine& e, bool on) {
    for (Overlay o : kOverlays) e.setOverlayVisible(o, on);
}

// The longest horizontal run of exactly `colour` inside r.
int longestRun(const iris::Image& img, const PixelRect& r, std::array<uint8_t, 3> colour) {
    int best = 0;
    for (int y = std::max(0, r.y); y < std::min<int>(int(img.height), r.y + r.height); ++y) {
        int run = 0;
        for (int x = std::max(0, r.x); x < std::min<int>(int(img.width), r.x + r.width); ++x) {
            run = same(pixel(img, uint32_t(x), uint32_t(y)), colour) ? run + 1 : 0;
            best = std::max(best, run);
        }
    }
    return best;
}

// Bounding box [x0, x1) × [y0, y1) of the pixels of exactly `colour` inside r; empty when none.
PixelRect colourBox(const iris::Image& img, const PixelRect& r, std::array<uint8_t, 3> colour) {
    int x0 = INT32_MAX, y0 = INT32_MAX, x1 = INT32_MIN, y1 = INT32_MIN;
    for (int y = std::max(0, r.y); y < std::min<int>(int(img.height), r.y + r.height); ++y)
        for (int x = std::max(0, r.x); x < std::min<int>(int(img.width), r.x + r.width); ++x)
            if (same(pixel(img, uint32_t(x), uint32_t(y)), colour)) {
                x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x + 1), y1 = std::max(y1, y + 1);
            }
    if (x1 < x0) return {};
    return {x0, y0, x1 - x0, y1 - y0};
}

bool differs(const iris::Image& a, const iris::Image& b, uint32_t x, uint32_t y) {
    const uint8_t* p = pixel(a, x, y);
    const uint8_t* q = pixel(b, x, y);
    return p[0] != q[0] || p[1] != q[1] || p[2] != q[2] || p[3] != q[3];
}

// Checks that `with` differs from `without` only inside the layout's rectangles, and inside
// each non-empty one somewhere. Returns an explanation, empty when it holds.
std::string checkDifferencesInside(const iris::Image& without, const iris::Image& with, const iris::OverlayLayout& l) {
    std::array<uint64_t, iris::kOverlayCount> inside{};
    uint64_t outside = 0;
    int ox = -1, oy = -1;
    for (uint32_t y = 0; y < with.height; ++y) {
        for (uint32_t x = 0; x < with.width; ++x) {
            if (!differs(without, with, x, y)) continue;
            bool in = false;
            for (size_t i = 0; i < l.rects.size(); ++i) {
                if (l.rects[i].contains(x + 0.5, y + 0.5)) {
                    ++inside[i];
                    in = true;
                }
            }
            if (!in && outside++ == 0) ox = int(x), oy = int(y);
        }
    }
    std::string why;
    if (outside)
        why += std::to_string(outside) + " pixels changed outside every overlay rectangle (first at " +
               std::to_string(ox) + ", " + std::to_string(oy) + "); ";
    for (size_t i = 0; i < l.rects.size(); ++i)
        if (!l.rects[i].empty() && inside[i] == 0)
            why += std::string("nothing drawn inside the ") + name(Overlay(i)) + " rectangle " + str(l.rects[i]) + "; ";
    return why;
}

// The first frame newer than serial `after` that readFrame returns. Woken by the engine's frame
// callback, which runs after the frame it reports was published to readFrame (no suite here
// sets another callback).
std::optional<iris::Frame> nextFrame(iris::Engine& e, uint64_t after, std::chrono::milliseconds timeout = 10s) {
    struct Wake {
        std::mutex mutex;
        std::condition_variable cv;
    };
    // Shared with the callback: the render thread may still be running it after this returns.
    const auto wake = std::make_shared<Wake>();
    e.setFrameCallback([wake](const iris::FrameStats&) {
        // Taking the lock orders this notification after a waiter's test of readFrame().
        { std::lock_guard lock(wake->mutex); }
        wake->cv.notify_all();
    });
    std::optional<iris::Frame> found;
    {
        std::unique_lock lock(wake->mutex);
        wake->cv.wait_for(lock, timeout, [&] {
            auto f = e.readFrame();
            if (f.ok() && f->serial > after) found = std::move(f.value());
            return found.has_value();
        });
    }
    e.setFrameCallback(nullptr);
    return found;
}

uint64_t lastSerial(iris::Engine& e) {
    auto f = e.readFrame();
    return f.ok() ? f->serial : 0;
}

// A label's ink inside `area`: coverage per pixel from the green channel, between the plate
// colour (sampled at `plateAt`) and white. Used where the plate lies over the uniform
// background, so the plate is one colour.
struct Ink {
    PixelRect box;     // pixels at least half covered
    double mass = 0;   // Σ coverage
    std::vector<float> coverage; // area.width × area.height
    PixelRect area;
};
Ink measureInk(const iris::Image& img, const PixelRect& area, uint32_t plateX, uint32_t plateY) {
    Ink ink;
    ink.area = area;
    ink.coverage.assign(size_t(area.width) * size_t(area.height), 0.f);
    const double plate = pixel(img, plateX, plateY)[1];
    int x0 = INT32_MAX, y0 = INT32_MAX, x1 = INT32_MIN, y1 = INT32_MIN;
    for (int y = area.y; y < area.y + area.height; ++y) {
        for (int x = area.x; x < area.x + area.width; ++x) {
            const double c = std::clamp((pixel(img, uint32_t(x), uint32_t(y))[1] - plate) / (255.0 - plate), 0.0, 1.0);
            ink.coverage[size_t(y - area.y) * size_t(area.width) + size_t(x - area.x)] = float(c);
            ink.mass += c;
            if (c >= 0.5) x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x + 1), y1 = std::max(y1, y + 1);
        }
    }
    if (x1 > x0) ink.box = {x0, y0, x1 - x0, y1 - y0};
    return ink;
}

// The label's own pixels at the bar's row and above (the bar is the longest white run).
int barRow(const iris::Image& img, const PixelRect& r) {
    int bestRow = -1, best = 0;
    for (int y = r.y; y < r.y + r.height; ++y) {
        const int run = longestRun(img, {r.x, y, r.width, 1}, kWhite);
        if (run > best) best = run, bestRow = y;
    }
    return bestRow;
}

} // namespace

class TstOverlay : public QObject {
    Q_OBJECT

    TestEngine e_;

    // An engine on a kW × kH offscreen target with the synthetic slide open.
    void openEngine(const std::string& slide = kSlide, uint32_t w = kW, uint32_t h = kH) {
        e_ = createTestEngine();
        QVERIFY2(e_, describe(e_.error).c_str());
        QVERIFY(e_->bindOffscreen(w, h).ok());
        const iris::Result r = e_->open(slide);
        QVERIFY2(r.ok(), describe(r).c_str());
    }
    std::optional<iris::Frame> render(const iris::View& v, uint32_t w = kW, uint32_t h = kH) {
        std::string why;
        auto f = renderView(*e_.engine, v, w, h, kTimeout, &why);
        if (!f) qWarning("%s", why.c_str());
        return f;
    }
    void save(const iris::Image& img, const std::string& what) {
        if (QTest::currentTestFailed() || std::getenv("IRIS_TEST_SAVE_FRAMES")) {
            const fs::path dir = testOutDir() / "failures";
            fs::create_directories(dir);
            writePng(dir / ("overlay." + what + ".png"), img);
        }
    }

private slots:
    void init() { e_ = {}; }
    void cleanup() {
        if (e_) {
            QVERIFY2(e_->validationMessageCount() == 0, "the Vulkan validation layers reported messages (see the log)");
            e_.engine.reset(); // joins the engine's threads before the next test
        }
    }

    void offByDefault() {
        openEngine();
        for (Overlay o : kOverlays) QVERIFY2(!e_->overlayVisible(o), name(o));
        QCOMPARE(e_->overlayCorner(Overlay::ScaleBar), Corner::BottomLeft);
        QCOMPARE(e_->overlayCorner(Overlay::Magnification), Corner::TopLeft);
        QCOMPARE(e_->overlayCorner(Overlay::Overview), Corner::TopRight);
        QCOMPARE(e_->devicePixelRatio(), 1.0);
        auto f = render(e_->fitView());
        QVERIFY(f);
        for (Overlay o : kOverlays) QVERIFY2(f->overlays.rect(o).empty(), name(o));
        QVERIFY(!e_->overviewHit(kW - 60, 60));
    }

    // (a) The bar's drawn length equals its label's length / (mpp × downsample) within a pixel.
    void scaleBarLengthMatchesItsLabel_data() {
        QTest::addColumn<double>("downsample");
        QTest::addColumn<double>("ratio");
        for (double ds : {0.3, 1.0, 3.7, 12.0, 55.0, 180.0}) {
            QTest::addRow("ds %g", ds) << ds << 1.0;
        }
        QTest::addRow("ds 2.5 at ratio 2") << 2.5 << 2.0;
        QTest::addRow("ds 30 at ratio 1.5") << 30.0 << 1.5;
    }
    void scaleBarLengthMatchesItsLabel() {
        QFETCH(double, downsample);
        QFETCH(double, ratio);
        openEngine();
        e_->setDevicePixelRatio(ratio);
        e_->setOverlayVisible(Overlay::ScaleBar, true);
        auto f = render(iris::View{kSlideW / 2, kSlideH / 2, downsample});
        QVERIFY(f);
        const iris::OverlayLayout& l = f->overlays;
        QVERIFY2(!l.rect(Overlay::ScaleBar).empty(), "no scale bar");
        QVERIFY(l.text);

        // The label: a number and µm or mm, saying the bar's physical length.
        const std::string& label = l.scaleBarLabel;
        char* end = nullptr;
        const double number = std::strtod(label.c_str(), &end);
        const std::string unit(end);
        QVERIFY2(unit == " \u00B5m" || unit == " mm", label.c_str());
        const double labelled = unit == " mm" ? number * 1000 : number;
        QVERIFY2(std::abs(labelled - l.scaleBarMicrons) <= 1e-9 * labelled, label.c_str());
        const double decade = std::pow(10.0, std::floor(std::log10(labelled) + 1e-9));
        const double mantissa = labelled / decade;
        QVERIFY2(std::abs(mantissa - 1) < 1e-9 || std::abs(mantissa - 2) < 1e-9 || std::abs(mantissa - 5) < 1e-9,
                 ("length " + std::to_string(labelled) + " µm is not 1, 2 or 5 × 10^n").c_str());

        // Its length in pixels at this view, and what was drawn.
        const double expected = labelled / (kSlideMpp * downsample);
        QVERIFY2(std::abs(l.scaleBarPixels - expected) < 1e-6, std::to_string(l.scaleBarPixels).c_str());
        QVERIFY2(expected >= 80 * ratio - 1e-9 && expected <= 200 * ratio + 1e-9,
                 ("bar of " + std::to_string(expected) + " px at ratio " + std::to_string(ratio)).c_str());
        const int drawn = longestRun(f->image, l.rect(Overlay::ScaleBar), kWhite);
        qInfo("%s: label '%s', %.2f px expected, %d px drawn", QTest::currentDataTag(), label.c_str(), expected, drawn);
        save(f->image, std::string("scalebar.") + QTest::currentDataTag());
        QVERIFY2(std::abs(drawn - expected) <= 1.0,
                 ("drawn " + std::to_string(drawn) + " px, label says " + std::to_string(expected) + " px").c_str());
    }

    // (b) Overlays change pixels only inside the rectangles the engine reports.
    void overlaysStayInsideTheirRectangles() {
        openEngine();
        const iris::View fit = e_->fitView();
        for (const iris::View& v : {fit, iris::View{20000, 9000, 7.3}, iris::View{-3000, 41000, 40}}) {
            setAll(*e_.engine, false);
            auto without = render(v);
            QVERIFY(without);
            setAll(*e_.engine, true);
            auto with = render(v);
            QVERIFY(with);
            for (Overlay o : kOverlays) QVERIFY2(!with->overlays.rect(o).empty(), name(o));
            const iris::OverlayLayout api = e_->overlayLayout();
            QVERIFY(api.rects == with->overlays.rects);
            const std::string why = checkDifferencesInside(without->image, with->image, with->overlays);
            if (!why.empty()) {
                save(with->image, "inside.with");
                save(without->image, "inside.without");
            }
            QVERIFY2(why.empty(), why.c_str());
        }
    }

    // (c) The overview's outline is the view's field in the thumbnail, after moves and zooms.
    void overviewFollowsTheView() {
        openEngine();
        e_->setOverlayVisible(Overlay::Overview, true);
        e_->setView(iris::View{15000, 12000, 20});
        struct Step {
            const char* what;
            std::function<void(iris::Engine&)> move;
        };
        const Step steps[] = {
            {"start", [](iris::Engine&) {}},
            {"pan right and down", [](iris::Engine& e) { e.translate(-300, -200); }},
            {"zoom in about a point", [](iris::Engine& e) { e.zoom(2.5, 100, 380); }},
            {"zoom out", [](iris::Engine& e) { e.zoom(0.2, 320, 240); }},
            {"set view far right", [](iris::Engine& e) { e.setView(iris::View{52000, 30000, 15}); }},
            {"fit", [](iris::Engine& e) { e.setView(e.fitView()); }},
        };
        for (const Step& step : steps) {
            step.move(*e_.engine);
            const iris::View v = e_->view();
            auto f = render(v);
            QVERIFY2(f, step.what);
            const iris::OverlayLayout& l = f->overlays;
            const PixelRect& img = l.overviewImage;
            QVERIFY2(!l.rect(Overlay::Overview).empty() && !img.empty(), step.what);
            const double ds = l.overviewDownsample;
            // The thumbnail is the whole slide at one downsample.
            QVERIFY(std::abs(img.width - kSlideW / ds) < 1 && std::abs(img.height - kSlideH / ds) < 1);
            // The reported field is the view's.
            const std::array<double, 4> field{img.x + (v.centerX - kW / 2.0 * v.downsample) / ds,
                                              img.y + (v.centerY - kH / 2.0 * v.downsample) / ds,
                                              img.x + (v.centerX + kW / 2.0 * v.downsample) / ds,
                                              img.y + (v.centerY + kH / 2.0 * v.downsample) / ds};
            for (int i = 0; i < 4; ++i) QVERIFY2(std::abs(l.overviewField[size_t(i)] - field[size_t(i)]) < 1e-6, step.what);
            // What is drawn: the outline's box is the field clipped to the slide, within a pixel.
            const double cx0 = std::max(field[0], double(img.x)), cx1 = std::min(field[2], img.x + kSlideW / ds);
            const double cy0 = std::max(field[1], double(img.y)), cy1 = std::min(field[3], img.y + kSlideH / ds);
            const PixelRect box = colourBox(f->image, l.rect(Overlay::Overview), kFieldCyan);
            qInfo("%s: field [%.1f %.1f %.1f %.1f] in the thumbnail, outline %s", step.what, cx0, cy0, cx1, cy1,
                  str(box).c_str());
            save(f->image, std::string("overview.") + step.what);
            QVERIFY2(!box.empty(), step.what);
            QVERIFY2(std::abs(box.x - cx0) <= 1 && std::abs(box.y - cy0) <= 1 && std::abs(box.x + box.width - cx1) <= 1 &&
                         std::abs(box.y + box.height - cy1) <= 1,
                     (std::string(step.what) + ": outline " + str(box)).c_str());
            // The outline is a frame, not a filled box: its centre shows the thumbnail.
            if (box.width > 12 && box.height > 12)
                QVERIFY(!same(pixel(f->image, uint32_t(box.x + box.width / 2), uint32_t(box.y + box.height / 2)), kFieldCyan));
        }
    }

    // A turned view's field is outlined turned: its reported corners are the target's corners
    // mapped through the view, and every outline pixel lies on the quadrilateral's sides (and
    // each side has outline pixels along it). The thumbnail itself stays unturned.
    void overviewOutlinesATurnedField() {
        openEngine();
        e_->setOverlayVisible(Overlay::Overview, true);
        for (const iris::View v : {iris::View{30000, 20000, 20, 30}, iris::View{22000, 15000, 25, 117.5, true}}) {
            auto f = render(v);
            QVERIFY(f);
            const iris::OverlayLayout& l = f->overlays;
            const PixelRect& img = l.overviewImage;
            QVERIFY(!img.empty());
            const double ds = l.overviewDownsample;
            const iris::ViewTransform t = iris::ViewTransform::of(v, kW, kH);
            const std::array<std::array<double, 2>, 4> target{{{0, 0}, {double(kW), 0}, {double(kW), double(kH)}, {0, double(kH)}}};
            std::array<std::array<double, 2>, 4> q{};
            for (size_t k = 0; k < 4; ++k) {
                const auto s = t.toSlide(target[k][0], target[k][1]);
                q[k] = {img.x + s[0] / ds, img.y + s[1] / ds};
                QVERIFY(std::abs(l.overviewFieldCorners[2 * k] - q[k][0]) < 1e-6);
                QVERIFY(std::abs(l.overviewFieldCorners[2 * k + 1] - q[k][1]) < 1e-6);
            }
            // Distance from (x, y) to side k.
            const auto toSide = [&](double x, double y, size_t k) {
                const auto& a = q[k];
                const auto& b = q[(k + 1) % 4];
                const double dx = b[0] - a[0], dy = b[1] - a[1];
                const double u = std::clamp(((x - a[0]) * dx + (y - a[1]) * dy) / (dx * dx + dy * dy), 0.0, 1.0);
                return std::hypot(x - (a[0] + u * dx), y - (a[1] + u * dy));
            };
            std::array<int, 4> onSide{};
            int cyan = 0;
            for (int32_t y = img.y; y < img.y + img.height; ++y) {
                for (int32_t x = img.x; x < img.x + img.width; ++x) {
                    if (!same(pixel(f->image, uint32_t(x), uint32_t(y)), kFieldCyan)) continue;
                    ++cyan;
                    double best = 1e9;
                    size_t side = 0;
                    for (size_t k = 0; k < 4; ++k) {
                        const double d = toSide(x + 0.5, y + 0.5, k);
                        if (d < best) best = d, side = k;
                    }
                    QVERIFY2(best <= 2.5, qPrintable(QString("outline pixel (%1, %2) is %3 px off the field").arg(x).arg(y).arg(best)));
                    ++onSide[side];
                }
            }
            save(f->image, "overview.turned");
            QVERIFY(cyan > 0);
            for (size_t k = 0; k < 4; ++k) {
                const double len = std::hypot(q[(k + 1) % 4][0] - q[k][0], q[(k + 1) % 4][1] - q[k][1]);
                // Sides inside the thumbnail are drawn along their length (clipped ones may not be).
                bool inside = true;
                for (const auto& p : {q[k], q[(k + 1) % 4]})
                    inside = inside && p[0] >= img.x + 2 && p[1] >= img.y + 2 && p[0] <= img.x + img.width - 2 &&
                             p[1] <= img.y + img.height - 2;
                if (inside) QVERIFY2(onSide[k] >= len, qPrintable(QString("side %1: %2 px for %3 px").arg(k).arg(onSide[k]).arg(len)));
            }
        }
    }

    // The cross-hair: drawn at the slide point (turned views included), over the tiles, and gone
    // when cleared.
    void crosshairMarksASlidePoint() {
        openEngine();
        for (const iris::View v : {iris::View{30000, 20000, 20}, iris::View{30000, 20000, 20, 41}}) {
            const std::array<double, 2> point{30000 + 1234.0, 20000 - 987.0};
            e_->setCrosshair(point);
            QVERIFY(e_->crosshair().has_value());
            auto f = render(v);
            QVERIFY(f);
            const auto at = iris::ViewTransform::of(v, kW, kH).toTarget(point[0], point[1]);
            const uint32_t cx = uint32_t(std::floor(at[0])), cy = uint32_t(std::floor(at[1]));
            const std::array<uint8_t, 3> yellow{255, 255, 0};
            QVERIFY2(same(pixel(f->image, cx, cy), yellow), "no cross-hair at the point");
            QVERIFY(same(pixel(f->image, cx + 10, cy), yellow) && same(pixel(f->image, cx, cy - 10), yellow));
            QVERIFY(!same(pixel(f->image, cx + 10, cy + 10), yellow)); // a plus, not a box
            e_->setCrosshair(std::nullopt);
            auto g = render(iris::View{v.centerX + 1, v.centerY, v.downsample, v.rotation}); // a new frame
            QVERIFY(g);
            int left = 0;
            for (uint32_t y = 0; y < kH; ++y)
                for (uint32_t x = 0; x < kW; ++x) left += same(pixel(g->image, x, y), yellow) ? 1 : 0;
            QCOMPARE(left, 0);
        }
        // A non-finite point is no cross-hair.
        e_->setCrosshair(std::array<double, 2>{std::nan(""), 0});
        QVERIFY(!e_->crosshair().has_value());
    }

    // A point of the thumbnail maps to the slide point under it; elsewhere nothing is hit.
    void overviewHitMapsToTheSlide() {
        openEngine();
        e_->setOverlayVisible(Overlay::Overview, true);
        const iris::View v0{30000, 20000, 12};
        auto f = render(v0);
        QVERIFY(f);
        const PixelRect img = f->overlays.overviewImage;
        const double ds = f->overlays.overviewDownsample;
        for (auto [fx, fy] : {std::pair{0.25, 0.25}, {0.5, 0.5}, {0.9, 0.1}}) {
            const double x = img.x + fx * img.width, y = img.y + fy * img.height;
            iris::View out;
            QVERIFY(e_->overviewHit(x, y, &out));
            QVERIFY(std::abs(out.centerX - (x - img.x) * ds) < 1e-6 && std::abs(out.centerY - (y - img.y) * ds) < 1e-6);
            QCOMPARE(out.downsample, v0.downsample);
        }
        QVERIFY(!e_->overviewHit(img.x - 5, img.y + 5));
        QVERIFY(!e_->overviewHit(kW / 2.0, kH / 2.0));
        QVERIFY(!e_->overviewHit(std::nan(""), 0));
        // Moving there puts the clicked point at the centre of the next frame's outline.
        iris::View target;
        QVERIFY(e_->overviewHit(img.x + 0.7 * img.width, img.y + 0.6 * img.height, &target));
        auto g = render(target);
        QVERIFY(g);
        const auto& fl = g->overlays.overviewField;
        QVERIFY(std::abs((fl[0] + fl[2]) / 2 - (img.x + 0.7 * img.width)) < 1e-6);
        QVERIFY(std::abs((fl[1] + fl[3]) / 2 - (img.y + 0.6 * img.height)) < 1e-6);
        // Another slide: the old layout no longer applies until a frame of the new one exists.
        e_->close();
        QVERIFY(!e_->overviewHit(img.x + 10, img.y + 10));
    }

    // (d) At ratio 2 the layout is twice the layout at 1, and the label is the same text
    // rasterised at twice the pixel size.
    void textScalesWithTheDevicePixelRatio() {
        // The same logical view at ratio 1 and 2: the slide fills the right half, so the
        // scale bar (bottom left) lies over the uniform background colour.
        struct Shot {
            iris::Frame frame;
            PixelRect rect;
            int barY = -1;
            Ink ink;
        };
        std::array<Shot, 2> shots;
        for (int k = 1; k <= 2; ++k) {
            openEngine(kSlide, kW * k, kH * k);
            e_->setDevicePixelRatio(k);
            e_->setOverlayVisible(Overlay::ScaleBar, true);
            auto f = render(iris::View{0, kSlideH / 2, 40.0 / k}, kW * k, kH * k);
            QVERIFY(f);
            Shot& s = shots[size_t(k - 1)];
            s.frame = std::move(*f);
            s.rect = s.frame.overlays.rect(Overlay::ScaleBar);
            QVERIFY(!s.rect.empty() && s.frame.overlays.text);
            s.barY = barRow(s.frame.image, s.rect);
            QVERIFY(s.barY > s.rect.y);
            const PixelRect textArea{s.rect.x, s.rect.y, s.rect.width, s.barY - s.rect.y};
            s.ink = measureInk(s.frame.image, textArea, uint32_t(s.rect.x + 1), uint32_t(s.rect.y + 1));
            save(s.frame.image, "ratio" + std::to_string(k));
            cleanup();
        }
        const Shot &a = shots[0], &b = shots[1];
        QCOMPARE(b.frame.overlays.scaleBarLabel, a.frame.overlays.scaleBarLabel);
        QVERIFY2(b.rect == (PixelRect{2 * a.rect.x, 2 * a.rect.y, 2 * a.rect.width, 2 * a.rect.height}),
                 (str(a.rect) + " at 1, " + str(b.rect) + " at 2").c_str());
        QVERIFY(std::abs(b.frame.overlays.scaleBarPixels - 2 * a.frame.overlays.scaleBarPixels) < 1e-6);
        QCOMPARE(b.barY - b.rect.y, 2 * (a.barY - a.rect.y));
        // The label's ink: same place and size, twice as large, within a pixel (the right
        // edge within two: the last glyph's pen position is rounded at each size).
        const PixelRect &ia = a.ink.box, &ib = b.ink.box;
        qInfo("label '%s': ink %s (mass %.1f) at 1, %s (mass %.1f) at 2", a.frame.overlays.scaleBarLabel.c_str(),
              str(ia).c_str(), a.ink.mass, str(ib).c_str(), b.ink.mass);
        QVERIFY(!ia.empty() && !ib.empty());
        QVERIFY2(std::abs(ib.x - 2 * ia.x) <= 1 && std::abs(ib.y - 2 * ia.y) <= 1 &&
                     std::abs((ib.y + ib.height) - 2 * (ia.y + ia.height)) <= 1 &&
                     std::abs((ib.x + ib.width) - 2 * (ia.x + ia.width)) <= 2,
                 "the label's ink box does not scale by 2");
        QVERIFY2(std::abs(b.ink.mass / a.ink.mass - 4) < 0.2, std::to_string(b.ink.mass / a.ink.mass).c_str());
        // Rasterised at the device size, not enlarged: an enlarged bitmap is made of uniform
        // 2×2 blocks (at one of four phases); this one has detail inside most inked blocks.
        for (int py = 0; py < 2; ++py) {
            for (int px = 0; px < 2; ++px) {
                int inked = 0, detailed = 0;
                const PixelRect& ar = b.ink.area;
                for (int y = py; y + 1 < ar.height; y += 2) {
                    for (int x = px; x + 1 < ar.width; x += 2) {
                        const auto c = [&](int dx, int dy) {
                            return b.ink.coverage[size_t(y + dy) * size_t(ar.width) + size_t(x + dx)];
                        };
                        const float lo = std::min({c(0, 0), c(1, 0), c(0, 1), c(1, 1)});
                        const float hi = std::max({c(0, 0), c(1, 0), c(0, 1), c(1, 1)});
                        if (hi < 0.05f) continue;
                        ++inked;
                        if (hi - lo > 0.1f) ++detailed;
                    }
                }
                QVERIFY2(inked > 20 && detailed > inked / 3,
                         ("phase " + std::to_string(px) + "," + std::to_string(py) + ": " + std::to_string(detailed) +
                          " of " + std::to_string(inked) + " inked 2x2 blocks have detail")
                             .c_str());
            }
        }
    }

    // The readout is objective × level-0 downsample / view downsample: the stated objective,
    // else 10 µm / mpp (the sample slide states only its mpp).
    void magnificationReadout() {
        openEngine();
        e_->setOverlayVisible(Overlay::Magnification, true);
        for (double ds : {0.5, 2.0, 16.0, 100.0}) {
            auto f = render(iris::View{kSlideW / 2, kSlideH / 2, ds});
            QVERIFY(f);
            QVERIFY(std::abs(f->overlays.magnification - 40 / ds) < 1e-9);
            QVERIFY(!f->overlays.rect(Overlay::Magnification).empty());
        }
        auto f = render(iris::View{kSlideW / 2, kSlideH / 2, 2.0});
        QVERIFY(f);
        QCOMPARE(f->overlays.magnificationLabel, std::string("20.0\u00D7"));
        f = render(iris::View{kSlideW / 2, kSlideH / 2, 160.0});
        QVERIFY(f);
        QCOMPARE(f->overlays.magnificationLabel, std::string("0.25\u00D7"));

        const auto sample = sampleSlidePath();
        QVERIFY2(sample && fs::exists(*sample), "no sample slide (the sample_slide fixture makes it)");
        QVERIFY(e_->open(sample->string()).ok());
        const iris::SlideInfo info = *e_->slideInfo();
        QVERIFY2(info.objectivePower == 0 && info.mppX > 0, "the sample slide should state mpp only");
        auto g = render(iris::View{3000, 2000, 4});
        QVERIFY(g);
        QVERIFY(!g->overlays.rect(Overlay::Magnification).empty());
        QVERIFY(std::abs(g->overlays.magnification - 10 / ((info.mppX + info.mppY) / 2) / 4) < 1e-9);
    }

    // (e) Each overlay alone in each corner: placed in that corner, drawn only there.
    void eachOverlayInEachCorner() {
        openEngine();
        const iris::View v{30000, 20000, 25};
        auto base = render(v);
        QVERIFY(base);
        const int m = kMargin;
        for (Overlay o : kOverlays) {
            for (Corner c : kCorners) {
                setAll(*e_.engine, false);
                e_->setOverlayCorner(o, c);
                e_->setOverlayVisible(o, true);
                QCOMPARE(e_->overlayCorner(o), c);
                QVERIFY(e_->overlayVisible(o));
                auto f = render(v);
                QVERIFY(f);
                const std::string what = std::string(name(o)) + " in the " + name(c) + " corner";
                const iris::OverlayLayout& l = f->overlays;
                for (Overlay other : kOverlays)
                    if (other != o) QVERIFY2(l.rect(other).empty(), (what + ": another overlay is shown").c_str());
                const PixelRect r = l.rect(o);
                QVERIFY2(!r.empty(), what.c_str());
                const bool left = c == Corner::TopLeft || c == Corner::BottomLeft;
                const bool top = c == Corner::TopLeft || c == Corner::TopRight;
                QVERIFY2(left ? r.x == m : r.x + r.width == int(kW) - m, (what + ": " + str(r)).c_str());
                QVERIFY2(top ? r.y == m : r.y + r.height == int(kH) - m, (what + ": " + str(r)).c_str());
                const std::string why = checkDifferencesInside(base->image, f->image, l);
                if (!why.empty()) save(f->image, "corner." + what);
                QVERIFY2(why.empty(), (what + ": " + why).c_str());
            }
        }
        // Off again: the frame is the slide's alone.
        setAll(*e_.engine, false);
        auto off = render(v);
        QVERIFY(off);
        for (Overlay o : kOverlays) QVERIFY(off->overlays.rect(o).empty());
        QVERIFY(off->image.rgba == base->image.rgba);
    }

    // Several overlays in one corner stack inwards without overlapping.
    void overlaysInOneCornerStack() {
        openEngine();
        const iris::View v{30000, 20000, 25};
        for (Corner c : {Corner::BottomRight, Corner::TopLeft}) {
            for (Overlay o : kOverlays) e_->setOverlayCorner(o, c);
            setAll(*e_.engine, true);
            auto f = render(v);
            QVERIFY(f);
            const iris::OverlayLayout& l = f->overlays;
            const bool top = c == Corner::TopLeft;
            int edge = top ? kMargin : int(kH) - kMargin; // where the next one starts
            for (Overlay o : kOverlays) {
                const PixelRect r = l.rect(o);
                QVERIFY2(!r.empty(), name(o));
                QVERIFY2(top ? r.x == kMargin : r.x + r.width == int(kW) - kMargin, str(r).c_str());
                QVERIFY2(top ? r.y == edge : r.y + r.height == edge, (std::string(name(o)) + " " + str(r)).c_str());
                edge = top ? r.y + r.height + kGap : r.y - kGap;
            }
            setAll(*e_.engine, false);
            auto without = render(v);
            QVERIFY(without);
            const std::string why = checkDifferencesInside(without->image, f->image, l);
            QVERIFY2(why.empty(), why.c_str());
        }
    }

    // No slide, no overlays: the frame is the background colour alone.
    void nothingWithoutASlide() {
        e_ = createTestEngine();
        QVERIFY(e_);
        QVERIFY(e_->bindOffscreen(kW, kH).ok());
        setAll(*e_.engine, true);
        const uint64_t first = lastSerial(*e_.engine);
        e_->setView(iris::View{100, 100, 1}); // one more change, so a frame of these settings follows
        auto f = nextFrame(*e_.engine, first);
        QVERIFY(f);
        for (Overlay o : kOverlays) QVERIFY(f->overlays.rect(o).empty());
        QCOMPARE(countNotColour(f->image, backgroundBytes(), nullptr), uint64_t(0));
        QVERIFY(!e_->overviewHit(kW - 60, 60));

        QVERIFY(e_->open(kSlide).ok());
        auto g = render(e_->fitView());
        QVERIFY(g);
        for (Overlay o : kOverlays) QVERIFY2(!g->overlays.rect(o).empty(), name(o));
        QVERIFY(!e_->overlayLayout().rect(Overlay::Overview).empty());

        uint64_t before = lastSerial(*e_.engine);
        e_->close();
        // A frame the render thread had already begun from the open slide's snapshot (a late
        // tile upload woke it) can still arrive after close(); the first frame drawn after the
        // close took effect must be empty. Wait for it (at most 10 s), then check all of it.
        const auto noOverlay = [](const iris::Frame& fr) {
            for (Overlay o : kOverlays)
                if (!fr.overlays.rect(o).empty()) return false;
            return true;
        };
        std::optional<iris::Frame> h;
        for (int i = 0; i < 100; ++i) {
            h = nextFrame(*e_.engine, before);
            QVERIFY(h);
            if (noOverlay(*h)) break;
            before = h->serial;
        }
        QVERIFY(h && noOverlay(*h));
        QCOMPARE(countNotColour(h->image, backgroundBytes(), nullptr), uint64_t(0));
        for (Overlay o : kOverlays) QVERIFY(e_->overlayLayout().rect(o).empty());
    }

    // A slide without mpp has no scale bar (and without objective power no readout); the
    // overview still shows.
    void scaleBarHiddenWithoutMpp() {
        const auto dir = slidesDir("generic-tiff");
        if (!dir) QSKIP("no test data (shared/testdata/slides/generic-tiff)");
        e_ = createTestEngine();
        QVERIFY(e_);
        QVERIFY(e_->bindOffscreen(kW, kH).ok());
        std::optional<iris::SlideInfo> info;
        for (const fs::path& p : filesUnder(*dir, false)) {
            if (!e_->open(p.string()).ok()) continue;
            info = e_->slideInfo();
            if (info && info->mppX == 0) break;
            info.reset();
        }
        QVERIFY2(info, "no generic TIFF without mpp in the test data");
        qInfo("slide without mpp: %s", info->path.c_str());
        setAll(*e_.engine, true);
        auto f = render(e_->fitView());
        QVERIFY(f);
        QVERIFY(f->overlays.rect(Overlay::ScaleBar).empty());
        QCOMPARE(f->overlays.rect(Overlay::Magnification).empty(), info->objectivePower <= 0); // and no mpp
        QVERIFY(!f->overlays.rect(Overlay::Overview).empty());
        // The same engine and settings on a slide with mpp: the bar is there.
        QVERIFY(e_->open(kSlide).ok());
        auto g = render(e_->fitView());
        QVERIFY(g);
        QVERIFY(!g->overlays.rect(Overlay::ScaleBar).empty());
    }

    // Bad fonts: a clear error, no labels, everything else still drawn; a good font brings
    // the labels back.
    void badFontsLeaveTheLabelsOut() {
        openEngine();
        setAll(*e_.engine, true);
        const iris::View v{30000, 20000, 25};
        auto good = render(v);
        QVERIFY(good);
        QVERIFY(good->overlays.text);
        const int withLabel = good->overlays.rect(Overlay::ScaleBar).height;

        const fs::path garbage = testOutDir() / "overlay-not-a-font.ttf";
        {
            std::ofstream out(garbage, std::ios::binary);
            for (int i = 0; i < 4096; ++i) out.put(char((i * 7919) & 0xFF));
        }
        const fs::path empty = testOutDir() / "overlay-empty-font.ttf";
        std::ofstream(empty, std::ios::binary).close();
        struct Case {
            std::string path;
            iris::Status status;
        };
        for (const Case& c : {Case{"/nonexistent/overlay-font.ttf", iris::Status::NotFound},
                              Case{testOutDir().string(), iris::Status::NotAFile},
                              Case{empty.string(), iris::Status::CorruptData},
                              Case{garbage.string(), iris::Status::UnsupportedFormat}}) {
            const iris::Result r = e_->setOverlayFont(c.path);
            QVERIFY2(r.status() == c.status, describe(r).c_str());
            QVERIFY2(r.message().find(c.path) != std::string::npos, r.message().c_str());
            QVERIFY2(e_->error().status() == c.status, describe(e_->error()).c_str());
            QVERIFY2(e_.log->errorCount() > 0, "the error was not logged");
            e_->clearError();
            e_.log->takeErrors();
            auto f = render(v);
            QVERIFY(f);
            const iris::OverlayLayout& l = f->overlays;
            QVERIFY(!l.text);
            QVERIFY2(l.rect(Overlay::Magnification).empty(), "a readout without text");
            QVERIFY(!l.rect(Overlay::ScaleBar).empty());
            QVERIFY(l.rect(Overlay::ScaleBar).height < withLabel);
            QVERIFY(!l.rect(Overlay::Overview).empty());
            const int drawn = longestRun(f->image, l.rect(Overlay::ScaleBar), kWhite);
            QVERIFY(std::abs(drawn - l.scaleBarPixels) <= 1);
            QVERIFY(e_->error().ok()); // the render thread adds nothing of its own
        }
        const iris::Result back = e_->setOverlayFont("");
        QVERIFY2(back.ok(), describe(back).c_str());
        auto f = render(v);
        QVERIFY(f);
        QVERIFY(f->overlays.text);
        QVERIFY(f->image.rgba == good->image.rgba);
    }

    // No font on the system (fontconfig configured with no font directory): the first
    // labelled overlay reports it; bars and the overview are drawn without labels.
    void noFontOnTheSystem() {
        const fs::path conf = testOutDir() / "overlay-no-fonts.conf";
        std::ofstream(conf) << "<?xml version=\"1.0\"?>\n<!DOCTYPE fontconfig SYSTEM \"fonts.dtd\">\n<fontconfig></fontconfig>\n";
        const QByteArray saved = qgetenv("FONTCONFIG_FILE");
        const bool had = qEnvironmentVariableIsSet("FONTCONFIG_FILE");
        qputenv("FONTCONFIG_FILE", QByteArray::fromStdString(conf.string()));
        openEngine();
        setAll(*e_.engine, true); // the default font is looked up here, and is not found
        if (had) qputenv("FONTCONFIG_FILE", saved); else qunsetenv("FONTCONFIG_FILE");
        QCOMPARE(e_->error().status(), iris::Status::NotFound);
        QVERIFY2(e_->error().message().find("fontconfig") != std::string::npos, e_->error().message().c_str());
        e_->clearError();
        e_.log->takeErrors();
        auto f = render(iris::View{30000, 20000, 25});
        QVERIFY(f);
        QVERIFY(!f->overlays.text);
        QVERIFY(!f->overlays.rect(Overlay::ScaleBar).empty());
        QVERIFY(f->overlays.rect(Overlay::Magnification).empty());
        QVERIFY(!f->overlays.rect(Overlay::Overview).empty());
        // Turning overlays on again does not look again (and does not log again) …
        setAll(*e_.engine, true);
        QVERIFY(e_->error().ok());
        // … but the host can still name a font (the system's default again, now that
        // fontconfig has its configuration back).
        QVERIFY(e_->setOverlayFont("").ok());
        auto g = render(iris::View{30000, 20000, 25});
        QVERIFY(g && g->overlays.text);
    }

    // Churn: overlays toggled, moved and re-fonted from other threads while slides open and
    // close and frames render; engines destroyed in the middle of it. Nothing may crash,
    // hang, leak (asan preset) or upset the validation layers.
    //
    // Each round lasts kSlideSteps steps of the slide thread (kSlideSteps / 5 opens and as many
    // closes); the other two churn until it is done. The sleeps in the loops set each thread's
    // pace (the slide thread's lets frames render between its changes); none waits for anything.
    void lifecycleChurn() {
        constexpr int kSlideSteps = 150;
        for (int round = 0; round < 3; ++round) {
            openEngine();
            std::atomic<bool> stop{false};
            std::vector<std::thread> threads;
            threads.emplace_back([&, round] {
                uint32_t i = uint32_t(round);
                while (!stop.load()) {
                    const Overlay o = kOverlays[i % 3];
                    e_->setOverlayVisible(o, (i / 3) % 2 == 0);
                    e_->setOverlayCorner(o, kCorners[(i / 2) % 4]);
                    e_->setDevicePixelRatio(1 + (i % 4) * 0.5);
                    (void)e_->overviewHit(kW - 50.0, 50.0);
                    (void)e_->overlayLayout();
                    ++i;
                    std::this_thread::sleep_for(1ms);
                }
            });
            threads.emplace_back([&] {
                int i = 0;
                while (!stop.load()) {
                    (void)e_->setOverlayFont(i % 3 == 2 ? "/nonexistent.ttf" : "");
                    ++i;
                    std::this_thread::sleep_for(7ms);
                }
            });
            std::thread slides([&] {
                for (int i = 0; i < kSlideSteps; ++i) {
                    if (i % 5 == 4) e_->close();
                    else if (i % 5 == 0) (void)e_->open(i % 10 == 0 ? "synthetic:3000x2000" : kSlide);
                    e_->setView(iris::View{1000.0 + 500 * (i % 7), 800.0 + 300 * (i % 5), 0.5 + (i % 9) * 3});
                    e_->translate(13, -7);
                    std::this_thread::sleep_for(3ms);
                }
            });
            const auto t0 = std::chrono::steady_clock::now();
            slides.join();
            qInfo("round %d: %d slide steps in %.0f ms", round, kSlideSteps,
                  std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
            stop = true;
            for (auto& t : threads) t.join();
            if (round == 2) {
                // The last engine goes while its render thread is still catching up with the
                // storm of changes (frames in flight, glyphs waiting for upload).
                QVERIFY(e_->validationMessageCount() == 0);
                e_.engine.reset();
                continue;
            }
            // Still consistent afterwards: a known state renders completely.
            e_->clearError();
            QVERIFY(e_->open(kSlide).ok());
            QVERIFY(e_->setOverlayFont("").ok());
            e_->setDevicePixelRatio(1);
            for (Overlay o : kOverlays) e_->setOverlayCorner(o, Corner::TopLeft);
            setAll(*e_.engine, true);
            auto f = render(iris::View{30000, 20000, 25});
            QVERIFY(f);
            for (Overlay o : kOverlays) QVERIFY(!f->overlays.rect(o).empty());
            QVERIFY(f->overlays.text);
            cleanup();
        }
    }
};

QTEST_GUILESS_MAIN(TstOverlay)
#include "tst_overlay.moc"
