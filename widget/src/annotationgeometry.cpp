#include "annotationgeometry_p.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include <geos_c.h>

namespace IrisWidget {

using iris::AnnotationKind;
using iris::AnnotationObject;
using iris::Box2;
using iris::Point2;

Box2 boxFromDrag(Point2 a, Point2 b, bool square)
{
    if (square) {
        const double side = std::max(std::abs(b.x - a.x), std::abs(b.y - a.y));
        b.x = a.x + (b.x < a.x ? -side : side);
        b.y = a.y + (b.y < a.y ? -side : side);
    }
    return {std::min(a.x, b.x), std::min(a.y, b.y), std::max(a.x, b.x), std::max(a.y, b.y)};
}

AnnotationObject translated(AnnotationObject o, double dx, double dy)
{
    const auto move = [&](Point2 &p) { p.x += dx, p.y += dy; };
    for (Point2 &p : o.points)
        move(p);
    for (iris::PolygonPart &part : o.polygons) {
        for (Point2 &p : part.outer)
            move(p);
        for (auto &hole : part.holes)
            for (Point2 &p : hole)
                move(p);
    }
    if (!o.box.empty())
        o.box = {o.box.minX + dx, o.box.minY + dy, o.box.maxX + dx, o.box.maxY + dy};
    return o;
}

std::vector<VertexHandle> vertexHandles(const AnnotationObject &o)
{
    std::vector<VertexHandle> handles;
    switch (o.kind) {
    case AnnotationKind::Point:
    case AnnotationKind::Polyline:
        for (int i = 0; i < int(o.points.size()); ++i)
            handles.push_back({o.points[size_t(i)], -1, 0, i});
        break;
    case AnnotationKind::Polygon:
        for (int p = 0; p < int(o.polygons.size()); ++p) {
            const iris::PolygonPart &part = o.polygons[size_t(p)];
            for (int i = 0; i < int(part.outer.size()); ++i)
                handles.push_back({part.outer[size_t(i)], p, 0, i});
            for (int h = 0; h < int(part.holes.size()); ++h)
                for (int i = 0; i < int(part.holes[size_t(h)].size()); ++i)
                    handles.push_back({part.holes[size_t(h)][size_t(i)], p, h + 1, i});
        }
        break;
    case AnnotationKind::Rectangle: {
        const Box2 &b = o.box;
        handles = {{{b.minX, b.minY}, -1, 0, 0}, {{b.maxX, b.minY}, -1, 0, 1}, {{b.maxX, b.maxY}, -1, 0, 2},
            {{b.minX, b.maxY}, -1, 0, 3}};
        break;
    }
    case AnnotationKind::Ellipse: {
        const Box2 &b = o.box;
        const double cx = (b.minX + b.maxX) / 2, cy = (b.minY + b.maxY) / 2;
        handles
            = {{{b.maxX, cy}, -1, 0, 0}, {{cx, b.maxY}, -1, 0, 1}, {{b.minX, cy}, -1, 0, 2}, {{cx, b.minY}, -1, 0, 3}};
        break;
    }
    }
    return handles;
}

AnnotationObject withHandleMoved(AnnotationObject o, const VertexHandle &h, Point2 to)
{
    switch (o.kind) {
    case AnnotationKind::Point:
    case AnnotationKind::Polyline:
        if (h.vertex >= 0 && h.vertex < int(o.points.size()))
            o.points[size_t(h.vertex)] = to;
        break;
    case AnnotationKind::Polygon: {
        if (h.polygon < 0 || h.polygon >= int(o.polygons.size()))
            break;
        iris::PolygonPart &part = o.polygons[size_t(h.polygon)];
        std::vector<Point2> *ring = h.ring == 0
            ? &part.outer
            : (h.ring >= 1 && h.ring <= int(part.holes.size()) ? &part.holes[size_t(h.ring - 1)] : nullptr);
        if (ring && h.vertex >= 0 && h.vertex < int(ring->size()))
            (*ring)[size_t(h.vertex)] = to;
        break;
    }
    case AnnotationKind::Rectangle: {
        Box2 b = o.box;
        const bool left = h.vertex == 0 || h.vertex == 3, top = h.vertex == 0 || h.vertex == 1;
        (left ? b.minX : b.maxX) = to.x;
        (top ? b.minY : b.maxY) = to.y;
        o.box
            = {std::min(b.minX, b.maxX), std::min(b.minY, b.maxY), std::max(b.minX, b.maxX), std::max(b.minY, b.maxY)};
        break;
    }
    case AnnotationKind::Ellipse: {
        Box2 b = o.box;
        switch (h.vertex) {
        case 0:
            b.maxX = to.x;
            break;
        case 1:
            b.maxY = to.y;
            break;
        case 2:
            b.minX = to.x;
            break;
        case 3:
            b.minY = to.y;
            break;
        default:
            break;
        }
        o.box
            = {std::min(b.minX, b.maxX), std::min(b.minY, b.maxY), std::max(b.minX, b.maxX), std::max(b.minY, b.maxY)};
        break;
    }
    }
    return o;
}

namespace {
double distance(Point2 a, Point2 b)
{
    return std::hypot(a.x - b.x, a.y - b.y);
}
} // namespace

void appendThinned(std::vector<Point2> &path, Point2 p, double minDistance)
{
    if (path.empty() || distance(path.back(), p) >= minDistance)
        path.push_back(p);
}

std::vector<Point2> withoutRepeats(const std::vector<Point2> &ring, double minDistance)
{
    std::vector<Point2> out;
    for (const Point2 &p : ring)
        if (out.empty() || distance(out.back(), p) >= minDistance)
            out.push_back(p);
    while (out.size() > 1 && distance(out.back(), out.front()) < minDistance)
        out.pop_back();
    return out;
}

// --- brush -----------------------------------------------------------------------------------

namespace {

// One GEOS context for the call (reentrant API; the engine uses its own per thread).
struct GeosContext
{
    GEOSContextHandle_t handle = GEOS_init_r();
    ~GeosContext() { GEOS_finish_r(handle); }
    GeosContext() = default;
    GeosContext(const GeosContext &) = delete;
    GeosContext &operator=(const GeosContext &) = delete;
};

std::vector<Point2> ringPoints(GEOSContextHandle_t ctx, const GEOSGeometry *ring)
{
    std::vector<Point2> out;
    const GEOSCoordSequence *seq = GEOSGeom_getCoordSeq_r(ctx, ring);
    unsigned int n = 0;
    if (!seq || !GEOSCoordSeq_getSize_r(ctx, seq, &n))
        return out;
    out.reserve(n);
    for (unsigned int i = 0; i < n; ++i) {
        double x = 0, y = 0;
        if (GEOSCoordSeq_getXY_r(ctx, seq, i, &x, &y))
            out.push_back({x, y});
    }
    if (out.size() > 1 && out.front() == out.back())
        out.pop_back(); // stored open
    return out;
}

void appendPolygon(GEOSContextHandle_t ctx, const GEOSGeometry *polygon, std::vector<iris::PolygonPart> &parts)
{
    iris::PolygonPart part;
    part.outer = ringPoints(ctx, GEOSGetExteriorRing_r(ctx, polygon));
    if (part.outer.size() < 3)
        return;
    const int holes = GEOSGetNumInteriorRings_r(ctx, polygon);
    for (int i = 0; i < holes; ++i) {
        std::vector<Point2> hole = ringPoints(ctx, GEOSGetInteriorRingN_r(ctx, polygon, i));
        if (hole.size() >= 3)
            part.holes.push_back(std::move(hole));
    }
    parts.push_back(std::move(part));
}

} // namespace

std::vector<iris::PolygonPart> brushOutline(const std::vector<Point2> &path, double radius, std::string *error)
{
    std::vector<iris::PolygonPart> parts;
    const auto fail = [&](const char *why) {
        if (error)
            *error = why;
        return std::vector<iris::PolygonPart>{};
    };
    if (path.empty() || !(radius > 0))
        return fail("no path to paint");
    GeosContext context;
    GEOSContextHandle_t ctx = context.handle;
    if (!ctx)
        return fail("GEOS could not start");
    GEOSCoordSequence *seq = GEOSCoordSeq_create_r(ctx, unsigned(path.size()), 2);
    if (!seq)
        return fail("GEOS could not make a coordinate sequence");
    for (unsigned i = 0; i < path.size(); ++i)
        GEOSCoordSeq_setXY_r(ctx, seq, i, path[i].x, path[i].y);
    // A line of one point is not a line: a single stamp is the buffer of the point.
    GEOSGeometry *line = path.size() == 1 ? GEOSGeom_createPoint_r(ctx, seq) : GEOSGeom_createLineString_r(ctx, seq);
    if (!line)
        return fail("GEOS could not make the brush path");
    GEOSGeometry *area = GEOSBuffer_r(ctx, line, radius, 8);
    GEOSGeom_destroy_r(ctx, line);
    if (!area)
        return fail("GEOS could not buffer the brush path");
    const int type = GEOSGeomTypeId_r(ctx, area);
    if (type == GEOS_POLYGON) {
        appendPolygon(ctx, area, parts);
    } else if (type == GEOS_MULTIPOLYGON) {
        const int n = GEOSGetNumGeometries_r(ctx, area);
        for (int i = 0; i < n; ++i)
            appendPolygon(ctx, GEOSGetGeometryN_r(ctx, area, i), parts);
    }
    GEOSGeom_destroy_r(ctx, area);
    if (parts.empty())
        return fail("the brush painted nothing");
    return parts;
}

// --- readouts ----------------------------------------------------------------------------------

namespace {

double ringLength(const std::vector<Point2> &ring, bool closed, double sx, double sy)
{
    double sum = 0;
    for (size_t i = 1; i < ring.size(); ++i)
        sum += std::hypot((ring[i].x - ring[i - 1].x) * sx, (ring[i].y - ring[i - 1].y) * sy);
    if (closed && ring.size() > 2)
        sum += std::hypot((ring.front().x - ring.back().x) * sx, (ring.front().y - ring.back().y) * sy);
    return sum;
}

double ringArea(const std::vector<Point2> &ring)
{
    double twice = 0;
    for (size_t i = 0, n = ring.size(); i < n; ++i) {
        const Point2 &a = ring[i];
        const Point2 &b = ring[(i + 1) % n];
        twice += a.x * b.y - b.x * a.y;
    }
    return std::abs(twice) / 2;
}

std::string number(double v)
{
    char buffer[64];
    const int decimals = v >= 100 ? 0 : v >= 10 ? 1 : v >= 1 ? 2 : 3;
    std::snprintf(buffer, sizeof buffer, "%.*f", decimals, v);
    return buffer;
}

std::string lengthText(double v, bool physical)
{
    if (!physical)
        return number(v) + " px";
    return v >= 1000 ? number(v / 1000) + " mm" : number(v) + " \u00b5m";
}

std::string areaText(double v, bool physical)
{
    if (!physical)
        return number(v) + " px\u00b2";
    return v >= 1e6 ? number(v / 1e6) + " mm\u00b2" : number(v) + " \u00b5m\u00b2";
}

} // namespace

Measurement measure(const AnnotationObject &o, double mppX, double mppY)
{
    Measurement m;
    m.physical = mppX > 0 && mppY > 0;
    const double sx = m.physical ? mppX : 1, sy = m.physical ? mppY : 1;
    switch (o.kind) {
    case AnnotationKind::Point:
        m.points = int(o.points.size());
        break;
    case AnnotationKind::Polyline:
        m.length = ringLength(o.points, false, sx, sy);
        break;
    case AnnotationKind::Polygon:
        m.closed = true;
        for (const iris::PolygonPart &part : o.polygons) {
            m.length += ringLength(part.outer, true, sx, sy);
            m.area += ringArea(part.outer);
            for (const auto &hole : part.holes) {
                m.length += ringLength(hole, true, sx, sy);
                m.area -= ringArea(hole);
            }
        }
        m.area *= sx * sy;
        break;
    case AnnotationKind::Rectangle:
        m.closed = true;
        m.length = 2 * (o.box.width() * sx + o.box.height() * sy);
        m.area = o.box.width() * sx * o.box.height() * sy;
        break;
    case AnnotationKind::Ellipse: {
        m.closed = true;
        const double a = o.box.width() * sx / 2, b = o.box.height() * sy / 2;
        // Ramanujan's second approximation: exact for circles, within 1e-4 relative of any ellipse.
        const double h = (a + b) > 0 ? ((a - b) * (a - b)) / ((a + b) * (a + b)) : 0;
        m.length = std::numbers::pi * (a + b) * (1 + 3 * h / (10 + std::sqrt(4 - 3 * h)));
        m.area = std::numbers::pi * a * b;
        break;
    }
    }
    return m;
}

std::string measurementText(const AnnotationObject &o, double mppX, double mppY)
{
    const Measurement m = measure(o, mppX, mppY);
    if (o.kind == AnnotationKind::Point)
        return std::to_string(m.points) + (m.points == 1 ? " point" : " points");
    if (!m.closed)
        return "length " + lengthText(m.length, m.physical);
    return "perimeter " + lengthText(m.length, m.physical) + ", area " + areaText(m.area, m.physical);
}

} // namespace IrisWidget
