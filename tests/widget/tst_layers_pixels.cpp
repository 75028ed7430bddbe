// tst_layers_pixels: the pixels of IrisSlideView's raster layers (issue 19), on an X display
// (Xvfb in CI) with lavapipe and the validation layers on. tst_layers_widget checks the layer
// API against the engine's stack; this suite checks what the view presents: after every change
// made through the view (layers added from files and from host memory, opacity, colour map, a
// user LUT, window, threshold, sampling, class visibility and colour, order, visibility,
// removal, a turned and mirrored view), the frame grabbed from the X server must equal, byte for
// byte, a headless engine's frame of the same view with the view's layers (layer_pixels.h). The
// overlays are hidden (the headless twin draws none). Each step must also change the frame, so
// that an edit the view dropped cannot pass.
//
// The view announces complete frames (framePresented) but not which layer edit a frame shows,
// and the X server shows a presented frame a moment after it was submitted: each check waits
// for a complete frame of the view, then polls the grab (QTest::qWaitFor, as QTRY_VERIFY does)
// until it equals the headless frame or 5 s pass.

#include <cmath>
#include <limits>
#include <memory>

#include <QtCore/QFileInfo>
#include <QtCore/QTemporaryDir>
#include <QtTest/QTest>
#include <QtWidgets/QApplication>
#include <QtWidgets/QVBoxLayout>

#include <iris/IrisSlideView.h>
#include <iris/layers.h>

#include "enginehost_p.h"
#include "layer_files.h"
#include "layer_pixels.h"
#include "widget_test_support.h"

using namespace iriswidgettest;

// checkFrame, leaving the test function at its first failure (each later step would wait 5 s).
#define CHECK_FRAME(name)                                                                                              \
    do {                                                                                                               \
        checkFrame(name);                                                                                              \
        if (QTest::currentTestFailed())                                                                                \
            return;                                                                                                    \
    } while (false)

namespace {

constexpr QSize kViewSize(480, 360);

struct ViewWindow
{
    std::unique_ptr<QWidget> window = std::make_unique<QWidget>();
    IrisSlideView *view = new IrisSlideView;
    std::unique_ptr<FrameWatcher> frames = std::make_unique<FrameWatcher>(view);

    ViewWindow()
    {
        auto *layout = new QVBoxLayout(window.get());
        layout->setContentsMargins(0, 0, 0, 0);
        layout->addWidget(view);
        window->resize(kViewSize);
    }
    ~ViewWindow() { frames.reset(); }
};

} // namespace

class TstLayersPixels : public QObject
{
    Q_OBJECT
private Q_SLOTS:
    void initTestCase();
    void init();
    void cleanup();
    void cleanupTestCase();

    void layersFromFilesAndTheirEdits();
    void hostMapWindowThresholdSampling();

private:
    QString path(const QString &name) const { return m_dir.filePath(name); }
    // Waits for a complete frame of the view and requires the presented frame to equal the
    // twin's, and the twin's to differ from the last frame checked.
    void checkFrame(const QString &name);

    QTemporaryDir m_dir;
    std::unique_ptr<ViewWindow> m_w;
    std::unique_ptr<layerpixels::HeadlessTwin> m_twin;
    QImage m_last; // the last frame checked
};

void TstLayersPixels::initTestCase()
{
    QCOMPARE(QGuiApplication::platformName(), QStringLiteral("xcb"));
    IrisSlideView::setVulkanValidation(true);
    QVERIFY2(QFileInfo::exists(sampleSlide()), qPrintable(sampleSlide()));
    QVERIFY(m_dir.isValid());
    // A smooth probability 0..1 with NaN holes (no data), 41 × 29 (~146 level-0 pixels each).
    constexpr int w = 41, h = 29;
    std::vector<float> values(size_t(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            values[size_t(y) * w + x] = (x * 5 + y * 3) % 19 == 0
                ? std::numeric_limits<float>::quiet_NaN()
                : 0.5f + 0.5f * std::sin(x * 0.41f) * std::cos(y * 0.33f);
    QVERIFY(layerfiles::writeNpy(path(QStringLiteral("heat.npy")), w, h, values));
    // Class ids 0..4 in diagonal bands, 32 × 22 (0 is the hidden background).
    QVERIFY(layerfiles::writeGreyPng(
        path(QStringLiteral("labels.png")), 32, 22, [](int x, int y) { return (x / 3 + y / 2) % 5; }));
    QVERIFY(layerfiles::writeTextLut(path(QStringLiteral("lut.txt"))));
}

void TstLayersPixels::init()
{
    m_w = std::make_unique<ViewWindow>();
    m_w->window->show();
    QVERIFY(QTest::qWaitForWindowExposed(m_w->window.get()));
    QVERIFY(m_w->view->isRendererAvailable());
    QVERIFY2(m_w->view->openSlide(sampleSlide()), qPrintable(sampleSlide()));
    QTRY_VERIFY(m_w->view->surfaceWindow()->isExposed());
    layerpixels::hideOverlays(m_w->view);
    // Inside the slide, between levels, where the maps' pixels are 28-35 device pixels wide.
    m_w->view->setView(QPointF(2900, 2100), 5.3, 0);
    QVERIFY(m_w->frames->waitForCompleteFrame());
    m_twin = std::make_unique<layerpixels::HeadlessTwin>();
    QString error;
    QVERIFY2(m_twin->start(m_w->view, &error), qPrintable(error));
    m_last = QImage();
}

void TstLayersPixels::cleanup()
{
    m_twin.reset();
    if (m_w) {
        QVERIFY(m_w->frames->waitForCompleteFrame());
        QCOMPARE(m_w->view->validationMessageCount(), quint64(0));
    }
    m_w.reset();
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 0);
}

void TstLayersPixels::cleanupTestCase()
{
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 0);
}

void TstLayersPixels::checkFrame(const QString &name)
{
    IrisSlideView *view = m_w->view;
    QVERIFY(m_w->frames->waitForCompleteFrame());
    QString error;
    const QImage expected = m_twin->render(view, &error);
    QVERIFY2(!expected.isNull(), qPrintable(error));
    // A step that shows nothing new would prove nothing.
    const ImageDifference step = compareImages(expected, m_last, 8);
    QVERIFY2(m_last.isNull() || step.fractionOver > 0.02,
        qPrintable(
            name + QStringLiteral(": the headless frame hardly differs from the last step's: ") + step.describe()));
    ImageDifference seen;
    QImage presented;
    const bool same
        = QTest::qWaitFor([&] { return layerpixels::presentedEquals(view, expected, &seen, &presented); }, 5000);
    qInfo("%s: presented %dx%d vs headless: %s", qPrintable(name), presented.width(), presented.height(),
        qPrintable(seen.describe()));
    if (!same || qEnvironmentVariableIsSet("IRIS_TEST_SAVE_FRAMES")) {
        saveArtefact(presented, QStringLiteral("layers-pixels-") + name + QStringLiteral("-presented"));
        saveArtefact(expected, QStringLiteral("layers-pixels-") + name + QStringLiteral("-headless"));
    }
    QVERIFY2(
        same, qPrintable(name + QStringLiteral(": the presented frame is not the headless one: ") + seen.describe()));
    m_last = expected;
}

void TstLayersPixels::layersFromFilesAndTheirEdits()
{
    IrisSlideView *view = m_w->view;
    CHECK_FRAME(QStringLiteral("plain"));
    const quint64 heat = view->addLayer(path(QStringLiteral("heat.npy")));
    QVERIFY(heat);
    CHECK_FRAME(QStringLiteral("heat"));
    const quint64 labels = view->addLayer(path(QStringLiteral("labels.png")), true);
    QVERIFY(labels);
    CHECK_FRAME(QStringLiteral("heat-labels"));
    QVERIFY(view->setLayerOpacity(heat, 0.85));
    CHECK_FRAME(QStringLiteral("opacity"));
    QVERIFY(view->setLayerColorMap(heat, QStringLiteral("magma")));
    CHECK_FRAME(QStringLiteral("magma"));
    QVERIFY(view->setLayerClassVisible(labels, 2, false));
    CHECK_FRAME(QStringLiteral("class-hidden"));
    QVERIFY(view->setLayerClassColor(labels, 3, QColor(250, 20, 30, 200)));
    CHECK_FRAME(QStringLiteral("class-colour"));
    QVERIFY(view->moveLayer(labels, 0)); // under the heat map now
    CHECK_FRAME(QStringLiteral("moved"));
    view->setView(QPointF(3300, 1800), 3.7, 30, true, false);
    CHECK_FRAME(QStringLiteral("turned-mirrored"));
    QVERIFY(view->setLayerVisible(heat, false));
    CHECK_FRAME(QStringLiteral("heat-hidden"));
    view->clearLayers();
    CHECK_FRAME(QStringLiteral("cleared"));
}

void TstLayersPixels::hostMapWindowThresholdSampling()
{
    IrisSlideView *view = m_w->view;
    CHECK_FRAME(QStringLiteral("host-plain"));
    const QImage plain = m_last;
    // A ramp 0..99 over 10 × 8 map pixels (~600 × 500 level-0 pixels each: a few fill the view).
    std::vector<float> ramp(10 * 8);
    for (size_t i = 0; i < ramp.size(); ++i)
        ramp[i] = float(i * 99 / (ramp.size() - 1));
    auto map = iris::fromHostMemory(ramp, 10, 8, "ramp");
    QVERIFY(map.ok());
    iris::LayerStyle style;
    style.opacity = 0.7;
    style.colorMap = iris::ColorMap::jet();
    style.sampling = iris::LayerSampling::Nearest;
    const quint64 id = view->addLayer(std::make_shared<const iris::RasterMap>(std::move(map).value()), style);
    QVERIFY(id);
    CHECK_FRAME(QStringLiteral("host-nearest"));
    QVERIFY(view->setLayerSampling(id, IrisLayerInfo::Bilinear));
    CHECK_FRAME(QStringLiteral("host-bilinear"));
    QVERIFY(view->setLayerWindow(id, 40, 60));
    CHECK_FRAME(QStringLiteral("host-window"));
    QVERIFY(view->setLayerThreshold(id, 50));
    CHECK_FRAME(QStringLiteral("host-threshold"));
    QVERIFY(view->loadLayerColorMap(id, path(QStringLiteral("lut.txt"))));
    CHECK_FRAME(QStringLiteral("host-lut"));
    view->removeLayer(id);
    CHECK_FRAME(QStringLiteral("host-removed"));
    QCOMPARE(compareImages(m_last, plain, 0).maxAbs, 0);
}

IRIS_WIDGET_TEST_MAIN(TstLayersPixels)
#include "tst_layers_pixels.moc"
