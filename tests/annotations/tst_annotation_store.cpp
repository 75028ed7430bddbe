// Unit tests of the annotation model (iris/annotations.h): store semantics and publication,
// spatial queries against a brute-force reference, hit-testing, level of detail, ellipse
// flattening, fill triangulation (area and containment) and the fit-view overview. No device.
#include <QtTest>

// Boost 1.74's Geometry includes a header that announces its own deprecation (annotation_index.h).
#define BOOST_ALLOW_DEPRECATED_HEADERS
#include <boost/geometry.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <numbers>
#include <random>
#include <set>
#include <thread>

#include "iris/annotations.h"

using namespace iris;

namespace {

AnnotationObject polygon(std::vector<Point2> outer, std::vector<std::vector<Point2>> holes = {}) {
    AnnotationObject o;
    o.kind = AnnotationKind::Polygon;
    o.polygons.push_back({std::move(outer), std::move(holes)});
    return o;
}
AnnotationObject square(double x, double y, double s) { return polygon({{x, y}, {x + s, y}, {x + s, y + s}, {x, y + s}}); }
AnnotationObject boxed(AnnotationKind k, Box2 b) {
    AnnotationObject o;
    o.kind = k;
    o.box = b;
    return o;
}
AnnotationObject points(AnnotationKind k, std::vector<Point2> p) {
    AnnotationObject o;
    o.kind = k;
    o.points = std::move(p);
    return o;
}

// A random object of any kind around (cx, cy), extent up to `size`.
AnnotationObject randomObject(std::mt19937_64& rng, double cx, double cy, double size) {
    std::uniform_real_distribution<double> u(0, 1);
    const int kind = int(rng() % 5);
    const double r = 0.5 + u(rng) * size;
    switch (kind) {
    case 0: return points(AnnotationKind::Point, {{cx, cy}});
    case 1: return points(AnnotationKind::Polyline, {{cx - r, cy}, {cx, cy + r / 2}, {cx + r, cy - r}});
    case 2: {
        std::vector<Point2> ring;
        const int n = 3 + int(rng() % 20);
        for (int i = 0; i < n; ++i) {
            const double a = 2 * std::numbers::pi * i / n, rr = r * (0.4 + 0.6 * u(rng));
            ring.push_back({cx + rr * std::cos(a), cy + rr * std::sin(a)});
        }
        return polygon(ring);
    }
    case 3: return boxed(AnnotationKind::Rectangle, {cx - r, cy - r / 2, cx + r, cy + r / 2});
    default: return boxed(AnnotationKind::Ellipse, {cx - r / 2, cy - r, cx + r / 2, cy + r});
    }
}

std::set<uint64_t> idSet(const std::vector<const StoredAnnotation*>& v) {
    std::set<uint64_t> s;
    for (auto* a : v) s.insert(a->object.id);
    return s;
}

// A star-shaped, concave ring around (cx, cy) with radii between r0 and r1.
std::vector<Point2> star(std::mt19937_64& rng, double cx, double cy, double r0, double r1, int n, bool clockwise) {
    std::uniform_real_distribution<double> u(r0, r1);
    std::vector<Point2> ring;
    for (int i = 0; i < n; ++i) {
        const double a = (clockwise ? -1 : 1) * 2 * std::numbers::pi * i / n;
        const double rr = u(rng);
        ring.push_back({cx + rr * std::cos(a), cy + rr * std::sin(a)});
    }
    return ring;
}

double shoelace(const std::vector<Point2>& r) {
    double s = 0;
    for (size_t i = 0, j = r.size() - 1; i < r.size(); j = i++) s += r[j].x * r[i].y - r[i].x * r[j].y;
    return std::fabs(s / 2);
}
bool inRing(Point2 p, const std::vector<Point2>& ring) {
    bool in = false;
    for (size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++)
        if ((ring[i].y > p.y) != (ring[j].y > p.y) &&
            p.x < (ring[j].x - ring[i].x) * (p.y - ring[i].y) / (ring[j].y - ring[i].y) + ring[i].x)
            in = !in;
    return in;
}
double trianglesArea(const AnnotationTriangles& t) {
    double a = 0;
    for (size_t i = 0; i + 2 < t.vertices.size(); i += 3) {
        const Point2 p = t.vertices[i], q = t.vertices[i + 1], r = t.vertices[i + 2];
        a += std::fabs((q.x - p.x) * (r.y - p.y) - (r.x - p.x) * (q.y - p.y)) / 2;
    }
    return a;
}

} // namespace

class TestAnnotationStore : public QObject {
    Q_OBJECT
private slots:
    void addFindUpdateRemove();
    void failedEditsChangeNothing();
    void classesAndColours();
    void batchPublishesOnce();
    void snapshotsAreImmutable();
    void editCostAtAMillion();
    void queriesMatchBruteForce();
    void convexQueryMatchesBoostGeometry();
    void hitTesting();
    void levelOfDetail();
    void ellipseFlattening();
    void triangulationAreaAndContainment();
    void triangulationOfShapesAndBadPolygons();
    void triangulationIsCachedAndShared();
    void overviewCountsEveryDrawnObject();
    void writersAndReadersStorm();
};

void TestAnnotationStore::addFindUpdateRemove() {
    AnnotationStore store;
    auto s0 = store.snapshot();
    QCOMPARE(s0->size(), size_t(0));
    QVERIFY(s0->bounds().empty());
    auto a = store.add(square(10, 10, 5));
    QVERIFY2(a.ok(), a.error().message().c_str());
    auto b = store.add(points(AnnotationKind::Point, {{100, 200}}));
    QVERIFY(b.ok());
    QVERIFY(*a != 0 && *b != 0 && *a != *b);
    auto s = store.snapshot();
    QCOMPARE(s->generation(), s0->generation() + 2);
    QCOMPARE(s->size(), size_t(2));
    QCOMPARE(s->bounds(), (Box2{10, 10, 100, 200}));
    QVERIFY(s->find(*a) && s->find(*a)->object.kind == AnnotationKind::Polygon);
    QCOMPARE(s->find(*a)->bounds, (Box2{10, 10, 15, 15}));

    AnnotationObject moved = s->find(*a)->object;
    moved.polygons[0].outer[2] = {50, 60};
    moved.name = "moved";
    QVERIFY(store.update(moved).ok());
    auto s2 = store.snapshot();
    QCOMPARE(s2->find(*a)->object.name, std::string("moved"));
    QCOMPARE(s2->find(*a)->bounds, (Box2{10, 10, 50, 60}));
    QCOMPARE(s->find(*a)->object.name, std::string()); // the old snapshot is unchanged

    QVERIFY(store.remove(*b).ok());
    auto s3 = store.snapshot();
    QCOMPARE(s3->size(), size_t(1));
    QVERIFY(!s3->find(*b));
    QCOMPARE(s3->bounds(), (Box2{10, 10, 50, 60}));

    // An explicit id is kept; the next fresh id is above it.
    AnnotationObject c = square(0, 0, 1);
    c.id = 1000;
    QCOMPARE(*store.add(c), uint64_t(1000));
    QVERIFY(*store.add(square(0, 0, 1)) > 1000);

    store.clear();
    QCOMPARE(store.snapshot()->size(), size_t(0));
    QVERIFY(!store.snapshot()->find(*a));
}

void TestAnnotationStore::failedEditsChangeNothing() {
    AnnotationStore store;
    const uint64_t id = *store.add(square(0, 0, 10));
    const uint64_t gen = store.snapshot()->generation();
    struct Case {
        AnnotationEdit edit;
        const char* expected;
    };
    AnnotationObject nan = square(0, 0, 1);
    nan.polygons[0].outer[1].x = NAN;
    AnnotationObject twoPoints = polygon({{0, 0}, {1, 1}});
    AnnotationObject dup = square(0, 0, 1);
    dup.id = id;
    AnnotationObject ghost = square(0, 0, 1);
    ghost.id = 999;
    AnnotationObject badBox = boxed(AnnotationKind::Ellipse, {5, 5, 1, 1});
    AnnotationObject opacity = square(0, 0, 1);
    opacity.fillOpacity = 2;
    std::vector<Case> cases;
    cases.push_back({{{square(1, 1, 1), nan}, {}, {}, {}}, "annotation 1 to add: polygon 0: a coordinate is not finite"});
    cases.push_back({{{twoPoints}, {}, {}, {}}, "annotation 0 to add: polygon 0: the outer ring has fewer than 3 vertices"});
    cases.push_back({{{dup}, {}, {}, {}}, "annotation id 1 is already used"});
    cases.push_back({{{square(1, 1, 1)}, {ghost}, {}, {}}, "no annotation with id 999 to update"});
    cases.push_back({{{square(1, 1, 1)}, {}, {id, 4242}, {}}, "no annotation with id 4242 to remove"});
    cases.push_back({{{badBox}, {}, {}, {}}, "annotation 0 to add: the box's minimum exceeds its maximum"});
    AnnotationObject same = square(0, 0, 2);
    same.id = id;
    cases.push_back({{{}, {same}, {id}, {}}, "annotation 1 is changed twice in one edit"});
    cases.push_back({{{}, {}, {id, id}, {}}, "annotation 1 is changed twice in one edit"});
    cases.push_back({{{}, {same, same}, {}, {}}, "annotation 1 is changed twice in one edit"});
    cases.push_back({{{points(AnnotationKind::Point, {{1, -1e13}})}, {}, {}, {}}, "annotation 0 to add: a coordinate is outside ±1e12"});
    cases.push_back({{{boxed(AnnotationKind::Ellipse, {-1e308, 0, 1e308, 1})}, {}, {}, {}},
                     "annotation 0 to add: a coordinate is outside ±1e12"});
    cases.push_back({{{opacity}, {}, {}, {}}, "annotation 0 to add: fill opacity is not in 0..1"});
    cases.push_back({{{points(AnnotationKind::Polyline, {{1, 1}})}, {}, {}, {}}, "annotation 0 to add: a polyline needs at least 2 points"});
    for (auto& c : cases) {
        auto r = store.apply(c.edit);
        QVERIFY2(!r.ok(), c.expected);
        QCOMPARE(QString::fromStdString(r.error().message()), QString(c.expected));
        QCOMPARE(store.snapshot()->generation(), gen);
        QCOMPARE(store.snapshot()->size(), size_t(1));
    }
    QVERIFY(store.update(ghost).status() == Status::NotFound);
    QVERIFY(store.remove(12345).status() == Status::NotFound);
    QCOMPARE(store.snapshot()->generation(), gen);
    // replaceAll refuses a bad batch whole: the store keeps its object.
    QVERIFY(!store.replaceAll({square(0, 0, 1), nan}, {}).ok());
    QCOMPARE(store.snapshot()->size(), size_t(1));
    QVERIFY(store.snapshot()->find(id));
}

void TestAnnotationStore::classesAndColours() {
    AnnotationStore store;
    AnnotationObject t = square(0, 0, 10);
    t.className = "Tumor";
    AnnotationObject own = t;
    own.color = Rgba8{1, 2, 3, 255};
    AnnotationObject none = square(20, 20, 10);
    const uint64_t a = *store.add(t), b = *store.add(own), c = *store.add(none);
    auto s = store.snapshot();
    QCOMPARE(s->colorOf(s->find(a)->object), defaultClassColor("Tumor"));
    QCOMPARE(s->colorOf(s->find(b)->object), (Rgba8{1, 2, 3, 255}));
    QCOMPARE(s->colorOf(s->find(c)->object), (Rgba8{255, 0, 0, 255}));
    QCOMPARE(s->classes().size(), size_t(1)); // a class named by an object joins the table
    QVERIFY(defaultClassColor("Tumor") == defaultClassColor("Tumor"));
    QVERIFY(!(defaultClassColor("Tumor") == defaultClassColor("Stroma")));

    store.setClassColor("Tumor", {9, 8, 7, 255});
    s = store.snapshot();
    QCOMPARE(s->colorOf(s->find(a)->object), (Rgba8{9, 8, 7, 255}));
    QCOMPARE(s->colorOf(s->find(b)->object), (Rgba8{1, 2, 3, 255}));
    QVERIFY(s->drawn(s->find(a)->object));
    store.setClassVisible("Tumor", false);
    s = store.snapshot();
    QVERIFY(!s->drawn(s->find(a)->object) && !s->drawn(s->find(b)->object) && s->drawn(s->find(c)->object));
    QCOMPARE(s->query(Box2{0, 0, 100, 100}, true).size(), size_t(1));
    QCOMPARE(s->query(Box2{0, 0, 100, 100}).size(), size_t(3));
    QCOMPARE(s->classInfo("Tumor").color, (Rgba8{9, 8, 7, 255}));
}

void TestAnnotationStore::batchPublishesOnce() {
    AnnotationStore store;
    std::mt19937_64 rng(1);
    std::vector<AnnotationObject> batch;
    for (int i = 0; i < 5000; ++i) batch.push_back(randomObject(rng, double(rng() % 100000), double(rng() % 100000), 40));
    const uint64_t gen = store.snapshot()->generation();
    auto r = store.addBatch(batch);
    QVERIFY(r.ok());
    QCOMPARE(r->size(), size_t(5000));
    QCOMPARE(store.snapshot()->generation(), gen + 1);
    QCOMPARE(store.snapshot()->size(), size_t(5000));
    std::set<uint64_t> unique(r->begin(), r->end());
    QCOMPARE(unique.size(), size_t(5000));
    for (uint64_t id : *r) QVERIFY(store.snapshot()->find(id));
    // One apply with adds, updates and removes: one publication.
    AnnotationEdit e;
    e.add.push_back(square(1, 1, 1));
    AnnotationObject u = store.snapshot()->find((*r)[7])->object;
    u.name = "u";
    e.update.push_back(u);
    e.remove = {(*r)[0], (*r)[1]};
    QVERIFY(store.apply(e).ok());
    QCOMPARE(store.snapshot()->generation(), gen + 2);
    QCOMPARE(store.snapshot()->size(), size_t(4999));
    QCOMPARE(store.snapshot()->find((*r)[7])->object.name, std::string("u"));
}

void TestAnnotationStore::snapshotsAreImmutable() {
    AnnotationStore store;
    std::mt19937_64 rng(2);
    std::vector<AnnotationObject> batch;
    for (int i = 0; i < 3000; ++i) batch.push_back(randomObject(rng, double(rng() % 10000), double(rng() % 10000), 40));
    auto ids = *store.addBatch(batch);
    auto before = store.snapshot();
    std::vector<AnnotationObject> kept;
    before->forEach([&](const StoredAnnotation& a) { kept.push_back(a.object); });
    for (int i = 0; i < 200; ++i) {
        const uint64_t id = ids[rng() % ids.size()];
        if (auto* a = store.snapshot()->find(id)) {
            if (i % 2) (void)store.remove(id);
            else {
                AnnotationObject o = a->object;
                o.name = "edited";
                (void)store.update(o);
            }
        }
    }
    std::vector<AnnotationObject> again;
    before->forEach([&](const StoredAnnotation& a) { again.push_back(a.object); });
    QVERIFY(kept == again);
}

void TestAnnotationStore::editCostAtAMillion() {
    // One edit of a 10^6-object store copies one chunk, the chunk directory and one id bucket,
    // and rebuilds one chunk's R-tree: it must cost a small fraction of publishing the batch.
    constexpr int kCount = 1'000'000;
    AnnotationStore store;
    std::vector<AnnotationObject> batch;
    batch.reserve(kCount);
    std::mt19937_64 rng(3);
    for (int i = 0; i < kCount; ++i) {
        const double x = double(rng() % 200000), y = double(rng() % 100000);
        batch.push_back(square(x, y, 8));
    }
    using clock = std::chrono::steady_clock;
    auto t0 = clock::now();
    auto ids = store.addBatch(std::move(batch));
    const double batchMs = std::chrono::duration<double, std::milli>(clock::now() - t0).count();
    QVERIFY(ids.ok());
    QCOMPARE(store.snapshot()->size(), size_t(kCount));
    constexpr int kEdits = 200;
    t0 = clock::now();
    for (int i = 0; i < kEdits; ++i) {
        AnnotationObject o = store.snapshot()->find((*ids)[rng() % kCount])->object;
        o.polygons[0].outer[0].x -= 1;
        QVERIFY(store.update(std::move(o)).ok());
    }
    const double editUs = std::chrono::duration<double, std::micro>(clock::now() - t0).count() / kEdits;
    t0 = clock::now();
    constexpr int kReads = 100000;
    size_t sink = 0;
    for (int i = 0; i < kReads; ++i) sink += store.snapshot()->size();
    const double snapNs = std::chrono::duration<double, std::nano>(clock::now() - t0).count() / kReads;
    QVERIFY(sink > 0);
    qInfo("10^6 squares: batch add %.0f ms (one publication), one update %.1f us, snapshot() %.0f ns", batchMs, editUs,
          snapNs);
    QVERIFY2(editUs / 1000 < batchMs / 50, "an edit costs more than 2% of building the whole store");
}

void TestAnnotationStore::queriesMatchBruteForce() {
    AnnotationStore store;
    std::mt19937_64 rng(4);
    std::vector<AnnotationObject> batch;
    for (int i = 0; i < 20000; ++i) batch.push_back(randomObject(rng, double(rng() % 50000), double(rng() % 30000), 300));
    auto ids = *store.addBatch(batch);
    // Some single adds, updates and removes, so that the tail chunk and edited chunks count too.
    for (int i = 0; i < 300; ++i) {
        (void)store.add(randomObject(rng, double(rng() % 50000), double(rng() % 30000), 300));
        const uint64_t id = ids[rng() % ids.size()];
        if (!store.snapshot()->find(id)) continue;
        if (i % 3 == 0) QVERIFY(store.remove(id).ok());
        else {
            AnnotationObject o = randomObject(rng, double(rng() % 50000), double(rng() % 30000), 300);
            o.id = id;
            QVERIFY(store.update(o).ok());
        }
    }
    auto s = store.snapshot();
    std::vector<const StoredAnnotation*> all;
    s->forEach([&](const StoredAnnotation& a) { all.push_back(&a); });
    QCOMPARE(all.size(), s->size());
    Box2 bounds;
    for (auto* a : all) bounds.expand(annotationBounds(a->object));
    QCOMPARE(s->bounds(), bounds);
    for (int q = 0; q < 300; ++q) {
        const double x = double(rng() % 52000) - 1000, y = double(rng() % 32000) - 1000;
        const double w = double(rng() % 5000), h = double(rng() % 5000);
        const Box2 r{x, y, x + w, y + h};
        std::set<uint64_t> expect;
        for (auto* a : all)
            if (annotationBounds(a->object).intersects(r)) expect.insert(a->object.id);
        QCOMPARE(idSet(s->query(r)), expect);
    }
    QVERIFY(s->query(Box2{}).empty());
}

void TestAnnotationStore::convexQueryMatchesBoostGeometry() {
    namespace bg = boost::geometry;
    using BP = bg::model::d2::point_xy<double>;
    AnnotationStore store;
    std::mt19937_64 rng(5);
    std::vector<AnnotationObject> batch;
    for (int i = 0; i < 10000; ++i) batch.push_back(randomObject(rng, double(rng() % 20000), double(rng() % 20000), 200));
    QVERIFY(store.addBatch(batch).ok());
    auto s = store.snapshot();
    std::vector<const StoredAnnotation*> all;
    s->forEach([&](const StoredAnnotation& a) { all.push_back(&a); });
    for (int q = 0; q < 100; ++q) {
        // A rotated view footprint: a rectangle turned by a random angle.
        const double cx = double(rng() % 20000), cy = double(rng() % 20000), hw = 200 + double(rng() % 3000),
                     hh = 200 + double(rng() % 3000), a = double(rng() % 360) * std::numbers::pi / 180;
        std::vector<Point2> quad;
        for (auto [sx, sy] : {std::pair{-1, -1}, {1, -1}, {1, 1}, {-1, 1}})
            quad.push_back({cx + sx * hw * std::cos(a) - sy * hh * std::sin(a), cy + sx * hw * std::sin(a) + sy * hh * std::cos(a)});
        bg::model::polygon<BP> poly;
        for (Point2 p : quad) bg::append(poly.outer(), BP(p.x, p.y));
        bg::correct(poly);
        std::set<uint64_t> expect;
        for (auto* o : all) {
            const Box2 b = annotationBounds(o->object);
            bg::model::box<BP> box(BP(b.minX, b.minY), BP(b.maxX, b.maxY));
            if (bg::intersects(box, poly)) expect.insert(o->object.id);
        }
        QCOMPARE(idSet(s->query(std::span<const Point2>(quad))), expect);
    }
}

void TestAnnotationStore::hitTesting() {
    AnnotationStore store;
    // A 100×100 square with a 40×40 hole in its middle, and a small square inside it.
    AnnotationObject donut = polygon({{0, 0}, {100, 0}, {100, 100}, {0, 100}}, {{{30, 30}, {70, 30}, {70, 70}, {30, 70}}});
    donut.fill = true;
    const uint64_t d = *store.add(donut);
    const uint64_t small = *store.add(square(5, 5, 10));
    const uint64_t pt = *store.add(points(AnnotationKind::Point, {{200, 200}, {210, 200}}));
    const uint64_t line = *store.add(points(AnnotationKind::Polyline, {{300, 0}, {400, 0}, {400, 100}}));
    const uint64_t ell = *store.add(boxed(AnnotationKind::Ellipse, {500, 0, 700, 100}));
    AnnotationObject hidden = square(1000, 1000, 10);
    hidden.visible = false;
    (void)store.add(hidden);
    auto s = store.snapshot();
    auto hit = [&](double x, double y, double tol) { return s->hitTest({x, y}, tol); };

    auto h = hit(20, 50, 2); // in the donut's body
    QVERIFY(h && h->annotation->object.id == d && h->part == AnnotationHit::Part::Inside);
    QVERIFY(!hit(50, 50, 2));                        // in the hole, far from its edges
    h = hit(31, 50, 2);                              // near the hole's left edge
    QVERIFY(h && h->annotation->object.id == d && h->part == AnnotationHit::Part::Edge && h->ring == 1 && h->vertex == 3);
    QCOMPARE(h->distance, 1.0);
    h = hit(69, 69, 2);                              // near the hole's corner
    QVERIFY(h && h->part == AnnotationHit::Part::Vertex && h->ring == 1 && h->vertex == 2);
    h = hit(10, 10, 1);                              // inside both: the smaller wins
    QVERIFY(h && h->annotation->object.id == small && h->part == AnnotationHit::Part::Inside);
    h = hit(15.5, 10, 1);                            // the small square's edge beats being inside the donut
    QVERIFY(h && h->annotation->object.id == small && h->part == AnnotationHit::Part::Edge);
    h = hit(209, 201, 3);
    QVERIFY(h && h->annotation->object.id == pt && h->part == AnnotationHit::Part::Vertex && h->vertex == 1);
    QVERIFY(!hit(205, 205, 3));
    h = hit(350, 1.5, 2);
    QVERIFY(h && h->annotation->object.id == line && h->part == AnnotationHit::Part::Edge && h->vertex == 0);
    QVERIFY(!hit(350, 50, 2)); // a polyline has no inside
    h = hit(600, 50, 1);
    QVERIFY(h && h->annotation->object.id == ell && h->part == AnnotationHit::Part::Inside);
    h = hit(600, -0.5, 0.2); // near the top, between handles: edge
    QVERIFY(!h);
    h = hit(600, -0.5, 1);
    QVERIFY(h && h->annotation->object.id == ell && h->part == AnnotationHit::Part::Vertex);
    QVERIFY(!hit(510, 10, 1)); // inside the ellipse's box, outside the ellipse
    QVERIFY(!hit(1005, 1005, 2)); // hidden objects are not selectable
    QVERIFY(!hit(NAN, 0, 1));
}

void TestAnnotationStore::levelOfDetail() {
    const Box2 b{0, 0, 40, 10};
    QCOMPARE(annotationLod(b, AnnotationKind::Polygon, true, 1), AnnotationLod::OutlineFill);
    QCOMPARE(annotationLod(b, AnnotationKind::Polygon, false, 1), AnnotationLod::Outline);
    QCOMPARE(annotationLod(b, AnnotationKind::Polyline, true, 1), AnnotationLod::Outline); // no fill for lines
    QCOMPARE(annotationLod(b, AnnotationKind::Polygon, true, 13.3), AnnotationLod::OutlineFill); // 3.008 px
    QCOMPARE(annotationLod(b, AnnotationKind::Polygon, true, 13.4), AnnotationLod::Dot);         // 2.985 px
    QCOMPARE(annotationLod(b, AnnotationKind::Ellipse, false, 1000), AnnotationLod::Dot);
    QCOMPARE(annotationLod(b, AnnotationKind::Point, true, 0.01), AnnotationLod::Dot);
    QCOMPARE(annotationLod(b, AnnotationKind::Rectangle, false, 4, LodThresholds{20}), AnnotationLod::Dot);
    QCOMPARE(annotationLod(b, AnnotationKind::Rectangle, false, 0), AnnotationLod::Dot); // nonsense downsample
}

void TestAnnotationStore::ellipseFlattening() {
    // Vertex counts grow with the on-screen size and keep the chord error under 0.25 px.
    int previous = 0;
    for (double r : {1.0, 5.0, 20.0, 100.0, 1000.0, 1e6}) {
        const int n = ellipseVertexCount(r, r / 2, 1);
        QVERIFY(n % 4 == 0 && n >= 8 && n <= 4096 && n >= previous);
        previous = n;
        if (n < 4096) QVERIFY(r * (1 - std::cos(std::numbers::pi / n)) <= 0.25 + 1e-12);
    }
    QCOMPARE(ellipseVertexCount(1000, 1000, 1000), 8); // one screen pixel
    QCOMPARE(ellipseVertexCount(1000, 1000, 1), ellipseVertexCount(10, 10, 0.01));
    const Box2 box{10, 20, 50, 40};
    const auto ring = flattenEllipse(box, 12);
    QCOMPARE(ring.size(), size_t(12));
    Box2 b;
    for (Point2 p : ring) b.expand(p);
    QCOMPARE(b, box); // the four extreme points are vertices: the bounds are exact
    for (Point2 p : ring) QVERIFY(std::fabs(std::pow((p.x - 30) / 20, 2) + std::pow((p.y - 30) / 10, 2) - 1) < 1e-12);
}

void TestAnnotationStore::triangulationAreaAndContainment() {
    AnnotationStore store;
    std::mt19937_64 rng(6);
    for (int i = 0; i < 60; ++i) {
        // A concave star with up to three star-shaped holes well inside its inner radius.
        const double cx = 1000.0 * i, cy = 500;
        const int holes = i % 4;
        AnnotationObject o = polygon(star(rng, cx, cy, 200, 400, 5 + i % 40, i % 2 == 0));
        for (int h = 0; h < holes; ++h) {
            const double a = 2 * std::numbers::pi * h / 3;
            o.polygons[0].holes.push_back(star(rng, cx + 110 * std::cos(a), cy + 110 * std::sin(a), 20, 60, 3 + h * 5, h == 1));
        }
        if (i % 5 == 0) o.polygons.push_back({star(rng, cx, cy + 2000, 50, 100, 9, false), {}}); // a multipolygon
        const uint64_t id = *store.add(o);
        auto s = store.snapshot();
        auto t = s->fillTriangles(*s->find(id));
        QVERIFY2(t.ok(), t.ok() ? "" : t.error().message().c_str());
        QVERIFY((*t)->note.empty());
        QCOMPARE((*t)->vertices.size() % 3, size_t(0));
        double expect = 0;
        for (const auto& part : o.polygons) {
            expect += shoelace(part.outer);
            for (const auto& h : part.holes) expect -= shoelace(h);
        }
        QVERIFY2(std::fabs(trianglesArea(**t) - expect) <= 1e-9 * expect,
                 qPrintable(QString("area %1 vs %2").arg(trianglesArea(**t)).arg(expect)));
        // Every triangle lies inside: its centroid is in an outer ring and in none of its holes
        // (with the areas equal, that leaves no room for a triangle poking out).
        for (size_t k = 0; k < (*t)->vertices.size(); k += 3) {
            const auto& v = (*t)->vertices;
            const Point2 c{(v[k].x + v[k + 1].x + v[k + 2].x) / 3, (v[k].y + v[k + 1].y + v[k + 2].y) / 3};
            bool inside = false;
            for (const auto& part : o.polygons)
                if (inRing(c, part.outer) && std::none_of(part.holes.begin(), part.holes.end(), [&](auto& h) { return inRing(c, h); }))
                    inside = true;
            QVERIFY(inside);
        }
    }
}

void TestAnnotationStore::triangulationOfShapesAndBadPolygons() {
    AnnotationStore store;
    const uint64_t rect = *store.add(boxed(AnnotationKind::Rectangle, {0, 0, 30, 20}));
    const uint64_t ell = *store.add(boxed(AnnotationKind::Ellipse, {0, 0, 200, 100}));
    const uint64_t line = *store.add(points(AnnotationKind::Polyline, {{0, 0}, {1, 1}}));
    const uint64_t bowtie = *store.add(polygon({{0, 0}, {10, 10}, {10, 0}, {0, 10}}));
    const uint64_t flat = *store.add(polygon({{0, 0}, {10, 0}, {20, 0}}));
    const uint64_t spike = *store.add(polygon({{0, 0}, {10, 0}, {10, 10}, {0, 10}}, {{{20, 20}, {30, 20}, {30, 30}}}));
    const uint64_t zeroBox = *store.add(boxed(AnnotationKind::Ellipse, {5, 5, 5, 9}));
    auto s = store.snapshot();
    auto r = s->fillTriangles(*s->find(rect));
    QVERIFY(r.ok() && trianglesArea(**r) == 600);
    for (double ds : {1.0, 0.1, 10.0}) {
        r = s->fillTriangles(*s->find(ell), ds);
        QVERIFY(r.ok());
        const int n = ellipseVertexCount(100, 50, ds);
        QCOMPARE((*r)->vertices.size(), size_t(3 * n));
        const double exact = std::numbers::pi * 100 * 50, inscribed = n / 2.0 * 100 * 50 * std::sin(2 * std::numbers::pi / n);
        QVERIFY(std::fabs(trianglesArea(**r) - inscribed) < 1e-6 * exact && trianglesArea(**r) < exact);
    }
    r = s->fillTriangles(*s->find(line));
    QVERIFY(!r.ok());
    QCOMPARE(QString::fromStdString(r.error().message()), QString("annotation %1 is a polyline: it has no fill").arg(line));
    // Self-intersecting: repaired (both loops of the bow-tie, 25 each), and the note says so.
    r = s->fillTriangles(*s->find(bowtie));
    QVERIFY2(r.ok(), r.ok() ? "" : r.error().message().c_str());
    QVERIFY(QString::fromStdString((*r)->note).startsWith("repaired with GEOSMakeValid: Self-intersection"));
    QVERIFY(std::fabs(trianglesArea(**r) - 50) < 1e-9);
    r = s->fillTriangles(*s->find(flat));
    QVERIFY(!r.ok());
    QCOMPARE(QString::fromStdString(r.error().message()), QString("annotation %1: the outer ring has zero area").arg(flat));
    // A hole outside its shell: invalid; MakeValid keeps the shell (and the hole as its own area).
    r = s->fillTriangles(*s->find(spike));
    QVERIFY(r.ok() && !(*r)->note.empty());
    r = s->fillTriangles(*s->find(zeroBox));
    QVERIFY(!r.ok());
    QCOMPARE(QString::fromStdString(r.error().message()), QString("annotation %1: the ellipse has no area").arg(zeroBox));
    // A polygon made by hand (not through the store) with NaN: an error, not a crash.
    StoredAnnotation loose;
    loose.object = polygon({{0, 0}, {NAN, 0}, {1, 1}});
    r = s->fillTriangles(loose);
    QVERIFY(!r.ok());
    QCOMPARE(QString::fromStdString(r.error().message()), QString("annotation 0: a coordinate is not finite"));
}

void TestAnnotationStore::triangulationIsCachedAndShared() {
    AnnotationStore store;
    std::mt19937_64 rng(7);
    const uint64_t id = *store.add(polygon(star(rng, 0, 0, 50, 100, 30, false)));
    auto s1 = store.snapshot();
    // Several threads ask at once: one triangulation, one result for all.
    std::vector<std::shared_ptr<const AnnotationTriangles>> got(4);
    std::vector<std::thread> threads;
    for (size_t i = 0; i < got.size(); ++i)
        threads.emplace_back([&, i] { got[i] = *s1->fillTriangles(*s1->find(id)); });
    for (auto& t : threads) t.join();
    for (auto& g : got) QCOMPARE(g.get(), got[0].get());
    // A later snapshot shares the unchanged object and its cache.
    (void)store.add(square(500, 500, 5));
    auto s2 = store.snapshot();
    QCOMPARE(s2->fillTriangles(*s2->find(id))->get(), got[0].get());
    // An update drops it.
    AnnotationObject o = s2->find(id)->object;
    o.polygons[0].outer[0].x += 1;
    QVERIFY(store.update(o).ok());
    auto s3 = store.snapshot();
    QVERIFY(s3->fillTriangles(*s3->find(id))->get() != got[0].get());
}

void TestAnnotationStore::overviewCountsEveryDrawnObject() {
    AnnotationStore store;
    std::mt19937_64 rng(8);
    std::vector<AnnotationObject> batch;
    for (int i = 0; i < 50000; ++i) {
        AnnotationObject o = randomObject(rng, double(rng() % 100000), double(rng() % 60000), 10);
        o.className = i % 10 == 0 ? "Hidden" : "Shown";
        batch.push_back(o);
    }
    QVERIFY(store.addBatch(batch).ok());
    store.setClassVisible("Hidden", false);
    auto s = store.snapshot();
    const AnnotationOverview& ov = s->overview();
    QCOMPARE(&ov, &s->overview()); // built once
    QVERIFY(ov.cellsX <= AnnotationOverview::kOverviewCells && ov.cellsY <= AnnotationOverview::kOverviewCells);
    QVERIFY(ov.cells.size() <= size_t(ov.cellsX) * size_t(ov.cellsY));
    uint64_t total = 0;
    for (const auto& c : ov.cells) {
        total += c.count;
        QVERIFY(c.count > 0);
        QCOMPARE(c.color, defaultClassColor("Shown"));
        QVERIFY(c.centroid.x >= ov.bounds.minX && c.centroid.x <= ov.bounds.maxX);
    }
    QCOMPARE(total, uint64_t(45000));
    QVERIFY(AnnotationStore().snapshot()->overview().cells.empty());
}

void TestAnnotationStore::writersAndReadersStorm() {
    // Writers add, update and remove from several threads while readers take snapshots and
    // check that each is whole: its count equals what forEach visits, every visited id is found,
    // its generation never goes back, and a query of the bounds returns everything.
    AnnotationStore store;
    std::atomic<bool> stop{false};
    std::atomic<int> writersLeft{3};
    std::atomic<uint64_t> snapshotsChecked{0};
    std::vector<std::thread> threads;
    for (int w = 0; w < 3; ++w) {
        threads.emplace_back([&, w] {
            std::mt19937_64 rng(100 + w);
            std::vector<uint64_t> mine;
            for (int i = 0; i < 600; ++i) {
                const int op = int(rng() % 4);
                if (op == 0 || mine.empty()) {
                    auto id = store.add(randomObject(rng, double(rng() % 10000), double(rng() % 10000), 50));
                    if (id.ok()) mine.push_back(*id);
                } else if (op == 1) {
                    std::vector<AnnotationObject> b;
                    for (int k = 0; k < 40; ++k) b.push_back(randomObject(rng, double(rng() % 10000), double(rng() % 10000), 50));
                    auto ids = store.addBatch(b);
                    if (ids.ok()) mine.insert(mine.end(), ids->begin(), ids->end());
                } else if (op == 2) {
                    const size_t k = rng() % mine.size();
                    AnnotationObject o = randomObject(rng, double(rng() % 10000), double(rng() % 10000), 50);
                    o.id = mine[k];
                    if (!store.update(o).ok()) std::abort();
                } else {
                    const size_t k = rng() % mine.size();
                    if (!store.remove(mine[k]).ok()) std::abort();
                    mine.erase(mine.begin() + long(k));
                }
                if (i % 100 == 0) store.setClassColor("c" + std::to_string(w), {uint8_t(i), 0, 0, 255});
            }
            --writersLeft;
        });
    }
    std::atomic<bool> failed{false};
    for (int r = 0; r < 2; ++r) {
        threads.emplace_back([&] {
            uint64_t lastGen = 0;
            while (!stop.load()) {
                auto s = store.snapshot();
                if (s->generation() < lastGen) failed = true;
                lastGen = s->generation();
                size_t n = 0;
                s->forEach([&](const StoredAnnotation& a) {
                    ++n;
                    if (s->find(a.object.id) != &a) failed = true;
                });
                if (n != s->size()) failed = true;
                if (n && s->query(s->bounds()).size() != n) failed = true;
                ++snapshotsChecked;
            }
        });
    }
    while (writersLeft.load() > 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    stop = true;
    for (auto& t : threads) t.join();
    QVERIFY(!failed.load());
    QVERIFY(snapshotsChecked.load() > 0);
    auto s = store.snapshot();
    size_t n = 0;
    s->forEach([&](const StoredAnnotation&) { ++n; });
    QCOMPARE(n, s->size());
}

QTEST_APPLESS_MAIN(TestAnnotationStore)
#include "tst_annotation_store.moc"
