// Unit tests of the frame's draw list (render/draw_list): which tiles are drawn, which are
// culled, and when the LR and HR layers are whole, against a fake tile map. A CPU rasteriser
// (pixel centres, painter's order: what the tile pipeline does) checks what each target pixel
// shows: culling must never change it.
#include <QtTest>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "render/draw_list.h"
#include "slide/slide_source.h"
#include "view/view_model.h"

using iris::LevelInfo;
using iris::SlideInfo;
using iris::TileKey;
using iris::Viewport;
using iris::render::DrawList;
using iris::render::DrawOptions;
using iris::render::LevelDraw;

namespace {

constexpr uint32_t kGen = 7;

LevelInfo level(int64_t w, int64_t h, double ds, bool synthetic = false) {
    LevelInfo l;
    l.width = w;
    l.height = h;
    l.downsample = ds;
    l.tilesX = (w + iris::kTileSize - 1) / iris::kTileSize;
    l.tilesY = (h + iris::kTileSize - 1) / iris::kTileSize;
    l.synthetic = synthetic;
    return l;
}

// A 20000×15000 scan with levels at 4× and 16× (the last, 5×4 tiles, is the base).
SlideInfo scan() {
    SlideInfo s;
    s.width = 20000;
    s.height = 15000;
    s.levels = {level(20000, 15000, 1), level(5000, 3750, 4), level(1250, 937, 16.004)};
    return s;
}

// The tile map: a set of resident keys, each with its own atlas layer; pins are counted.
class FakeMap final : public iris::render::TileResidency {
public:
    void add(uint64_t key) {
        if (!layers_.count(key)) {
            layers_[key] = int(keys_.size());
            keys_.push_back(key);
        }
    }
    void addLevel(const SlideInfo& s, int li) {
        const LevelInfo& l = s.levels[size_t(li)];
        for (int64_t y = 0; y < l.tilesY; ++y)
            for (int64_t x = 0; x < l.tilesX; ++x) add(TileKey::make(kGen, li, x, y));
    }
    int pin(uint64_t key) override {
        const auto it = layers_.find(key);
        if (it == layers_.end()) return -1;
        ++pins;
        return it->second;
    }
    bool isActive(uint64_t key) const override { return layers_.count(key) != 0; }
    uint64_t uploadSeq(int layer) const override { return uint64_t(layer) + 1000; } // a stamp per tile
    uint64_t keyOf(int layer) const { return keys_[size_t(layer)]; }
    // A resident tile whose mip levels are still to come (TileMap::mipsReadyOf).
    void withoutMips(uint64_t key) { noMips_.insert(layers_.at(key)); }
    bool mipsReady(int layer) const override { return noMips_.count(layer) == 0; }
    int layerOf(uint64_t key) const { return layers_.at(key); }
    int pins = 0;

private:
    std::unordered_map<uint64_t, int> layers_;
    std::unordered_set<int> noMips_;
    std::vector<uint64_t> keys_;
};

// What each pixel of the target shows: the layer of the topmost instance whose rect holds the
// pixel's centre (-1: the background).
std::vector<int> rasterise(const std::vector<iris::gpu::TileInstance>& instances, uint32_t w, uint32_t h) {
    std::vector<int> top(size_t(w) * h, -1);
    for (const iris::gpu::TileInstance& t : instances) {
        const int64_t x0 = std::max<int64_t>(0, int64_t(std::ceil(t.rect[0] - 0.5f)));
        const int64_t y0 = std::max<int64_t>(0, int64_t(std::ceil(t.rect[1] - 0.5f)));
        const int64_t x1 = std::min<int64_t>(w, int64_t(std::ceil(t.rect[2] - 0.5f)));
        const int64_t y1 = std::min<int64_t>(h, int64_t(std::ceil(t.rect[3] - 0.5f)));
        for (int64_t y = y0; y < y1; ++y)
            for (int64_t x = x0; x < x1; ++x) top[size_t(y * w + x)] = int(t.texel[2]);
    }
    return top;
}

std::vector<iris::gpu::TileInstance> instancesOf(const DrawList& list) {
    std::vector<iris::gpu::TileInstance> out(list.instanceCount());
    list.copyInstances(out.data());
    return out;
}

Viewport viewport(double cx, double cy, double ds, uint32_t w = 320, uint32_t h = 240) {
    return Viewport{.view = {cx, cy, ds}, .width = w, .height = h};
}

// The pins a level's draw takes: its drawn tiles, and once each the resident tiles of the level
// next to a drawn one (8-connected) that are not drawn themselves (the seam pass's neighbours),
// unless the level is drawn exactly (no seam pass).
int pinsOf(const LevelDraw& d, const LevelInfo& level, const FakeMap& map) {
    std::set<std::pair<int64_t, int64_t>> pinned;
    const int64_t reach = d.linked ? 1 : 0;
    for (int64_t ty = d.range.y0; ty <= d.range.y1; ++ty)
        for (int64_t tx = d.range.x0; tx <= d.range.x1; ++tx) {
            if (!d.isDrawn(tx, ty)) continue;
            for (int64_t y = ty - reach; y <= ty + reach; ++y)
                for (int64_t x = tx - reach; x <= tx + reach; ++x)
                    if (x >= 0 && y >= 0 && x < level.tilesX && y < level.tilesY &&
                        map.isActive(TileKey::make(kGen, d.level, x, y)))
                        pinned.insert({x, y});
        }
    return int(pinned.size());
}

// What each pixel of a turned target shows: as rasterise(), the pixel's centre taken into the
// view's unturned frame (what tile.frag and tile_resolve.comp do; the quads' corners are turned
// by the same orthonormal map, so a centre lies in a turned quad iff its unturned position lies
// in the quad's rect).
std::vector<int> rasteriseTurned(const std::vector<iris::gpu::TileInstance>& instances, const Viewport& vp) {
    const iris::ViewTransform t = iris::ViewTransform::of(vp.view, vp.width, vp.height);
    std::vector<int> top(size_t(vp.width) * vp.height, -1);
    for (const iris::gpu::TileInstance& i : instances) {
        // The pixels of the turned quad's bounding box, each tested in the unturned frame.
        double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
        for (const auto& [cx, cy] : {std::pair{i.rect[0], i.rect[1]}, std::pair{i.rect[2], i.rect[1]},
                                     std::pair{i.rect[0], i.rect[3]}, std::pair{i.rect[2], i.rect[3]}}) {
            const double dx = cx - t.targetCX, dy = cy - t.targetCY;
            const double px = t.targetCX + t.m[0] * dx + t.m[1] * dy, py = t.targetCY + t.m[2] * dx + t.m[3] * dy;
            x0 = std::min(x0, px), y0 = std::min(y0, py), x1 = std::max(x1, px), y1 = std::max(y1, py);
        }
        const int64_t px0 = std::max<int64_t>(0, int64_t(std::floor(x0)) - 1), py0 = std::max<int64_t>(0, int64_t(std::floor(y0)) - 1);
        const int64_t px1 = std::min<int64_t>(vp.width, int64_t(std::ceil(x1)) + 1), py1 = std::min<int64_t>(vp.height, int64_t(std::ceil(y1)) + 1);
        for (int64_t y = py0; y < py1; ++y) {
            for (int64_t x = px0; x < px1; ++x) {
                const double dx = double(x) + 0.5 - t.targetCX, dy = double(y) + 0.5 - t.targetCY;
                const double ux = t.targetCX + t.m[0] * dx + t.m[2] * dy, uy = t.targetCY + t.m[1] * dx + t.m[3] * dy;
                if (ux >= i.rect[0] && ux < i.rect[2] && uy >= i.rect[1] && uy < i.rect[3])
                    top[size_t(y) * vp.width + size_t(x)] = int(i.texel[2]);
            }
        }
    }
    return top;
}

// The tiles of `level` that the target rectangle overlaps: what a turned field truly shows of
// the level. Sampled every pixel inside and every 1/64 pixel along its edges (a tile, larger
// than a pixel, that overlaps the rectangle without holding an inner sample crosses an edge).
std::set<std::pair<int64_t, int64_t>> tilesUnderTarget(const LevelInfo& level, const Viewport& vp) {
    const iris::ViewTransform t = iris::ViewTransform::of(vp.view, vp.width, vp.height);
    std::vector<char> hit(size_t(level.tilesX * level.tilesY), 0);
    const auto sample = [&](double x, double y) {
        const auto s = t.toSlide(x, y);
        const double lx = s[0] / level.downsample, ly = s[1] / level.downsample;
        if (lx < 0 || ly < 0 || lx >= double(level.width) || ly >= double(level.height)) return;
        hit[size_t((int64_t(ly) / iris::kTileSize) * level.tilesX + int64_t(lx) / iris::kTileSize)] = 1;
    };
    for (uint32_t y = 0; y < vp.height; ++y)
        for (uint32_t x = 0; x < vp.width; ++x) sample(x + 0.5, y + 0.5);
    const double e = 1e-9; // just inside the closed rectangle
    for (double k = 0; k <= vp.width; k += 1.0 / 64) sample(k, e), sample(k, vp.height - e);
    for (double k = 0; k <= vp.height; k += 1.0 / 64) sample(e, k), sample(vp.width - e, k);
    std::set<std::pair<int64_t, int64_t>> out;
    for (int64_t ty = 0; ty < level.tilesY; ++ty)
        for (int64_t tx = 0; tx < level.tilesX; ++tx)
            if (hit[size_t(ty * level.tilesX + tx)]) out.insert({tx, ty});
    return out;
}

// The tiles of `level` the filter reads for the target's pixels: each pixel centre's taps reach
// `reach` level pixels along the level's axes (bilinear at LOD 0: half a texel).
std::set<std::pair<int64_t, int64_t>> tilesTapped(const LevelInfo& level, const Viewport& vp, double reach) {
    const iris::ViewTransform t = iris::ViewTransform::of(vp.view, vp.width, vp.height);
    std::set<std::pair<int64_t, int64_t>> out;
    for (uint32_t y = 0; y < vp.height; ++y) {
        for (uint32_t x = 0; x < vp.width; ++x) {
            const auto s = t.toSlide(x + 0.5, y + 0.5);
            for (double oy : {-reach, reach})
                for (double ox : {-reach, reach}) {
                    const double lx = s[0] / level.downsample + ox, ly = s[1] / level.downsample + oy;
                    if (lx < 0 || ly < 0 || lx >= double(level.width) || ly >= double(level.height)) continue;
                    out.insert({int64_t(lx) / iris::kTileSize, int64_t(ly) / iris::kTileSize});
                }
        }
    }
    return out;
}

DrawList build(const SlideInfo& s, const Viewport& vp, FakeMap& map, DrawOptions options = {}) {
    DrawList list;
    iris::render::buildDrawList(s, kGen, vp, options, map, list);
    return list;
}

} // namespace

class TestDrawList : public QObject {
    Q_OBJECT
private slots:
    void nothingResidentDrawsNothing();
    void allResidentCullsWhatHrCovers();
    void lrAloneIsWholeAndShows();
    void failingTilesShowThePlaceholder();
    void cullingNeverChangesAPixel();
    void slideEdgesKeepTheirCoarseTiles();
    void fieldOnTileBoundariesCullsCoarseTiles();
    void instanceBudget();
    void wrongSizeIsNeverComplete();
    void syntheticBase();
    void thumbnail();
    void zoomedInTilesNameTheirNeighbours();
    void tilesWithoutLevelsOnlyWhereLevelZeroIsRead();
    void exactLevels_data();
    void exactLevels();
    void viewTransformRoundTrips();
    void turnedViewsHaveNoHoles_data();
    void turnedViewsHaveNoHoles();
    void turnedBufferRegionFollowsTheFootprint();
    void turnedFootprintsHoldWhatTheFilterReads();
};

// Many small turned views at random: every tile the filter reads for some pixel (where the
// field's edge passes near a tile corner, a tap box corner lands in a tile the field does not
// overlap) is in the footprint, and the footprint holds no tile the filter never reads beyond
// one tile from the field.
void TestDrawList::turnedFootprintsHoldWhatTheFilterReads() {
    const SlideInfo s = scan();
    std::mt19937 rng(4242);
    std::uniform_real_distribution<double> u(0, 1);
    int cornerCases = 0;
    for (int i = 0; i < 1500; ++i) {
        const double ds = 0.6 + 3.3 * u(rng); // LOD 0 to 1.9 on level 0: a reach of 0.5 to 2 level pixels
        const Viewport vp{.view = {3000 + 14000 * u(rng), 3000 + 9000 * u(rng), ds, 360 * u(rng), u(rng) < 0.3},
                          .width = 96, .height = 72};
        const int hr = iris::chooseLevels(s, ds).hr;
        const LevelInfo& l = s.levels[size_t(hr)];
        const double lod = std::max(0.0, std::log2(ds / l.downsample));
        const iris::Footprint f = iris::footprint(l, vp, 0);
        const auto tapped = tilesTapped(l, vp, 0.5 * std::exp2(std::ceil(lod)));
        const auto under = tilesUnderTarget(l, vp);
        for (const auto& t : tapped)
            QVERIFY2(f.contains(t.first, t.second),
                     qPrintable(QString("view %1: tile (%2, %3) is read but not in the footprint").arg(i).arg(t.first).arg(t.second)));
        for (const auto& t : tapped) cornerCases += under.count(t) ? 0 : 1;
    }
    qInfo("%d tiles read only through a tap box's corner", cornerCases);
    QVERIFY2(cornerCases > 0, "no view put a tap across a tile corner: the case is not exercised");
}

// A level drawn 1:1 on whole pixels is drawn exactly (the tile pass fetches its texels, with no
// seam pass): drawsExact must hold exactly when every pixel centre the level's tiles cover maps,
// in the fragment shader's float arithmetic (tile_turn.glsl, tile.frag), onto a texel centre.
// Checked pixel by pixel, with the instances as the draw list makes them.
void TestDrawList::exactLevels_data() {
    QTest::addColumn<double>("cx");
    QTest::addColumn<double>("cy");
    QTest::addColumn<double>("downsample");
    QTest::addColumn<double>("rotation");
    QTest::addColumn<bool>("flipH");
    QTest::addColumn<uint32_t>("width");
    QTest::addColumn<bool>("exact");
    QTest::newRow("1:1 whole") << 10000.0 << 7000.0 << 1.0 << 0.0 << false << 320u << true;
    QTest::newRow("1:1 half a pixel off") << 10000.5 << 7000.0 << 1.0 << 0.0 << false << 320u << false;
    QTest::newRow("1:1 a quarter off") << 10000.0 << 7000.25 << 1.0 << 0.0 << false << 320u << false;
    QTest::newRow("1:1 odd width, half") << 10000.5 << 7000.0 << 1.0 << 0.0 << false << 321u << true;
    QTest::newRow("1:1 odd width, whole") << 10000.0 << 7000.0 << 1.0 << 0.0 << false << 321u << false;
    QTest::newRow("level 1 whole") << 10000.0 << 7000.0 << 4.0 << 0.0 << false << 320u << true;
    QTest::newRow("level 1 a level-0 pixel off") << 10001.0 << 7000.0 << 4.0 << 0.0 << false << 320u << false;
    QTest::newRow("level 2 (16.004)") << 10000.0 << 7000.0 << 16.004 << 0.0 << false << 320u << false;
    QTest::newRow("zoomed in 0.5") << 10000.0 << 7000.0 << 0.5 << 0.0 << false << 320u << false;
    QTest::newRow("between levels 1.37") << 10000.0 << 7000.0 << 1.37 << 0.0 << false << 320u << false;
    QTest::newRow("turned 90") << 10000.0 << 7000.0 << 1.0 << 90.0 << false << 320u << true;
    QTest::newRow("turned 90, odd width") << 10000.0 << 7000.0 << 1.0 << 90.0 << false << 321u << false;
    QTest::newRow("turned 90, odd width, half") << 10000.0 << 7000.5 << 1.0 << 90.0 << false << 321u << true;
    QTest::newRow("turned 180, flipped") << 10000.0 << 7000.0 << 1.0 << 180.0 << true << 320u << true;
    QTest::newRow("turned 270, flipped, off") << 10000.25 << 7000.0 << 1.0 << 270.0 << true << 320u << false;
    QTest::newRow("turned 30") << 10000.0 << 7000.0 << 1.0 << 30.0 << false << 320u << false;
}

void TestDrawList::exactLevels() {
    QFETCH(double, cx);
    QFETCH(double, cy);
    QFETCH(double, downsample);
    QFETCH(double, rotation);
    QFETCH(bool, flipH);
    QFETCH(uint32_t, width);
    QFETCH(bool, exact);
    const SlideInfo s = scan();
    FakeMap map;
    for (int li = 0; li < 3; ++li) map.addLevel(s, li);
    const Viewport vp{.view = {cx, cy, downsample, rotation, flipH}, .width = width, .height = 240};
    const DrawList list = build(s, vp, map);
    const LevelDraw& hr = list.levels[2];
    QVERIFY(hr.level >= 0 && !hr.instances.empty());
    QCOMPARE(iris::render::drawsExact(s.levels[size_t(hr.level)], vp), exact);
    QCOMPARE(hr.exact, exact);
    QCOMPARE(hr.linked, !exact); // an exact level has no seam bands, and names no neighbours
    for (const LevelDraw& d : list.levels)
        if (d.level >= 0 && d.level != hr.level) QVERIFY(!d.exact); // coarser levels are shrunk
    if (exact) QCOMPARE(map.pins, pinsOf(hr, s.levels[size_t(hr.level)], map)); // only the drawn tiles

    // The shader's mapping, in float: every covered pixel centre on a texel centre, or not.
    const iris::ViewTransform t = iris::ViewTransform::of(vp.view, vp.width, vp.height);
    const float m[4] = {float(t.m[0]), float(t.m[1]), float(t.m[2]), float(t.m[3])};
    const float c[2] = {float(t.targetCX), float(t.targetCY)};
    size_t covered = 0, onCentre = 0;
    for (uint32_t y = 0; y < vp.height; ++y) {
        for (uint32_t x = 0; x < vp.width; ++x) {
            const float px = float(x) + 0.5f - c[0], py = float(y) + 0.5f - c[1];
            const float ux = c[0] + (m[0] * px + m[2] * py), uy = c[1] + (m[1] * px + m[3] * py);
            for (const iris::gpu::TileInstance& i : hr.instances) {
                if (ux < i.rect[0] || ux >= i.rect[2] || uy < i.rect[1] || uy >= i.rect[3]) continue;
                const float tx = (ux - i.rect[0]) * i.scale, ty = (uy - i.rect[1]) * i.scale;
                ++covered;
                if (tx - std::floor(tx) == 0.5f && ty - std::floor(ty) == 0.5f) ++onCentre;
                if (exact) {
                    QCOMPARE(i.scale, 1.0f);
                    QCOMPARE(i.texel[3], 0.0f); // LOD 0
                    for (int k = 0; k < 4; ++k) QCOMPARE(i.sides[k], -1.0f);
                }
                break;
            }
        }
    }
    QVERIFY(covered > 0);
    if (exact) QCOMPARE(onCentre, covered);
    else QVERIFY(onCentre < covered);
}

void TestDrawList::viewTransformRoundTrips() {
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> u(0, 1);
    for (int i = 0; i < 2000; ++i) {
        iris::View v{u(rng) * 1e5, u(rng) * 1e5, 0.01 + u(rng) * 300, u(rng) * 720 - 360, u(rng) < 0.5, u(rng) < 0.5};
        const iris::ViewTransform t = iris::ViewTransform::of(v, 1000 + 999 * u(rng), 700 + 777 * u(rng));
        const double x = u(rng) * 3000 - 500, y = u(rng) * 3000 - 500;
        const auto s = t.toSlide(x, y);
        const auto back = t.toTarget(s[0], s[1]);
        QVERIFY2(std::abs(back[0] - x) < 1e-6 && std::abs(back[1] - y) < 1e-6, "target -> slide -> target");
        // The target's centre shows the view's centre, and M is orthonormal (a turn keeps scale).
        const auto c = t.toSlide(t.targetCX, t.targetCY);
        QCOMPARE(c[0], v.centerX);
        QCOMPARE(c[1], v.centerY);
        const auto one = t.toSlide(t.targetCX + 1, t.targetCY);
        QVERIFY(std::abs(std::hypot(one[0] - c[0], one[1] - c[1]) - v.downsample) < 1e-9 * v.downsample);
    }
    // Clockwise on screen: at 90° the slide's +x points down the target.
    const iris::ViewTransform q = iris::ViewTransform::of({100, 100, 1, 90}, 200, 200);
    const auto right = q.toTarget(101, 100);
    QCOMPARE(right[0], 100.0);
    QCOMPARE(right[1], 101.0);
    // Mirrored: at rotation 0 flipH swaps left and right, flipV top and bottom.
    const auto mirrored = iris::ViewTransform::of({100, 100, 1, 0, true, true}, 200, 200).toTarget(101, 99);
    QCOMPARE(mirrored[0], 99.0);
    QCOMPARE(mirrored[1], 101.0);
    // Right angles are exact: with the target's first pixel centre on a slide pixel centre,
    // every pixel centre lands on one.
    for (double r : {90.0, 180.0, 270.0, 450.0, -90.0}) {
        iris::View v{0, 0, 1, r, true};
        const auto first = iris::ViewTransform::of(v, 333, 257).toSlide(0.5, 0.5);
        v.centerX = 1000.5 - first[0];
        v.centerY = 2000.5 - first[1];
        const iris::ViewTransform e = iris::ViewTransform::of(v, 333, 257);
        QVERIFY(e.axisAligned());
        for (int k = 0; k < 50; ++k) {
            const auto s = e.toSlide(k * 7 + 0.5, k * 5 + 0.5);
            QCOMPARE(s[0] - std::floor(s[0]), 0.5);
            QCOMPARE(s[1] - std::floor(s[1]), 0.5);
        }
    }
    QCOMPARE(iris::normalizedRotation(-90), 270.0);
    QCOMPARE(iris::normalizedRotation(720), 0.0);
    QCOMPARE(iris::normalizedRotation(89.9999999999999), 90.0); // animated steps land on the right angle
    QCOMPARE(iris::normalizedRotation(std::nan("")), 0.0);
}

void TestDrawList::turnedViewsHaveNoHoles_data() {
    QTest::addColumn<double>("rotation");
    QTest::addColumn<bool>("flip");
    QTest::addColumn<double>("downsample");
    for (double r : {30.0, 45.0, 137.0, 217.5, 333.0})
        for (double ds : {1.0, 2.6})
            QTest::addRow("%.1f° ds %.1f", r, ds) << r << false << ds;
    QTest::newRow("30° flipped ds 1.7") << 30.0 << true << 1.7;
    QTest::newRow("90° ds 1.3") << 90.0 << false << 1.3;
}

void TestDrawList::turnedViewsHaveNoHoles() {
    QFETCH(double, rotation);
    QFETCH(bool, flip);
    QFETCH(double, downsample);
    const SlideInfo s = scan();
    FakeMap map;
    for (int li = 0; li < 3; ++li) map.addLevel(s, li);
    Viewport vp{.view = {9000.3, 6000.7, downsample, rotation, flip}, .width = 640, .height = 480};
    const DrawList list = build(s, vp, map);
    QVERIFY(list.hrComplete);
    QVERIFY(list.lrComplete);
    const int hr = iris::chooseLevels(s, downsample).hr;
    // Every pixel shows an HR tile: none of the field's corners is left to coarser levels.
    const std::vector<int> top = rasteriseTurned(instancesOf(list), vp);
    for (size_t i = 0; i < top.size(); ++i) {
        QVERIFY2(top[i] >= 0, "a pixel shows the background");
        QCOMPARE(TileKey::level(map.keyOf(top[i])), hr);
    }
    // Every HR tile the field touches is drawn and counted, and besides them only tiles the
    // filter reaches from a pixel centre (half a texel of the coarsest mip read, past a turned
    // field's edge: next to a touched tile), not the bounding range's corners; culling a coarse
    // tile never changes a pixel.
    const std::set<std::pair<int64_t, int64_t>> under = tilesUnderTarget(s.levels[size_t(hr)], vp);
    const LevelDraw& d = list.levels[2];
    QCOMPARE(size_t(list.hrTiles), d.instances.size());
    std::set<std::pair<int64_t, int64_t>> drawn;
    for (int64_t ty = d.range.y0; ty <= d.range.y1; ++ty)
        for (int64_t tx = d.range.x0; tx <= d.range.x1; ++tx)
            if (d.isDrawn(tx, ty)) drawn.insert({tx, ty});
    for (const auto& t : under) QVERIFY2(drawn.count(t), "a tile the field touches is not drawn");
    // So is every tile the filter reads for a pixel (a tap box corner across a tile corner).
    const double lod = std::max(0.0, std::log2(downsample / s.levels[size_t(hr)].downsample));
    for (const auto& t : tilesTapped(s.levels[size_t(hr)], vp, 0.5 * std::exp2(std::ceil(lod))))
        QVERIFY2(drawn.count(t), qPrintable(QString("tile (%1, %2), which the filter reads, is not drawn").arg(t.first).arg(t.second)));
    for (const auto& t : drawn) {
        bool next = false;
        for (const auto& u : under) next = next || (std::abs(u.first - t.first) <= 1 && std::abs(u.second - t.second) <= 1);
        QVERIFY2(next, "a tile away from the field is drawn");
    }
    qInfo("drawn %zu HR tiles, the field touches %zu, bounding range %lld", drawn.size(), under.size(),
          (long long)d.range.count());
    if (std::fmod(rotation, 90.0) != 0) QVERIFY(int64_t(drawn.size()) < d.range.count());
    DrawOptions all;
    all.drawCovered = true;
    QCOMPARE(rasteriseTurned(instancesOf(build(s, vp, map, all)), vp), top);
}

void TestDrawList::turnedBufferRegionFollowsTheFootprint() {
    const SlideInfo s = scan();
    for (double r : {30.0, 60.0, 200.0}) {
        const Viewport vp{.view = {9000.3, 6000.7, 2.2, r}, .width = 800, .height = 600};
        const int perimeter = 1;
        const std::vector<iris::TileRef> region = iris::bufferRegion(s, kGen, vp, perimeter);
        const iris::LevelChoice c = iris::chooseLevels(s, vp.view.downsample);
        for (int li : {c.hr, c.lr}) {
            const LevelInfo& l = s.levels[size_t(li)];
            const auto under = tilesUnderTarget(l, vp);
            std::set<std::pair<int64_t, int64_t>> listed;
            for (const iris::TileRef& t : region)
                if (t.level == li) listed.insert({t.tx, t.ty});
            // Every tile the field touches is buffered …
            for (const auto& t : under) QVERIFY2(listed.count(t), "a visible tile is missing from the buffer region");
            // … and nothing further from it than the perimeter (Chebyshev distance in tiles,
            // plus one for the footprint's growth along its own turned sides).
            for (const auto& t : listed) {
                int64_t best = INT64_MAX;
                for (const auto& v : under)
                    best = std::min(best, std::max(std::abs(v.first - t.first), std::abs(v.second - t.second)));
                QVERIFY2(best <= perimeter + 1, qPrintable(QString("tile (%1, %2) of level %3 is %4 tiles from the field")
                                                                .arg(t.first).arg(t.second).arg(li).arg(best)));
            }
            // The bounding range's corners are not loaded.
            const iris::TileRange box = iris::visibleTiles(l, vp, perimeter);
            QVERIFY(int64_t(listed.size()) < box.count());
        }
    }
}

void TestDrawList::nothingResidentDrawsNothing() {
    const SlideInfo s = scan();
    FakeMap map;
    const Viewport vp = viewport(10000, 7000, 2); // between level 0 (HR) and level 1 (LR)
    const DrawList list = build(s, vp, map);
    QCOMPARE(list.instanceCount(), 0u);
    QVERIFY(list.hasLr);
    QVERIFY(!list.hrComplete);
    QVERIFY(!list.lrComplete);
    QCOMPARE(list.hrTiles, uint32_t(iris::visibleTiles(s.levels[0], vp, 0).count()));
    QCOMPARE(list.lrTiles, uint32_t(iris::visibleTiles(s.levels[1], vp, 0).count()));
    QCOMPARE(list.levels[0].level, 2);
    QCOMPARE(list.levels[1].level, 1);
    QCOMPARE(list.levels[2].level, 0);
}

void TestDrawList::allResidentCullsWhatHrCovers() {
    const SlideInfo s = scan();
    FakeMap map;
    for (int li = 0; li < 3; ++li) map.addLevel(s, li);
    const Viewport vp = viewport(10000, 7000, 2);
    const DrawList culled = build(s, vp, map);
    QVERIFY(culled.hrComplete);
    QVERIFY(culled.lrComplete);
    // Inside the slide the HR tiles cover everything: no base or LR tile is drawn.
    QCOMPARE(culled.levels[0].instances.size(), size_t(0));
    QCOMPARE(culled.levels[1].instances.size(), size_t(0));
    QCOMPARE(uint32_t(culled.levels[2].instances.size()), culled.hrTiles);
    // Culled tiles are not pinned either: only HR's and, for its seams, their neighbours.
    QCOMPARE(map.pins, pinsOf(culled.levels[2], s.levels[0], map));
    // The newest upload among the drawn LR and HR tiles (what tells a revisit from a field
    // that loaded before its first frame: metrics/field_metrics).
    uint64_t newest = 0;
    for (const iris::gpu::TileInstance& t : culled.levels[2].instances)
        newest = std::max(newest, uint64_t(t.texel[2]) + 1000);
    QCOMPARE(culled.newestUpload, newest);

    const DrawList all = build(s, vp, map, DrawOptions{.drawCovered = true});
    QCOMPARE(all.instanceCount(), uint32_t(iris::visibleTiles(s.levels[0], vp, 0).count() +
                                           iris::visibleTiles(s.levels[1], vp, 0).count() +
                                           iris::visibleTiles(s.levels[2], vp, 0).count()));
    QCOMPARE(rasterise(instancesOf(culled), vp.width, vp.height), rasterise(instancesOf(all), vp.width, vp.height));
}

void TestDrawList::lrAloneIsWholeAndShows() {
    const SlideInfo s = scan();
    FakeMap map;
    map.addLevel(s, 1);
    map.addLevel(s, 2);
    const Viewport vp = viewport(10000, 7000, 2);
    const DrawList list = build(s, vp, map);
    QVERIFY(list.lrComplete);
    QVERIFY(!list.hrComplete);
    QCOMPARE(uint32_t(list.levels[1].instances.size()), list.lrTiles);
    QCOMPARE(list.levels[0].instances.size(), size_t(0)); // the base lies under LR
    // Every pixel shows an LR tile.
    for (int layer : rasterise(instancesOf(list), vp.width, vp.height)) {
        QVERIFY(layer >= 0);
        QCOMPARE(TileKey::level(map.keyOf(layer)), 1);
    }
}

// Tiles whose read failed for now (core/failing_tiles.h) are drawn with the placeholder's atlas
// layer where they are not resident, over what lies beneath (the LR level does not show through
// them), and the frame stays incomplete; without the placeholder resident they are left out as
// before, and a listed tile that is resident is drawn as itself.
void TestDrawList::failingTilesShowThePlaceholder() {
    const SlideInfo s = scan();
    const Viewport vp = viewport(10000, 7000, 2);
    const iris::TileRange hr = iris::visibleTiles(s.levels[0], vp, 0);
    QVERIFY(hr.x1 > hr.x0 && hr.y1 > hr.y0);
    const uint64_t ph = TileKey::make(kGen, 63, iris::kMaxTilesPerAxis - 1, iris::kMaxTilesPerAxis - 1);
    // All of LR and the base resident; HR resident but for its first row, whose tiles failed.
    FakeMap map;
    map.addLevel(s, 1);
    map.addLevel(s, 2);
    std::unordered_set<uint64_t> failing;
    for (int64_t ty = hr.y0; ty <= hr.y1; ++ty)
        for (int64_t tx = hr.x0; tx <= hr.x1; ++tx) {
            const uint64_t k = TileKey::make(kGen, 0, tx, ty);
            if (ty == hr.y0)
                failing.insert(k);
            else
                map.add(k);
        }
    // A listed tile that is resident after all (read since) is drawn as itself.
    const uint64_t readSince = TileKey::make(kGen, 0, hr.x0 + 1, hr.y0 + 1);
    failing.insert(readSince);
    const DrawOptions withFailing{.failing = &failing, .placeholder = ph};

    // The placeholder not resident yet: the failing row shows LR, as a tile merely missing does.
    const DrawList before = build(s, vp, map, withFailing);
    QCOMPARE(before.placeholderLayer, -1);
    QCOMPARE(before.placeholders, 0u);
    QVERIFY(!before.hrComplete);

    map.add(ph);
    const int phLayer = map.pin(ph);
    const DrawList list = build(s, vp, map, withFailing);
    QCOMPARE(list.placeholderLayer, phLayer);
    QCOMPARE(list.placeholders, uint32_t(hr.x1 - hr.x0 + 1));
    QVERIFY(!list.hrComplete); // the failing tiles are read again: not the complete frame
    QVERIFY(list.lrComplete);
    // Every pixel shows an HR tile: its own where resident, the placeholder on the failing row
    // (LR, all resident, never shows through).
    const std::vector<int> top = rasterise(instancesOf(list), vp.width, vp.height);
    int placeholderPixels = 0;
    for (uint32_t y = 0; y < vp.height; ++y)
        for (uint32_t x = 0; x < vp.width; ++x) {
            const int layer = top[size_t(y) * vp.width + x];
            QVERIFY(layer >= 0);
            const std::array<double, 2> at = {vp.view.centerX + (x + 0.5 - vp.width / 2.0) * vp.view.downsample,
                                              vp.view.centerY + (y + 0.5 - vp.height / 2.0) * vp.view.downsample};
            const int64_t ty = int64_t(at[1]) / iris::kTileSize;
            if (ty == hr.y0) {
                QCOMPARE(layer, phLayer);
                ++placeholderPixels;
            } else {
                QCOMPARE(TileKey::level(map.keyOf(layer)), 0);
                QVERIFY(map.keyOf(layer) != ph);
            }
        }
    QVERIFY(placeholderPixels > 0);
    // The read-since tile is drawn as itself; the placeholder never counts as a newest upload.
    QVERIFY(list.levels[2].isDrawn(hr.x0 + 1, hr.y0 + 1));
    QVERIFY(list.levels[2].layers[size_t((1) * (hr.x1 - hr.x0 + 1) + 1)] != phLayer);
    QVERIFY(list.newestUpload < uint64_t(phLayer) + 1000); // it has the highest layer of all

    // Without the list nothing changes: the row shows LR.
    const DrawList plain = build(s, vp, map);
    QCOMPARE(plain.placeholders, 0u);
    for (const iris::gpu::TileInstance& t : instancesOf(plain)) QVERIFY(int(t.texel[2]) != phLayer);
}

void TestDrawList::cullingNeverChangesAPixel() {
    // Random views (positions over and past the slide's edges, downsamples from zoomed-in
    // past 1:1 to the whole slide) and random residency: culled and uncut lists show the same
    // tile at every pixel, and agree on completeness.
    const SlideInfo s = scan();
    std::mt19937_64 rng(12);
    std::uniform_real_distribution<double> pos(-2000, 22000), logDs(std::log2(0.4), std::log2(80)), unit(0, 1);
    int culledSomething = 0;
    for (int round = 0; round < 300; ++round) {
        FakeMap map;
        // Each level: none, a random part, or all of it resident.
        const auto fraction = [&] {
            const double u = unit(rng);
            return u < 0.2 ? 0.0 : u < 0.6 ? 1.0 : unit(rng);
        };
        const double keep[3] = {fraction(), fraction(), round % 3 == 0 ? 1.0 : fraction()};
        for (int li = 0; li < 3; ++li) {
            const LevelInfo& l = s.levels[size_t(li)];
            for (int64_t y = 0; y < l.tilesY; ++y)
                for (int64_t x = 0; x < l.tilesX; ++x)
                    if (unit(rng) < keep[li]) map.add(TileKey::make(kGen, li, x, y));
        }
        const uint32_t w = 96 + uint32_t(unit(rng) * 300), h = 64 + uint32_t(unit(rng) * 200);
        const Viewport vp = viewport(pos(rng), pos(rng) * 0.75, std::exp2(logDs(rng)), w, h);
        const DrawList culled = build(s, vp, map);
        const DrawList all = build(s, vp, map, DrawOptions{.drawCovered = true});
        QVERIFY(culled.instanceCount() <= all.instanceCount());
        culledSomething += culled.instanceCount() < all.instanceCount();
        QCOMPARE(culled.hrComplete, all.hrComplete);
        QCOMPARE(culled.lrComplete, all.lrComplete);
        if (rasterise(instancesOf(culled), w, h) != rasterise(instancesOf(all), w, h))
            QFAIL(qPrintable(QStringLiteral("round %1: view (%2, %3) at %4 on %5x%6 shows other tiles when culled")
                                 .arg(round)
                                 .arg(vp.view.centerX)
                                 .arg(vp.view.centerY)
                                 .arg(vp.view.downsample)
                                 .arg(w)
                                 .arg(h)));
    }
    QVERIFY2(culledSomething > 60, "the random views hardly ever culled: the test lost its point");
}

void TestDrawList::slideEdgesKeepTheirCoarseTiles() {
    // The bottom-right corner of the slide, everything resident: coarse tiles along the edges
    // are drawn (their levels' extents round differently), and still no pixel changes.
    const SlideInfo s = scan();
    FakeMap map;
    for (int li = 0; li < 3; ++li) map.addLevel(s, li);
    const Viewport vp = viewport(19950, 14950, 2.5);
    const DrawList culled = build(s, vp, map);
    QVERIFY(culled.hrComplete);
    QVERIFY(culled.levels[0].instances.size() + culled.levels[1].instances.size() > 0);
    const DrawList all = build(s, vp, map, DrawOptions{.drawCovered = true});
    const std::vector<int> top = rasterise(instancesOf(culled), vp.width, vp.height);
    QCOMPARE(top, rasterise(instancesOf(all), vp.width, vp.height));
    // The pixel just inside the slide's corner shows level 0; the one past it the background.
    const int64_t cornerX = int64_t(std::floor(vp.width / 2.0 + (20000 - 19950) / 2.5)) - 1;
    const int64_t cornerY = int64_t(std::floor(vp.height / 2.0 + (15000 - 14950) / 2.5)) - 1;
    const int inside = top[size_t(cornerY * vp.width + cornerX)];
    QVERIFY(inside >= 0);
    QCOMPARE(TileKey::level(map.keyOf(inside)), 0);
    QCOMPARE(top[size_t((cornerY + 4) * vp.width + cornerX + 4)], -1); // (past the base level's rounded extent too)
}

void TestDrawList::fieldOnTileBoundariesCullsCoarseTiles() {
    // Fields whose edges lie on HR tile boundaries (a level's own scale on whole pixels with
    // the field at a multiple of 256: where iris-bench's walk and the widget's presets land),
    // and fields along the slide's top and left edges, everything resident: HR covers every
    // pixel of the slide, so no base or LR tile is drawn, and no pixel changes. (The one-pixel
    // margin of coveredBy once reached past the target into HR tiles outside the field, or past
    // the slide's top or left edge, and drew every coarse tile along that edge, and the base
    // level's one tile across the whole target.)
    const SlideInfo s = scan();
    FakeMap map;
    for (int li = 0; li < 3; ++li) map.addLevel(s, li);
    struct Case {
        double x0, y0, ds;
        uint32_t w, h;
    };
    for (const Case& c : {Case{2048, 1024, 1, 1920, 1024}, Case{2048 + 128, 1024, 1, 1920, 1080},
                          Case{4096, 2048, 4, 1024, 768}, Case{4096, 2048, 2, 1024, 512},
                          Case{2560, 1280, 1, 768, 512}, Case{15360, 0, 1, 1920, 1080},
                          Case{0, 1000.5, 1.5, 640, 480}, Case{-300, -200, 2.2, 800, 600}}) {
        const Viewport vp = viewport(c.x0 + c.w * c.ds / 2, c.y0 + c.h * c.ds / 2, c.ds, c.w, c.h);
        const DrawList culled = build(s, vp, map);
        QVERIFY(culled.hrComplete);
        QVERIFY(culled.lrComplete);
        const QByteArray where = QStringLiteral("field at (%1, %2), downsample %3, %4x%5")
                                     .arg(c.x0).arg(c.y0).arg(c.ds).arg(c.w).arg(c.h).toUtf8();
        QVERIFY2(culled.levels[0].instances.empty(), where.constData());
        QVERIFY2(culled.levels[1].instances.empty(), where.constData());
        QCOMPARE(uint32_t(culled.levels[2].instances.size()), culled.hrTiles);
        const DrawList all = build(s, vp, map, DrawOptions{.drawCovered = true});
        QVERIFY(all.levels[0].instances.size() + all.levels[1].instances.size() > 0);
        QCOMPARE(rasterise(instancesOf(culled), vp.width, vp.height), rasterise(instancesOf(all), vp.width, vp.height));
    }
}

void TestDrawList::instanceBudget() {
    const SlideInfo s = scan();
    FakeMap map;
    for (int li = 0; li < 3; ++li) map.addLevel(s, li);
    const Viewport vp = viewport(10000, 7000, 2);
    const DrawList list = build(s, vp, map, DrawOptions{.maxInstances = 5});
    QCOMPARE(list.instanceCount(), 5u);
    QCOMPARE(map.pins, pinsOf(list.levels[2], s.levels[0], map)); // the 5 and their neighbours
    QVERIFY(!list.hrComplete);
}

void TestDrawList::wrongSizeIsNeverComplete() {
    const SlideInfo s = scan();
    FakeMap map;
    for (int li = 0; li < 3; ++li) map.addLevel(s, li);
    const DrawList list = build(s, viewport(10000, 7000, 2), map, DrawOptions{.sizeMatches = false});
    QVERIFY(!list.hrComplete);
    QVERIFY(!list.lrComplete);
    QVERIFY(list.instanceCount() > 0); // drawn all the same
}

void TestDrawList::syntheticBase() {
    // One stored 8192² level (1024 tiles, too many to keep whole) and the synthetic levels the
    // engine computes down to a base it can keep: drawn like stored ones.
    SlideInfo s;
    s.width = s.height = 8192;
    s.levels = {level(8192, 8192, 1), level(2048, 2048, 4, true), level(512, 512, 16, true)};
    FakeMap map;
    map.addLevel(s, 2);
    const Viewport whole = viewport(4096, 4096, 32);
    const DrawList list = build(s, whole, map);
    QVERIFY(list.hrComplete);
    QCOMPARE(list.levels[2].level, 2); // HR is the base: drawn once
    QCOMPARE(list.levels[0].level, -1);
    QCOMPARE(list.instanceCount(), 4u);
    map.addLevel(s, 1);
    const DrawList closer = build(s, viewport(4096, 4096, 3), map); // HR level 0, LR synthetic level 1
    QVERIFY(closer.lrComplete);
    QVERIFY(!closer.hrComplete);
    QCOMPARE(closer.levels[1].level, 1);
}

void TestDrawList::thumbnail() {
    const SlideInfo s = scan(); // base 5×4 tiles: kept whole
    const Viewport thumb = viewport(10000, 7500, 100, 200, 150);
    FakeMap map;
    std::vector<iris::gpu::TileInstance> out;
    QVERIFY(!iris::render::appendThumbnail(s, kGen, 2, thumb, 10, 20, 100, map, out)); // waits for it
    QVERIFY(out.empty());
    map.addLevel(s, 2);
    QVERIFY(iris::render::appendThumbnail(s, kGen, 2, thumb, 10, 20, 100, map, out));
    QCOMPARE(out.size(), size_t(20));
    // Placed at the origin: the top-left tile starts there.
    QCOMPARE(out.front().rect[0], 10.0f + float(iris::placeTile(s.levels[2], thumb, 0, 0).x0));
    out.clear();
    QVERIFY(!iris::render::appendThumbnail(s, kGen, 2, thumb, 0, 0, 3, map, out)); // budget: incomplete
    QCOMPARE(out.size(), size_t(3));

    // A base too large to keep whole (a single 8192² level) is never waited for.
    SlideInfo big;
    big.width = big.height = 8192;
    big.levels = {level(8192, 8192, 1)};
    FakeMap none;
    out.clear();
    QVERIFY(iris::render::appendThumbnail(big, kGen, 1, viewport(4096, 4096, 64, 128, 128), 0, 0, 100, none, out));
}

// A resident tile whose mip levels are still to come (a host-written atlas makes them after the
// base level: BufferThread::completeMips) is drawn where its level is read at level 0 alone
// (lod 0: the level's own scale or enlarged) and left out where it is shrunk: not drawn, not
// named as a neighbour, the frame incomplete; the overview's thumbnail (shrunk) leaves it out.
void TestDrawList::tilesWithoutLevelsOnlyWhereLevelZeroIsRead() {
    const SlideInfo s = scan();
    FakeMap map;
    map.addLevel(s, 0);
    map.addLevel(s, 1);
    map.addLevel(s, 2);
    const uint64_t waiting = TileKey::make(kGen, 0, 20, 14); // the tile under (5200, 3700)
    map.withoutMips(waiting);
    const int layer = map.layerOf(waiting);
    const auto drawsLayer = [](const LevelDraw& d, int l) {
        return std::any_of(d.instances.begin(), d.instances.end(), [&](const auto& t) { return int(t.texel[2]) == l; });
    };
    const auto namesLayer = [](const LevelDraw& d, int l) {
        return std::any_of(d.instances.begin(), d.instances.end(), [&](const auto& t) {
            return std::any_of(std::begin(t.sides), std::end(t.sides), [&](float v) { return int(v) == l; }) ||
                   std::any_of(std::begin(t.corners), std::end(t.corners), [&](float v) { return int(v) == l; });
        });
    };
    for (const double ds : {1.0, 0.5}) { // the level's own scale, enlarged: level 0 alone is read
        const DrawList list = build(s, viewport(5200.3, 3700.6, ds, 640, 480), map);
        QCOMPARE(list.levels[2].level, 0);
        QVERIFY2(drawsLayer(list.levels[2], layer), qPrintable(QString("downsample %1").arg(ds)));
        QVERIFY(list.hrComplete);
    }
    const DrawList shrunk = build(s, viewport(5200.3, 3700.6, 1.7, 640, 480), map);
    QCOMPARE(shrunk.levels[2].level, 0);
    QVERIFY(!drawsLayer(shrunk.levels[2], layer));
    QVERIFY(!shrunk.hrComplete);
    // Its neighbours are drawn and linked, without it.
    QVERIFY(!shrunk.levels[2].instances.empty() && shrunk.levels[2].linked);
    QVERIFY(!namesLayer(shrunk.levels[2], layer));
    // Beside the view: not named as a neighbour when shrunk either.
    const DrawList beside =
        build(s, viewport(20 * 256 + 256 + 320 + 0.3, 14 * 256 + 100.6, 1.0 + 1.0 / 256, 640, 480), map);
    QVERIFY(!drawsLayer(beside.levels[2], layer));
    QVERIFY(!namesLayer(beside.levels[2], layer));
    // The thumbnail draws the base level shrunk: a base tile without its levels is left out.
    const uint64_t baseTile = TileKey::make(kGen, 2, 1, 1);
    map.withoutMips(baseTile);
    std::vector<iris::gpu::TileInstance> out;
    QVERIFY(!iris::render::appendThumbnail(s, kGen, 2, viewport(10000, 7500, 100, 200, 150), 0, 0, 100, map, out));
    QCOMPARE(out.size(), size_t(19));
}

// Each instance names the atlas layers of its eight neighbours in the level for the seam pass:
// drawn tiles as drawn, tiles just outside the view pinned when resident, -1 past the slide's
// edge and where a tile is not resident; zoomed in past 1:1 (LOD 0) and shrunk (LOD 1) alike.
void TestDrawList::zoomedInTilesNameTheirNeighbours() {
    const SlideInfo s = scan();
    FakeMap map;
    map.addLevel(s, 2);
    const LevelInfo& l0 = s.levels[0];
    // Level 0 resident except tile (3, 1); the view shows its top-left corner at 2x.
    for (int64_t y = 0; y < l0.tilesY; ++y)
        for (int64_t x = 0; x < l0.tilesX; ++x)
            if (!(x == 3 && y == 1)) map.add(TileKey::make(kGen, 0, x, y));
    const Viewport vp = viewport(550 + 3.3, 250 + 1.7, 0.5, 2200, 1000); // level-0 tiles 0-4 × 0-1 in view
    const DrawList list = build(s, vp, map);
    const LevelDraw& hr = list.levels[2];
    QCOMPARE(hr.level, 0);
    QVERIFY(hr.linked);
    QVERIFY(!hr.instances.empty());
    const auto layerOf = [&](int64_t x, int64_t y) {
        if (x < 0 || y < 0 || x >= l0.tilesX || y >= l0.tilesY || (x == 3 && y == 1)) return -1.0f;
        for (int layer = 0;; ++layer)
            if (map.keyOf(layer) == TileKey::make(kGen, 0, x, y)) return float(layer);
    };
    size_t k = 0;
    for (int64_t ty = hr.range.y0; ty <= hr.range.y1; ++ty) {
        for (int64_t tx = hr.range.x0; tx <= hr.range.x1; ++tx) {
            if (!hr.isDrawn(tx, ty)) continue;
            const iris::gpu::TileInstance& t = hr.instances[k++];
            QCOMPARE(t.texel[2], layerOf(tx, ty));
            const float sides[4] = {layerOf(tx - 1, ty), layerOf(tx + 1, ty), layerOf(tx, ty - 1), layerOf(tx, ty + 1)};
            const float corners[4] = {layerOf(tx - 1, ty - 1), layerOf(tx + 1, ty - 1), layerOf(tx - 1, ty + 1),
                                      layerOf(tx + 1, ty + 1)};
            for (int i = 0; i < 4; ++i) {
                QCOMPARE(t.sides[i], sides[i]);
                QCOMPARE(t.corners[i], corners[i]);
            }
        }
    }
    QCOMPARE(k, hr.instances.size());
    QVERIFY(hr.range.x0 == 0 && hr.range.y0 == 0); // the slide's edge is in view: -1 there was checked
    QVERIFY(hr.range.contains(3, 1));               // and so is the missing tile

    // Shrunk (LOD 1), the seams are filtered across too (through the mips): the same names.
    const DrawList shrunk = build(s, viewport(10000, 7000, 2), map);
    const LevelDraw& small = shrunk.levels[2];
    QCOMPARE(small.level, 0);
    QVERIFY(small.linked);
    QVERIFY(!small.instances.empty());
    k = 0;
    for (int64_t ty = small.range.y0; ty <= small.range.y1; ++ty) {
        for (int64_t tx = small.range.x0; tx <= small.range.x1; ++tx) {
            if (!small.isDrawn(tx, ty)) continue;
            const iris::gpu::TileInstance& t = small.instances[k++];
            QCOMPARE(t.texel[3], 1.0f);
            QCOMPARE(t.sides[0], layerOf(tx - 1, ty));
            QCOMPARE(t.sides[1], layerOf(tx + 1, ty));
            QCOMPARE(t.corners[3], layerOf(tx + 1, ty + 1));
        }
    }
    QCOMPARE(k, small.instances.size());
}

QTEST_APPLESS_MAIN(TestDrawList)
#include "tst_draw_list.moc"
