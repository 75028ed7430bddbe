// Raster layers aligned to slides whose pyramid levels are not powers of two (issue 19,
// "Alignment"): a checkerboard map of patch size k aligned to the slide's grid lands on exactly
// the slide pixels it should, at every level's downsample, at non-integer downsamples (within
// one screen pixel) and pan offsets, on slides whose level factors are not powers of two.
//
// The suite writes two tiled generic TIFF slides (uncompressed 8-bit RGB, 256-px tiles; the
// engine reads them with its TIFF tile reader, OpenSlide giving the levels): level factors
// 1, 3, 9 (5760 × 4032, every level exact), and 1, 2.5, 6.25 with the level sides rounded as a
// writer rounds them (6007 × 4003, 2403 × 1601, 961 × 640; OpenSlide reports the mean of the
// two axes' factors, 2.50005 and 6.25273). Both are large enough that no level is smaller than
// a tile (SOURCES.md's warning about OpenSlide 3.4.1 on small generic-TIFF levels).
//
// Alignment is two facts, each checked against the level-0 point ViewTransform gives a screen
// pixel's centre:
//  1. The slide is drawn where the view says. The picture is a function of the level-0
//     position (triangle waves, linear between kinks), each level's pixel holding it at the
//     pixel's centre, so a frame pixel's value says which level-0 point it shows. Where a
//     view's screen pixels fall on a level's pixel centres the frame equals the level's pixels
//     byte for byte (and the background outside). Everywhere else, away from the kinks and the
//     edges, every channel is within 3 codes of what the pixel should show (shown 1:1 with a
//     sub-pixel pan: the bilinear interpolation of the stored pixels, rounded; shrunk: the
//     picture), and the mean offset (least squares over the ramps) is below a tenth of a screen
//     pixel; a 0.2-pixel shift of the reference reads as 0.18. The engine draws level L at its
//     one downsample d_L, so on a level whose sides were rounded, level-0 point p shows the
//     picture at p · (W0/w_L) / d_L: that drift is where the file itself disagrees with any
//     single downsample; it is computed, reported (0.30 screen px at most here, at 6.25 in the
//     bottom-right corner) and must stay within one screen pixel.
//  2. The layer is drawn where the view says: every pixel of a frame with layers equals the
//     frame without them with iris::shadeLayerAt blended over (iris::blendOver) at the pixel's
//     centre within ±2 codes; where the reference changes within a hair of the centre (the
//     edge of a checkerboard square) the pixel must equal the reference at some point at most
//     one screen pixel away (tst_layers_render.cpp's rule). Maps: label checkerboards of
//     k = 64 and of k = 45 (not a power of two) with the identity
//     placement (one map pixel per level-0 pixel) and spanning the slide (one map pixel per
//     patch, Placement::spanning, so a patch measures W0/ceil(W0/k)), and a scalar map of
//     224-px patches on the patch grid, bilinear.
// Views: every level's downsample and 1.7, 4.4 and 13 (between and beyond the levels), each at
// four pans: interior on the level grid, interior shifted by a fraction of a screen pixel, the
// slide's top-left corner in view, and its bottom-right corner shifted by a fraction.
#include <QtTest>

#include <tiffio.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "iris/layers.h"
#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;

namespace {

constexpr uint32_t kW = 300, kH = 220;
constexpr uint32_t kTile = 256;

// A slide the suite writes: level 0's size and each level's nominal factor. A level's side is
// level 0's divided by the factor, rounded to nearest.
struct SlideSpec {
    const char* name;
    int64_t width, height;
    std::vector<double> factors;
    int64_t levelWidth(size_t l) const { return std::llround(double(width) / factors[l]); }
    int64_t levelHeight(size_t l) const { return std::llround(double(height) / factors[l]); }
};
const SlideSpec kSlides[] = {
    {"factors 1, 3, 9", 5760, 4032, {1, 3, 9}},
    {"factors 1, 2.5, 6.25 rounded", 6007, 4003, {1, 2.5, 6.25}},
};

// The picture: R a triangle wave along x (period 372 level-0 pixels, about 1.37 codes a
// pixel), G one along y (period 315, about 1.62), B a steeper one along x (period 97, about
// 5.26). Linear between kinks, so bilinear taps and box mips give the function itself back
// there. The slopes are far from simple fractions, so that the rounding of the stored and the
// shown values averages out over a frame rather than repeating one error on every pixel (with
// a slope of 2, a shrunk view would read it as an offset).
constexpr double kPeriodR = 372, kPeriodG = 315, kPeriodB = 97;
double tri(double v, double period) {
    const double f = v / period - std::floor(v / period);
    return 255.0 * (1.0 - std::abs(2.0 * f - 1.0));
}
double triSlope(double v, double period) {
    const double f = v / period - std::floor(v / period);
    return f < 0.5 ? 510.0 / period : -510.0 / period;
}
// Distance from v to the nearest kink of tri(·, period).
double kinkDistance(double v, double period) {
    const double h = period / 2;
    return std::abs(v - h * std::round(v / h));
}
std::array<double, 3> picture(double x, double y) { return {tri(x, kPeriodR), tri(y, kPeriodG), tri(x, kPeriodB)}; }
// Pixel (i, j) of level l: the picture at the pixel's centre; the level covers level 0's whole
// extent, so its pixel measures W0/w × H0/h level-0 pixels.
std::array<uint8_t, 3> levelPixel(const SlideSpec& s, size_t l, int64_t i, int64_t j) {
    const double sx = double(s.width) / double(s.levelWidth(l)), sy = double(s.height) / double(s.levelHeight(l));
    const auto c = picture((double(i) + 0.5) * sx, (double(j) + 0.5) * sy);
    return {uint8_t(std::lround(c[0])), uint8_t(std::lround(c[1])), uint8_t(std::lround(c[2]))};
}

bool writeSlide(const std::string& path, const SlideSpec& s, std::string* why) {
    TIFF* tif = TIFFOpen(path.c_str(), "w");
    if (!tif) return *why = "TIFFOpen failed for " + path, false;
    std::vector<uint8_t> tile(size_t(kTile) * kTile * 3);
    for (size_t l = 0; l < s.factors.size(); ++l) {
        const auto w = uint32_t(s.levelWidth(l)), h = uint32_t(s.levelHeight(l));
        TIFFSetField(tif, TIFFTAG_SUBFILETYPE, l == 0 ? 0 : FILETYPE_REDUCEDIMAGE);
        TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, w);
        TIFFSetField(tif, TIFFTAG_IMAGELENGTH, h);
        TIFFSetField(tif, TIFFTAG_TILEWIDTH, kTile);
        TIFFSetField(tif, TIFFTAG_TILELENGTH, kTile);
        TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, 8);
        TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, 3);
        TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_RGB);
        TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
        TIFFSetField(tif, TIFFTAG_COMPRESSION, COMPRESSION_NONE);
        // R and B depend on the column only, G on the row only.
        std::vector<std::array<uint8_t, 3>> col(w), row(h);
        for (uint32_t x = 0; x < w; ++x) col[x] = levelPixel(s, l, x, 0);
        for (uint32_t y = 0; y < h; ++y) row[y] = levelPixel(s, l, 0, y);
        for (uint32_t ty = 0; ty < h; ty += kTile)
            for (uint32_t tx = 0; tx < w; tx += kTile) {
                std::fill(tile.begin(), tile.end(), 0);
                for (uint32_t y = ty; y < std::min(h, ty + kTile); ++y) {
                    uint8_t* d = &tile[size_t(y - ty) * kTile * 3];
                    for (uint32_t x = tx; x < std::min(w, tx + kTile); ++x, d += 3)
                        d[0] = col[x][0], d[1] = row[y][1], d[2] = col[x][2];
                }
                if (TIFFWriteEncodedTile(tif, TIFFComputeTile(tif, tx, ty, 0, 0), tile.data(), tmsize_t(tile.size())) <
                    0) {
                    TIFFClose(tif);
                    return *why = "TIFFWriteEncodedTile failed", false;
                }
            }
        if (!TIFFWriteDirectory(tif)) {
            TIFFClose(tif);
            return *why = "TIFFWriteDirectory failed", false;
        }
    }
    TIFFClose(tif);
    return true;
}

std::shared_ptr<const iris::RasterMap> shared(iris::Expected<iris::RasterMap> m) {
    return m ? std::make_shared<const iris::RasterMap>(std::move(*m)) : nullptr;
}

// Class ids 1 and 2 in squares of k map pixels, w × h, with coarser levels each half the one
// before (sides rounded up) down to 512 pixels a side, as the engine would add them, each pixel
// the id at its centre: given here so that the engine draws the very map the reference shades,
// and made a row at a time (the whole-slide map has 24 million pixels).
std::shared_ptr<const iris::RasterMap> checkerboard(int w, int h, int k) {
    std::vector<iris::RasterLevel> levels;
    for (int f = 1;; f *= 2) {
        iris::RasterLevel lv;
        lv.width = (w + f - 1) / f, lv.height = (h + f - 1) / f;
        std::array<std::vector<uint16_t>, 2> rows; // a row of squares whose first square is id 1 + r
        for (int r = 0; r < 2; ++r)
            for (int i = 0; i < lv.width; ++i)
                rows[r].push_back(uint16_t(1 + (std::min(i * f + f / 2, w - 1) / k + r) % 2));
        lv.label.resize(size_t(lv.width) * size_t(lv.height));
        for (int j = 0; j < lv.height; ++j) {
            const auto& row = rows[size_t((std::min(j * f + f / 2, h - 1) / k) % 2)];
            std::copy(row.begin(), row.end(), lv.label.begin() + ptrdiff_t(j) * lv.width);
        }
        levels.push_back(std::move(lv));
        if (levels.back().width <= 512 && levels.back().height <= 512) break;
    }
    return shared(iris::fromHostMemory(iris::RasterKind::Label, std::move(levels), "checkerboard"));
}

} // namespace

class TestLayersAlign : public QObject {
    Q_OBJECT

    TestEngine e_;
    QTemporaryDir dir_;
    int current_ = -1; // the slide open
    iris::SlideInfo info_;
    struct Case {
        iris::View view;
        std::string name;
        bool onLevelGrid; // screen pixel centres on the centres of the level's pixels
    };
    std::vector<Case> cases_;
    std::vector<iris::Image> bases_; // each case's frame without layers

    const SlideSpec& spec() const { return kSlides[current_]; }
    std::string slidePath(int slide) const { return dir_.filePath(QString("slide%1.tiff").arg(slide)).toStdString(); }

    // Opens slide `slide` (once), checks the levels the engine reports, and renders each view
    // without layers.
    void use(int slide) {
        if (current_ == slide) return;
        current_ = -1;
        QVERIFY2(e_->open(slidePath(slide)).ok(), slidePath(slide).c_str());
        info_ = *e_->slideInfo();
        const SlideSpec& s = kSlides[slide];
        QCOMPARE(info_.vendor, std::string("generic-tiff"));
        QCOMPARE(info_.width, s.width);
        QCOMPARE(info_.height, s.height);
        QCOMPARE(info_.levels.size(), s.factors.size());
        for (size_t l = 0; l < s.factors.size(); ++l) {
            const iris::LevelInfo& lv = info_.levels[l];
            qInfo("%s: level %zu %lldx%lld, downsample %.6f (nominal %.4g)", s.name, l, (long long)lv.width,
                  (long long)lv.height, lv.downsample, s.factors[l]);
            QCOMPARE(lv.width, s.levelWidth(l));
            QCOMPARE(lv.height, s.levelHeight(l));
            QVERIFY(!lv.synthetic);
            // The factor within 0.05 % (the rounded slide's levels differ from the nominal by less).
            QVERIFY2(std::abs(lv.downsample / s.factors[l] - 1) < 5e-4,
                     ("level " + std::to_string(l) + " downsample " + std::to_string(lv.downsample)).c_str());
        }
        cases_.clear();
        std::vector<double> downsamples;
        for (const iris::LevelInfo& lv : info_.levels) downsamples.push_back(lv.downsample);
        for (double ds : {1.7, 4.4, 13.0}) downsamples.push_back(ds);
        for (double ds : downsamples) {
            const bool level = info_.levels[size_t(info_.levelFor(ds))].downsample == ds;
            const double kx = std::floor(0.31 * double(s.width) / ds), ky = std::floor(0.43 * double(s.height) / ds);
            const double ex = std::floor(double(s.width) / ds) - kW + 20,
                         ey = std::floor(double(s.height) / ds) - kH + 15;
            const std::string at = " at " + std::to_string(ds).substr(0, 7);
            cases_.push_back({viewWithOrigin(kx * ds, ky * ds, ds, kW, kH), "interior" + at, level});
            cases_.push_back(
                {viewWithOrigin((kx + 0.37) * ds, (ky + 0.61) * ds, ds, kW, kH), "interior+(0.37,0.61)" + at, false});
            cases_.push_back({viewWithOrigin(-20 * ds, -13 * ds, ds, kW, kH), "top-left" + at, level});
            cases_.push_back({viewWithOrigin((ex + 0.29) * ds, (ey + 0.83) * ds, ds, kW, kH),
                              "bottom-right+(0.29,0.83)" + at, false});
        }
        bases_.clear();
        e_->clearLayers();
        std::string why;
        for (const Case& c : cases_) {
            auto f = renderView(*e_.engine, c.view, kW, kH, 60s, &why);
            QVERIFY2(f.has_value(), (c.name + ": " + why).c_str());
            bases_.push_back(std::move(f->image));
        }
        current_ = slide;
    }

    // The frame without layers with `layers` blended over at screen point (px, py).
    static std::array<uint8_t, 3> shadeAt(const iris::ViewTransform& t,
                                          const std::vector<iris::Engine::LayerEntry>& layers, double px, double py,
                                          std::array<uint8_t, 3> dst) {
        const auto s = t.toSlide(px, py);
        for (const auto& l : layers)
            dst = iris::blendOver(dst, iris::shadeLayerAt(*l.map, *l.placement, l.style, s[0], s[1], t.downsample));
        return dst;
    }

    // Frame vs reference (tst_layers_render.cpp's rule): every pixel within 2 codes of the
    // reference at its centre or, where that reference changes within 0.02 px of the centre,
    // within 2 codes of the reference at some point at most one screen pixel away.
    void compare(const iris::Image& frame, const iris::Image& base, const iris::View& view,
                 const std::vector<iris::Engine::LayerEntry>& layers, const std::string& what) {
        const iris::ViewTransform t = iris::ViewTransform::of(view, kW, kH);
        iris::Image ref = base;
        uint64_t bad = 0, nearEdges = 0, changed = 0;
        for (uint32_t y = 0; y < kH; ++y)
            for (uint32_t x = 0; x < kW; ++x) {
                const uint8_t *f = pixel(frame, x, y), *b = pixel(base, x, y);
                const std::array<uint8_t, 3> dst{b[0], b[1], b[2]};
                const auto r = shadeAt(t, layers, x + 0.5, y + 0.5, dst);
                uint8_t* o = pixel(ref, x, y);
                o[0] = r[0], o[1] = r[1], o[2] = r[2];
                changed += r != dst;
                const auto close = [&](const std::array<uint8_t, 3>& q) {
                    return std::abs(f[0] - q[0]) <= 2 && std::abs(f[1] - q[1]) <= 2 && std::abs(f[2] - q[2]) <= 2;
                };
                if (close(r)) continue;
                bool ambiguous = false;
                for (auto [dx, dy] : {std::array<double, 2>{0.02, 0}, {-0.02, 0}, {0, 0.02}, {0, -0.02}})
                    ambiguous = ambiguous || shadeAt(t, layers, x + 0.5 + dx, y + 0.5 + dy, dst) != r;
                bool ok = false;
                for (int j = -4; j <= 4 && ambiguous && !ok; ++j)
                    for (int i = -4; i <= 4 && !ok; ++i)
                        ok = close(shadeAt(t, layers, x + 0.5 + i * 0.25, y + 0.5 + j * 0.25, dst));
                if (ok) {
                    ++nearEdges;
                    continue;
                }
                if (++bad <= 5)
                    qWarning("%s: pixel (%u, %u) is %d %d %d, the reference %d %d %d (without layers %d %d %d)",
                             what.c_str(), x, y, f[0], f[1], f[2], r[0], r[1], r[2], b[0], b[1], b[2]);
            }
        if (bad) {
            const std::string where = saveFailureArtefacts("layers-align-" + what, frame, ref, nullptr);
            QFAIL((what + ": " + std::to_string(bad) + " pixels differ from the reference; " + where).c_str());
        }
        QVERIFY2(changed > 0, (what + ": the layer changed no pixel: the view shows none of it").c_str());
        if (nearEdges > 0)
            qInfo("%s: %llu pixels matched within one pixel of an edge", what.c_str(), (unsigned long long)nearEdges);
    }

    // Renders every case with `map` shown and compares it with its frame without layers.
    void check(const std::shared_ptr<const iris::RasterMap>& map, const iris::LayerStyle& style,
               const iris::Placement& place, const std::string& what) {
        QVERIFY(map);
        e_->clearLayers();
        auto id = e_->addLayer(map, style, place);
        QVERIFY2(id.ok(), describe(id.error()).c_str());
        const std::vector<iris::Engine::LayerEntry> shown = e_->layers();
        QCOMPARE(shown.size(), size_t(1));
        QVERIFY(shown.front().map == map); // shared: the reference shades the map the engine draws
        std::string why;
        for (size_t i = 0; i < cases_.size(); ++i) {
            auto f = renderView(*e_.engine, cases_[i].view, kW, kH, 60s, &why);
            QVERIFY2(f.has_value(), why.c_str());
            compare(f->image, bases_[i], cases_[i].view, shown, what + ", " + cases_[i].name);
            if (QTest::currentTestFailed()) return;
        }
        e_->clearLayers();
    }

    void addSlideRows() {
        QTest::addColumn<int>("slide");
        for (int i = 0; i < int(std::size(kSlides)); ++i) QTest::newRow(kSlides[i].name) << i;
    }

private Q_SLOTS:
    void initTestCase() {
        e_ = createTestEngine();
        QVERIFY2(e_, describe(e_.error).c_str());
        QVERIFY(dir_.isValid());
        QVERIFY(e_->bindOffscreen(kW, kH).ok());
        QElapsedTimer timer;
        timer.start();
        for (int i = 0; i < int(std::size(kSlides)); ++i) {
            std::string why;
            QVERIFY2(writeSlide(slidePath(i), kSlides[i], &why), why.c_str());
        }
        qInfo("slides written in %lld ms", (long long)timer.elapsed());
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

    // The engine reports the slide's own levels: sizes and downsamples (use() checks them).
    void reportsTheLevels_data() { addSlideRows(); }
    void reportsTheLevels() {
        QFETCH(int, slide);
        use(slide);
    }

    // Fact 1: the slide is drawn where the view says (the header's first point).
    void slideWhereTheViewSays_data() { addSlideRows(); }
    void slideWhereTheViewSays() {
        QFETCH(int, slide);
        use(slide);
        if (QTest::currentTestFailed()) return;
        const SlideSpec& s = spec();
        const auto bg = backgroundBytes();
        for (size_t c = 0; c < cases_.size(); ++c) {
            const Case& k = cases_[c];
            const iris::Image& base = bases_[c];
            const iris::ViewTransform t = iris::ViewTransform::of(k.view, kW, kH);
            const double ds = k.view.downsample;
            const size_t L = size_t(info_.levelFor(ds));
            const iris::LevelInfo& lv = info_.levels[L];
            const double ax = (double(s.width) / double(lv.width)) / lv.downsample;
            const double ay = (double(s.height) / double(lv.height)) / lv.downsample;
            // How far the filter reaches from a pixel centre, level-0 pixels: a tap of the
            // coarsest mip the trilinear filter reads (2^m level pixels a texel) either side.
            const double shrink = ds / lv.downsample; // level pixels per screen pixel
            const double m = std::max(0.0, std::ceil(std::log2(shrink) - 1e-9));
            const double reach = (1.5 * std::exp2(m) + 1) * lv.downsample;
            // What the pixel at level-0 point (px, py) must show. Shown 1:1 or enlarged the level
            // is filtered bilinearly, and the exact value is the bilinear interpolation of its
            // stored pixels, rounded: against the continuous picture, a view shifted by a
            // constant fraction f shows v + f·d rounded (d the integer step between stored
            // pixels), the same rounding on every pixel, which would read as an offset. Shrunk,
            // the fractions vary across the frame and the picture itself is the reference.
            const auto expected = [&](double px, double py) -> std::array<double, 3> {
                if (shrink > 1 + 1e-9) return picture(px * ax, py * ay);
                const double u = px / lv.downsample - 0.5, v = py / lv.downsample - 0.5;
                const double i = std::floor(u), j = std::floor(v), fu = u - i, fv = v - j;
                const auto at = [&](double di, double dj) {
                    return levelPixel(s, L, std::clamp(int64_t(i + di), int64_t(0), lv.width - 1),
                                      std::clamp(int64_t(j + dj), int64_t(0), lv.height - 1));
                };
                const auto p00 = at(0, 0), p10 = at(1, 0), p01 = at(0, 1), p11 = at(1, 1);
                std::array<double, 3> out;
                for (size_t ch = 0; ch < 3; ++ch)
                    out[ch] = std::round((1 - fv) * ((1 - fu) * p00[ch] + fu * p10[ch]) +
                                         fv * ((1 - fu) * p01[ch] + fu * p11[ch]));
                return out;
            };
            uint64_t exactBad = 0, bad = 0, samples = 0;
            double drift = 0, sx = 0, sxx = 0, sy = 0, syy = 0;
            for (uint32_t y = 0; y < kH; ++y)
                for (uint32_t x = 0; x < kW; ++x) {
                    const uint8_t* f = pixel(base, x, y);
                    const auto p = t.toSlide(x + 0.5, y + 0.5);
                    if (k.onLevelGrid) {
                        const int64_t i = std::llround(p[0] / lv.downsample - 0.5),
                                      j = std::llround(p[1] / lv.downsample - 0.5);
                        std::array<uint8_t, 3> want = bg;
                        if (i >= 0 && j >= 0 && i < lv.width && j < lv.height) want = levelPixel(s, L, i, j);
                        if (f[0] != want[0] || f[1] != want[1] || f[2] != want[2]) {
                            if (++exactBad <= 5)
                                qWarning("%s: pixel (%u, %u) is %d %d %d, level %zu pixel (%lld, %lld) is %d %d %d",
                                         k.name.c_str(), x, y, f[0], f[1], f[2], L, (long long)i, (long long)j, want[0],
                                         want[1], want[2]);
                        }
                    }
                    // The level-0 point whose picture the engine's level-L pixel at p holds.
                    const double qx = p[0] * ax, qy = p[1] * ay;
                    if (qx < reach || qy < reach || qx > double(s.width) - reach || qy > double(s.height) - reach)
                        continue;
                    drift = std::max({drift, std::abs(qx - p[0]), std::abs(qy - p[1])});
                    const auto want = expected(p[0], p[1]);
                    const auto checkChannel = [&](int ch, double slope, double& se, double& ss) {
                        const double e = f[ch] - want[size_t(ch)];
                        if (std::abs(e) > 3 && ++bad <= 5)
                            qWarning("%s: pixel (%u, %u) channel %d is %d, expected %.2f (the picture at %.2f, %.2f)",
                                     k.name.c_str(), x, y, ch, f[ch], want[size_t(ch)], qx, qy);
                        se += e * slope, ss += slope * slope;
                    };
                    if (kinkDistance(qx, kPeriodR) >= reach)
                        checkChannel(0, triSlope(qx, kPeriodR), sx, sxx), ++samples;
                    if (kinkDistance(qy, kPeriodG) >= reach) checkChannel(1, triSlope(qy, kPeriodG), sy, syy);
                    if (kinkDistance(qx, kPeriodB) >= reach) checkChannel(2, triSlope(qx, kPeriodB), sx, sxx);
                }
            // Least squares: the frame shows what it should at p + (dx, dy) level-0 pixels.
            const double dx = sxx > 0 ? sx / sxx : 0, dy = syy > 0 ? sy / syy : 0;
            qInfo("%s: level %zu, offset (%+.3f, %+.3f) screen px over %llu ramp pixels; level drift %.3f screen px",
                  k.name.c_str(), L, dx / ds, dy / ds, (unsigned long long)samples, drift / ds);
            if (exactBad || bad) {
                saveFailureArtefacts("layers-align-slide-" + k.name, base, base, nullptr);
                QFAIL((k.name + ": " + std::to_string(exactBad) + " pixels differ from the level's, " +
                       std::to_string(bad) + " channels from the picture by more than 3")
                          .c_str());
            }
            QVERIFY2(samples > 2000, (k.name + ": too few pixels on the ramps to measure the offset").c_str());
            QVERIFY2(std::abs(dx) <= 0.1 * ds && std::abs(dy) <= 0.1 * ds,
                     (k.name + ": the slide is drawn off where the view says by more than 0.1 screen pixel").c_str());
            QVERIFY2(drift <= ds,
                     (k.name + ": the level's rounded sides move it by more than one screen pixel").c_str());
        }
    }

    // Fact 2: label checkerboards of patch size k, identity placement and spanning the slide.
    void labelCheckerboard_data() {
        QTest::addColumn<int>("slide");
        QTest::addColumn<int>("k");
        QTest::addColumn<bool>("spanning");
        for (int i = 0; i < int(std::size(kSlides)); ++i)
            for (int k : {64, 45})
                for (bool spanning : {false, true})
                    QTest::addRow("%s, k %d, %s", kSlides[i].name, k, spanning ? "spanning" : "identity")
                        << i << k << spanning;
    }
    void labelCheckerboard() {
        QFETCH(int, slide);
        QFETCH(int, k);
        QFETCH(bool, spanning);
        use(slide);
        if (QTest::currentTestFailed()) return;
        const SlideSpec& s = spec();
        iris::LayerStyle style;
        style.opacity = 0.7;
        style.classes = iris::defaultLabelClasses(3);
        if (spanning) {
            // One map pixel a patch: ceil(W0/k) × ceil(H0/k), stretched over the slide.
            const int w = int((s.width + k - 1) / k), h = int((s.height + k - 1) / k);
            check(checkerboard(w, h, 1), style, iris::Placement::spanning(w, h, s.width, s.height), "spanning");
        } else {
            check(checkerboard(int(s.width), int(s.height), k), style, iris::Placement{}, "identity");
        }
    }

    // Fact 2: a scalar map of 224-px patches on the slide's patch grid, bilinear.
    void scalarPatchMap_data() { addSlideRows(); }
    void scalarPatchMap() {
        QFETCH(int, slide);
        use(slide);
        if (QTest::currentTestFailed()) return;
        const SlideSpec& s = spec();
        const int w = int((s.width + 223) / 224), h = int((s.height + 223) / 224);
        std::vector<float> v(size_t(w) * h);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) v[size_t(y) * w + x] = 0.5f + 0.5f * std::sin(x * 0.9f) * std::cos(y * 0.7f);
        iris::LayerStyle style;
        style.opacity = 0.6;
        check(shared(iris::fromHostMemory(std::span<const float>(v), w, h, "patches")), style,
              iris::Placement::scaleRotateOffset(224, 224, 0, 0, 0), "scalar 224");
    }
};

QTEST_GUILESS_MAIN(TestLayersAlign)
#include "tst_layers_align.moc"
