// Annotations drawn by the engine (render/annotation_pass, issue 18 "Tests"), on lavapipe with
// the validation layers on.
//
//   * Against a CPU rasteriser: polygons (concave, with a hole), a rectangle and an ellipse,
//     filled and outlined, a polyline and points, at several zooms, turned and mirrored. The
//     reference composites, over the engine's own frame of the same view with annotations
//     hidden, exactly what the pass promises: each fill covers the pixels whose centre lies
//     inside it (the triangles tile the polygon), at the fill's opacity; each outline segment
//     is a capsule of the object's line width in screen pixels whose coverage is
//     clamp(halfWidth + 0.5 − distance, 0, 1), composited "over" one after another; points are
//     discs of radius 4. Every pixel must match within 3 codes, except those whose centre lies
//     within 0.05 px of a fill's edge (which side a rasteriser puts them is not defined).
//   * Many objects: over the budget, the fit view draws the fit-view aggregate's cells as
//     dots; the frame is complete and shows them.
//   * The selection: a yellow outline and white-centred handles at the vertices.
//   * iris-render --annotations FILE writes the frame the engine draws for the same view.
//   * Changes from other threads redraw; hiding, detaching, and a store edited while engines
//     that show it are created and destroyed (asan preset).
#include <QFileInfo>
#include <QImage>
#include <QProcess>
#include <QtTest>

#include <atomic>
#include <cmath>
#include <condition_variable>
#include <fstream>
#include <mutex>
#include <thread>

#include "iris/annotations.h"
#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;

namespace {

constexpr uint32_t kW = 420, kH = 300;

iris::AnnotationObject polygon(std::vector<iris::Point2> outer, std::vector<std::vector<iris::Point2>> holes,
                               iris::Rgba8 colour, bool fill, float opacity, float width) {
    iris::AnnotationObject o;
    o.kind = iris::AnnotationKind::Polygon;
    o.polygons.push_back({std::move(outer), std::move(holes)});
    o.color = colour;
    o.fill = fill;
    o.fillOpacity = opacity;
    o.lineWidth = width;
    return o;
}

// The scene, around level-0 point (cx, cy): objects apart from each other, vertices far apart.
std::vector<iris::AnnotationObject> scene(double cx, double cy) {
    std::vector<iris::AnnotationObject> v;
    // A concave star with a square hole, filled.
    std::vector<iris::Point2> star;
    for (int i = 0; i < 10; ++i) {
        const double a = i * 3.14159265358979 / 5, r = (i % 2) ? 45.0 : 110.0;
        star.push_back({cx - 120 + r * std::cos(a), cy - 40 + r * std::sin(a)});
    }
    v.push_back(polygon(star, {{{cx - 135, cy - 55}, {cx - 105, cy - 55}, {cx - 105, cy - 25}, {cx - 135, cy - 25}}},
                        {220, 40, 30, 255}, true, 0.4f, 2.0f));
    // A rectangle, filled, thick outline.
    iris::AnnotationObject r;
    r.kind = iris::AnnotationKind::Rectangle;
    r.box = {cx + 20, cy - 130, cx + 150, cy - 60};
    r.color = iris::Rgba8{30, 200, 60, 255};
    r.fill = true;
    r.fillOpacity = 0.6f;
    r.lineWidth = 4;
    v.push_back(r);
    // An ellipse, outline only.
    iris::AnnotationObject e;
    e.kind = iris::AnnotationKind::Ellipse;
    e.box = {cx + 20, cy + 10, cx + 170, cy + 100};
    e.color = iris::Rgba8{40, 60, 230, 255};
    e.lineWidth = 3;
    v.push_back(e);
    // A polyline, thin.
    iris::AnnotationObject l;
    l.kind = iris::AnnotationKind::Polyline;
    l.points = {{cx - 200, cy + 90}, {cx - 120, cy + 130}, {cx - 40, cy + 80}, {cx + 5, cy + 140}};
    l.color = iris::Rgba8{250, 250, 20, 255};
    l.lineWidth = 1.5f;
    v.push_back(l);
    // Points.
    iris::AnnotationObject p;
    p.kind = iris::AnnotationKind::Point;
    p.points = {{cx - 190, cy - 140}, {cx - 170, cy - 140}, {cx + 190, cy + 130}};
    p.color = iris::Rgba8{255, 0, 255, 255};
    v.push_back(p);
    return v;
}

struct Rgbf {
    double r, g, b;
};
void over(Rgbf& dst, iris::Rgba8 c, double coverage) {
    const double a = c.a / 255.0 * coverage;
    dst.r = c.r / 255.0 * a + dst.r * (1 - a);
    dst.g = c.g / 255.0 * a + dst.g * (1 - a);
    dst.b = c.b / 255.0 * a + dst.b * (1 - a);
}

double segmentDistance(double px, double py, double ax, double ay, double bx, double by) {
    const double dx = bx - ax, dy = by - ay, l2 = dx * dx + dy * dy;
    const double t = l2 > 1e-12 ? std::clamp(((px - ax) * dx + (py - ay) * dy) / l2, 0.0, 1.0) : 0.0;
    return std::hypot(px - (ax + t * dx), py - (ay + t * dy));
}

// Target-pixel rings of an object (what the pass outlines), its fill rings, and its points.
struct Shape {
    std::vector<std::vector<std::array<double, 2>>> rings; // closed
    std::vector<std::array<double, 2>> line;               // open
    std::vector<std::array<double, 2>> points;
    bool filled = false;
    iris::Rgba8 colour, fill;
    double half = 1;
};

Shape shapeOf(const iris::AnnotationObject& o, const iris::ViewTransform& t) {
    Shape s;
    const auto map = [&](const iris::Point2& p) { return t.toTarget(p.x, p.y); };
    const auto ring = [&](const std::vector<iris::Point2>& pts) {
        std::vector<std::array<double, 2>> r;
        for (const auto& p : pts) r.push_back(map(p));
        return r;
    };
    switch (o.kind) {
    case iris::AnnotationKind::Polygon:
        for (const auto& part : o.polygons) {
            s.rings.push_back(ring(part.outer));
            for (const auto& h : part.holes) s.rings.push_back(ring(h));
        }
        break;
    case iris::AnnotationKind::Rectangle:
        s.rings.push_back(ring({{o.box.minX, o.box.minY}, {o.box.maxX, o.box.minY}, {o.box.maxX, o.box.maxY},
                                {o.box.minX, o.box.maxY}}));
        break;
    case iris::AnnotationKind::Ellipse:
        s.rings.push_back(ring(iris::flattenEllipse(
            o.box, iris::ellipseVertexCount(o.box.width() / 2, o.box.height() / 2, t.downsample))));
        break;
    case iris::AnnotationKind::Polyline: s.line = ring(o.points); break;
    case iris::AnnotationKind::Point: s.points = ring(o.points); break;
    }
    s.colour = *o.color;
    s.fill = *o.color;
    s.fill.a = uint8_t(std::lround(s.fill.a * double(o.fillOpacity)));
    s.filled = o.fill && o.kind != iris::AnnotationKind::Polyline && o.kind != iris::AnnotationKind::Point;
    s.half = std::max(0.5, o.lineWidth * 0.5);
    return s;
}

// Even-odd inside test and the distance to the nearest ring edge.
bool insideRings(const std::vector<std::vector<std::array<double, 2>>>& rings, double x, double y, double* edge) {
    bool in = false;
    double d = 1e300;
    for (const auto& r : rings) {
        for (size_t i = 0, j = r.size() - 1; i < r.size(); j = i++) {
            const auto& a = r[i];
            const auto& b = r[j];
            if ((a[1] > y) != (b[1] > y) && x < (b[0] - a[0]) * (y - a[1]) / (b[1] - a[1]) + a[0]) in = !in;
            d = std::min(d, segmentDistance(x, y, a[0], a[1], b[0], b[1]));
        }
    }
    *edge = d;
    return in;
}

// The CPU reference over `base`; `mask` is 0 where a pixel is left out (centre on a fill's edge).
iris::Image reference(const iris::Image& base, const std::vector<iris::AnnotationObject>& objects,
                      const iris::ViewTransform& t, Mask* mask) {
    std::vector<Shape> shapes;
    for (const auto& o : objects) shapes.push_back(shapeOf(o, t));
    iris::Image out = base;
    mask->assign(size_t(base.width) * base.height, 1);
    for (uint32_t y = 0; y < base.height; ++y) {
        for (uint32_t x = 0; x < base.width; ++x) {
            const double px = x + 0.5, py = y + 0.5;
            const uint8_t* b = pixel(base, x, y);
            Rgbf c{b[0] / 255.0, b[1] / 255.0, b[2] / 255.0};
            bool ambiguous = false;
            for (const Shape& s : shapes) { // fills first, in order
                if (!s.filled) continue;
                double edge = 0;
                const bool in = insideRings(s.rings, px, py, &edge);
                if (edge < 0.05) ambiguous = true;
                if (in) over(c, s.fill, 1.0);
            }
            const auto capsule = [&](const std::array<double, 2>& a, const std::array<double, 2>& bb, double half,
                                     iris::Rgba8 col) {
                const double d = segmentDistance(px, py, a[0], a[1], bb[0], bb[1]);
                const double cov = std::clamp(half + 0.5 - d, 0.0, 1.0);
                if (cov > 0) over(c, col, cov);
            };
            for (const Shape& s : shapes) { // then outlines, segment after segment
                for (const auto& r : s.rings)
                    for (size_t i = 0; i < r.size(); ++i) capsule(r[i], r[(i + 1) % r.size()], s.half, s.colour);
                for (size_t i = 0; i + 1 < s.line.size(); ++i) capsule(s.line[i], s.line[i + 1], s.half, s.colour);
                for (const auto& p : s.points) capsule(p, p, 4.0, s.colour);
            }
            uint8_t* o = pixel(out, x, y);
            o[0] = uint8_t(std::lround(c.r * 255));
            o[1] = uint8_t(std::lround(c.g * 255));
            o[2] = uint8_t(std::lround(c.b * 255));
            if (ambiguous) (*mask)[size_t(y) * base.width + x] = 0;
        }
    }
    return out;
}

// Waits (on the frame callback, not by polling) for a frame drawn after now.
class FrameWaiter {
public:
    explicit FrameWaiter(iris::Engine& e) : e_(e) {
        e_.setFrameCallback([this](const iris::FrameStats&) {
            {
                std::lock_guard lock(m_);
                ++frames_;
            }
            cv_.notify_all();
        });
    }
    ~FrameWaiter() { e_.setFrameCallback({}); }
    uint64_t count() {
        std::lock_guard lock(m_);
        return frames_;
    }
    bool waitBeyond(uint64_t n, std::chrono::milliseconds timeout) {
        std::unique_lock lock(m_);
        return cv_.wait_for(lock, timeout, [&] { return frames_ > n; });
    }

private:
    iris::Engine& e_;
    std::mutex m_;
    std::condition_variable cv_;
    uint64_t frames_ = 0;
};

} // namespace

class TestAnnotations : public QObject {
    Q_OBJECT
    TestEngine e_;

    // The frame of `view` with annotations hidden, then shown.
    bool renderBoth(const iris::View& view, iris::Frame* base, iris::Frame* with, std::string* why) {
        e_->setAnnotationsVisible(false);
        auto b = renderView(*e_.engine, view, kW, kH, 20s, why);
        if (!b) return false;
        e_->setAnnotationsVisible(true);
        auto w = renderView(*e_.engine, view, kW, kH, 20s, why);
        if (!w) return false;
        *base = std::move(*b);
        *with = std::move(*w);
        return true;
    }

private slots:
    void initTestCase() {
        iris::EngineConfig cfg;
        cfg.color.managed = false;
        e_ = createTestEngine(cfg);
        QVERIFY2(e_, describe(e_.error).c_str());
        QVERIFY(e_->bindOffscreen(kW, kH).ok());
        QVERIFY(e_->annotationsVisible());
        QCOMPARE(e_->selectedAnnotation(), uint64_t(0));
    }
    void init() {
        e_.beginTest();
        if (!e_->error().ok()) e_->clearError();
        const auto sample = sampleSlidePath();
        if (!sample) QSKIP("no sample slide");
        QVERIFY(e_->open(sample->string()).ok());
    }
    void cleanup() {
        e_->setAnnotations(nullptr);
        e_->setSelectedAnnotation(0);
        e_->setAnnotationsVisible(true);
        const std::string why = e_.endTest();
        QVERIFY2(why.empty(), why.c_str());
    }
    void cleanupTestCase() {
        const std::string why = e_.finish();
        QVERIFY2(why.empty(), why.c_str());
    }

    void matchesCpuRasteriser_data() {
        QTest::addColumn<double>("downsample");
        QTest::addColumn<double>("rotation");
        QTest::addColumn<bool>("flipH");
        QTest::newRow("1:1") << 1.0 << 0.0 << false;
        QTest::newRow("zoomed in 2x") << 0.5 << 0.0 << false;
        QTest::newRow("downsample 1.7") << 1.7 << 0.0 << false;
        QTest::newRow("turned 30") << 1.3 << 30.0 << false;
        QTest::newRow("turned 90 mirrored") << 1.0 << 90.0 << true;
    }
    void matchesCpuRasteriser() {
        QFETCH(double, downsample);
        QFETCH(double, rotation);
        QFETCH(bool, flipH);
        const double cx = 2000.3, cy = 1500.6;
        auto store = std::make_shared<iris::AnnotationStore>();
        const auto objects = scene(cx, cy);
        QVERIFY(store->addBatch(objects).ok());
        e_->setAnnotations(store);
        QCOMPARE(e_->annotations(), store);
        iris::View v{cx, cy, downsample, rotation, flipH, false};
        iris::Frame base, with;
        std::string why;
        QVERIFY2(renderBoth(v, &base, &with, &why), why.c_str());
        Mask mask;
        const iris::Image ref = reference(base.image, objects, iris::ViewTransform::of(with.view, kW, kH), &mask);
        const DiffStats d = compareImages(with.image, ref, &mask);
        uint64_t changed = 0;
        for (size_t i = 0; i < base.image.rgba.size(); ++i) changed += base.image.rgba[i] != with.image.rgba[i];
        QVERIFY2(changed > 1000, "the annotations changed almost nothing");
        if (d.maxAbs > 3) {
            const std::string where = saveFailureArtefacts(QTest::currentDataTag(), with.image, ref, &mask);
            QFAIL(("frame differs from the CPU rasteriser: " + d.summary() + "; " + where).c_str());
        }
    }

    void hiddenAndDetachedDrawNothing() {
        auto store = std::make_shared<iris::AnnotationStore>();
        QVERIFY(store->addBatch(scene(2000, 1500)).ok());
        const iris::View v{2000, 1500, 1.0};
        std::string why;
        auto plain = renderView(*e_.engine, v, kW, kH, 20s, &why);
        QVERIFY2(plain, why.c_str());
        e_->setAnnotations(store);
        auto shown = renderView(*e_.engine, v, kW, kH, 20s, &why);
        QVERIFY2(shown, why.c_str());
        QVERIFY(shown->image.rgba != plain->image.rgba);
        e_->setAnnotationsVisible(false);
        auto hidden = renderView(*e_.engine, v, kW, kH, 20s, &why);
        QVERIFY2(hidden, why.c_str());
        QVERIFY(hidden->image.rgba == plain->image.rgba);
        e_->setAnnotationsVisible(true);
        e_->setAnnotations(nullptr);
        QVERIFY(!e_->annotations());
        auto detached = renderView(*e_.engine, v, kW, kH, 20s, &why);
        QVERIFY2(detached, why.c_str());
        QVERIFY(detached->image.rgba == plain->image.rgba);
    }

    void selectionDrawsOutlineAndHandles() {
        auto store = std::make_shared<iris::AnnotationStore>();
        iris::AnnotationObject r;
        r.kind = iris::AnnotationKind::Rectangle;
        r.box = {1900, 1420, 2100, 1560};
        r.color = iris::Rgba8{0, 0, 0, 255};
        auto id = store->add(r);
        QVERIFY(id.ok());
        e_->setAnnotations(store);
        e_->setSelectedAnnotation(*id);
        QCOMPARE(e_->selectedAnnotation(), *id);
        const iris::View v = viewWithOrigin(1800, 1350, 1.0, kW, kH);
        std::string why;
        auto f = renderView(*e_.engine, v, kW, kH, 20s, &why);
        QVERIFY2(f, why.c_str());
        // Corner (1900, 1420) is target pixel (100, 70): a handle, white in the middle, dark rim.
        const uint8_t* c = pixel(f->image, 100, 70);
        QVERIFY2(c[0] == 255 && c[1] == 255 && c[2] == 255, "no light handle at the corner");
        const uint8_t* rim = pixel(f->image, 100, 73); // centre 3.5 px below the corner: the dark rim
        QVERIFY2(rim[0] < 64 && rim[1] < 64 && rim[2] < 64,
                 ("no dark rim around the handle: " + std::to_string(rim[0]) + "," + std::to_string(rim[1]) + "," +
                  std::to_string(rim[2]))
                     .c_str());
        // The middle of the top edge (2000, 1420) → (200, 70): the yellow selection outline.
        const uint8_t* edge = pixel(f->image, 200, 70);
        QVERIFY2(edge[0] == 255 && edge[1] == 255 && edge[2] == 0, "no yellow outline on the selected edge");
        e_->setSelectedAnnotation(0);
        auto g = renderView(*e_.engine, v, kW, kH, 20s, &why);
        QVERIFY2(g, why.c_str());
        const uint8_t* plainEdge = pixel(g->image, 200, 70);
        QVERIFY2(plainEdge[0] == 0 && plainEdge[1] == 0 && plainEdge[2] == 0, "unselected edge is not its own black");
    }

    // More objects than the per-frame budget: the fit view draws the aggregate's cells.
    void manyObjectsAtFitDrawCells() {
        auto store = std::make_shared<iris::AnnotationStore>();
        std::vector<iris::AnnotationObject> many;
        const int n = 120000; // over AnnotationBudget::maxObjects (20000)
        many.reserve(n);
        for (int i = 0; i < n; ++i) {
            const double x = 20 + (i % 400) * 14.9, y = 20 + (i / 400) * 13.2;
            iris::AnnotationObject o;
            o.kind = iris::AnnotationKind::Rectangle;
            o.box = {x, y, x + 6, y + 6};
            o.color = iris::Rgba8{0, 0, 0, 255};
            many.push_back(std::move(o));
        }
        QVERIFY(store->replaceAll(std::move(many), {}).ok());
        e_->setAnnotations(store);
        const iris::View fit{3000, 2000, 6000.0 / kW * 1.05};
        std::string why;
        iris::Frame base, with;
        const auto t0 = std::chrono::steady_clock::now();
        QVERIFY2(renderBoth(fit, &base, &with, &why), why.c_str());
        qInfo("fit view of %d objects: %.0f ms for both frames", n,
              std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        uint64_t dark = 0;
        for (uint32_t y = 0; y < kH; ++y)
            for (uint32_t x = 0; x < kW; ++x) {
                const uint8_t* p = pixel(with.image, x, y);
                dark += p[0] < 8 && p[1] < 8 && p[2] < 8;
            }
        // The objects fill 6000 × 3960 of the slide: at this zoom, cells of the aggregate cover it
        // with dots (radius 1.5 px), a good part of that area dark.
        QVERIFY2(dark > 2000, ("only " + std::to_string(dark) + " dark pixels").c_str());
    }

    // iris-render --annotations: the same pixels as the engine's frame of the same view.
    void irisRenderDrawsAnnotationFiles() {
        const auto objects = scene(2000, 1500);
        iris::AnnotationDocument doc;
        doc.objects = objects;
        const std::filesystem::path file = testOutDir() / "annotations-render.geojson";
        std::ofstream(file) << iris::writeGeoJson(doc);
        const std::filesystem::path png = testOutDir() / "annotations-render.png";
        std::filesystem::remove(png);
        // iris-render beside this program (the build's bin/ folder, or a bundle copied elsewhere).
        const QString exe = QCoreApplication::applicationDirPath() + "/iris-render";
        QVERIFY2(QFileInfo::exists(exe), qPrintable(exe + " does not exist (built with this suite)"));
        QProcess p;
        p.start(exe, {QString::fromStdString(sampleSlidePath()->string()), "--out",
                                  QString::fromStdString(png.string()), "--size", QString("%1x%2").arg(kW).arg(kH),
                                  "--center", "2000,1500", "--downsample", "1.25", "--color-managed", "off",
                                  "--annotations", QString::fromStdString(file.string())});
        QVERIFY2(p.waitForFinished(120000), qPrintable(exe + ": " + p.errorString()));
        QVERIFY2(p.exitCode() == 0, p.readAllStandardError().constData());
        QImage img(QString::fromStdString(png.string()));
        QVERIFY(!img.isNull());
        img = img.convertToFormat(QImage::Format_RGBA8888);
        auto store = std::make_shared<iris::AnnotationStore>();
        QVERIFY(store->addBatch(objects).ok());
        e_->setAnnotations(store);
        std::string why;
        auto f = renderView(*e_.engine, iris::View{2000, 1500, 1.25}, kW, kH, 20s, &why);
        QVERIFY2(f, why.c_str());
        QCOMPARE(uint32_t(img.width()), kW);
        uint64_t differing = 0;
        for (uint32_t y = 0; y < kH; ++y)
            differing += std::memcmp(img.constScanLine(int(y)), pixel(f->image, 0, y), kW * 4) != 0;
        QCOMPARE(differing, uint64_t(0));
        // And a file that is not annotations: exit 1, with the reader's message.
        const std::filesystem::path bad = testOutDir() / "annotations-bad.geojson";
        std::ofstream(bad) << "{\"type\": \"FeatureCollection\", \"features\": [}";
        QProcess q;
        q.start(exe, {QString::fromStdString(sampleSlidePath()->string()), "--out",
                                  QString::fromStdString(png.string()), "--annotations",
                                  QString::fromStdString(bad.string())});
        QVERIFY(q.waitForFinished(120000));
        QCOMPARE(q.exitCode(), 1);
        QVERIFY2(q.readAllStandardError().contains("GeoJSON line 1"), "no line in the error");
    }

    // A change made on another thread is drawn without the host asking for a frame.
    void changesFromAnotherThreadRedraw() {
        auto store = std::make_shared<iris::AnnotationStore>();
        e_->setAnnotations(store);
        const iris::View v = viewWithOrigin(1800, 1350, 1.0, kW, kH);
        std::string why;
        auto before = renderView(*e_.engine, v, kW, kH, 20s, &why);
        QVERIFY2(before, why.c_str());
        FrameWaiter frames(*e_.engine);
        const uint64_t seen = frames.count();
        std::thread writer([&] {
            iris::AnnotationObject r;
            r.kind = iris::AnnotationKind::Rectangle;
            r.box = {1850, 1400, 1950, 1500};
            r.color = iris::Rgba8{255, 0, 0, 255};
            r.fill = true;
            r.fillOpacity = 1.0f;
            (void)store->add(r);
        });
        writer.join();
        // A frame under way when the store changed may come first, and the callback runs
        // before the frame's read-back is published: wait frame by frame (each wait bounded)
        // until one shows the object. Without the store's wake-up no frame comes at all.
        const auto deadline = std::chrono::steady_clock::now() + 10s;
        uint64_t n = seen;
        bool shown = false;
        while (!shown && std::chrono::steady_clock::now() < deadline) {
            if (!frames.waitBeyond(n, 2s)) break;
            n = frames.count();
            auto after = e_->readFrame();
            QVERIFY(after.ok());
            const uint8_t* p = pixel(after->image, 100, 100); // (1900, 1450): inside the red rectangle
            shown = p[0] == 255 && p[1] == 0 && p[2] == 0;
            if (!shown && n - seen > 5) break; // frames came but none shows it
        }
        QVERIFY2(shown, "no frame shows the object added on another thread");
    }

    // Engines come and go while another thread keeps editing the store they show.
    void storeOutlivesEnginesUnderEdits() {
        auto store = std::make_shared<iris::AnnotationStore>();
        std::atomic<bool> stop{false};
        std::thread writer([&] {
            uint64_t i = 0;
            while (!stop.load()) {
                iris::AnnotationObject r;
                r.kind = iris::AnnotationKind::Rectangle;
                const double x = 100 + double(i++ % 50) * 30;
                r.box = {x, 100, x + 20, 120};
                (void)store->add(r);
                if (store->snapshot()->size() > 200) store->clear();
            }
        });
        const auto sample = sampleSlidePath();
        for (int round = 0; round < 4; ++round) {
            iris::EngineConfig cfg;
            TestEngine other = createTestEngine(cfg);
            QVERIFY2(other, describe(other.error).c_str());
            QVERIFY(other->bindOffscreen(160, 120).ok());
            QVERIFY(other->open(sample->string()).ok());
            other->setAnnotations(store);
            QVERIFY(other->waitForFrame(20s).ok());
            if (round % 2) other->setAnnotations(nullptr);
            const std::string why = other.finish();
            QVERIFY2(why.empty(), why.c_str());
        }
        stop = true;
        writer.join();
    }
};

QTEST_GUILESS_MAIN(TestAnnotations)
#include "tst_annotations.moc"
