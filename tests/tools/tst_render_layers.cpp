// render.layers: iris-render's --heatmap and --label-map (issue 19) checked pixel by pixel.
// The suite writes map files (a float32 .npy with NaN holes, a 16-bit grey PNG, an 8-bit grey
// PNG of class ids), runs the built iris-render on the sample slide once without layers and
// once with them at the same view, and requires every pixel of the layered PNG to equal the
// plain PNG with iris::shadeLayerAt + iris::blendOver applied at the pixel's centre, within ±2
// codes, each map spanning the slide's level 0 (Placement::spanning) in the style the command
// line names (its defaults otherwise: opacity 0.5, viridis, the default class colours). Where
// the reference itself changes within a hair of a pixel's centre (a class edge, a NaN hole, the
// slide's border), the pixel may instead match the reference at a point at most one screen
// pixel away, as engine.layers_render allows.
//
// The reference maps are made from the values the suite wrote (iris::fromHostMemory), not read
// back from the files, so the loaders iris-render uses are checked too. The view is the one
// iris-render derives: --center and --downsample given, rotation from --rotate; without them
// the fitted view, which a test engine bound to the same size computes (Engine::fitView, as
// iris-render does); its -v line must agree with it.
#include <QtTest>

#include <QtCore/QProcess>
#include <QtCore/QRegularExpression>
#include <QtCore/QTemporaryDir>
#include <QtGui/QImage>

#include <cmath>
#include <cstring>
#include <limits>
#include <span>

#include "iris/layers.h"
#include "layer_files.h"
#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;

namespace {

constexpr uint32_t kW = 320, kH = 240;

struct RefLayer {
    std::shared_ptr<const iris::RasterMap> map;
    iris::LayerStyle style;
};

template <class T>
std::shared_ptr<const iris::RasterMap> hostMap(const std::vector<T>& values, int w, int h) {
    auto m = iris::fromHostMemory(std::span<const T>(values), w, h);
    return m ? std::make_shared<const iris::RasterMap>(std::move(*m)) : nullptr;
}

} // namespace

class TestRenderLayers : public QObject {
    Q_OBJECT

    QTemporaryDir dir_;
    QString slide_;
    iris::SlideInfo info_;
    iris::View fitted_; // the fitted view of a kW × kH target
    std::shared_ptr<const iris::RasterMap> heat_, heat16_, labels_;

    QString path(const char* name) const { return dir_.filePath(QString::fromLatin1(name)); }

    // Runs iris-render on the sample at kW × kH with `args`; the frame, or none after a failure.
    // *reported: the view its -v line names (centre and downsample as printed, rotation).
    std::optional<iris::Image> render(const QStringList& args, const QString& name, iris::View* reported) {
        const QString out = path(qPrintable(name + ".png"));
        QProcess p;
        // iris-render beside this program (the build's bin/ folder).
        p.start(QCoreApplication::applicationDirPath() + QStringLiteral("/iris-render"),
                QStringList{slide_, "--out", out, "--size", QString("%1x%2").arg(kW).arg(kH), "-v"} + args);
        if (!p.waitForFinished(60000)) {
            QTest::qFail(qPrintable("iris-render did not finish: " + p.errorString()), __FILE__, __LINE__);
            return std::nullopt;
        }
        const QString err = QString::fromLocal8Bit(p.readAllStandardError());
        if (p.exitStatus() != QProcess::NormalExit || p.exitCode() != 0) {
            QTest::qFail(
                qPrintable(
                    QString("iris-render %1 failed (exit %2): %3").arg(args.join(' ')).arg(p.exitCode()).arg(err)),
                __FILE__, __LINE__);
            return std::nullopt;
        }
        static const QRegularExpression line(
            R"(view centre \(([-0-9.]+), ([-0-9.]+)\) downsample ([-0-9.e+]+) rotation ([-0-9.e+]+))");
        const QRegularExpressionMatch m = line.match(err);
        if (!m.hasMatch()) {
            QTest::qFail(qPrintable("no view in iris-render's -v output: " + err), __FILE__, __LINE__);
            return std::nullopt;
        }
        *reported = iris::View{m.captured(1).toDouble(), m.captured(2).toDouble(), m.captured(3).toDouble(),
                               m.captured(4).toDouble()};
        QImage img(out);
        if (img.isNull() || img.width() != int(kW) || img.height() != int(kH)) {
            QTest::qFail(qPrintable("cannot read a " + QString("%1x%2").arg(kW).arg(kH) + " PNG from " + out), __FILE__,
                         __LINE__);
            return std::nullopt;
        }
        img = img.convertToFormat(QImage::Format_RGBA8888);
        iris::Image frame = makeImage(kW, kH);
        for (uint32_t y = 0; y < kH; ++y) std::memcpy(pixel(frame, 0, y), img.constScanLine(int(y)), kW * 4);
        return frame;
    }

    // The plain pixel with every layer blended over at target point (px, py).
    std::array<uint8_t, 3> shadeAt(const iris::ViewTransform& t, double downsample, const std::vector<RefLayer>& layers,
                                   double px, double py, std::array<uint8_t, 3> dst) const {
        const auto s = t.toSlide(px, py);
        for (const RefLayer& l : layers) {
            const iris::Placement p =
                iris::Placement::spanning(l.map->width(), l.map->height(), info_.width, info_.height);
            dst = iris::blendOver(dst, iris::shadeLayerAt(*l.map, p, l.style, s[0], s[1], downsample));
        }
        return dst;
    }

    // Every pixel of `layered` within 2 codes of the reference, or (where the reference changes
    // within 0.02 pixel of the centre) of the reference somewhere within one screen pixel.
    void compare(const iris::Image& layered, const iris::Image& plain, const iris::View& view,
                 const std::vector<RefLayer>& layers, const std::string& what) {
        const iris::ViewTransform t = iris::ViewTransform::of(view, kW, kH);
        iris::Image ref = plain;
        uint64_t bad = 0, nearEdges = 0, changed = 0;
        for (uint32_t y = 0; y < kH; ++y)
            for (uint32_t x = 0; x < kW; ++x) {
                const uint8_t *f = pixel(layered, x, y), *b = pixel(plain, x, y);
                const std::array<uint8_t, 3> dst{b[0], b[1], b[2]};
                const auto r = shadeAt(t, view.downsample, layers, x + 0.5, y + 0.5, dst);
                uint8_t* o = pixel(ref, x, y);
                o[0] = r[0], o[1] = r[1], o[2] = r[2];
                changed += r != dst;
                const auto close = [&](const std::array<uint8_t, 3>& q) {
                    return std::abs(f[0] - q[0]) <= 2 && std::abs(f[1] - q[1]) <= 2 && std::abs(f[2] - q[2]) <= 2;
                };
                if (close(r)) continue;
                bool ambiguous = false;
                for (auto [dx, dy] : {std::array<double, 2>{0.02, 0}, {-0.02, 0}, {0, 0.02}, {0, -0.02}})
                    ambiguous = ambiguous || shadeAt(t, view.downsample, layers, x + 0.5 + dx, y + 0.5 + dy, dst) != r;
                bool ok = false;
                for (int j = -4; j <= 4 && ambiguous && !ok; ++j)
                    for (int i = -4; i <= 4 && !ok; ++i)
                        ok = close(shadeAt(t, view.downsample, layers, x + 0.5 + i * 0.25, y + 0.5 + j * 0.25, dst));
                if (ok) {
                    ++nearEdges;
                    continue;
                }
                if (++bad <= 5)
                    qWarning("%s: pixel (%u, %u) is %d %d %d, the reference %d %d %d (without layers %d %d %d)",
                             what.c_str(), x, y, f[0], f[1], f[2], r[0], r[1], r[2], b[0], b[1], b[2]);
            }
        qInfo("%s: %llu of %u pixels changed by the layers, %llu matched within one pixel of an edge", what.c_str(),
              (unsigned long long)changed, kW * kH, (unsigned long long)nearEdges);
        if (bad) {
            const std::string where = saveFailureArtefacts("render-layers-" + what, layered, ref, nullptr);
            QFAIL((what + ": " + std::to_string(bad) + " pixels differ from the reference; " + where).c_str());
        }
        // The layers must cover most of what the view shows of the slide (NaN holes and hidden
        // class 0 leave the rest), else the check proves little.
        QVERIFY2(changed > kW * kH / 3,
                 (what + ": the layers changed only " + std::to_string(changed) + " pixels").c_str());
    }

    // iris-render without layers and with `layerArgs` at the view `viewArgs` gives (the fitted
    // one when empty), compared with `layers` over the plain frame at `expected`.
    void check(const QStringList& viewArgs, const QStringList& layerArgs, const iris::View& expected,
               const std::vector<RefLayer>& layers, const std::string& what) {
        iris::View seenPlain, seenLayered;
        const auto plain = render(viewArgs, QString::fromStdString(what + "-plain"), &seenPlain);
        if (!plain) return;
        const auto layered = render(viewArgs + layerArgs, QString::fromStdString(what), &seenLayered);
        if (!layered) return;
        // -v prints the centre to 0.1 and the downsample and rotation to 4 significant digits.
        for (const iris::View& v : {seenPlain, seenLayered}) {
            QVERIFY2(std::abs(v.centerX - expected.centerX) <= 0.051 &&
                         std::abs(v.centerY - expected.centerY) <= 0.051 &&
                         std::abs(v.downsample - expected.downsample) <= 5e-4 * expected.downsample &&
                         std::abs(v.rotation - expected.rotation) <= 5e-4 * std::max(1.0, expected.rotation),
                     qPrintable(QString("%1: iris-render drew the view (%2, %3) at %4, %5°, not the one expected")
                                    .arg(QString::fromStdString(what))
                                    .arg(v.centerX)
                                    .arg(v.centerY)
                                    .arg(v.downsample)
                                    .arg(v.rotation)));
        }
        QVERIFY2(compareImages(*plain, *layered).differing > 0, "the layers changed nothing");
        compare(*layered, *plain, expected, layers, what);
    }

private Q_SLOTS:
    void initTestCase() {
        const auto sample = sampleSlidePath();
        QVERIFY2(sample && fs::exists(*sample), "no sample slide (the sample_slide fixture makes it)");
        slide_ = QString::fromStdString(sample->string());
        QVERIFY(dir_.isValid());
        // The slide's extent and the fitted view, as iris-render's engine sees them.
        TestEngine e = createTestEngine();
        QVERIFY2(e, describe(e.error).c_str());
        QVERIFY(e->bindOffscreen(kW, kH).ok());
        QVERIFY(e->open(sample->string()).ok());
        info_ = *e->slideInfo();
        fitted_ = e->fitView();
        const std::string why = e.finish();
        QVERIFY2(why.empty(), why.c_str());

        // A smooth probability 0..1 with NaN holes (no data), 47 × 31: ~128 level-0 pixels each.
        constexpr int hw = 47, hh = 31;
        std::vector<float> heat(size_t(hw) * hh);
        for (int y = 0; y < hh; ++y)
            for (int x = 0; x < hw; ++x)
                heat[size_t(y) * hw + x] = (x * 7 + y * 3) % 23 == 0
                                               ? std::numeric_limits<float>::quiet_NaN()
                                               : 0.5f + 0.5f * std::sin(x * 0.37f) * std::cos(y * 0.29f);
        QVERIFY(layerfiles::writeNpy(path("heat.npy"), hw, hh, heat));
        heat_ = hostMap(heat, hw, hh);
        // A 16-bit grey ramp (values 0..62000), 23 × 19.
        constexpr int gw = 23, gh = 19;
        QImage grey16(gw, gh, QImage::Format_Grayscale16);
        std::vector<float> ramp(size_t(gw) * gh);
        for (int y = 0; y < gh; ++y)
            for (int x = 0; x < gw; ++x) {
                const uint16_t v = uint16_t(x * 2000 + y * 1000);
                reinterpret_cast<uint16_t*>(grey16.scanLine(y))[x] = v;
                ramp[size_t(y) * gw + x] = float(v);
            }
        QVERIFY(grey16.save(path("ramp16.png"), "PNG"));
        // (Written as 16-bit samples, not scaled to 8.)
        const auto written = iris::loadRasterMap(path("ramp16.png").toStdString());
        QVERIFY2(written.ok() && written->maxValue == 62000.0, "ramp16.png is not the 16-bit ramp written");
        heat16_ = hostMap(ramp, gw, gh);
        // Class ids 0..4 in diagonal bands (0 is the hidden background), 40 × 27.
        constexpr int lw = 40, lh = 27;
        std::vector<uint16_t> ids(size_t(lw) * lh);
        for (int y = 0; y < lh; ++y)
            for (int x = 0; x < lw; ++x) ids[size_t(y) * lw + x] = uint16_t((x / 3 + y / 2) % 5);
        QVERIFY(layerfiles::writeGreyPng(path("labels.png"), lw, lh,
                                         [&](int x, int y) { return ids[size_t(y) * lw + x]; }));
        labels_ = hostMap(ids, lw, lh);
        QVERIFY(heat_ && heat16_ && labels_);
    }

    // --heatmap FILE:0.6:magma, between levels (downsample 6.5).
    void heatmap() {
        iris::LayerStyle style;
        style.opacity = 0.6;
        style.colorMap = iris::ColorMap::magma();
        check({"--center", "2900,2100", "--downsample", "6.5"}, {"--heatmap", path("heat.npy") + ":0.6:magma"},
              iris::View{2900, 2100, 6.5}, {{heat_, style}}, "heatmap");
    }

    // --label-map FILE:0.45 at a given view, and at the fitted view (the slide's border shows).
    void labelMap() {
        iris::LayerStyle style;
        style.opacity = 0.45;
        style.classes = iris::defaultLabelClasses(5);
        check({"--center", "2900,2100", "--downsample", "6.5"}, {"--label-map", path("labels.png") + ":0.45"},
              iris::View{2900, 2100, 6.5}, {{labels_, style}}, "label-map");
        if (QTest::currentTestFailed()) return;
        check({}, {"--label-map", path("labels.png") + ":0.45"}, fitted_, {{labels_, style}}, "label-map-fitted");
    }

    // Two heat maps stacked in the order given (the last on top), the second with the defaults
    // but its opacity, and a label map over both; the slide turned 30°.
    void stacked() {
        iris::LayerStyle magma;
        magma.opacity = 0.6;
        magma.colorMap = iris::ColorMap::magma();
        iris::LayerStyle viridis; // the default colour map
        viridis.opacity = 0.35;
        iris::LayerStyle classes; // the default opacity
        classes.classes = iris::defaultLabelClasses(5);
        check({"--center", "3100,1900", "--downsample", "4.3"},
              {"--heatmap", path("heat.npy") + ":0.6:magma", "--heatmap", path("ramp16.png") + ":0.35"},
              iris::View{3100, 1900, 4.3}, {{heat_, magma}, {heat16_, viridis}}, "two-heatmaps");
        if (QTest::currentTestFailed()) return;
        check({"--center", "3100,1900", "--downsample", "4.3", "--rotate", "30"},
              {"--heatmap", path("ramp16.png") + ":0.35", "--label-map", path("labels.png"), "--heatmap",
               path("heat.npy") + ":0.6:magma"},
              iris::View{3100, 1900, 4.3, 30}, {{heat16_, viridis}, {labels_, classes}, {heat_, magma}},
              "three-layers-turned");
    }
};

QTEST_GUILESS_MAIN(TestRenderLayers)
#include "tst_render_layers.moc"
