// Iris View engine — annotations: the model, its store and snapshots, spatial queries, level of
// detail, fill triangulation and the QuPath GeoJSON / ASAP XML formats. Qt-free and Vulkan-free;
// docs/ANNOTATIONS.md describes the design, the format mapping and the measured costs.
//
// Threads, in one table:
//
//   AnnotationStore::snapshot()            any thread, never waits on a writer's work (a spin lock
//                                          held for one shared_ptr copy: core/published.h)
//   AnnotationStore's writers (add, update, remove, clear, setClass…, apply, replaceAll)
//                                          any thread; writers serialise among themselves on a
//                                          mutex and each call publishes at most one snapshot
//   AnnotationSnapshot and everything it returns
//                                          immutable: any number of threads at once, for as long as
//                                          they hold the shared_ptr (pointers into it die with it)
//   AnnotationSnapshot::fillTriangles()    any thread; the first call per object triangulates
//                                          (GEOS) and caches, concurrent first calls wait for it
//   annotationLod(), flattenEllipse()      pure functions
//   readGeoJson/readAsapXml/write…         any thread, no shared state
//   AnnotationLoader                       its callbacks run on its worker thread
//
// Cost of a change: one edit of a 10^6-object store copies a bounded part of it (one chunk of
// ≤ 512 object pointers and its R-tree, one id bucket, and the two directories of pointers),
// not the world: ≈ 0.2 ms at -O2 against 1.7 s to build the store (docs/ANNOTATIONS.md has
// every measured figure). A batch (addBatch, apply, replaceAll) publishes once.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "iris/export.h"
#include "iris/types.h"

namespace iris {

// A point in level-0 pixels.
struct Point2 {
    double x = 0;
    double y = 0;
    friend bool operator==(const Point2&, const Point2&) = default;
};

// An axis-aligned box in level-0 pixels, [minX, maxX] × [minY, maxY]. Empty when minX > maxX.
struct Box2 {
    double minX = 1;
    double minY = 1;
    double maxX = 0;
    double maxY = 0;
    bool empty() const { return !(minX <= maxX && minY <= maxY); }
    double width() const { return empty() ? 0 : maxX - minX; }
    double height() const { return empty() ? 0 : maxY - minY; }
    void expand(Point2 p) {
        if (empty()) {
            *this = {p.x, p.y, p.x, p.y};
            return;
        }
        minX = std::min(minX, p.x), minY = std::min(minY, p.y);
        maxX = std::max(maxX, p.x), maxY = std::max(maxY, p.y);
    }
    void expand(const Box2& b) {
        if (b.empty()) return;
        expand(Point2{b.minX, b.minY});
        expand(Point2{b.maxX, b.maxY});
    }
    bool intersects(const Box2& b) const {
        return !empty() && !b.empty() && minX <= b.maxX && b.minX <= maxX && minY <= b.maxY && b.minY <= maxY;
    }
    friend bool operator==(const Box2&, const Box2&) = default;
};

// sRGB colour, 8 bits a channel, straight alpha.
struct Rgba8 {
    uint8_t r = 0, g = 0, b = 0, a = 255;
    friend bool operator==(const Rgba8&, const Rgba8&) = default;
};

enum class AnnotationKind : uint8_t {
    Point,     // points: one or more (a QuPath MultiPoint / an ASAP PointSet)
    Polyline,  // points: an open line of two or more
    Polygon,   // polygons: one or more parts, each an outer ring and holes (MultiPolygon)
    Rectangle, // box
    Ellipse,   // box: the ellipse inscribed in it
};
IRIS_API const char* annotationKindName(AnnotationKind k) noexcept;

// QuPath's objectType: a hand-drawn annotation or a detection (a model's output; usually many).
enum class AnnotationType : uint8_t { Annotation, Detection };

// One polygon: an outer ring and holes. Rings are stored open (the last vertex is not the first
// repeated); readers drop a closing duplicate, writers add it where the format wants it.
struct PolygonPart {
    std::vector<Point2> outer;
    std::vector<std::vector<Point2>> holes;
    friend bool operator==(const PolygonPart&, const PolygonPart&) = default;
};

// One annotation object, as a value a host fills in and hands to the store.
struct AnnotationObject {
    uint64_t id = 0;                          // 0: the store assigns the next free id
    AnnotationKind kind = AnnotationKind::Polygon;
    AnnotationType type = AnnotationType::Annotation;
    std::string name;                         // QuPath's name / ASAP's Name
    std::string className;                    // "" = unclassified
    std::optional<Rgba8> color;               // none: the class's colour
    float lineWidth = 2.0f;                   // outline width in screen pixels
    bool fill = false;
    float fillOpacity = 0.25f;                // 0..1, of the fill only
    bool visible = true;
    bool locked = false;                      // QuPath's isLocked: tools must not edit it
    std::vector<Point2> points;               // Point, Polyline
    std::vector<PolygonPart> polygons;        // Polygon
    Box2 box;                                 // Rectangle, Ellipse
    std::vector<std::pair<std::string, std::string>> properties;  // free-form, in file order
    std::vector<std::pair<std::string, double>> measurements;     // named numbers, in file order
    friend bool operator==(const AnnotationObject&, const AnnotationObject&) = default;
};

// The object's geometric bounds (level-0 pixels); empty for an object without vertices.
IRIS_API Box2 annotationBounds(const AnnotationObject& o) noexcept;
// Why an object cannot be stored (an empty string when it can): no vertices for its kind, a
// non-finite coordinate, a ring of fewer than 3 vertices, a negative box, opacity outside 0..1.
IRIS_API std::string annotationProblem(const AnnotationObject& o);

// A class (QuPath's PathClass, ASAP's group): its colour and whether its objects are drawn.
struct AnnotationClass {
    std::string name;
    Rgba8 color;
    bool visible = true;
    friend bool operator==(const AnnotationClass&, const AnnotationClass&) = default;
};
// The colour of a class that the table does not name: a fixed colour for "" (unclassified) and
// one derived from the name otherwise, the same in every run.
IRIS_API Rgba8 defaultClassColor(std::string_view className) noexcept;

// An object as the store keeps it: the value, its bounds, and the fill triangulation's cache.
struct StoredAnnotation {
    AnnotationObject object;
    Box2 bounds;
    std::shared_ptr<struct AnnotationFillCache> fillCache; // engine-internal
};

// ---- Level of detail (pure; the view model's style) ----------------------------------------

enum class AnnotationLod : uint8_t {
    Dot,         // smaller than dotPixels on screen: one dot (a point sprite) at the centre
    Outline,     // the outline only
    OutlineFill, // the outline over the triangulated fill
};
struct LodThresholds {
    double dotPixels = 3.0; // objects whose larger side is under this many screen pixels are dots
};
// How an object with level-0 `bounds`, filled or not, draws at view `downsample` (level-0
// pixels per screen pixel). Points always draw as dots.
IRIS_API AnnotationLod annotationLod(const Box2& bounds, AnnotationKind kind, bool filled, double downsample,
                                     const LodThresholds& t = {}) noexcept;
// The vertex count an ellipse of radii rx, ry (level-0) needs at `downsample` so that the chord
// leaves the true curve by at most a quarter of a screen pixel: a multiple of 4 (so the four
// extreme points are vertices and the box is exact), 8..4096.
IRIS_API int ellipseVertexCount(double rx, double ry, double downsample) noexcept;
// The ellipse inscribed in `box` as a closed-ring polygon (open storage) of `vertices` vertices,
// starting at the rightmost point, counter-clockwise in y-up terms.
IRIS_API std::vector<Point2> flattenEllipse(const Box2& box, int vertices);

// ---- Snapshot: queries, hit-testing, triangles, the fit-view aggregate -----------------------

struct AnnotationHit {
    enum class Part : uint8_t { Vertex, Edge, Inside };
    const StoredAnnotation* annotation = nullptr;
    Part part = Part::Inside;
    double distance = 0; // level-0 pixels to the vertex/edge; 0 inside
    int polygon = -1;    // which part (Polygon), -1 otherwise
    int ring = -1;       // 0 outer, 1.. holes (Polygon); 0 for the other kinds' outline
    int vertex = -1;     // the vertex (Vertex) or the edge's first vertex (Edge)
};

// Triangles of a fill, level-0 coordinates, three vertices a triangle.
struct AnnotationTriangles {
    std::vector<Point2> vertices;
    std::string note; // "" or how an invalid polygon was repaired (the documented fallback)
};

// The fit-view aggregate: objects binned into a grid over the snapshot's bounds. Where a view
// would touch more than a budget of objects (the whole slide at fit), the pass draws one dot per
// non-empty cell instead: bounded work (at most kOverviewCells² cells) whatever the count.
struct AnnotationOverview {
    static constexpr int kOverviewCells = 512; // along the longer side
    Box2 bounds;
    double cellSize = 0; // level-0 pixels
    int cellsX = 0, cellsY = 0;
    struct Cell {
        Point2 centroid;  // of the object centres in the cell
        uint32_t count = 0;
        Rgba8 color;      // the colour of the first drawn object binned into the cell
    };
    std::vector<Cell> cells; // non-empty cells only, row-major order
};

class IRIS_API AnnotationSnapshot {
public:
    struct Impl;
    explicit AnnotationSnapshot(std::unique_ptr<Impl> impl);
    ~AnnotationSnapshot();
    AnnotationSnapshot(const AnnotationSnapshot&) = delete;
    AnnotationSnapshot& operator=(const AnnotationSnapshot&) = delete;

    // Grows by one with every publication of its store (the empty store's first snapshot is 0).
    uint64_t generation() const noexcept;
    size_t size() const noexcept;
    // The union of every object's bounds (empty when there are none).
    Box2 bounds() const noexcept;
    // The object with that id, or null.
    const StoredAnnotation* find(uint64_t id) const noexcept;
    // Every object, in storage order (chunks in order; not sorted by id).
    void forEach(const std::function<void(const StoredAnnotation&)>& fn) const;

    // The class table: every class set on the store or named by an object.
    std::vector<AnnotationClass> classes() const;
    // The class `name`'s entry, or its defaults (defaultClassColor, visible).
    AnnotationClass classInfo(std::string_view name) const;
    // The colour it draws in: its own, else its class's.
    Rgba8 colorOf(const AnnotationObject& o) const;
    // Whether it draws: visible and its class visible.
    bool drawn(const AnnotationObject& o) const;

    // Objects whose bounds intersect `rect` (level-0 pixels).
    // Hidden objects are included (`drawnOnly` leaves them out).
    std::vector<const StoredAnnotation*> query(const Box2& rect, bool drawnOnly = false) const;
    // Objects whose bounds intersect a convex polygon (a rotated view's footprint, any winding).
    std::vector<const StoredAnnotation*> query(std::span<const Point2> convex, bool drawnOnly = false) const;
    // The object at `p` for selection: the nearest vertex, else edge, within `tolerance` level-0
    // pixels, else the smallest closed shape containing p (holes excluded). Only drawn objects.
    std::optional<AnnotationHit> hitTest(Point2 p, double tolerance) const;

    // Triangles filling the object (Polygon with holes, Rectangle, Ellipse at `downsample`'s
    // vertex count). Polygons triangulate once (GEOS constrained Delaunay) and are cached in the
    // object's stored form, shared by every snapshot holding it. Invalid polygons: NaN never
    // reaches here (the store refuses it); self-intersecting ones are repaired with
    // GEOSMakeValid (the note says so); zero-area ones give an error.
    Expected<std::shared_ptr<const AnnotationTriangles>> fillTriangles(const StoredAnnotation& a,
                                                                       double downsample = 1) const;

    // The fit-view aggregate of the drawn objects, built on first use and kept in the snapshot.
    const AnnotationOverview& overview() const;

private:
    friend class AnnotationStore; // builds the next snapshot from this one's pieces
    const Impl& impl() const { return *impl_; }
    std::unique_ptr<Impl> impl_;
};

// ---- The store -------------------------------------------------------------------------------

// Many changes published as one snapshot (AnnotationStore::apply).
struct AnnotationEdit {
    std::vector<AnnotationObject> add;      // id 0 gets a fresh id; a used id is an error
    std::vector<AnnotationObject> update;   // replaces the object of the same id
    std::vector<uint64_t> remove;
    std::vector<AnnotationClass> classes;   // set or replace class entries
};

// A registration made by AnnotationStore::onChange: while it lives, its function is called after
// every publication; destroying (or reset()) it ends the calls and waits for one in progress.
class IRIS_API AnnotationSubscription {
public:
    AnnotationSubscription() = default;
    AnnotationSubscription(AnnotationSubscription&& o) noexcept;
    AnnotationSubscription& operator=(AnnotationSubscription&& o) noexcept;
    AnnotationSubscription(const AnnotationSubscription&) = delete;
    AnnotationSubscription& operator=(const AnnotationSubscription&) = delete;
    ~AnnotationSubscription();
    void reset();
    explicit operator bool() const { return id_ != 0; }

    struct Registry; // engine-internal
private:
    friend class AnnotationStore;
    AnnotationSubscription(std::weak_ptr<Registry> r, uint64_t id) : registry_(std::move(r)), id_(id) {}
    std::weak_ptr<Registry> registry_;
    uint64_t id_ = 0;
};

class IRIS_API AnnotationStore {
public:
    AnnotationStore();
    ~AnnotationStore();
    AnnotationStore(const AnnotationStore&) = delete;
    AnnotationStore& operator=(const AnnotationStore&) = delete;

    // The newest snapshot. Any thread; a few nanoseconds; never null.
    std::shared_ptr<const AnnotationSnapshot> snapshot() const;

    // Every writer: any thread; all-or-nothing (an error changes nothing and publishes nothing);
    // a success publishes exactly one snapshot.
    Expected<uint64_t> add(AnnotationObject o);
    Expected<std::vector<uint64_t>> addBatch(std::vector<AnnotationObject> objects);
    Result update(AnnotationObject o);
    Result remove(uint64_t id);
    void clear(); // objects and classes
    void setClassColor(const std::string& name, Rgba8 color);
    void setClassVisible(const std::string& name, bool visible);
    // Ids of the added objects, in order.
    Expected<std::vector<uint64_t>> apply(AnnotationEdit edit);
    // Everything replaced by `objects` and `classes` (a loaded file), one publication.
    Result replaceAll(std::vector<AnnotationObject> objects, std::vector<AnnotationClass> classes);

    // Calls `fn` after every publication, on the writer's thread, with the writers' lock held:
    // it must be quick and must not call this store's writers or end its own subscription (an
    // engine bumps its render thread's wake counter). The store may die first: the
    // subscription then does nothing.
    [[nodiscard]] AnnotationSubscription onChange(std::function<void()> fn);

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// ---- Formats ---------------------------------------------------------------------------------

// What a file holds: objects and the classes it declares (ASAP groups; QuPath classes as seen).
struct AnnotationDocument {
    std::vector<AnnotationObject> objects;
    std::vector<AnnotationClass> classes;
};

enum class AnnotationFormat { GeoJson, AsapXml };
// From the content: '{' or '[' first (after blanks) is GeoJSON, '<' is XML.
IRIS_API std::optional<AnnotationFormat> detectAnnotationFormat(std::string_view text) noexcept;

// Progress and cancellation for the readers: `progress(done, total)` counts bytes parsed (0..total)
// now and then; `cancel` set stops the read with Status::Cancelled.
struct ReadControl {
    std::function<void(uint64_t done, uint64_t total)> progress;
    const std::atomic<bool>* cancel = nullptr;
};

// QuPath GeoJSON (docs/ANNOTATIONS.md has the mapping). Errors name the line and the feature.
IRIS_API Expected<AnnotationDocument> readGeoJson(std::string_view text, const ReadControl& control = {});
IRIS_API std::string writeGeoJson(const AnnotationDocument& doc);
// ASAP XML (CAMELYON). Errors name the XML line.
IRIS_API Expected<AnnotationDocument> readAsapXml(std::string_view text, const ReadControl& control = {});
IRIS_API std::string writeAsapXml(const AnnotationDocument& doc);
// The document of a snapshot (objects in storage order, its classes).
IRIS_API AnnotationDocument documentOf(const AnnotationSnapshot& s);

// Reads a file (either format, by content) on a worker thread and, on success, replaces the
// store's contents in one publication; on any failure or cancel the store is untouched.
class IRIS_API AnnotationLoader {
public:
    // Both run on the worker thread and must not call wait() or destroy the loader (it joins
    // that very thread); cancel() is fine.
    struct Callbacks {
        std::function<void(uint64_t done, uint64_t total)> progress; // bytes, 2 passes (docs/ANNOTATIONS.md)
        std::function<void(const Result&, size_t objects)> finished; // once, before wait() returns
    };
    enum class Mode { Replace, Append };
    // Starts at once. The store must outlive the loader.
    AnnotationLoader(AnnotationStore& store, std::string path, Callbacks callbacks, Mode mode = Mode::Replace);
    // Cancels and joins.
    ~AnnotationLoader();
    AnnotationLoader(const AnnotationLoader&) = delete;
    AnnotationLoader& operator=(const AnnotationLoader&) = delete;
    void cancel() noexcept;
    // Blocks until done; the result (Cancelled after cancel()).
    Result wait();

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace iris
