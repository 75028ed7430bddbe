// Not API: the store's persistent structure, shared by store.cpp, queries.cpp and the tests.
//
// A snapshot is a directory of chunks and a directory of id buckets, each entry a shared_ptr to
// an immutable piece. A writer copies the two directories (pointers only) and replaces the one
// chunk and the one bucket an edit touches; every other piece is shared with the snapshot
// before. Each chunk carries its own Boost.Geometry R-tree over its ≤ kAnnotationChunk objects,
// so an edit rebuilds one small tree; a batch of new objects is sorted along a Morton curve
// before it is cut into chunks, so that chunks cover compact areas and a query skips most of
// them by their bounds alone.
#pragma once

#include <atomic>

// Boost 1.74's R-tree includes <boost/detail/no_exceptions_support.hpp>, which prints a
// deprecation #pragma message in every file that includes it; nothing here can change that.
#ifndef BOOST_ALLOW_DEPRECATED_HEADERS
#define BOOST_ALLOW_DEPRECATED_HEADERS
#endif
#include <boost/geometry.hpp>
#include <boost/geometry/index/rtree.hpp>

#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "iris/annotations.h"

namespace iris {

// Cached fill of a Polygon (AnnotationSnapshot::fillTriangles): computed once, under `once`.
struct AnnotationFillCache {
    std::once_flag once;
    std::optional<Expected<std::shared_ptr<const AnnotationTriangles>>> result;
    // Set (release) once `result` is written: the render pass asks, without waiting, whether a
    // fill is ready or would cost a triangulation (render/annotation_geometry.cpp).
    std::atomic<bool> ready{false};
};
// Whether fillTriangles(a) would return at once: not a polygon, or its triangulation is cached.
inline bool fillReady(const StoredAnnotation& a) {
    return !a.fillCache || a.fillCache->ready.load(std::memory_order_acquire);
}

namespace ann {

constexpr size_t kChunk = 512;    // objects a chunk: the copy and the tree rebuilt per edit
// Id buckets: an edit copies the directory (kBuckets pointers) and one bucket (≈ n / kBuckets
// 16-byte entries); 1024 balances the two at 10^6 objects.
constexpr size_t kBuckets = 1024;

namespace bg = boost::geometry;
namespace bgi = boost::geometry::index;
using BPoint = bg::model::point<double, 2, bg::cs::cartesian>;
using BBox = bg::model::box<BPoint>;
using RValue = std::pair<BBox, uint32_t>; // bounds, index into Chunk::entries
using RTree = bgi::rtree<RValue, bgi::rstar<16>>;

inline BBox toBBox(const Box2& b) { return BBox(BPoint(b.minX, b.minY), BPoint(b.maxX, b.maxY)); }

using Entry = std::shared_ptr<const StoredAnnotation>;

struct Chunk {
    std::vector<Entry> entries;
    Box2 bounds;
    RTree tree; // over entries (packed bulk load)
};
// Builds bounds and tree over `entries`.
std::shared_ptr<const Chunk> makeChunk(std::vector<Entry> entries);

struct IdBucket {
    std::vector<std::pair<uint64_t, uint32_t>> ids; // id → chunk index, sorted by id
};
inline size_t bucketOf(uint64_t id) { return size_t((id * 0x9E3779B97F4A7C15ull) >> 54) % kBuckets; } // Fibonacci hashing

using ClassTable = std::map<std::string, AnnotationClass, std::less<>>;

} // namespace ann

struct AnnotationSnapshot::Impl {
    uint64_t generation = 0;
    size_t count = 0;
    Box2 bounds;
    std::vector<std::shared_ptr<const ann::Chunk>> chunks;
    std::vector<std::shared_ptr<const ann::IdBucket>> buckets; // kBuckets, null = empty
    std::shared_ptr<const ann::ClassTable> classes;
    mutable std::once_flag overviewOnce;
    mutable AnnotationOverview overview;
};

namespace ann {
// Geometry helpers (geometry.cpp).
double distanceToSegment(Point2 p, Point2 a, Point2 b);
bool insideRing(Point2 p, const std::vector<Point2>& ring); // even-odd
double ringArea(const std::vector<Point2>& ring);            // signed (shoelace)
double partArea(const PolygonPart& part);                    // |outer| − Σ|holes|
// The object's exact hit at p within tol, or none (AnnotationSnapshot::hitTest's rules).
std::optional<AnnotationHit> hitObject(const StoredAnnotation& a, Point2 p, double tol);
// Whether box b and convex polygon c (≥ 3 vertices) overlap (separating axes).
bool boxIntersectsConvex(const Box2& b, std::span<const Point2> c);
// GEOS triangulation of a polygon part (triangulate.cpp).
Expected<AnnotationTriangles> triangulatePolygon(const std::vector<PolygonPart>& parts);
} // namespace ann

} // namespace iris
