// Raster layers drawn by the engine (issue 19): every pixel of a frame with layers equals the
// frame without them with iris::shadeLayerAt blended over by iris::blendOver (the CPU reference
// in engine/src/layers/shading.cpp), within ±2 codes, at 1:1, zoomed in, at non-integer
// downsamples, turned and mirrored, for scalar maps (bilinear and nearest, NaN holes, threshold,
// window), label maps (class colours and visibility), RGBA maps and several layers stacked.
// Where the reference itself changes colour within a hair of a pixel's centre (the edge of a
// checkerboard square at a non-integer downsample), the GPU may take the neighbour's side: such
// a pixel must then equal the reference at a point at most one screen pixel away. Also: a map
// whose level a view cannot hold within the budget is refused with a warning, replacing a map
// shows the new one, and a removed layer leaves the frame as it was without it.
#include <QtTest>

#include <cmath>
#include <limits>

#include "iris/layers.h"
#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;

namespace {

constexpr uint32_t kW = 300, kH = 220;

// A smooth scalar field with NaN holes and a range of 0..1.
std::shared_ptr<const iris::RasterMap> scalarMap(int w, int h, bool holes) {
    std::vector<float> v(size_t(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float f = 0.5f + 0.5f * std::sin(x * 0.21f) * std::cos(y * 0.17f);
            if (holes && (x / 5 + y / 7) % 9 == 0) f = std::numeric_limits<float>::quiet_NaN();
            v[size_t(y) * w + x] = f;
        }
    auto m = iris::fromHostMemory(std::span<const float>(v), w, h, "scalar");
    return m ? std::make_shared<const iris::RasterMap>(std::move(*m)) : nullptr;
}

// A checkerboard of class ids 1 and 2 with squares of `k` map pixels (and id 3 in a corner).
std::shared_ptr<const iris::RasterMap> checkerboard(int w, int h, int k) {
    std::vector<uint16_t> v(size_t(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) v[size_t(y) * w + x] = uint16_t(x < k && y < k ? 3 : 1 + ((x / k + y / k) % 2));
    auto m = iris::fromHostMemory(std::span<const uint16_t>(v), w, h, "checkerboard");
    return m ? std::make_shared<const iris::RasterMap>(std::move(*m)) : nullptr;
}

std::shared_ptr<const iris::RasterMap> rgbaMap(int w, int h) {
    std::vector<uint8_t> v(size_t(w) * h * 4);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            uint8_t* p = &v[(size_t(y) * w + x) * 4];
            p[0] = uint8_t(x * 255 / std::max(1, w - 1)), p[1] = uint8_t(y * 255 / std::max(1, h - 1));
            p[2] = uint8_t((x * 7 + y * 3) % 256), p[3] = uint8_t((x + y) % 3 == 0 ? 0 : 60 + (x * y) % 190);
        }
    auto m = iris::fromHostMemoryRgba(std::span<const uint8_t>(v), w, h, "rgba");
    return m ? std::make_shared<const iris::RasterMap>(std::move(*m)) : nullptr;
}

} // namespace

class TestLayersRender : public QObject {
    Q_OBJECT

    TestEngine e_;
    iris::SlideInfo info_;

    // The frame of `view` with the engine's current layers, and without any.
    std::optional<iris::Frame> frameOf(const iris::View& view, std::string* why) {
        return renderView(*e_.engine, view, kW, kH, 60s, why);
    }

    // The reference: the frame without layers with each layer of `layers` blended over, at each
    // pixel's centre. `ambiguous` marks pixels whose reference changes within one screen pixel.
    iris::Image reference(const iris::Image& base, const iris::View& view,
                          const std::vector<iris::Engine::LayerEntry>& layers, std::vector<uint8_t>* ambiguous) {
        iris::Image out = base;
        const iris::ViewTransform t = iris::ViewTransform::of(view, kW, kH);
        const auto shadeAt = [&](double px, double py, std::array<uint8_t, 3> dst) {
            const auto s = t.toSlide(px, py);
            for (const auto& l : layers) {
                const iris::Placement p = l.placement ? *l.placement
                                                      : iris::Placement::spanning(l.map->width(), l.map->height(),
                                                                                  info_.width, info_.height);
                dst = iris::blendOver(dst, iris::shadeLayerAt(*l.map, p, l.style, s[0], s[1], view.downsample));
            }
            return dst;
        };
        if (ambiguous) ambiguous->assign(size_t(kW) * kH, 0);
        for (uint32_t y = 0; y < kH; ++y)
            for (uint32_t x = 0; x < kW; ++x) {
                const uint8_t* b = pixel(base, x, y);
                const std::array<uint8_t, 3> dst{b[0], b[1], b[2]};
                const auto c = shadeAt(x + 0.5, y + 0.5, dst);
                uint8_t* o = pixel(out, x, y);
                o[0] = c[0], o[1] = c[1], o[2] = c[2];
                if (ambiguous) {
                    for (auto [dx, dy] : {std::array<double, 2>{0.02, 0}, {-0.02, 0}, {0, 0.02}, {0, -0.02}}) {
                        if (shadeAt(x + 0.5 + dx, y + 0.5 + dy, dst) != c) (*ambiguous)[size_t(y) * kW + x] = 1;
                    }
                }
            }
        return out;
    }

    // Frame vs reference: every pixel within 2 codes, or (ambiguous pixels) equal within 2 codes
    // to the reference at some point at most one screen pixel away.
    void compare(const iris::Image& frame, const iris::Image& base, const iris::View& view,
                 const std::vector<iris::Engine::LayerEntry>& layers, const std::string& what) {
        std::vector<uint8_t> ambiguous;
        const iris::Image ref = reference(base, view, layers, &ambiguous);
        const iris::ViewTransform t = iris::ViewTransform::of(view, kW, kH);
        uint64_t bad = 0, nearEdges = 0, changed = 0;
        for (uint32_t y = 0; y < kH; ++y)
            for (uint32_t x = 0; x < kW; ++x) {
                const uint8_t *f = pixel(frame, x, y), *r = pixel(ref, x, y), *b = pixel(base, x, y);
                changed += r[0] != b[0] || r[1] != b[1] || r[2] != b[2];
                const auto close = [&](const uint8_t* q) {
                    return std::abs(f[0] - q[0]) <= 2 && std::abs(f[1] - q[1]) <= 2 && std::abs(f[2] - q[2]) <= 2;
                };
                if (close(r)) continue;
                bool ok = false;
                if (ambiguous[size_t(y) * kW + x]) {
                    // Some point within one screen pixel whose reference the GPU matches.
                    for (int j = -4; j <= 4 && !ok; ++j)
                        for (int i = -4; i <= 4 && !ok; ++i) {
                            const double px = x + 0.5 + i * 0.25, py = y + 0.5 + j * 0.25;
                            const auto s = t.toSlide(px, py);
                            std::array<uint8_t, 3> dst{b[0], b[1], b[2]};
                            for (const auto& l : layers) {
                                const iris::Placement p =
                                    l.placement ? *l.placement
                                                : iris::Placement::spanning(l.map->width(), l.map->height(), info_.width,
                                                                            info_.height);
                                dst = iris::blendOver(dst, iris::shadeLayerAt(*l.map, p, l.style, s[0], s[1], view.downsample));
                            }
                            ok = close(dst.data());
                        }
                }
                if (ok) {
                    ++nearEdges;
                    continue;
                }
                if (++bad <= 5)
                    qWarning("%s: pixel (%u, %u) is %d %d %d, the reference %d %d %d (without layers %d %d %d)", what.c_str(),
                             x, y, f[0], f[1], f[2], r[0], r[1], r[2], b[0], b[1], b[2]);
            }
        qInfo("%s: %llu pixels changed by the layers, %llu matched within one pixel of an edge", what.c_str(),
              (unsigned long long)changed, (unsigned long long)nearEdges);
        if (bad) {
            const std::string where = saveFailureArtefacts("layers-" + what, frame, ref, nullptr);
            QFAIL((what + ": " + std::to_string(bad) + " pixels differ from the reference; " + where).c_str());
        }
        QVERIFY2(changed > 0, (what + ": the layers changed no pixel of the reference: the view shows none").c_str());
    }

    // Renders `views` with `layers` shown, then without, and compares each.
    void check(const std::vector<iris::Engine::LayerEntry>& layers, const std::vector<iris::View>& views,
               const std::string& what) {
        e_->clearLayers();
        for (const auto& l : layers) {
            auto id = e_->addLayer(l.map, l.style, l.placement);
            QVERIFY2(id.ok(), describe(id.error()).c_str());
        }
        // The maps as the engine draws them: a large single-level map was given coarser levels.
        const std::vector<iris::Engine::LayerEntry> shown = e_->layers();
        QCOMPARE(shown.size(), layers.size());
        std::vector<iris::Frame> with;
        std::string why;
        for (const iris::View& v : views) {
            auto f = frameOf(v, &why);
            QVERIFY2(f.has_value(), why.c_str());
            with.push_back(std::move(*f));
        }
        e_->clearLayers();
        for (size_t i = 0; i < views.size(); ++i) {
            auto base = frameOf(views[i], &why);
            QVERIFY2(base.has_value(), why.c_str());
            compare(with[i].image, base->image, views[i], shown, what + " view " + std::to_string(i));
            if (QTest::currentTestFailed()) return;
        }
    }

    std::vector<iris::View> views() const {
        const double w = info_.width, h = info_.height;
        std::vector<iris::View> v{
            viewWithOrigin(w * 0.3, h * 0.3, 1.0, kW, kH),    // 1:1
            viewWithOrigin(w * 0.45, h * 0.2, 0.37, kW, kH),  // zoomed in
            iris::View{w * 0.5, h * 0.5, 1.7},                // between levels
            iris::View{w * 0.5, h * 0.5, 4.0},
            iris::View{w * 0.6, h * 0.4, 2.3, 30.0},          // turned
        };
        iris::View m{w * 0.4, h * 0.6, 3.1, 90.0};
        m.flipH = true;
        v.push_back(m); // turned a right angle and mirrored
        v.push_back(e_->fitView());
        return v;
    }

private Q_SLOTS:
    void initTestCase() {
        e_ = createTestEngine();
        QVERIFY2(e_, describe(e_.error).c_str());
        const auto sample = sampleSlidePath();
        if (!sample) QSKIP("no sample slide");
        QVERIFY(e_->bindOffscreen(kW, kH).ok());
        QVERIFY(e_->open(sample->string()).ok());
        info_ = *e_->slideInfo();
    }
    void init() { e_.beginTest(); }
    void cleanup() {
        e_->clearLayers();
        const std::string why = e_.endTest();
        QVERIFY2(why.empty(), why.c_str());
    }
    void cleanupTestCase() {
        const std::string why = e_.finish();
        QVERIFY2(why.empty(), why.c_str());
    }

    // A patch-level probability map spanning the slide (one map pixel = 224 level-0 pixels,
    // the common convention), bilinear, with NaN holes, a threshold and a window.
    void scalarSpanningTheSlide() {
        auto map = scalarMap(int(info_.width / 224) + 1, int(info_.height / 224) + 1, true);
        QVERIFY(map);
        iris::LayerStyle style;
        style.opacity = 0.6;
        style.threshold = 0.2;
        style.low = 0.1, style.high = 0.9;
        check({{0, map, style, std::nullopt}}, views(), "scalar bilinear");
        style.sampling = iris::LayerSampling::Nearest;
        style.colorMap = iris::ColorMap::magma();
        check({{0, map, style, std::nullopt}}, views(), "scalar nearest");
    }

    // A map larger than one chunk (several chunks, their seams) placed turned and scaled; it has
    // one level over 1024 pixels, so the engine draws it with the coarser levels it adds.
    void scalarAcrossChunksTurned() {
        auto map = scalarMap(1300, 900, false);
        QVERIFY(map);
        iris::LayerStyle style;
        style.opacity = 0.8;
        style.colorMap = iris::ColorMap::jet();
        const iris::Placement place = iris::Placement::scaleRotateOffset(2.5, 2.5, 20.0, info_.width * 0.25, info_.height * 0.1);
        check({{0, map, style, place}}, views(), "scalar chunks turned");
        QVERIFY(e_->layers().empty());
        QVERIFY(e_->addLayer(map, style, place).ok());
        QCOMPARE(e_->layers().front().map->levels.size(), size_t(3)); // 1300, 650, 325 wide
        // The same map added again, or set on another layer, shares the first one's pyramid;
        // a copy of it (another map) gets its own.
        QVERIFY(e_->addLayer(map, style).ok());
        const auto second = e_->layers().back().map;
        QCOMPARE(second.get(), e_->layers().front().map.get());
        auto copy = std::make_shared<const iris::RasterMap>(*map);
        QVERIFY(e_->setLayerMap(e_->layers().back().id, copy).ok());
        QVERIFY(e_->layers().back().map.get() != e_->layers().front().map.get());
        QVERIFY(e_->setLayerMap(e_->layers().back().id, map).ok());
        QCOMPARE(e_->layers().back().map.get(), e_->layers().front().map.get());
    }

    // A label checkerboard of 64-pixel squares aligned to the slide's level-0 grid (placement:
    // the identity, offset 0) lands on exactly the slide pixels it should at every level
    // downsample and between them (within one screen pixel where an edge passes a pixel centre).
    void labelCheckerboardAligned() {
        auto map = checkerboard(int(info_.width), int(info_.height) / 2, 64);
        QVERIFY(map);
        iris::LayerStyle style;
        style.opacity = 1.0;
        style.classes = iris::defaultLabelClasses(4);
        style.classes[3].visible = false;
        std::vector<iris::View> v = views();
        for (const iris::LevelInfo& l : info_.levels) v.push_back(iris::View{info_.width * 0.3, info_.height * 0.3, l.downsample});
        check({{0, map, style, iris::Placement{}}}, v, "label checkerboard");
    }

    // An RGBA map and a scalar and a label map of different resolutions, stacked.
    void stackedLayers() {
        auto rgba = rgbaMap(97, 61);
        auto scalar = scalarMap(40, 30, true);
        auto labels = checkerboard(300, 200, 16);
        QVERIFY(rgba && scalar && labels);
        iris::LayerStyle a;
        a.opacity = 0.7;
        iris::LayerStyle b;
        b.opacity = 0.4;
        b.colorMap = iris::ColorMap::gray();
        iris::LayerStyle c;
        c.opacity = 0.35;
        c.classes = iris::defaultLabelClasses(3);
        check({{0, rgba, a, std::nullopt},
               {0, scalar, b, std::nullopt},
               {0, labels, c, iris::Placement::scaleRotateOffset(7.0, 7.0, 0.0, 300.0, 200.0)}},
              views(), "stacked");
        a.sampling = iris::LayerSampling::Nearest;
        check({{0, rgba, a, std::nullopt}}, {views()[1], views()[2]}, "rgba nearest");
    }

    // setLayerMap shows the new map; removeLayer leaves the frame without it; a map the budget
    // cannot hold is refused with a warning and nothing else changes.
    void replaceRemoveAndRefuse() {
        const iris::View v = views()[2];
        std::string why;
        auto plain = frameOf(v, &why);
        QVERIFY2(plain.has_value(), why.c_str());
        iris::LayerStyle style;
        style.opacity = 0.5;
        auto id = e_->addLayer(scalarMap(50, 40, false), style);
        QVERIFY(id.ok());
        auto first = frameOf(v, &why);
        QVERIFY2(first.has_value(), why.c_str());
        QVERIFY(compareImages(first->image, plain->image).differing > 0);
        QVERIFY(e_->setLayerMap(*id, scalarMap(80, 10, false)).ok());
        auto second = frameOf(v, &why);
        QVERIFY2(second.has_value(), why.c_str());
        QVERIFY(compareImages(second->image, first->image).differing > 0);
        QCOMPARE(e_->setLayerMap(*id + 1000, scalarMap(2, 2, false)).status(), iris::Status::NotFound);
        QCOMPARE(e_->addLayer(nullptr).error().status(), iris::Status::InvalidArgument);
        e_->removeLayer(*id);
        auto none = frameOf(v, &why);
        QVERIFY2(none.has_value(), why.c_str());
        QCOMPARE(compareImages(none->image, plain->image).differing, uint64_t(0));
        // A map given with two levels, the coarser still 6500 × 6500 floats: the fit view would
        // need 170 MiB of it, more than half the layer budget: refused with a warning, the
        // frame as without it.
        std::vector<iris::RasterLevel> levels(2);
        levels[0].width = levels[0].height = 7000;
        levels[0].scalar.assign(size_t(7000) * 7000, 0.5f);
        levels[1].width = levels[1].height = 6500;
        levels[1].scalar.assign(size_t(6500) * 6500, 0.5f);
        auto big = iris::fromHostMemory(iris::RasterKind::Scalar, std::move(levels));
        QVERIFY2(big.ok(), big.ok() ? "" : big.error().message().c_str());
        QVERIFY(e_->addLayer(std::make_shared<const iris::RasterMap>(std::move(*big)), style).ok());
        auto refused = frameOf(e_->fitView(), &why);
        QVERIFY2(refused.has_value(), why.c_str());
        e_->clearLayers();
        auto fit = frameOf(e_->fitView(), &why);
        QVERIFY2(fit.has_value(), why.c_str());
        QCOMPARE(compareImages(refused->image, fit->image).differing, uint64_t(0));
    }
};

QTEST_GUILESS_MAIN(TestLayersRender)
#include "tst_layers_render.moc"
