// Fill triangulation with GEOS's constrained Delaunay triangulator (GEOS ≥ 3.10; Debian 12 has
// 3.11): it honours holes and concave outlines. The reentrant C API with one context per thread,
// whose error handler keeps the last message, so that failures say what GEOS said.
#include <geos_c.h>

#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <memory>

#include "annotations/annotation_index.h"

namespace iris::ann {
namespace {

struct Context {
    GEOSContextHandle_t h = GEOS_init_r();
    std::string lastError;
    Context() {
        GEOSContext_setErrorMessageHandler_r(
            h,
            [](const char* fmt, void* user) {
                // GEOS passes the whole message as fmt with no further arguments in 3.11.
                static_cast<Context*>(user)->lastError = fmt ? fmt : "";
            },
            this);
    }
    ~Context() { GEOS_finish_r(h); }
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;
};
Context& context() {
    thread_local Context c;
    return c;
}

struct GeomDeleter {
    GEOSContextHandle_t h;
    void operator()(GEOSGeometry* g) const {
        if (g) GEOSGeom_destroy_r(h, g);
    }
};
using Geom = std::unique_ptr<GEOSGeometry, GeomDeleter>;

// A closed GEOS ring from an open one.
GEOSGeometry* makeRing(GEOSContextHandle_t h, const std::vector<Point2>& ring) {
    GEOSCoordSequence* seq = GEOSCoordSeq_create_r(h, unsigned(ring.size() + 1), 2);
    if (!seq) return nullptr;
    for (size_t i = 0; i <= ring.size(); ++i) {
        const Point2 p = ring[i % ring.size()];
        GEOSCoordSeq_setXY_r(h, seq, unsigned(i), p.x, p.y);
    }
    return GEOSGeom_createLinearRing_r(h, seq); // takes seq, also on failure
}

Geom makePolygon(GEOSContextHandle_t h, const PolygonPart& part) {
    GEOSGeometry* shell = makeRing(h, part.outer);
    if (!shell) return Geom(nullptr, {h});
    std::vector<GEOSGeometry*> holes;
    for (const auto& r : part.holes) {
        GEOSGeometry* g = makeRing(h, r);
        if (!g) {
            GEOSGeom_destroy_r(h, shell);
            for (auto* x : holes) GEOSGeom_destroy_r(h, x);
            return Geom(nullptr, {h});
        }
        holes.push_back(g);
    }
    return Geom(GEOSGeom_createPolygon_r(h, shell, holes.data(), unsigned(holes.size())), {h});
}

// Appends the triangles of a polygonal geometry's constrained Delaunay triangulation.
bool appendTriangles(GEOSContextHandle_t h, const GEOSGeometry* polygonal, std::vector<Point2>& out) {
    Geom tri(GEOSConstrainedDelaunayTriangulation_r(h, polygonal), {h});
    if (!tri) return false;
    const int n = GEOSGetNumGeometries_r(h, tri.get());
    for (int i = 0; i < n; ++i) {
        const GEOSGeometry* t = GEOSGetGeometryN_r(h, tri.get(), i);
        const GEOSGeometry* ring = GEOSGetExteriorRing_r(h, t);
        const GEOSCoordSequence* seq = ring ? GEOSGeom_getCoordSeq_r(h, ring) : nullptr;
        unsigned size = 0;
        if (!seq || !GEOSCoordSeq_getSize_r(h, seq, &size) || size < 3) return false;
        for (unsigned k = 0; k < 3; ++k) {
            Point2 p;
            GEOSCoordSeq_getXY_r(h, seq, k, &p.x, &p.y);
            out.push_back(p);
        }
    }
    return true;
}

// Whether every vertex lies on the line through the first two distinct ones (exactly).
bool collinear(const std::vector<Point2>& ring) {
    size_t k = 1;
    while (k < ring.size() && ring[k] == ring[0]) ++k;
    if (k == ring.size()) return true;
    const double dx = ring[k].x - ring[0].x, dy = ring[k].y - ring[0].y;
    for (Point2 p : ring)
        if ((p.x - ring[0].x) * dy - (p.y - ring[0].y) * dx != 0) return false;
    return true;
}

} // namespace

Expected<AnnotationTriangles> triangulatePolygon(const std::vector<PolygonPart>& parts) {
    Context& ctx = context();
    const GEOSContextHandle_t h = ctx.h;
    AnnotationTriangles out;
    for (size_t k = 0; k < parts.size(); ++k) {
        const PolygonPart& part = parts[k];
        const std::string where = parts.size() > 1 ? "polygon " + std::to_string(k) + ": " : "";
        // The store refuses these; a StoredAnnotation made by hand might not have been checked.
        for (const auto* ring : [&] {
                 std::vector<const std::vector<Point2>*> v{&part.outer};
                 for (const auto& r : part.holes) v.push_back(&r);
                 return v;
             }()) {
            if (ring->size() < 3) return Result(Status::InvalidArgument, where + "a ring has fewer than 3 vertices");
            for (Point2 p : *ring)
                if (!std::isfinite(p.x) || !std::isfinite(p.y)) return Result(Status::InvalidArgument, where + "a coordinate is not finite");
        }
        // All on one line: no area to fill (a bow-tie's signed area is 0 too, but it has area).
        if (collinear(part.outer)) return Result(Status::InvalidArgument, where + "the outer ring has zero area");
        ctx.lastError.clear();
        Geom poly = makePolygon(h, part);
        if (!poly) return Result(Status::InvalidArgument, where + "GEOS refused the polygon: " + ctx.lastError);
        if (GEOSisValid_r(h, poly.get()) != 1) {
            // The documented fallback: repair (GEOS's MakeValid keeps every area the rings
            // enclose, splitting a bow-tie into its two loops) and fill what it gives.
            char* reason = GEOSisValidReason_r(h, poly.get());
            std::string why = reason ? reason : "invalid";
            if (reason) GEOSFree_r(h, reason);
            Geom valid(GEOSMakeValid_r(h, poly.get()), {h});
            if (!valid) return Result(Status::InvalidArgument, where + "invalid polygon (" + why + ") that GEOS cannot repair: " + ctx.lastError);
            // MakeValid may return a collection with lines and points: only polygons are filled.
            double area = 0;
            GEOSArea_r(h, valid.get(), &area);
            if (!(area > 0)) return Result(Status::InvalidArgument, where + "invalid polygon (" + why + ") with no area left after repair");
            const int n = GEOSGetNumGeometries_r(h, valid.get());
            for (int i = 0; i < n; ++i) {
                const GEOSGeometry* g = GEOSGetGeometryN_r(h, valid.get(), i);
                const int type = GEOSGeomTypeId_r(h, g);
                if (type != GEOS_POLYGON && type != GEOS_MULTIPOLYGON) continue;
                if (!appendTriangles(h, g, out.vertices))
                    return Result(Status::InvalidArgument, where + "GEOS could not triangulate the repaired polygon: " + ctx.lastError);
            }
            if (!out.note.empty()) out.note += "; ";
            out.note += where + "repaired with GEOSMakeValid: " + why;
            continue;
        }
        if (!appendTriangles(h, poly.get(), out.vertices))
            return Result(Status::InvalidArgument, where + "GEOS could not triangulate the polygon: " + ctx.lastError);
    }
    if (out.vertices.empty()) return Result(Status::InvalidArgument, "the polygon gives no triangles");
    return out;
}

} // namespace iris::ann
