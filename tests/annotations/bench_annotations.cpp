// Measures what docs/ANNOTATIONS.md states: loading 10^6 polygons of 20 vertices from QuPath
// GeoJSON (written here first), one edit of a 10^6-object store, taking a snapshot, queries at
// fit view and at 1:1, the fit-view overview, fill triangulation and hit-testing.
//
//   bench_annotations [objects=1000000] [vertices=20]
//
// Built with -O2 -DNDEBUG whatever the tree's build type (tests/annotations/CMakeLists.txt), so
// that the dev tree gives release figures; not a CTest test (it takes a minute and ~3 GB).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>

#include "iris/annotations.h"

// Unbuffered: a long run shows its figures as they come.
static const int kUnbuffered = std::setvbuf(stdout, nullptr, _IONBF, 0);

using namespace iris;
using Clock = std::chrono::steady_clock;

static double ms(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); }

int main(int argc, char** argv) {
    const size_t n = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 1'000'000;
    const int vertices = argc > 2 ? std::atoi(argv[2]) : 20;
    std::mt19937_64 rng(42);
    // Nuclei-sized detections over a 150000 × 80000 slide, as a detection model returns them.
    AnnotationDocument doc;
    doc.classes = {{"Tumor", {200, 0, 0, 255}, true}, {"Stroma", {0, 150, 0, 255}, true}};
    doc.objects.reserve(n);
    for (size_t i = 0; i < n; ++i) {
        AnnotationObject o;
        o.kind = AnnotationKind::Polygon;
        o.type = AnnotationType::Detection;
        o.className = i % 3 ? "Tumor" : "Stroma";
        const double cx = double(rng() % 150000), cy = double(rng() % 80000);
        PolygonPart p;
        for (int k = 0; k < vertices; ++k) {
            const double a = 2 * M_PI * k / vertices, r = 6 + double(rng() % 400) / 100;
            p.outer.push_back({std::round((cx + r * std::cos(a)) * 100) / 100, std::round((cy + r * std::sin(a)) * 100) / 100});
        }
        o.polygons.push_back(std::move(p));
        o.measurements = {{"Nucleus: Area µm^2", double(rng() % 10000) / 100}, {"Nucleus: Circularity", 0.9}};
        doc.objects.push_back(std::move(o));
    }
    auto t0 = Clock::now();
    const std::string text = writeGeoJson(doc);
    auto t1 = Clock::now();
    const std::string path = (std::filesystem::temp_directory_path() / "iris-annotation-bench.geojson").string();
    std::ofstream(path, std::ios::binary) << text;
    std::printf("objects %zu × %d vertices; GeoJSON %.1f MB, written in %.0f ms\n", n, vertices, text.size() / 1e6, ms(t0, t1));

    t0 = Clock::now();
    auto parsed = readGeoJson(text);
    t1 = Clock::now();
    if (!parsed) {
        std::printf("read failed: %s\n", parsed.error().message().c_str());
        return 1;
    }
    std::printf("readGeoJson (parse + convert, in memory): %.0f ms (%.0f MB/s)\n", ms(t0, t1), text.size() / 1e3 / ms(t0, t1));

    AnnotationStore store;
    t0 = Clock::now();
    Result r = store.replaceAll(std::move(parsed->objects), parsed->classes);
    t1 = Clock::now();
    std::printf("replaceAll (index, one publication): %.0f ms\n", ms(t0, t1));

    AnnotationStore store2;
    t0 = Clock::now();
    AnnotationLoader loader(store2, path, {});
    r = loader.wait();
    t1 = Clock::now();
    std::printf("AnnotationLoader, file to published snapshot: %.0f ms (%s)\n", ms(t0, t1), r.ok() ? "ok" : r.message().c_str());
    std::filesystem::remove(path);

    auto s = store.snapshot();
    std::vector<uint64_t> ids;
    s->forEach([&](const StoredAnnotation& a) { ids.push_back(a.object.id); });
    constexpr int kEdits = 2000;
    t0 = Clock::now();
    for (int i = 0; i < kEdits; ++i) {
        AnnotationObject o = store.snapshot()->find(ids[rng() % ids.size()])->object;
        o.polygons[0].outer[0].x += 1;
        (void)store.update(std::move(o));
    }
    t1 = Clock::now();
    std::printf("update one object of %zu: %.1f us (find + copy + publish)\n", ids.size(), ms(t0, t1) * 1000 / kEdits);
    t0 = Clock::now();
    for (int i = 0; i < kEdits; ++i) (void)store.remove(ids[size_t(i) * 37 % ids.size()]);
    t1 = Clock::now();
    std::printf("remove one object: %.1f us\n", ms(t0, t1) * 1000 / kEdits);
    t0 = Clock::now();
    for (int i = 0; i < kEdits; ++i) (void)store.add(doc.objects[size_t(i)]);
    t1 = Clock::now();
    std::printf("add one object: %.1f us\n", ms(t0, t1) * 1000 / kEdits);
    constexpr int kSnaps = 1'000'000;
    t0 = Clock::now();
    size_t sink = 0;
    for (int i = 0; i < kSnaps; ++i) sink += store.snapshot()->size();
    t1 = Clock::now();
    std::printf("snapshot(): %.0f ns\n", ms(t0, t1) * 1e6 / kSnaps);

    s = store.snapshot();
    t0 = Clock::now();
    auto all = s->query(s->bounds(), true);
    t1 = Clock::now();
    std::printf("query at fit view (all %zu drawn objects): %.1f ms\n", all.size(), ms(t0, t1));
    t0 = Clock::now();
    size_t found = 0;
    for (int i = 0; i < 1000; ++i) {
        const double x = double(rng() % 148000), y = double(rng() % 78800);
        found += s->query(Box2{x, y, x + 2000, y + 1200}, true).size();
    }
    t1 = Clock::now();
    std::printf("query of a 2000×1200 1:1 view: %.1f us, %.0f objects\n", ms(t0, t1), found / 1000.0);
    t0 = Clock::now();
    const auto& ov = s->overview();
    t1 = Clock::now();
    std::printf("overview (first use): %.0f ms, %zu cells of %.0f px\n", ms(t0, t1), ov.cells.size(), ov.cellSize);
    t0 = Clock::now();
    size_t tri = 0;
    for (int i = 0; i < 10000; ++i) tri += (*s->fillTriangles(*all[size_t(i) * 97 % all.size()], 1))->vertices.size() / 3;
    t1 = Clock::now();
    std::printf("fillTriangles, first call (GEOS): %.1f us per %d-vertex polygon (%zu triangles)\n", ms(t0, t1) / 10, vertices,
                tri / 10000);
    t0 = Clock::now();
    int hits = 0;
    for (int i = 0; i < 100000; ++i) hits += s->hitTest({double(rng() % 150000), double(rng() % 80000)}, 4).has_value();
    t1 = Clock::now();
    std::printf("hitTest (tolerance 4 px): %.2f us (%d hits of 100000)\n", ms(t0, t1) / 100, hits);
    return sink == 0 || kUnbuffered != 0;
}
