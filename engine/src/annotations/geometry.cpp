// Pure geometry of annotations: bounds, validation, class colours, level of detail, ellipse
// flattening and the exact hit test (the view model's style: no state, unit-tested alone).
#include <algorithm>
#include <cmath>
#include <numbers>

#include "annotations/annotation_index.h"

namespace iris {

const char* annotationKindName(AnnotationKind k) noexcept {
    switch (k) {
    case AnnotationKind::Point: return "point";
    case AnnotationKind::Polyline: return "polyline";
    case AnnotationKind::Polygon: return "polygon";
    case AnnotationKind::Rectangle: return "rectangle";
    case AnnotationKind::Ellipse: return "ellipse";
    }
    return "?";
}

Box2 annotationBounds(const AnnotationObject& o) noexcept {
    Box2 b;
    switch (o.kind) {
    case AnnotationKind::Point:
    case AnnotationKind::Polyline:
        for (Point2 p : o.points) b.expand(p);
        break;
    case AnnotationKind::Polygon:
        for (const auto& part : o.polygons)
            for (Point2 p : part.outer) b.expand(p); // holes lie inside the outer ring
        break;
    case AnnotationKind::Rectangle:
    case AnnotationKind::Ellipse: b = o.box; break;
    }
    return b;
}

namespace {
bool finite(Point2 p) { return std::isfinite(p.x) && std::isfinite(p.y); }
bool allFinite(const std::vector<Point2>& v) { return std::all_of(v.begin(), v.end(), finite); }
// Slides are under 10^7 pixels a side; past 10^12 sums, areas and ellipse centres would lose
// all precision or overflow, so such coordinates are refused as out of range.
constexpr double kMaxCoordinate = 1e12;
bool inRange(Point2 p) { return std::fabs(p.x) <= kMaxCoordinate && std::fabs(p.y) <= kMaxCoordinate; }
bool allInRange(const std::vector<Point2>& v) { return std::all_of(v.begin(), v.end(), inRange); }
const char* const kOutOfRange = "a coordinate is outside ±1e12";
} // namespace

std::string annotationProblem(const AnnotationObject& o) {
    if (!(o.fillOpacity >= 0 && o.fillOpacity <= 1)) return "fill opacity is not in 0..1";
    if (!(o.lineWidth >= 0) || !std::isfinite(o.lineWidth)) return "line width is negative or not finite";
    switch (o.kind) {
    case AnnotationKind::Point:
        if (o.points.empty()) return "a point annotation without points";
        if (!allFinite(o.points)) return "a coordinate is not finite";
        if (!allInRange(o.points)) return kOutOfRange;
        break;
    case AnnotationKind::Polyline:
        if (o.points.size() < 2) return "a polyline needs at least 2 points";
        if (!allFinite(o.points)) return "a coordinate is not finite";
        if (!allInRange(o.points)) return kOutOfRange;
        break;
    case AnnotationKind::Polygon:
        if (o.polygons.empty()) return "a polygon annotation without polygons";
        for (size_t i = 0; i < o.polygons.size(); ++i) {
            const auto& part = o.polygons[i];
            if (part.outer.size() < 3) return "polygon " + std::to_string(i) + ": the outer ring has fewer than 3 vertices";
            if (!allFinite(part.outer)) return "polygon " + std::to_string(i) + ": a coordinate is not finite";
            if (!allInRange(part.outer)) return "polygon " + std::to_string(i) + ": " + kOutOfRange;
            for (size_t h = 0; h < part.holes.size(); ++h) {
                if (part.holes[h].size() < 3)
                    return "polygon " + std::to_string(i) + ": hole " + std::to_string(h) + " has fewer than 3 vertices";
                if (!allFinite(part.holes[h])) return "polygon " + std::to_string(i) + ": a coordinate is not finite";
                if (!allInRange(part.holes[h])) return "polygon " + std::to_string(i) + ": " + kOutOfRange;
            }
        }
        break;
    case AnnotationKind::Rectangle:
    case AnnotationKind::Ellipse:
        if (!finite({o.box.minX, o.box.minY}) || !finite({o.box.maxX, o.box.maxY})) return "a coordinate is not finite";
        if (!inRange({o.box.minX, o.box.minY}) || !inRange({o.box.maxX, o.box.maxY})) return kOutOfRange;
        if (o.box.empty()) return "the box's minimum exceeds its maximum";
        break;
    }
    return {};
}

Rgba8 defaultClassColor(std::string_view name) noexcept {
    if (name.empty()) return {255, 0, 0, 255}; // QuPath draws unclassified objects red
    // FNV-1a of the name to a hue; full saturation and value: distinct, stable colours.
    uint32_t h = 2166136261u;
    for (char c : name) h = (h ^ uint8_t(c)) * 16777619u;
    const double hue = double(h % 360u) / 60.0;
    const double x = 1 - std::fabs(std::fmod(hue, 2.0) - 1);
    double r = 0, g = 0, b = 0;
    switch (int(hue)) {
    case 0: r = 1, g = x; break;
    case 1: r = x, g = 1; break;
    case 2: g = 1, b = x; break;
    case 3: g = x, b = 1; break;
    case 4: r = x, b = 1; break;
    default: r = 1, b = x; break;
    }
    return {uint8_t(std::lround(r * 255)), uint8_t(std::lround(g * 255)), uint8_t(std::lround(b * 255)), 255};
}

AnnotationLod annotationLod(const Box2& bounds, AnnotationKind kind, bool filled, double downsample,
                            const LodThresholds& t) noexcept {
    if (kind == AnnotationKind::Point || bounds.empty() || !(downsample > 0)) return AnnotationLod::Dot;
    const double px = std::max(bounds.width(), bounds.height()) / downsample;
    if (!(px >= t.dotPixels)) return AnnotationLod::Dot;
    if (filled && kind != AnnotationKind::Polyline) return AnnotationLod::OutlineFill;
    return AnnotationLod::Outline;
}

int ellipseVertexCount(double rx, double ry, double downsample) noexcept {
    const double r = std::max(rx, ry) / (downsample > 0 ? downsample : 1); // screen pixels
    if (!(r > 0.25)) return 8;
    // A chord of angle θ leaves a circle of radius r by r(1 − cos(θ/2)); ≤ 0.25 px.
    const double theta = 2 * std::acos(std::max(-1.0, 1 - 0.25 / r));
    double n = std::ceil(2 * std::numbers::pi / theta);
    n = std::clamp(n, 8.0, 4096.0);
    return int(std::ceil(n / 4) * 4);
}

std::vector<Point2> flattenEllipse(const Box2& box, int vertices) {
    vertices = std::max(4, vertices);
    const double cx = (box.minX + box.maxX) / 2, cy = (box.minY + box.maxY) / 2;
    const double rx = box.width() / 2, ry = box.height() / 2;
    std::vector<Point2> out;
    out.reserve(size_t(vertices));
    for (int i = 0; i < vertices; ++i) {
        // Quarter turns exactly on the axes (sin/cos of π/2 multiples are not exact).
        double c, s;
        if (i * 4 % vertices == 0) {
            const int q = i * 4 / vertices;
            c = q == 0 ? 1 : q == 2 ? -1 : 0;
            s = q == 1 ? 1 : q == 3 ? -1 : 0;
        } else {
            const double a = 2 * std::numbers::pi * i / vertices;
            c = std::cos(a), s = std::sin(a);
        }
        out.push_back({cx + rx * c, cy - ry * s});
    }
    return out;
}

namespace ann {

double distanceToSegment(Point2 p, Point2 a, Point2 b) {
    const double dx = b.x - a.x, dy = b.y - a.y;
    const double len2 = dx * dx + dy * dy;
    double t = len2 > 0 ? ((p.x - a.x) * dx + (p.y - a.y) * dy) / len2 : 0;
    t = std::clamp(t, 0.0, 1.0);
    return std::hypot(p.x - (a.x + t * dx), p.y - (a.y + t * dy));
}

bool insideRing(Point2 p, const std::vector<Point2>& ring) {
    bool in = false;
    for (size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
        const Point2 a = ring[i], b = ring[j];
        if ((a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x) in = !in;
    }
    return in;
}

double ringArea(const std::vector<Point2>& ring) {
    double s = 0;
    for (size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) s += (ring[j].x * ring[i].y - ring[i].x * ring[j].y);
    return s / 2;
}

double partArea(const PolygonPart& part) {
    double a = std::fabs(ringArea(part.outer));
    for (const auto& h : part.holes) a -= std::fabs(ringArea(h));
    return a;
}

namespace {

struct Best {
    std::optional<AnnotationHit> hit;
    void offer(AnnotationHit h) {
        if (!hit || int(h.part) < int(hit->part) || (h.part == hit->part && h.distance < hit->distance)) hit = h;
    }
};

// Vertices and edges of one ring (closed or open) within tol.
void ringHits(Best& best, const StoredAnnotation& a, Point2 p, double tol, const std::vector<Point2>& ring, bool closed,
              int polygon, int ringIndex) {
    for (size_t i = 0; i < ring.size(); ++i) {
        const double d = std::hypot(p.x - ring[i].x, p.y - ring[i].y);
        if (d <= tol) best.offer({&a, AnnotationHit::Part::Vertex, d, polygon, ringIndex, int(i)});
    }
    const size_t edges = closed ? ring.size() : ring.size() - 1;
    for (size_t i = 0; i < edges; ++i) {
        const double d = distanceToSegment(p, ring[i], ring[(i + 1) % ring.size()]);
        if (d <= tol) best.offer({&a, AnnotationHit::Part::Edge, d, polygon, ringIndex, int(i)});
    }
}

} // namespace

std::optional<AnnotationHit> hitObject(const StoredAnnotation& a, Point2 p, double tol) {
    const AnnotationObject& o = a.object;
    Best best;
    switch (o.kind) {
    case AnnotationKind::Point:
        for (size_t i = 0; i < o.points.size(); ++i) {
            const double d = std::hypot(p.x - o.points[i].x, p.y - o.points[i].y);
            if (d <= tol) best.offer({&a, AnnotationHit::Part::Vertex, d, -1, 0, int(i)});
        }
        break;
    case AnnotationKind::Polyline: ringHits(best, a, p, tol, o.points, false, -1, 0); break;
    case AnnotationKind::Polygon:
        for (size_t k = 0; k < o.polygons.size(); ++k) {
            const auto& part = o.polygons[k];
            ringHits(best, a, p, tol, part.outer, true, int(k), 0);
            for (size_t h = 0; h < part.holes.size(); ++h) ringHits(best, a, p, tol, part.holes[h], true, int(k), int(h) + 1);
            if (!best.hit && insideRing(p, part.outer) &&
                std::none_of(part.holes.begin(), part.holes.end(), [&](const auto& h) { return insideRing(p, h); }))
                best.offer({&a, AnnotationHit::Part::Inside, 0, int(k), 0, -1});
        }
        break;
    case AnnotationKind::Rectangle: {
        const Box2& b = o.box;
        ringHits(best, a, p, tol, {{b.minX, b.minY}, {b.maxX, b.minY}, {b.maxX, b.maxY}, {b.minX, b.maxY}}, true, -1, 0);
        if (!best.hit && p.x >= b.minX && p.x <= b.maxX && p.y >= b.minY && p.y <= b.maxY)
            best.offer({&a, AnnotationHit::Part::Inside, 0, -1, 0, -1});
        break;
    }
    case AnnotationKind::Ellipse: {
        const Box2& b = o.box;
        const double rx = b.width() / 2, ry = b.height() / 2, cx = b.minX + rx, cy = b.minY + ry;
        // The four extreme points are its vertices (handles); the outline, finely flattened.
        const auto ring = flattenEllipse(b, std::max(64, ellipseVertexCount(rx, ry, std::max(tol, 1e-3) / 4)));
        for (size_t i = 0; i < 4; ++i) {
            const Point2 v = ring[i * ring.size() / 4];
            const double d = std::hypot(p.x - v.x, p.y - v.y);
            if (d <= tol) best.offer({&a, AnnotationHit::Part::Vertex, d, -1, 0, int(i)});
        }
        for (size_t i = 0; i < ring.size(); ++i) {
            const double d = distanceToSegment(p, ring[i], ring[(i + 1) % ring.size()]);
            if (d <= tol) best.offer({&a, AnnotationHit::Part::Edge, d, -1, 0, -1});
        }
        const double ex = rx > 0 ? (p.x - cx) / rx : 0, ey = ry > 0 ? (p.y - cy) / ry : 0;
        if (!best.hit && rx > 0 && ry > 0 && ex * ex + ey * ey <= 1) best.offer({&a, AnnotationHit::Part::Inside, 0, -1, 0, -1});
        break;
    }
    }
    return best.hit;
}

bool boxIntersectsConvex(const Box2& b, std::span<const Point2> c) {
    if (b.empty() || c.size() < 3) return false;
    // Axes of the box.
    double minX = c[0].x, maxX = c[0].x, minY = c[0].y, maxY = c[0].y;
    for (Point2 p : c) minX = std::min(minX, p.x), maxX = std::max(maxX, p.x), minY = std::min(minY, p.y), maxY = std::max(maxY, p.y);
    if (maxX < b.minX || minX > b.maxX || maxY < b.minY || minY > b.maxY) return false;
    // The polygon's edge normals.
    const Point2 corners[4] = {{b.minX, b.minY}, {b.maxX, b.minY}, {b.maxX, b.maxY}, {b.minX, b.maxY}};
    for (size_t i = 0; i < c.size(); ++i) {
        const Point2 e0 = c[i], e1 = c[(i + 1) % c.size()];
        const double nx = -(e1.y - e0.y), ny = e1.x - e0.x;
        if (nx == 0 && ny == 0) continue;
        double pMin = INFINITY, pMax = -INFINITY;
        for (Point2 q : c) {
            const double d = q.x * nx + q.y * ny;
            pMin = std::min(pMin, d), pMax = std::max(pMax, d);
        }
        double bMin = INFINITY, bMax = -INFINITY;
        for (Point2 q : corners) {
            const double d = q.x * nx + q.y * ny;
            bMin = std::min(bMin, d), bMax = std::max(bMax, d);
        }
        if (bMax < pMin || bMin > pMax) return false;
    }
    return true;
}

} // namespace ann
} // namespace iris
