// tst_overlay_widget: IrisSlideView's overlays on a real X display (Xvfb in CI), presenting
// through the swapchain, with the Vulkan validation layers on.
//
//   * the widget shows every overlay by default; its properties (the ones Designer offers)
//     show, hide and move them, and a bad font leaves the labels out with a slideError;
//   * the presented frame, overlays included, equals a headless (offscreen) render of the
//     same view with the same overlays: the overlays work on the swapchain as offscreen;
//   * clicking the overview map moves the view there (the next frame's outline is centred on
//     the click) and dragging on it keeps moving the view; a press elsewhere still pans;
//   * the overlays follow the device pixel ratio: in logical pixels they are where a headless
//     engine at ratio 1 puts them (the suite also runs with QT_SCALE_FACTOR=2).

#include <cmath>
#include <memory>

#include <QtCore/QFile>
#include <QtCore/QFileInfo>
#include <QtGui/QWindow>
#include <QtTest/QSignalSpy>
#include <QtTest/QTest>
#include <QtWidgets/QApplication>
#include <QtWidgets/QVBoxLayout>

#include <iris/IrisSlideView.h>
#include <iris/engine.h>
#include <iris/layers.h>

#include "enginehost_p.h"
#include "widget_test_support.h"

using namespace iriswidgettest;

namespace {

constexpr QSize kViewSize(560, 400);
constexpr double kMaxMeanDifference = 1.0; // as tst_irisslideview: presented vs headless
constexpr double kMaxFractionOver = 0.002;
constexpr int kPixelThreshold = 16;
constexpr int kMargin = 10; // the engine's corner margin, logical pixels

struct ViewWindow {
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
    QWindow *surface() const { return view->surfaceWindow(); }
    double dpr() const { return view->surfaceWindow()->devicePixelRatio(); }
};

QString rectText(const QRectF &r)
{
    return QStringLiteral("[%1, %2 %3x%4]").arg(r.x()).arg(r.y()).arg(r.width()).arg(r.height());
}

// Bounding box (device pixels) of the pixels of exactly `colour` inside `area`.
QRect colourBox(const QImage &image, const QRect &area, QColor colour)
{
    QRect box;
    for (int y = std::max(0, area.top()); y <= std::min(image.height() - 1, area.bottom()); ++y)
        for (int x = std::max(0, area.left()); x <= std::min(image.width() - 1, area.right()); ++x)
            if (image.pixelColor(x, y).rgb() == colour.rgb())
                box |= QRect(x, y, 1, 1);
    return box;
}

constexpr std::array<IrisSlideView::Overlay, 3> kOverlays{IrisSlideView::ScaleBar, IrisSlideView::MagnificationLabel,
                                                          IrisSlideView::Overview};

} // namespace

class TstOverlayWidget : public QObject {
    Q_OBJECT

private Q_SLOTS:
    void initTestCase();
    void init();
    void cleanup();

    void defaultsShowEveryOverlay();
    void propertiesShowHideAndMove();
    void badFontIsReported();
    void presentedOverlaysMatchHeadless();
    void clickingTheOverviewMovesTheView();
    void legendShowsWithAHeatMap();
    void overlaysFollowTheDevicePixelRatio();

private:
    void showSample();

    QString m_sample;
    std::unique_ptr<ViewWindow> m_w;
};

void TstOverlayWidget::initTestCase()
{
    QCOMPARE(QGuiApplication::platformName(), QStringLiteral("xcb"));
    IrisSlideView::setVulkanValidation(true); // before the first view makes the shared instance
    m_sample = sampleSlide();
    QVERIFY2(QFileInfo::exists(m_sample), qPrintable(m_sample));
}

void TstOverlayWidget::init()
{
    m_w = std::make_unique<ViewWindow>();
}

void TstOverlayWidget::cleanup()
{
    if (m_w)
        QCOMPARE(m_w->view->validationMessageCount(), quint64(0));
    m_w.reset();
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 0);
}

void TstOverlayWidget::showSample()
{
    m_w->window->show();
    QVERIFY(QTest::qWaitForWindowExposed(m_w->window.get()));
    QVERIFY(m_w->view->isRendererAvailable());
    QVERIFY2(m_w->view->openSlide(m_sample), qPrintable(m_sample));
    QTRY_VERIFY(m_w->view->surfaceWindow()->isExposed());
    QVERIFY(m_w->frames->waitForCompleteFrame());
}

void TstOverlayWidget::defaultsShowEveryOverlay()
{
    IrisSlideView *view = m_w->view;
    for (auto o : kOverlays)
        QVERIFY(view->isOverlayVisible(o));
    QCOMPARE(view->scaleBarCorner(), IrisSlideView::BottomLeft);
    QCOMPARE(view->magnificationLabelCorner(), IrisSlideView::TopLeft);
    QCOMPARE(view->overviewCorner(), IrisSlideView::TopRight);
    QVERIFY(view->overlayFont().isEmpty());
    // Before a slide: nothing drawn, nothing reported.
    for (auto o : kOverlays)
        QVERIFY(view->overlayRect(o).isEmpty());

    showSample();
    const QSizeF size = view->size();
    const QRectF bar = view->overlayRect(IrisSlideView::ScaleBar);
    const QRectF mag = view->overlayRect(IrisSlideView::MagnificationLabel);
    const QRectF map = view->overlayRect(IrisSlideView::Overview);
    qInfo("scale bar %s, magnification %s, overview %s", qPrintable(rectText(bar)), qPrintable(rectText(mag)),
          qPrintable(rectText(map)));
    QVERIFY(!bar.isEmpty() && !mag.isEmpty() && !map.isEmpty());
    const double eps = 1e-9;
    QVERIFY(std::abs(bar.left() - kMargin) < eps && std::abs(bar.bottom() - (size.height() - kMargin)) < eps);
    QVERIFY(std::abs(mag.left() - kMargin) < eps && std::abs(mag.top() - kMargin) < eps);
    QVERIFY(std::abs(map.right() - (size.width() - kMargin)) < eps && std::abs(map.top() - kMargin) < eps);
    // The Designer-visible properties are the same switches.
    const QMetaObject *mo = view->metaObject();
    for (const char *name : {"scaleBarVisible", "scaleBarCorner", "magnificationLabelVisible",
                             "magnificationLabelCorner", "overviewVisible", "overviewCorner", "overlayFont"}) {
        const QMetaProperty p = mo->property(mo->indexOfProperty(name));
        QVERIFY2(p.isValid() && p.isWritable() && p.isDesignable() && p.hasNotifySignal(), name);
    }
    // The readout says what magnification() says.
    QVERIFY(view->magnification() > 0);
    QVERIFY(mo->property(mo->indexOfProperty("overviewCorner")).isEnumType());
}

void TstOverlayWidget::propertiesShowHideAndMove()
{
    showSample();
    IrisSlideView *view = m_w->view;
    QSignalSpy changed(view, &IrisSlideView::overlaysChanged);
    const QSizeF size = view->size();

    QVERIFY(view->setProperty("scaleBarCorner", QVariant::fromValue(IrisSlideView::TopRight)));
    QCOMPARE(view->scaleBarCorner(), IrisSlideView::TopRight);
    QVERIFY(view->setProperty("overviewCorner", QVariant::fromValue(IrisSlideView::BottomLeft)));
    QVERIFY(view->setProperty("magnificationLabelVisible", false));
    QCOMPARE(changed.count(), 3);
    view->setScaleBarCorner(IrisSlideView::TopRight); // no change, no signal
    QCOMPARE(changed.count(), 3);

    // The next frames show them there.
    QTRY_VERIFY(view->overlayRect(IrisSlideView::MagnificationLabel).isEmpty());
    QTRY_VERIFY(std::abs(view->overlayRect(IrisSlideView::ScaleBar).right() - (size.width() - kMargin)) < 1e-9);
    QVERIFY(std::abs(view->overlayRect(IrisSlideView::ScaleBar).top() - kMargin) < 1e-9);
    QTRY_VERIFY(std::abs(view->overlayRect(IrisSlideView::Overview).left() - kMargin) < 1e-9);
    QVERIFY(std::abs(view->overlayRect(IrisSlideView::Overview).bottom() - (size.height() - kMargin)) < 1e-9);

    view->setOverviewVisible(false);
    view->setScaleBarVisible(false);
    for (auto o : kOverlays)
        QTRY_VERIFY(view->overlayRect(o).isEmpty());
    view->setMagnificationLabelVisible(true);
    QTRY_VERIFY(!view->overlayRect(IrisSlideView::MagnificationLabel).isEmpty());
    QVERIFY(m_w->frames->waitForCompleteFrame());
}

void TstOverlayWidget::badFontIsReported()
{
    showSample();
    IrisSlideView *view = m_w->view;
    QSignalSpy errors(view, &IrisSlideView::slideError);
    const QString missing = QStringLiteral("/nonexistent/iris-overlay-font.ttf");
    view->setOverlayFont(missing);
    QCOMPARE(view->overlayFont(), missing);
    // The readout is nothing but its label: without a font it is not shown; the bar still is.
    QTRY_VERIFY(view->overlayRect(IrisSlideView::MagnificationLabel).isEmpty());
    QVERIFY(!view->overlayRect(IrisSlideView::ScaleBar).isEmpty());
    QTRY_VERIFY(errors.count() >= 1);
    QVERIFY2(errors.first().first().toString().contains(missing), qPrintable(errors.first().first().toString()));
    view->resetOverlayFont();
    QVERIFY(view->overlayFont().isEmpty());
    QTRY_VERIFY(!view->overlayRect(IrisSlideView::MagnificationLabel).isEmpty());
}

void TstOverlayWidget::presentedOverlaysMatchHeadless()
{
    showSample();
    IrisSlideView *view = m_w->view;
    view->zoomBy(3);
    view->panBy(QPointF(-80, 40));
    QVERIFY(m_w->frames->waitForCompleteFrame());
    const QSize target = view->targetSize();
    QString error;
    const QImage headless = renderHeadless(m_sample, target, view->centre(), view->downsample(),
                                           view->backgroundColor(), &error, view);
    QVERIFY2(!headless.isNull(), qPrintable(error));
    const QImage bare = renderHeadless(m_sample, target, view->centre(), view->downsample(), view->backgroundColor(),
                                       &error);
    QVERIFY2(!bare.isNull(), qPrintable(error));
    // Not a vacuous comparison: the overlays change the frame.
    QVERIFY(compareImages(headless, bare, kPixelThreshold).fractionOver > 0.01);

    ImageDifference difference;
    QImage presented;
    const auto matches = [&] {
        presented = grabPresented(view);
        difference = compareImages(presented, headless, kPixelThreshold);
        return presented.size() == target && difference.meanAbs <= kMaxMeanDifference
            && difference.fractionOver <= kMaxFractionOver;
    };
    QTRY_VERIFY_WITH_TIMEOUT(matches(), 5000);
    qInfo("presented %dx%d with overlays vs headless: %s", target.width(), target.height(),
          qPrintable(difference.describe()));
    if (QTest::currentTestFailed() || qEnvironmentVariableIsSet("IRIS_TEST_SAVE_FRAMES")) {
        saveArtefact(presented, QStringLiteral("overlays-presented"));
        saveArtefact(headless, QStringLiteral("overlays-headless"));
    }
}

// The legend is on by default but drawn only while a heat map (Scalar layer) is shown; its
// properties switch and move it like the others'.
void TstOverlayWidget::legendShowsWithAHeatMap()
{
    IrisSlideView *view = m_w->view;
    QVERIFY(view->isLegendVisible());
    QCOMPARE(view->legendCorner(), IrisSlideView::BottomRight);
    const QMetaObject *mo = view->metaObject();
    for (const char *name : {"legendVisible", "legendCorner"}) {
        const QMetaProperty p = mo->property(mo->indexOfProperty(name));
        QVERIFY2(p.isValid() && p.isWritable() && p.isDesignable() && p.hasNotifySignal(), name);
    }
    showSample();
    QVERIFY(view->overlayRect(IrisSlideView::Legend).isEmpty());

    const std::vector<float> values{0, 0.5f, 1, 0.25f};
    auto map = iris::fromHostMemory(std::span<const float>(values), 2, 2, "probability");
    QVERIFY(map);
    QVERIFY(view->addLayer(std::make_shared<const iris::RasterMap>(std::move(map).value())) != 0);
    QTRY_VERIFY(!view->overlayRect(IrisSlideView::Legend).isEmpty());
    const QSizeF size = view->size();
    const QRectF legend = view->overlayRect(IrisSlideView::Legend);
    QVERIFY2(std::abs(legend.right() - (size.width() - kMargin)) < 1e-9
                 && std::abs(legend.bottom() - (size.height() - kMargin)) < 1e-9,
             qPrintable(rectText(legend)));

    QSignalSpy changed(view, &IrisSlideView::overlaysChanged);
    QVERIFY(view->setProperty("legendCorner", QVariant::fromValue(IrisSlideView::BottomLeft)));
    QTRY_VERIFY(std::abs(view->overlayRect(IrisSlideView::Legend).left() - kMargin) < 1e-9);
    QVERIFY(view->setProperty("legendVisible", false));
    QCOMPARE(changed.count(), 2);
    QTRY_VERIFY(view->overlayRect(IrisSlideView::Legend).isEmpty());
    QVERIFY(m_w->frames->waitForCompleteFrame());
}

void TstOverlayWidget::clickingTheOverviewMovesTheView()
{
    showSample();
    IrisSlideView *view = m_w->view;
    const double dpr = m_w->dpr();
    view->zoomBy(8); // the field is an eighth of the slide: its outline is a small box
    QVERIFY(m_w->frames->waitForCompleteFrame());
    QTRY_VERIFY(!view->overlayRect(IrisSlideView::Overview).isEmpty());
    const QRectF map = view->overlayRect(IrisSlideView::Overview);

    // A click: the view moves there, and the next frame's field outline is centred on it.
    const QPoint click = (map.topLeft() + QPointF(0.3 * map.width(), 0.6 * map.height())).toPoint();
    const QPointF before = view->centre();
    QTest::mouseClick(m_w->surface(), Qt::LeftButton, {}, click);
    QTRY_VERIFY(view->centre() != before);
    const double downsample = view->downsample();
    QVERIFY(m_w->frames->waitForCompleteFrame());
    const QRect mapDevice((map.topLeft() * dpr).toPoint(), (map.size() * dpr).toSize());
    QRect outline;
    QPointF centre;
    const auto outlineCentredOn = [&](QPoint p) {
        outline = colourBox(grabPresented(view), mapDevice, QColor(0, 255, 255));
        centre = QRectF(outline).center();
        return outline.isValid() && std::abs(centre.x() - p.x() * dpr) <= 1.5 && std::abs(centre.y() - p.y() * dpr) <= 1.5;
    };
    QTRY_VERIFY2_WITH_TIMEOUT(outlineCentredOn(click), qPrintable(QStringLiteral("outline %1,%2 %3x%4, click at %5,%6")
                                                                       .arg(outline.x()).arg(outline.y())
                                                                       .arg(outline.width()).arg(outline.height())
                                                                       .arg(click.x() * dpr).arg(click.y() * dpr)),
                              5000);
    QCOMPARE(view->downsample(), downsample); // a click moves, it does not zoom

    // A drag on the map keeps moving the view; nothing glides after the release.
    const QPoint start = (map.topLeft() + QPointF(0.6 * map.width(), 0.4 * map.height())).toPoint();
    const QPoint end = (map.topLeft() + QPointF(0.7 * map.width(), 0.5 * map.height())).toPoint();
    QTest::mousePress(m_w->surface(), Qt::LeftButton, {}, start);
    const QPointF atStart = view->centre();
    for (int i = 1; i <= 5; ++i)
        QTest::mouseMove(m_w->surface(), start + (end - start) * i / 5, 16);
    QTest::mouseRelease(m_w->surface(), Qt::LeftButton, {}, end, 16);
    // Moving right and down on the map moves the view right and down on the slide.
    QVERIFY(view->centre().x() > atStart.x() && view->centre().y() > atStart.y());
    const QPointF afterDrag = view->centre();
    QVERIFY(viewStaysStill(view));
    QCOMPARE(view->centre(), afterDrag);
    QVERIFY(m_w->frames->waitForCompleteFrame());
    QTRY_VERIFY_WITH_TIMEOUT(outlineCentredOn(end), 5000);

    // Outside the map a press and drag pans as before.
    const QPointF c0 = view->centre();
    const double ds = view->downsample();
    const QPoint p0(150, 200), p1(200, 230);
    QTest::mousePress(m_w->surface(), Qt::LeftButton, {}, p0);
    QTest::mouseMove(m_w->surface(), p1, 16);
    QTest::mouseRelease(m_w->surface(), Qt::LeftButton, {}, p1, 400);
    const QPointF expected = c0 - QPointF(p1 - p0) * dpr * ds;
    QVERIFY(std::abs(view->centre().x() - expected.x()) < 1e-6 && std::abs(view->centre().y() - expected.y()) < 1e-6);
}

void TstOverlayWidget::overlaysFollowTheDevicePixelRatio()
{
    showSample();
    IrisSlideView *view = m_w->view;
    view->zoomBy(2);
    QVERIFY(m_w->frames->waitForCompleteFrame());
    const double dpr = m_w->dpr();
    // A headless engine at ratio 1 showing the same logical field at the widget's logical size.
    iris::EngineConfig config;
    config.validation = true;
    config.loaderThreads = 2;
    auto created = iris::Engine::create(config);
    QVERIFY(created);
    iris::Engine &engine = **created;
    const QSize logical = view->size();
    QVERIFY(engine.bindOffscreen(uint32_t(logical.width()), uint32_t(logical.height())).ok());
    QVERIFY(engine.open(QFile::encodeName(m_sample).toStdString()).ok());
    for (int i = 0; i < iris::kOverlayCount; ++i)
        engine.setOverlayVisible(iris::Overlay(i), true);
    QTRY_VERIFY(!view->overlayRect(IrisSlideView::ScaleBar).isEmpty());
    for (auto o : kOverlays) {
        // The scale bar and the map measure the slide: the same logical field at ratio 1. The
        // magnification is per device pixel (as IrisSlideView::magnification()): the label of
        // the same device downsample.
        const double ds = o == IrisSlideView::MagnificationLabel ? view->downsample() : view->downsample() * dpr;
        engine.setView(iris::View{view->centre().x(), view->centre().y(), ds});
        QVERIFY(engine.waitForFrame(std::chrono::seconds(30)).ok());
        auto frame = engine.readFrame();
        QVERIFY(frame.ok());
        const iris::PixelRect r = frame->overlays.rect(iris::Overlay(int(o)));
        const QRectF expected(r.x, r.y, r.width, r.height);
        const QRectF shown = view->overlayRect(o);
        qInfo("overlay %d at ratio %g: %s logical, at ratio 1: %s", int(o), dpr, qPrintable(rectText(shown)),
              qPrintable(rectText(expected)));
        if (o == IrisSlideView::Overview) {
            // The thumbnail is fitted in device pixels: within a logical pixel.
            QVERIFY(std::abs(shown.left() - expected.left()) <= 1 && std::abs(shown.top() - expected.top()) <= 1
                    && std::abs(shown.width() - expected.width()) <= 1
                    && std::abs(shown.height() - expected.height()) <= 1);
        } else {
            QCOMPARE(shown, expected);
        }
    }
    QCOMPARE(engine.validationMessageCount(), uint64_t(0));
}

IRIS_WIDGET_TEST_MAIN(TstOverlayWidget)
#include "tst_overlay_widget.moc"
