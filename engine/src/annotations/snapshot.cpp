// AnnotationSnapshot: read-only queries over one published state. Everything here reads
// immutable data; the only writes are the once-only caches (overview, fill triangles), each
// behind its std::once_flag.
#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "annotations/annotation_index.h"

namespace iris {

using namespace ann;

AnnotationSnapshot::AnnotationSnapshot(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
AnnotationSnapshot::~AnnotationSnapshot() = default;

uint64_t AnnotationSnapshot::generation() const noexcept { return impl_->generation; }
size_t AnnotationSnapshot::size() const noexcept { return impl_->count; }
Box2 AnnotationSnapshot::bounds() const noexcept { return impl_->bounds; }

const StoredAnnotation* AnnotationSnapshot::find(uint64_t id) const noexcept {
    const auto& bucket = impl_->buckets[bucketOf(id)];
    if (!bucket) return nullptr;
    auto it = std::lower_bound(bucket->ids.begin(), bucket->ids.end(), std::make_pair(id, uint32_t(0)));
    if (it == bucket->ids.end() || it->first != id) return nullptr;
    const auto& chunk = impl_->chunks[it->second];
    for (const auto& e : chunk->entries)
        if (e->object.id == id) return e.get();
    return nullptr;
}

void AnnotationSnapshot::forEach(const std::function<void(const StoredAnnotation&)>& fn) const {
    for (const auto& c : impl_->chunks)
        if (c)
            for (const auto& e : c->entries) fn(*e);
}

std::vector<AnnotationClass> AnnotationSnapshot::classes() const {
    std::vector<AnnotationClass> out;
    for (const auto& [name, c] : *impl_->classes) out.push_back(c);
    return out;
}

AnnotationClass AnnotationSnapshot::classInfo(std::string_view name) const {
    if (auto it = impl_->classes->find(name); it != impl_->classes->end()) return it->second;
    return {std::string(name), defaultClassColor(name), true};
}

Rgba8 AnnotationSnapshot::colorOf(const AnnotationObject& o) const {
    return o.color ? *o.color : classInfo(o.className).color;
}

bool AnnotationSnapshot::drawn(const AnnotationObject& o) const {
    if (!o.visible) return false;
    auto it = impl_->classes->find(o.className);
    return it == impl_->classes->end() || it->second.visible;
}

std::vector<const StoredAnnotation*> AnnotationSnapshot::query(const Box2& rect, bool drawnOnly) const {
    std::vector<const StoredAnnotation*> out;
    if (rect.empty()) return out;
    const BBox q = toBBox(rect);
    std::vector<RValue> hits;
    for (const auto& c : impl_->chunks) {
        if (!c || !c->bounds.intersects(rect)) continue;
        hits.clear();
        c->tree.query(bgi::intersects(q), std::back_inserter(hits));
        for (const auto& h : hits) {
            const StoredAnnotation* a = c->entries[h.second].get();
            if (!drawnOnly || drawn(a->object)) out.push_back(a);
        }
    }
    return out;
}

std::vector<const StoredAnnotation*> AnnotationSnapshot::query(std::span<const Point2> convex, bool drawnOnly) const {
    Box2 box;
    for (Point2 p : convex) box.expand(p);
    auto candidates = query(box, drawnOnly);
    if (convex.size() < 3) return candidates;
    std::erase_if(candidates, [&](const StoredAnnotation* a) { return !boxIntersectsConvex(a->bounds, convex); });
    return candidates;
}

std::optional<AnnotationHit> AnnotationSnapshot::hitTest(Point2 p, double tolerance) const {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !(tolerance >= 0)) return std::nullopt;
    const Box2 around{p.x - tolerance, p.y - tolerance, p.x + tolerance, p.y + tolerance};
    std::optional<AnnotationHit> best;
    double bestArea = INFINITY;
    for (const StoredAnnotation* a : query(around, true)) {
        auto h = hitObject(*a, p, tolerance);
        if (!h) continue;
        if (h->part == AnnotationHit::Part::Inside) {
            // Among shapes containing p, the smallest: a nucleus inside a tumour outline.
            double area = a->bounds.width() * a->bounds.height();
            if (a->object.kind == AnnotationKind::Polygon) area = partArea(a->object.polygons[size_t(h->polygon)]);
            if (!best || (best->part == AnnotationHit::Part::Inside && area < bestArea)) best = h, bestArea = area;
            continue;
        }
        if (!best || int(h->part) < int(best->part) || (h->part == best->part && h->distance < best->distance)) best = h;
    }
    return best;
}

Expected<std::shared_ptr<const AnnotationTriangles>> AnnotationSnapshot::fillTriangles(const StoredAnnotation& a,
                                                                                       double downsample) const {
    const AnnotationObject& o = a.object;
    switch (o.kind) {
    case AnnotationKind::Point:
    case AnnotationKind::Polyline:
        return Result(Status::InvalidArgument,
                      std::string("annotation ") + std::to_string(o.id) + " is a " + annotationKindName(o.kind) +
                          ": it has no fill");
    case AnnotationKind::Rectangle: {
        const Box2& b = o.box;
        if (!(b.width() > 0 && b.height() > 0))
            return Result(Status::InvalidArgument, "annotation " + std::to_string(o.id) + ": the rectangle has no area");
        auto t = std::make_shared<AnnotationTriangles>();
        t->vertices = {{b.minX, b.minY}, {b.maxX, b.minY}, {b.maxX, b.maxY}, {b.minX, b.minY}, {b.maxX, b.maxY}, {b.minX, b.maxY}};
        return std::shared_ptr<const AnnotationTriangles>(t);
    }
    case AnnotationKind::Ellipse: {
        // Convex: a fan from the centre, its vertex count from the on-screen size (not cached:
        // it depends on the downsample and costs less than a cache lookup would save).
        const Box2& b = o.box;
        if (!(b.width() > 0 && b.height() > 0))
            return Result(Status::InvalidArgument, "annotation " + std::to_string(o.id) + ": the ellipse has no area");
        const auto ring = flattenEllipse(b, ellipseVertexCount(b.width() / 2, b.height() / 2, downsample));
        const Point2 c{(b.minX + b.maxX) / 2, (b.minY + b.maxY) / 2};
        auto t = std::make_shared<AnnotationTriangles>();
        t->vertices.reserve(ring.size() * 3);
        for (size_t i = 0; i < ring.size(); ++i) t->vertices.insert(t->vertices.end(), {c, ring[i], ring[(i + 1) % ring.size()]});
        return std::shared_ptr<const AnnotationTriangles>(t);
    }
    case AnnotationKind::Polygon: break;
    }
    AnnotationFillCache* cache = a.fillCache.get();
    auto compute = [&]() -> Expected<std::shared_ptr<const AnnotationTriangles>> {
        auto t = triangulatePolygon(o.polygons);
        if (!t) return Result(t.error().status(), "annotation " + std::to_string(o.id) + ": " + t.error().message());
        return std::shared_ptr<const AnnotationTriangles>(std::make_shared<AnnotationTriangles>(std::move(*t)));
    };
    if (!cache) return compute(); // a StoredAnnotation made outside the store
    std::call_once(cache->once, [&] {
        cache->result.emplace(compute());
        cache->ready.store(true, std::memory_order_release);
    });
    return *cache->result;
}

const AnnotationOverview& AnnotationSnapshot::overview() const {
    std::call_once(impl_->overviewOnce, [this] {
        AnnotationOverview& ov = impl_->overview;
        ov.bounds = impl_->bounds;
        if (ov.bounds.empty()) return;
        const double side = std::max(ov.bounds.width(), ov.bounds.height());
        ov.cellSize = std::max(1.0, side / AnnotationOverview::kOverviewCells);
        ov.cellsX = std::max(1, int(std::ceil(ov.bounds.width() / ov.cellSize)));
        ov.cellsY = std::max(1, int(std::ceil(ov.bounds.height() / ov.cellSize)));
        struct Acc {
            double sx = 0, sy = 0;
            uint32_t n = 0;
            Rgba8 color;
        };
        std::vector<Acc> grid(size_t(ov.cellsX) * size_t(ov.cellsY));
        forEach([&](const StoredAnnotation& a) {
            if (!drawn(a.object) || a.bounds.empty()) return;
            const double cx = (a.bounds.minX + a.bounds.maxX) / 2, cy = (a.bounds.minY + a.bounds.maxY) / 2;
            const int gx = std::clamp(int((cx - ov.bounds.minX) / ov.cellSize), 0, ov.cellsX - 1);
            const int gy = std::clamp(int((cy - ov.bounds.minY) / ov.cellSize), 0, ov.cellsY - 1);
            Acc& c = grid[size_t(gy) * size_t(ov.cellsX) + size_t(gx)];
            if (c.n == 0) c.color = colorOf(a.object); // the first object's colour stands for the cell
            c.sx += cx, c.sy += cy, ++c.n;
        });
        for (const Acc& c : grid)
            if (c.n) ov.cells.push_back({{c.sx / c.n, c.sy / c.n}, c.n, c.color});
    });
    return impl_->overview;
}

AnnotationDocument documentOf(const AnnotationSnapshot& s) {
    AnnotationDocument d;
    d.classes = s.classes();
    d.objects.reserve(s.size());
    s.forEach([&](const StoredAnnotation& a) { d.objects.push_back(a.object); });
    return d;
}

} // namespace iris
