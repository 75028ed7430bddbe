// tst_layers_dock_pixels: what the viewer's Layers dock (demo/layersdock.*) does to the frame,
// on an X display with lavapipe and the validation layers on. tst_layers_dock checks that its
// controls reach the view's layer styles; this checks that the frame follows: a heat map opened
// through the dock, then its opacity slider moved and another colour map chosen, each presented
// frame equal byte for byte to a headless engine's frame of the same view with the view's layers
// at that opacity and colour map (layer_pixels.h; the overlays hidden), and different from the
// frame before.

#include <cmath>
#include <limits>
#include <memory>

#include <QtCore/QSettings>
#include <QtCore/QTemporaryDir>
#include <QtTest/QTest>
#include <QtWidgets/QApplication>
#include <QtWidgets/QComboBox>
#include <QtWidgets/QSlider>

#include <iris/IrisSlideView.h>

#include "enginehost_p.h"
#include "layer_files.h"
#include "layer_pixels.h"
#include "layersdock.h"
#include "mainwindow.h"
#include "widget_test_support.h"

using namespace iriswidgettest;

class TstLayersDockPixels : public QObject
{
    Q_OBJECT
private Q_SLOTS:
    void initTestCase();
    void cleanupTestCase();

    void opacitySliderAndColorMapChangeTheFrame();

private:
    // Waits for a complete frame and requires the presented one to equal the twin's, and the
    // twin's to differ from the last frame checked.
    void checkFrame(const QString &name);

    QTemporaryDir m_dir;
    std::unique_ptr<MainWindow> m_main;
    std::unique_ptr<FrameWatcher> m_frames;
    std::unique_ptr<layerpixels::HeadlessTwin> m_twin;
    QImage m_last;
};

void TstLayersDockPixels::initTestCase()
{
    QCOMPARE(QGuiApplication::platformName(), QStringLiteral("xcb"));
    QVERIFY2(!qEnvironmentVariableIsEmpty("XDG_CONFIG_HOME"), "the test's settings need a folder of their own");
    QApplication::setOrganizationName(QStringLiteral("IrisView"));
    QApplication::setApplicationName(QStringLiteral("tst_layers_dock_pixels"));
    QSettings().clear();
    IrisSlideView::setVulkanValidation(true);
    QVERIFY(m_dir.isValid());
    constexpr int w = 37, h = 26;
    std::vector<float> values(size_t(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            values[size_t(y) * w + x] = (x * 5 + y * 3) % 17 == 0
                ? std::numeric_limits<float>::quiet_NaN()
                : 0.5f + 0.5f * std::sin(x * 0.45f) * std::cos(y * 0.31f);
    QVERIFY(layerfiles::writeNpy(m_dir.filePath(QStringLiteral("heat.npy")), w, h, values));
}

void TstLayersDockPixels::cleanupTestCase()
{
    m_twin.reset();
    m_frames.reset();
    if (m_main)
        QCOMPARE(m_main->view()->validationMessageCount(), quint64(0));
    m_main.reset();
    QSettings().clear();
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 0);
}

void TstLayersDockPixels::checkFrame(const QString &name)
{
    IrisSlideView *view = m_main->view();
    QVERIFY(m_frames->waitForCompleteFrame());
    QString error;
    const QImage expected = m_twin->render(view, &error);
    QVERIFY2(!expected.isNull(), qPrintable(error));
    const ImageDifference step = compareImages(expected, m_last, 8);
    QVERIFY2(m_last.isNull() || step.fractionOver > 0.02,
        qPrintable(name + QStringLiteral(": the headless frame hardly differs from the last one: ") + step.describe()));
    ImageDifference seen;
    QImage presented;
    const bool same
        = QTest::qWaitFor([&] { return layerpixels::presentedEquals(view, expected, &seen, &presented); }, 5000);
    qInfo("%s: presented %dx%d vs headless: %s", qPrintable(name), presented.width(), presented.height(),
        qPrintable(seen.describe()));
    if (!same || qEnvironmentVariableIsSet("IRIS_TEST_SAVE_FRAMES")) {
        saveArtefact(presented, QStringLiteral("layers-dock-pixels-") + name + QStringLiteral("-presented"));
        saveArtefact(expected, QStringLiteral("layers-dock-pixels-") + name + QStringLiteral("-headless"));
    }
    QVERIFY2(
        same, qPrintable(name + QStringLiteral(": the presented frame is not the headless one: ") + seen.describe()));
    m_last = expected;
}

void TstLayersDockPixels::opacitySliderAndColorMapChangeTheFrame()
{
    m_main = std::make_unique<MainWindow>();
    m_main->resize(1100, 800);
    m_main->show();
    QVERIFY(QTest::qWaitForWindowExposed(m_main.get()));
    IrisSlideView *view = m_main->view();
    LayersDock *dock = m_main->layersDock();
    QVERIFY(view->isRendererAvailable());
    QTRY_VERIFY(view->surfaceWindow()->isExposed());
    m_frames = std::make_unique<FrameWatcher>(view);
    QVERIFY(m_main->openSlide(sampleSlide(), false));
    dock->show();
    dock->raise();
    layerpixels::hideOverlays(view);
    view->setView(QPointF(3100, 1900), 4.6, 0);
    QVERIFY(m_frames->waitForCompleteFrame());
    m_twin = std::make_unique<layerpixels::HeadlessTwin>();
    QString error;
    QVERIFY2(m_twin->start(view, &error), qPrintable(error));

    const quint64 id = dock->addLayerFile(m_dir.filePath(QStringLiteral("heat.npy")), false);
    QVERIFY(id);
    checkFrame(QStringLiteral("added"));
    QCOMPARE(dock->opacitySlider()->value(), 50);
    dock->opacitySlider()->setValue(90);
    QCOMPARE(view->layer(id).opacity, 0.9);
    checkFrame(QStringLiteral("opacity-90"));
    dock->colorMapCombo()->setCurrentIndex(dock->colorMapCombo()->findText(QStringLiteral("jet")));
    Q_EMIT dock->colorMapCombo()->activated(dock->colorMapCombo()->currentIndex());
    QCOMPARE(view->layer(id).colorMap, QStringLiteral("jet"));
    checkFrame(QStringLiteral("jet"));
}

IRIS_WIDGET_TEST_MAIN(TstLayersDockPixels)
#include "tst_layers_dock_pixels.moc"
