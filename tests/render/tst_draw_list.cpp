// Unit tests of the frame's draw list (render/draw_list): which tiles are drawn, which are
// culled, and when the LR and HR layers are whole, against a fake tile map. A CPU rasteriser
// (pixel centres, painter's order: what the tile pipeline does) checks what each target pixel
// shows: culling must never change it.
#include <QtTest>

#include <set>

#include <cmath>
#include <random>
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
    int pins = 0;

private:
    std::unordered_map<uint64_t, int> layers_;
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
// next to a drawn one (8-connected) that are not drawn themselves (the seam pass's neighbours).
int pinsOf(const LevelDraw& d, const LevelInfo& level, const FakeMap& map) {
    std::set<std::pair<int64_t, int64_t>> pinned;
    for (int64_t ty = d.range.y0; ty <= d.range.y1; ++ty)
        for (int64_t tx = d.range.x0; tx <= d.range.x1; ++tx) {
            if (!d.isDrawn(tx, ty)) continue;
            for (int64_t y = ty - 1; y <= ty + 1; ++y)
                for (int64_t x = tx - 1; x <= tx + 1; ++x)
                    if (x >= 0 && y >= 0 && x < level.tilesX && y < level.tilesY &&
                        map.isActive(TileKey::make(kGen, d.level, x, y)))
                        pinned.insert({x, y});
        }
    return int(pinned.size());
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
    void cullingNeverChangesAPixel();
    void slideEdgesKeepTheirCoarseTiles();
    void instanceBudget();
    void wrongSizeIsNeverComplete();
    void syntheticBase();
    void thumbnail();
    void zoomedInTilesNameTheirNeighbours();
};

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
