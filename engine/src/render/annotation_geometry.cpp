#include "render/annotation_geometry.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>

#include "annotations/annotation_index.h"

namespace iris::render {

void AnnotationGeometry::clear() {
    fills.clear();
    strokes.clear();
    objects = dots = 0;
    overview = false;
    complete = true;
    errors.clear();
}

namespace {

using Clock = std::chrono::steady_clock;
constexpr uint32_t kHandleDark = 0xFF202020u;  // packRgba of (32, 32, 32, 255)
constexpr uint32_t kHandleLight = 0xFFFFFFFFu; // white

class Builder {
public:
    Builder(const AnnotationSnapshot& snap, const Viewport& vp, AnnotationGeometry& out)
        : snap_(snap), t_(ViewTransform::of(vp.view, vp.width, vp.height)), w_(double(vp.width)),
          h_(double(vp.height)), ds_(vp.view.downsample), out_(out) {}

    double downsample() const { return ds_; }

    std::array<float, 2> map(Point2 p) const {
        const auto q = t_.toTarget(p.x, p.y);
        return {float(q[0]), float(q[1])};
    }

    // Whether a shape within `reach` pixels of the box a–b can touch the target.
    bool onTarget(std::array<float, 2> a, std::array<float, 2> b, double reach) const {
        return std::max(a[0], b[0]) >= -reach && std::min(a[0], b[0]) <= w_ + reach && std::max(a[1], b[1]) >= -reach &&
               std::min(a[1], b[1]) <= h_ + reach;
    }

    void capsule(std::array<float, 2> a, std::array<float, 2> b, float half, uint32_t colour) {
        if (!onTarget(a, b, std::abs(half) + 1)) return;
        out_.strokes.push_back({{a[0], a[1]}, {b[0], b[1]}, half, colour});
    }
    void dot(Point2 c, float radius, uint32_t colour) {
        const auto p = map(c);
        capsule(p, p, radius, colour);
    }
    void handle(Point2 c) {
        const auto p = map(c);
        capsule(p, p, -kAnnotationHandleHalf, kHandleDark);
        capsule(p, p, -(kAnnotationHandleHalf - 1.5f), kHandleLight);
    }

    // A ring (closed) or a line (open) as capsules. A vertex within half a pixel of the last
    // one drawn is merged into it (a 10^5-vertex outline zoomed out is a few hundred segments);
    // the last vertex of an open line is always drawn.
    void line(const std::vector<Point2>& pts, bool closed, float half, uint32_t colour) {
        if (pts.empty()) return;
        const auto first = map(pts[0]);
        auto prev = first;
        bool drew = false;
        for (size_t i = 1; i < pts.size(); ++i) {
            const auto q = map(pts[i]);
            const float dx = q[0] - prev[0], dy = q[1] - prev[1];
            if (dx * dx + dy * dy < 0.25f && (closed || i + 1 < pts.size())) continue;
            capsule(prev, q, half, colour);
            prev = q;
            drew = true;
        }
        if (closed && pts.size() > 2) {
            capsule(prev, first, half, colour);
            drew = true;
        }
        if (!drew) capsule(first, first, half, colour);
    }

    void fill(const AnnotationTriangles& t, uint32_t colour) {
        const size_t n = t.vertices.size() / 3 * 3;
        for (size_t i = 0; i < n; i += 3) {
            const auto a = map(t.vertices[i]), b = map(t.vertices[i + 1]), c = map(t.vertices[i + 2]);
            const float minX = std::min({a[0], b[0], c[0]}), maxX = std::max({a[0], b[0], c[0]});
            const float minY = std::min({a[1], b[1], c[1]}), maxY = std::max({a[1], b[1], c[1]});
            if (maxX < 0 || minX > w_ || maxY < 0 || minY > h_) continue;
            out_.fills.push_back({{a[0], a[1]}, colour});
            out_.fills.push_back({{b[0], b[1]}, colour});
            out_.fills.push_back({{c[0], c[1]}, colour});
        }
    }

    // Every outline of an object: a polygon's rings, a rectangle's or an ellipse's boundary, a
    // polyline.
    template <class Fn>
    void forEachOutline(const AnnotationObject& o, Fn&& fn) const {
        switch (o.kind) {
        case AnnotationKind::Polygon:
            for (const PolygonPart& part : o.polygons) {
                fn(part.outer, true);
                for (const auto& hole : part.holes) fn(hole, true);
            }
            break;
        case AnnotationKind::Rectangle: {
            const Box2& b = o.box;
            fn(std::vector<Point2>{{b.minX, b.minY}, {b.maxX, b.minY}, {b.maxX, b.maxY}, {b.minX, b.maxY}}, true);
            break;
        }
        case AnnotationKind::Ellipse: {
            const double rx = o.box.width() / 2, ry = o.box.height() / 2;
            fn(flattenEllipse(o.box, ellipseVertexCount(rx, ry, ds_)), true);
            break;
        }
        case AnnotationKind::Polyline: fn(o.points, false); break;
        case AnnotationKind::Point: break;
        }
    }

private:
    const AnnotationSnapshot& snap_;
    ViewTransform t_;
    double w_, h_, ds_;
    AnnotationGeometry& out_;
};

uint32_t withOpacity(Rgba8 c, float opacity) {
    c.a = uint8_t(std::lround(std::clamp(double(c.a) * double(opacity), 0.0, 255.0)));
    return packRgba(c);
}

// The handles of the selected object: its vertices (a rectangle's corners, an ellipse's four
// extremes), at most `limit`.
std::vector<Point2> handlePoints(const AnnotationObject& o, size_t limit) {
    std::vector<Point2> pts;
    const auto add = [&](const std::vector<Point2>& v) {
        for (const Point2& p : v) {
            if (pts.size() >= limit) return;
            pts.push_back(p);
        }
    };
    switch (o.kind) {
    case AnnotationKind::Polygon:
        for (const PolygonPart& part : o.polygons) {
            add(part.outer);
            for (const auto& hole : part.holes) add(hole);
        }
        break;
    case AnnotationKind::Rectangle:
        add({{o.box.minX, o.box.minY}, {o.box.maxX, o.box.minY}, {o.box.maxX, o.box.maxY}, {o.box.minX, o.box.maxY}});
        break;
    case AnnotationKind::Ellipse: {
        const double cx = (o.box.minX + o.box.maxX) / 2, cy = (o.box.minY + o.box.maxY) / 2;
        add({{o.box.maxX, cy}, {cx, o.box.minY}, {o.box.minX, cy}, {cx, o.box.maxY}});
        break;
    }
    case AnnotationKind::Point:
    case AnnotationKind::Polyline: add(o.points); break;
    }
    return pts;
}

} // namespace

void buildAnnotationGeometry(const AnnotationSnapshot& snap, const Viewport& vp, uint64_t selected,
                             const AnnotationBudget& budget, AnnotationGeometry& out) {
    out.clear();
    if (snap.size() == 0 || vp.width == 0 || vp.height == 0 || !(vp.view.downsample > 0)) return;
    Builder b(snap, vp, out);
    const ViewTransform t = ViewTransform::of(vp.view, vp.width, vp.height);
    const double ds = vp.view.downsample;

    // The footprint: the target grown by the margin, in level-0 pixels.
    const double m = kAnnotationMarginPx;
    std::array<Point2, 4> quad;
    const double corners[4][2] = {{-m, -m}, {vp.width + m, -m}, {vp.width + m, vp.height + m}, {-m, vp.height + m}};
    Box2 field;
    for (int i = 0; i < 4; ++i) {
        const auto s = t.toSlide(corners[i][0], corners[i][1]);
        quad[size_t(i)] = {s[0], s[1]};
        field.expand(quad[size_t(i)]);
    }

    // Too many objects in view: the fit-view aggregate.
    if (snap.size() > budget.maxObjects) {
        const AnnotationOverview& ov = snap.overview();
        const bool fine = ov.cellSize / ds <= budget.aggregateCellPixels;
        size_t inView = 0;
        if (ov.cellSize > 0) {
            for (const AnnotationOverview::Cell& c : ov.cells) {
                const double ix = std::floor((c.centroid.x - ov.bounds.minX) / ov.cellSize);
                const double iy = std::floor((c.centroid.y - ov.bounds.minY) / ov.cellSize);
                const Box2 cell{ov.bounds.minX + ix * ov.cellSize, ov.bounds.minY + iy * ov.cellSize,
                                ov.bounds.minX + (ix + 1) * ov.cellSize, ov.bounds.minY + (iy + 1) * ov.cellSize};
                if (cell.intersects(field)) inView += c.count;
            }
        }
        if ((fine && inView > budget.maxObjects) || inView > budget.hardMaxObjects) {
            out.overview = true;
            for (const AnnotationOverview::Cell& c : ov.cells) {
                if (c.centroid.x < field.minX || c.centroid.x > field.maxX || c.centroid.y < field.minY ||
                    c.centroid.y > field.maxY)
                    continue;
                b.dot(c.centroid, kAnnotationDotRadius, packRgba(c.color));
                ++out.objects;
                ++out.dots;
            }
            return;
        }
    }

    const std::vector<const StoredAnnotation*> objects =
        t.axisAligned() ? snap.query(field, true) : snap.query(std::span<const Point2>(quad.data(), quad.size()), true);
    std::optional<Clock::time_point> triangulateUntil; // set at the first new triangulation
    const StoredAnnotation* chosen = nullptr;
    for (const StoredAnnotation* a : objects) {
        const AnnotationObject& o = a->object;
        if (o.id == selected) chosen = a;
        const Rgba8 colour = snap.colorOf(o);
        const uint32_t packed = packRgba(colour);
        ++out.objects;
        if (o.kind == AnnotationKind::Point) {
            for (const Point2& p : o.points) b.dot(p, kAnnotationPointRadius, packed);
            continue;
        }
        const AnnotationLod lod = annotationLod(a->bounds, o.kind, o.fill, ds);
        if (lod == AnnotationLod::Dot) {
            b.dot({(a->bounds.minX + a->bounds.maxX) / 2, (a->bounds.minY + a->bounds.maxY) / 2}, kAnnotationDotRadius,
                  packed);
            ++out.dots;
            continue;
        }
        if (lod == AnnotationLod::OutlineFill && o.fillOpacity > 0) {
            bool make = true;
            if (!fillReady(*a)) {
                const auto now = Clock::now();
                if (!triangulateUntil)
                    triangulateUntil = now + std::chrono::duration_cast<Clock::duration>(
                                                 std::chrono::duration<double, std::milli>(budget.triangulateMs));
                else if (now > *triangulateUntil)
                    make = false;
            }
            if (make) {
                auto tri = snap.fillTriangles(*a, ds);
                if (tri) {
                    b.fill(**tri, withOpacity(colour, o.fillOpacity));
                } else {
                    out.errors.push_back(tri.error().message());
                }
            } else {
                out.complete = false;
            }
        }
    }
    // Outlines over every fill.
    for (const StoredAnnotation* a : objects) {
        const AnnotationObject& o = a->object;
        if (o.kind == AnnotationKind::Point) continue;
        if (annotationLod(a->bounds, o.kind, o.fill, ds) == AnnotationLod::Dot) continue;
        const uint32_t packed = packRgba(snap.colorOf(o));
        const float half = std::max(0.5f, o.lineWidth * 0.5f);
        b.forEachOutline(o, [&](const std::vector<Point2>& ring, bool closed) { b.line(ring, closed, half, packed); });
    }
    // The selection on top: a contrasting outline and the vertex handles.
    if (chosen) {
        const AnnotationObject& o = chosen->object;
        const float half = std::max(0.5f, o.lineWidth * 0.5f) + 1.0f;
        b.forEachOutline(o, [&](const std::vector<Point2>& ring, bool closed) {
            b.line(ring, closed, half, kAnnotationSelectedRgba);
        });
        for (const Point2& p : handlePoints(o, budget.maxHandles)) b.handle(p);
    }
}

} // namespace iris::render
