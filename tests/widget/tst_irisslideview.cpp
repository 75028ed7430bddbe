// tst_irisslideview: IrisSlideView on a real X display (Xvfb in CI) with lavapipe and the
// Vulkan validation layers on (IrisSlideView::setVulkanValidation). Every test ends by checking that the
// layers reported nothing.
//
// Input is synthesised on the widget's Vulkan surface window (QTest mouse and key events go
// through QGuiApplication like real ones; wheel and gesture events are sent to the window),
// so each test also covers the forwarding from the window to the widget. Expected views are
// computed from the engine's contract: translate(dx, dy) moves centre by −(dx, dy) ×
// downsample, zoom keeps the anchor's level-0 point fixed.
//
// The suite runs twice: as is, and with QT_SCALE_FACTOR=2 (ctest entry widget.view.scale2),
// where every logical distance becomes two device pixels.
//
// Presented and headless frames are saved under $IRIS_TEST_OUT/failures when they differ
// (always, with IRIS_TEST_SAVE_FRAMES=1).

#include <algorithm>
#include <cmath>
#include <memory>

#include <QtCore/QDeadlineTimer>
#include <QtCore/QDir>
#include <QtCore/QElapsedTimer>
#include <QtCore/QFileInfo>
#include <QtGui/QScreen>
#include <QtGui/QWindow>
#include <QtTest/QSignalSpy>
#include <QtTest/QTest>
#include <QtWidgets/QApplication>
#include <QtWidgets/QHBoxLayout>
#include <QtWidgets/QLabel>
#include <QtWidgets/QVBoxLayout>

#include <iris/IrisSlideView.h>
#include <iris/types.h>

#include "enginehost_p.h"
#include "iris/annotations.h"
#include "irisslideview_p.h"
#include "navigator_p.h"
#include "widget_test_support.h"

using namespace iriswidgettest;

namespace {

constexpr QSize kViewSize(480, 360);
// Presented vs headless frame: at most this mean absolute difference per channel (0…255) …
constexpr double kMaxMeanDifference = 1.0;
// … and at most this fraction of pixels with a channel off by more than kPixelThreshold.
constexpr double kMaxFractionOver = 0.002;
constexpr int kPixelThreshold = 16;
// How long to wait for what the X server shows to catch up (a presented frame, a repaint). A
// bound on failure only: the waits return as soon as the condition holds. 5 s once ran out by
// 50 ms in CI (widget.view.scale2, after two device recoveries at twice the pixels, with other
// suites on the two cores).
constexpr int kPresentTimeoutMs = 30000;

bool near(double a, double b, double tolerance)
{
    return std::abs(a - b) <= tolerance;
}

double length(QPointF p)
{
    return std::hypot(p.x(), p.y());
}

QString pointText(QPointF p)
{
    return QStringLiteral("(%1, %2)").arg(p.x(), 0, 'f', 4).arg(p.y(), 0, 'f', 4);
}

// A top-level window holding one view that fills it.
struct ViewWindow {
    std::unique_ptr<QWidget> window = std::make_unique<QWidget>();
    IrisSlideView *view = new IrisSlideView;
    std::unique_ptr<FrameWatcher> frames = std::make_unique<FrameWatcher>(view);

    explicit ViewWindow(QSize size = kViewSize)
    {
        auto *layout = new QVBoxLayout(window.get());
        layout->setContentsMargins(0, 0, 0, 0);
        layout->addWidget(view);
        window->resize(size);
    }
    ~ViewWindow()
    {
        frames.reset(); // before the view it watches
    }
    QWindow *surface() const { return view->surfaceWindow(); }
    double dpr() const { return view->surfaceWindow()->devicePixelRatio(); }
};

} // namespace

class TstIrisSlideView : public QObject {
    Q_OBJECT

private Q_SLOTS:
    void initTestCase();
    void init();
    void cleanup();
    void cleanupTestCase();

    void showsSlide();
    void reportsDevicePixels();
    void dragPansWithThePointer();
    void releasedDragGlidesAndStops();
    void wheelKeepsPointUnderCursor();
    void trackpadAndPinchZoomAboutTheFingers();
    void doubleClickZoomsIn();
    void arrowKeysMoveOneField();
    void plusMinusAndFitKeys();
    void fitShowsWholeSlide();
    void uncoveredPixelsArePresentedAgain();
    void magnificationPresets();
    void resizeKeepsCentreAndMagnification();
    void hiddenViewRendersNothing();
    void reparentingRebindsTheSurface();
    void openErrorsLeaveTheViewUsable();
    void propertiesAndSignals();
    void twoViewsOnTwoSlides();
    void closingWhileTilesLoad();
    void turnsAndMirrors();
    void annotationsAreDrawnOverTheSlide();
    void resizeStormEndsRightAndValid();
    void survivesLostSurfacesAndDevices();
    void panningFrameTimesAreReported();

private:
    // Shows m_w with the sample slide and waits for a complete frame.
    void showSample();
    void checkPresentedMatchesHeadless(IrisSlideView *view, const QString &slide, const QString &name);
    void finishView(ViewWindow &w);

    QString m_sample;
    int m_baselineEngines = 0;
    std::unique_ptr<ViewWindow> m_w;
};

void TstIrisSlideView::initTestCase()
{
    QCOMPARE(QGuiApplication::platformName(), QStringLiteral("xcb"));
    // The widget never reads IRIS_VALIDATION (the environment does not set it for this suite):
    // the host turns validation on, before the first view makes the shared instance.
    QVERIFY(!IrisSlideView::vulkanValidation());
    IrisSlideView::setVulkanValidation(true);
    m_sample = sampleSlide();
    QVERIFY2(QFileInfo::exists(m_sample), qPrintable(QStringLiteral("no sample slide at '%1' "
                                                                     "(the sample_slide fixture makes it)")
                                                         .arg(m_sample)));
    m_baselineEngines = IrisWidget::EngineHost::liveEngineCount();
    QCOMPARE(m_baselineEngines, 0);
}

void TstIrisSlideView::init()
{
    m_w = std::make_unique<ViewWindow>();
}

void TstIrisSlideView::cleanup()
{
    if (m_w)
        finishView(*m_w);
    m_w.reset();
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), m_baselineEngines);
}

void TstIrisSlideView::cleanupTestCase()
{
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 0);
}

void TstIrisSlideView::finishView(ViewWindow &w)
{
    QVERIFY2(w.view->validationMessageCount() == 0,
             qPrintable(QStringLiteral("%1 Vulkan validation messages (see the log above)")
                            .arg(w.view->validationMessageCount())));
}

void TstIrisSlideView::showSample()
{
    m_w->window->show();
    QVERIFY(QTest::qWaitForWindowExposed(m_w->window.get()));
    QVERIFY(m_w->view->isRendererAvailable());
    QVERIFY2(m_w->view->openSlide(m_sample), qPrintable(m_sample));
    QTRY_VERIFY(m_w->view->surfaceWindow()->isExposed());
    QVERIFY(m_w->frames->waitForCompleteFrame());
}

void TstIrisSlideView::checkPresentedMatchesHeadless(IrisSlideView *view, const QString &slide, const QString &name)
{
    const QSize target = view->targetSize();
    QString error;
    const QImage headless = renderHeadless(slide, target, view->centre(), view->downsample(),
                                           view->backgroundColor(), &error, view);
    QVERIFY2(!headless.isNull(), qPrintable(error));

    // The complete frame was submitted; its presentation reaches the X server a moment later.
    ImageDifference difference;
    QImage presented;
    const auto matches = [&] {
        presented = grabPresented(view);
        difference = compareImages(presented, headless, kPixelThreshold);
        return presented.size() == target && difference.meanAbs <= kMaxMeanDifference
            && difference.fractionOver <= kMaxFractionOver;
    };
    QTRY_VERIFY_WITH_TIMEOUT(matches(), kPresentTimeoutMs);
    qInfo("%s: presented %dx%d vs headless: %s", qPrintable(name), target.width(), target.height(),
          qPrintable(difference.describe()));
    if (QTest::currentTestFailed() || qEnvironmentVariableIsSet("IRIS_TEST_SAVE_FRAMES")) {
        saveArtefact(presented, name + QStringLiteral("-presented"));
        saveArtefact(headless, name + QStringLiteral("-headless"));
    }
}

// --- rendering -----------------------------------------------------------------------------

void TstIrisSlideView::showsSlide()
{
    showSample();
    // Somewhere inside the slide, not at the fitted view, so tiles of a finer level show.
    m_w->view->setCentre(QPointF(2400, 1700));
    m_w->view->setDownsample(3.0);
    QVERIFY(m_w->frames->waitForCompleteFrame());
    checkPresentedMatchesHeadless(m_w->view, m_sample, QStringLiteral("showsSlide"));
    QVERIFY(m_w->frames->last()->tilesDrawn > 0);
}

void TstIrisSlideView::reportsDevicePixels()
{
    showSample();
    const double expected = qEnvironmentVariableIsSet("QT_SCALE_FACTOR")
        ? qEnvironmentVariable("QT_SCALE_FACTOR").toDouble() : m_w->window->screen()->devicePixelRatio();
    QCOMPARE(m_w->dpr(), expected);
    QCOMPARE(m_w->view->targetSize(), m_w->view->size() * expected);
    QCOMPARE(grabPresented(m_w->view).size(), m_w->view->targetSize());
}

// --- pointer -------------------------------------------------------------------------------

void TstIrisSlideView::dragPansWithThePointer()
{
    showSample();
    IrisSlideView *view = m_w->view;
    view->setDownsample(2.0);
    const QPointF c0 = view->centre();
    const double ds = view->downsample();
    const double dpr = m_w->dpr();
    const QPoint p0(100, 100);
    const QPoint p1(260, 190);
    const QPointF grabbed = view->mapToSlide(p0);

    QTest::mousePress(m_w->surface(), Qt::LeftButton, {}, p0);
    for (int i = 1; i <= 8; ++i)
        QTest::mouseMove(m_w->surface(), p0 + (p1 - p0) * i / 8, 16);
    // Held still before letting go: no glide.
    QTest::mouseRelease(m_w->surface(), Qt::LeftButton, {}, p1, 400);

    const QPointF expected = c0 - QPointF(p1 - p0) * dpr * ds;
    QVERIFY2(length(view->centre() - expected) < 1e-6,
             qPrintable(pointText(view->centre()) + QStringLiteral(" != ") + pointText(expected)));
    // The grabbed image point is under the pointer again.
    QVERIFY(length(view->mapFromSlide(grabbed) - QPointF(p1)) * dpr < 0.01);
    QVERIFY(viewStaysStill(view));
    QVERIFY(length(view->centre() - expected) < 1e-6);
    QVERIFY(m_w->frames->waitForCompleteFrame());
}

void TstIrisSlideView::releasedDragGlidesAndStops()
{
    showSample();
    IrisSlideView *view = m_w->view;
    view->setDownsample(2.0);
    const QPointF c0 = view->centre();
    const double ds = view->downsample();
    const double dpr = m_w->dpr();
    // 20 logical px every 16 ms: 1250 px/s, released while moving.
    QPoint p(100, 180);
    QTest::mousePress(m_w->surface(), Qt::LeftButton, {}, p);
    for (int i = 0; i < 8; ++i) {
        p += QPoint(20, 0);
        QTest::mouseMove(m_w->surface(), p, 16);
    }
    QTest::mouseRelease(m_w->surface(), Qt::LeftButton, {}, p, 1);
    const double dragged = (c0.x() - view->centre().x()) / (dpr * ds);
    QVERIFY2(near(dragged, 160, 1e-6) || dragged > 160, qPrintable(QString::number(dragged)));

    // It glides on in the same direction, slows down and stops.
    QTRY_VERIFY((c0.x() - view->centre().x()) / (dpr * ds) > 170);
    // The glide moves the view on every tick until it stops: it has stopped once the view
    // stays still for a few ticks.
    QDeadlineTimer deadline(5000);
    while (!viewStaysStill(view))
        QVERIFY2(!deadline.hasExpired(), "the glide did not stop within 5 s");
    const double glide = (c0.x() - view->centre().x()) / (dpr * ds) - 160;
    const double theoretical = 1250 * IrisWidget::KineticPanner::kTimeConstantS; // ∫ v e^(−t/τ) dt
    QVERIFY2(glide > 0.6 * theoretical && glide < 1.05 * theoretical,
             qPrintable(QStringLiteral("glided %1 px, expected about %2").arg(glide).arg(theoretical)));
    QCOMPARE(view->centre().y(), c0.y());

    // With kinetic panning off, the same gesture stops where the pointer let go.
    view->setKineticPanning(false);
    const QPointF c1 = view->centre();
    p = QPoint(100, 180);
    QTest::mousePress(m_w->surface(), Qt::LeftButton, {}, p);
    for (int i = 0; i < 8; ++i) {
        p += QPoint(20, 0);
        QTest::mouseMove(m_w->surface(), p, 16);
    }
    QTest::mouseRelease(m_w->surface(), Qt::LeftButton, {}, p, 1);
    QVERIFY(viewStaysStill(view));
    QVERIFY(near((c1.x() - view->centre().x()) / (dpr * ds), 160, 1e-6));
}

void TstIrisSlideView::wheelKeepsPointUnderCursor()
{
    showSample();
    IrisSlideView *view = m_w->view;
    const double dpr = m_w->dpr();
    const double ds0 = view->downsample();
    const QPointF p(130, 95);
    const QPointF under = view->mapToSlide(p);
    QSignalSpy viewChanges(view, &IrisSlideView::viewChanged);

    QWheelEvent wheel(p, m_w->surface()->mapToGlobal(p), QPoint(), QPoint(0, 120), Qt::NoButton,
                      Qt::NoModifier, Qt::NoScrollPhase, false);
    QCoreApplication::sendEvent(m_w->surface(), &wheel);
    const double expected = ds0 / IrisWidget::ViewNavigator::kWheelNotchFactor;
    QTRY_VERIFY(near(view->downsample(), expected, 1e-9 * expected));
    // Smooth: the zoom arrived in steps, not one jump.
    QVERIFY2(viewChanges.count() >= 2, qPrintable(QString::number(viewChanges.count())));
    const double offset = length(view->mapFromSlide(under) - p) * dpr;
    QVERIFY2(offset <= 1.0, qPrintable(QStringLiteral("the point moved %1 device px").arg(offset)));

    // Two notches out in quick succession add up, about the same point.
    QWheelEvent out(p, m_w->surface()->mapToGlobal(p), QPoint(), QPoint(0, -240), Qt::NoButton,
                    Qt::NoModifier, Qt::NoScrollPhase, false);
    QCoreApplication::sendEvent(m_w->surface(), &out);
    const double back = expected * std::pow(IrisWidget::ViewNavigator::kWheelNotchFactor, 2);
    QTRY_VERIFY(near(view->downsample(), back, 1e-9 * back));
    QVERIFY(length(view->mapFromSlide(under) - p) * dpr <= 1.0);
    QVERIFY(m_w->frames->waitForCompleteFrame());
}

void TstIrisSlideView::trackpadAndPinchZoomAboutTheFingers()
{
    showSample();
    IrisSlideView *view = m_w->view;
    const double dpr = m_w->dpr();
    const QPointF p(300, 120);
    const QPointF under = view->mapToSlide(p);

    // Trackpad: pixel deltas zoom at once (2× per kPixelsPerDoubling pixels).
    double ds = view->downsample();
    QWheelEvent pixels(p, m_w->surface()->mapToGlobal(p), QPoint(0, 150), QPoint(0, 150), Qt::NoButton,
                       Qt::NoModifier, Qt::ScrollUpdate, false);
    QCoreApplication::sendEvent(m_w->surface(), &pixels);
    const double afterPixels = ds / std::exp2(150 / IrisWidget::ViewNavigator::kPixelsPerDoubling);
    QVERIFY(near(view->downsample(), afterPixels, 1e-9 * afterPixels));
    QVERIFY(length(view->mapFromSlide(under) - p) * dpr <= 1.0);

    // Pinch: value() is the scale change of this step.
    ds = view->downsample();
    QNativeGestureEvent pinch(Qt::ZoomNativeGesture, QPointingDevice::primaryPointingDevice(), 2, p, p,
                              m_w->surface()->mapToGlobal(p), 0.25, QPointF());
    QCoreApplication::sendEvent(m_w->surface(), &pinch);
    QVERIFY(near(view->downsample(), ds / 1.25, 1e-9 * ds));
    QVERIFY(length(view->mapFromSlide(under) - p) * dpr <= 1.0);
}

void TstIrisSlideView::doubleClickZoomsIn()
{
    showSample();
    IrisSlideView *view = m_w->view;
    const double dpr = m_w->dpr();
    const double ds0 = view->downsample();
    const QPoint p(200, 150);
    const QPointF under = view->mapToSlide(p);
    QTest::mouseDClick(m_w->surface(), Qt::LeftButton, {}, p);
    QTRY_VERIFY(near(view->downsample(), ds0 / 2, 1e-9 * ds0));
    QVERIFY(length(view->mapFromSlide(under) - QPointF(p)) * dpr <= 1.0);
    QTest::mouseDClick(m_w->surface(), Qt::LeftButton, Qt::ShiftModifier, p);
    QTRY_VERIFY(near(view->downsample(), ds0, 1e-9 * ds0));
}

// --- keys ----------------------------------------------------------------------------------

void TstIrisSlideView::arrowKeysMoveOneField()
{
    showSample();
    IrisSlideView *view = m_w->view;
    view->setDownsample(1.5);
    const QPointF c0 = view->centre();
    const double ds = view->downsample();
    const QSize field = view->targetSize();

    // A click on the surface gives the view the keyboard, despite the window container: the
    // platform then delivers keys to the focus window, which is the view's surface (Qt 6.4's
    // QWindowContainer leaves QApplication::focusWidget() empty while an embedded window has
    // focus) or, when a widget has focus, the top-level window.
    QWidget elsewhere;
    m_w->window->layout()->addWidget(&elsewhere);
    elsewhere.setFocusPolicy(Qt::StrongFocus);
    m_w->window->activateWindow();
    QVERIFY(QTest::qWaitForWindowActive(m_w->window.get()));
    elsewhere.setFocus();
    QTRY_VERIFY(elsewhere.hasFocus());
    QTest::mouseClick(m_w->surface(), Qt::LeftButton, {}, QPoint(20, 20));
    QTRY_VERIFY(!elsewhere.hasFocus());
    QTRY_VERIFY(QGuiApplication::focusWindow() == m_w->surface() || view->hasFocus());
    QCOMPARE(view->centre(), c0); // a click without a drag does not move the view
    QTest::keyClick(QGuiApplication::focusWindow(), Qt::Key_Right);
    QCOMPARE(view->centre(), c0 + QPointF(field.width() * ds, 0)); // one whole field: no overlap
    m_w->window->layout()->removeWidget(&elsewhere);
    elsewhere.setParent(nullptr);
    QTRY_COMPARE(view->targetSize(), field);

    // Keys sent to the surface window directly …
    QTest::keyClick(m_w->surface(), Qt::Key_Down);
    QCOMPARE(view->centre(), c0 + QPointF(field.width() * ds, field.height() * ds));
    QVERIFY(m_w->frames->waitForCompleteFrame());
    // … and on the widget (focus on the view itself) do the same.
    m_w->view->setFocus();
    QTest::keyClick(view, Qt::Key_Left);
    QCOMPARE(view->centre(), c0 + QPointF(0, field.height() * ds));
    QTest::keyClick(view, Qt::Key_Up);
    QCOMPARE(view->centre(), c0);
}

void TstIrisSlideView::plusMinusAndFitKeys()
{
    showSample();
    IrisSlideView *view = m_w->view;
    const double fitted = view->downsample();
    const QPointF centre = view->centre();
    QTest::keyClick(m_w->surface(), Qt::Key_Plus);
    QTRY_VERIFY(near(view->downsample(), fitted / 2, 1e-9 * fitted));
    QVERIFY(length(view->centre() - centre) < 1e-6 * fitted);
    QTest::keyClick(m_w->surface(), Qt::Key_Plus);
    QTRY_VERIFY(near(view->downsample(), fitted / 4, 1e-9 * fitted));
    QTest::keyClick(m_w->surface(), Qt::Key_Minus);
    QTRY_VERIFY(near(view->downsample(), fitted / 2, 1e-9 * fitted));
    view->panBy(QPointF(40, 25));
    QTest::keyClick(m_w->surface(), Qt::Key_0);
    QCOMPARE(view->downsample(), fitted);
    QCOMPARE(view->centre(), centre);
    view->zoomBy(3);
    view->panBy(QPointF(-70, 10));
    QTest::keyClick(m_w->surface(), Qt::Key_Home);
    QCOMPARE(view->downsample(), fitted);
    QCOMPARE(view->centre(), centre);
}

void TstIrisSlideView::fitShowsWholeSlide()
{
    m_w->view->setBackgroundColor(QColor(40, 90, 160));
    showSample();
    IrisSlideView *view = m_w->view;
    view->zoomBy(6);
    view->panBy(QPointF(120, -60));
    view->fitToWindow();
    QVERIFY(m_w->frames->waitForCompleteFrame());

    const IrisSlideInfo info = view->slideInfo();
    const QPointF topLeft = view->mapFromSlide(QPointF(0, 0));
    const QPointF bottomRight = view->mapFromSlide(QPointF(double(info.width), double(info.height)));
    const QSizeF size = view->size();
    QVERIFY2(topLeft.x() >= -0.5 && topLeft.y() >= -0.5, qPrintable(pointText(topLeft)));
    QVERIFY2(bottomRight.x() <= size.width() + 0.5 && bottomRight.y() <= size.height() + 0.5,
             qPrintable(pointText(bottomRight)));
    // Whole and as large as fits: it touches both sides of one dimension.
    const QSizeF shown(bottomRight.x() - topLeft.x(), bottomRight.y() - topLeft.y());
    QVERIFY(shown.width() >= size.width() - 1 || shown.height() >= size.height() - 1);

    // 6000 × 4000 in 480 × 360: bands above and below the slide show the background. The
    // complete frame was submitted; its presentation reaches the X server later, and must within
    // 1 s (issue 13: what a user accepts, on lavapipe under load). Three CI runs once saw the
    // window still show the zoomed view 5-10 s after the fit view's complete frame; an X server
    // without a compositor leaves stale pixels where an expose is not answered with a present,
    // which the view now does (uncoveredPixelsArePresentedAgain). Since then none in 20 runs
    // here with the two cores loaded 4-5 times over (load average 8-10), nor in CI.
    //
    // The presented pixel is sampled every 20 ms until it has shown the band for 1 s without a
    // break (a window that shows the band and then something else again starts over). The
    // failure message, and the warning when it took long or flipped, is the whole timeline
    // (ms since the complete frame: colour seen, frames delivered meanwhile), so that a
    // recurrence says what the window showed when.
    const QPoint topCentre(view->targetSize().width() / 2, 1);
    const QColor wanted(40, 90, 160);
    QElapsedTimer presentWait;
    presentWait.start();
    QStringList timeline;
    qint64 bandSince = -1;
    bool flippedBack = false;
    int framesBefore = m_w->frames->frames();
    QString lastSeen;
    constexpr qint64 kPresentWithinMs = 1000;
    while (presentWait.elapsed() < kPresentWithinMs + 1000) {
        QColor seen;
        const bool isBand = presentedPixelIs(view, topCentre, wanted, 2, &seen);
        const qint64 now = presentWait.elapsed();
        const int frames = m_w->frames->frames();
        if (seen.name() != lastSeen || frames != framesBefore) {
            const auto last = m_w->frames->last();
            timeline << QStringLiteral("%1 ms: %2 (%3 new frames, last #%4 %5)")
                            .arg(now)
                            .arg(seen.isValid() ? seen.name() : QStringLiteral("no grab"))
                            .arg(frames - framesBefore)
                            .arg(last ? last->serial : 0)
                            .arg(last && last->complete ? QStringLiteral("complete") : QStringLiteral("partial"));
            lastSeen = seen.name();
            framesBefore = frames;
        }
        if (isBand) {
            if (bandSince < 0)
                bandSince = now;
            if (now - bandSince >= 1000)
                break;
        } else if (bandSince >= 0) {
            flippedBack = true;
            bandSince = -1;
        }
        QTest::qWait(20);
    }
    const QString story = timeline.join(QStringLiteral("; "));
    qInfo("fitShowsWholeSlide: the fit view was presented for good %lld ms after its complete frame%s",
          static_cast<long long>(bandSince), flippedBack ? " (it showed and then lost the band)" : "");
    QVERIFY2(bandSince >= 0 && bandSince <= kPresentWithinMs && presentWait.elapsed() - bandSince >= 1000,
             qPrintable(QStringLiteral("the fit view's band at (%1, %2), within %3 ms and then for 1 s: %4")
                            .arg(topCentre.x())
                            .arg(topCentre.y())
                            .arg(kPresentWithinMs)
                            .arg(story)));
    if (flippedBack)
        qWarning("fitShowsWholeSlide: %s", qPrintable(story));
    checkPresentedMatchesHeadless(view, m_sample, QStringLiteral("fitShowsWholeSlide"));
}

// Qt makes the surface window without a background, and an X server without a compositor
// (Xvfb here, many remote and kiosk desktops) leaves in it whatever covered it when the cover
// goes away: the view must present its frame again on that expose, although nothing changed.
void TstIrisSlideView::uncoveredPixelsArePresentedAgain()
{
    m_w->view->setBackgroundColor(QColor(40, 90, 160));
    showSample();
    IrisSlideView *view = m_w->view;
    const QColor band(40, 90, 160), cover(0, 200, 0);
    const QPoint at(view->targetSize().width() / 2, 2); // device pixels, in the band above the slide
    QColor seen;
    QTRY_VERIFY2(presentedPixelIs(view, at, band, 2, &seen), qPrintable(seen.name()));

    // A frameless top-level window over that spot (logical pixels on the screen).
    QWidget coverWindow(nullptr, Qt::FramelessWindowHint | Qt::WindowStaysOnTopHint | Qt::X11BypassWindowManagerHint);
    QPalette palette;
    palette.setColor(QPalette::Window, cover);
    coverWindow.setPalette(palette);
    coverWindow.setAutoFillBackground(true);
    const double dpr = m_w->dpr();
    const QPoint logical(int(at.x() / dpr), 0);
    coverWindow.setGeometry(QRect(view->surfaceWindow()->mapToGlobal(logical) - QPoint(20, 0), QSize(40, 20)));
    coverWindow.show();
    QVERIFY(QTest::qWaitForWindowExposed(&coverWindow));
    // Reading the view's window back gives the screen's pixels there: the cover's colour.
    if (!QTest::qWaitFor([&] { return presentedPixelIs(view, at, cover, 2, &seen); }, 5000))
        QSKIP(qPrintable(QStringLiteral("the X server did not show the cover over the view (%1): it composites or "
                                        "keeps backing store, so nothing is lost").arg(seen.name())));
    const int framesBefore = m_w->frames->frames();
    coverWindow.hide();
    // Without a new present the spot keeps the cover's green for good.
    QTRY_VERIFY2_WITH_TIMEOUT(presentedPixelIs(view, at, band, 2, &seen), qPrintable(seen.name()), kPresentTimeoutMs);
    // The frame's signal is queued after its present: the X server may show the pixels before
    // the event loop has delivered it.
    QTRY_VERIFY_WITH_TIMEOUT(m_w->frames->frames() > framesBefore, kPresentTimeoutMs);
    QCOMPARE(view->validationMessageCount(), quint64(0));
}

void TstIrisSlideView::magnificationPresets()
{
    showSample();
    IrisSlideView *view = m_w->view;
    if (view->objectivePower() <= 0) {
        // The slide states neither objective nor resolution: presets do nothing.
        const double ds = view->downsample();
        QCOMPARE(view->magnification(), 0.0);
        QTest::keyClick(m_w->surface(), Qt::Key_3);
        QCOMPARE(view->downsample(), ds);
    }

    const QString svs = testDataSlide(QStringLiteral("aperio/CMU-1-Small-Region.svs"));
    if (svs.isEmpty())
        QSKIP("needs the shared test data (aperio/CMU-1-Small-Region.svs states 20× and 0.499 µm/px)");
    QVERIFY(view->openSlide(svs));
    QVERIFY(view->objectivePower() > 0);
    const double presets[] = {5, 10, 20, 40};
    int aligned = 0;
    for (int i = 0; i < 4; ++i) {
        view->setCentre(QPointF(1000.3, 700.6)); // between pixels
        QTest::keyClick(m_w->surface(), Qt::Key(Qt::Key_1 + i));
        QVERIFY2(near(view->magnification(), presets[i], 1e-9 * presets[i]),
                 qPrintable(QString::number(view->magnification())));
        const double ds = view->downsample();
        QCOMPARE(ds, view->objectivePower() * view->slideInfo().levels.first().downsample / presets[i]);
        // At a level's own scale (20× here, downsample 1) the centre moved, by under half a
        // device pixel, so that every device pixel's centre is a level pixel's centre.
        for (const IrisSlideLevel &level : view->slideInfo().levels) {
            if (level.downsample != ds)
                continue;
            ++aligned;
            const QPointF c = view->centre();
            QVERIFY(std::abs(c.x() - 1000.3) <= 0.5 * ds && std::abs(c.y() - 700.6) <= 0.5 * ds);
            const QSize target = view->targetSize();
            const iris::ViewTransform t = iris::ViewTransform::of(
                iris::View{.centerX = c.x(), .centerY = c.y(), .downsample = ds}, target.width(), target.height());
            for (const int x : {0, target.width() / 2, target.width() - 1})
                for (const int y : {0, target.height() / 2, target.height() - 1}) {
                    const auto [sx, sy] = t.toSlide(x + 0.5, y + 0.5);
                    QCOMPARE(sx / level.downsample - std::floor(sx / level.downsample), 0.5);
                    QCOMPARE(sy / level.downsample - std::floor(sy / level.downsample), 0.5);
                }
        }
    }
    QVERIFY(aligned > 0); // 20× on this 20× scan
    view->setMagnification(2.5);
    QVERIFY(near(view->magnification(), 2.5, 1e-9));
    QVERIFY(m_w->frames->waitForCompleteFrame());
}

// --- window life ---------------------------------------------------------------------------

void TstIrisSlideView::resizeKeepsCentreAndMagnification()
{
    showSample();
    IrisSlideView *view = m_w->view;
    view->setCentre(QPointF(3100, 1900));
    view->setDownsample(2.5);
    const QPointF centre = view->centre();
    const double ds = view->downsample();
    const double magnification = view->magnification();

    for (const QSize size : {QSize(640, 300), QSize(300, 420), kViewSize}) {
        m_w->window->resize(size);
        const QSize target = size * m_w->dpr();
        QTRY_COMPARE(view->targetSize(), target);
        QCOMPARE(view->centre(), centre);
        QCOMPARE(view->downsample(), ds);
        QCOMPARE(view->magnification(), magnification);
        QVERIFY(m_w->frames->waitForCompleteFrame());
        QTRY_COMPARE(grabPresented(view).size(), target);
    }
    checkPresentedMatchesHeadless(view, m_sample, QStringLiteral("resize"));
}

void TstIrisSlideView::hiddenViewRendersNothing()
{
    showSample();
    IrisSlideView *view = m_w->view;
    m_w->window->hide();
    QTRY_VERIFY(!m_w->surface()->isExposed());
    const int before = m_w->frames->frames();
    view->panBy(QPointF(50, 0));
    view->zoomBy(1.5);
    // Frames of the view shown before the hide may still arrive (tiles of its perimeter
    // landing); none of the view set while hidden may. A negative check: nothing announces
    // "no frame will come", so it waits several times what a visible view takes to present a
    // frame of a change (tens of milliseconds here, lavapipe at 480 × 360).
    const QPointF hiddenCentre = view->centre();
    const double hiddenDownsample = view->downsample();
    int hiddenFrames = 0;
    const auto counter = connect(view, &IrisSlideView::framePresented, this, [&](const IrisFrameMetrics &metrics) {
        if (metrics.centre == hiddenCentre && metrics.downsample == hiddenDownsample)
            ++hiddenFrames;
    });
    QTest::qWait(200);
    disconnect(counter);
    QCOMPARE(hiddenFrames, 0);

    m_w->window->show();
    QVERIFY(QTest::qWaitForWindowExposed(m_w->window.get()));
    QVERIFY(m_w->frames->waitForCompleteFrame());
    QVERIFY(m_w->frames->frames() > before);
    checkPresentedMatchesHeadless(view, m_sample, QStringLiteral("hideShow"));
}

void TstIrisSlideView::reparentingRebindsTheSurface()
{
    showSample();
    IrisSlideView *view = m_w->view;
    view->setDownsample(4);
    const QPointF centre = view->centre();
    // Into another top-level window: Qt may destroy and recreate the native surface; the
    // view releases the swapchain first and binds the new surface when it is exposed.
    QWidget other;
    auto *layout = new QHBoxLayout(&other);
    layout->setContentsMargins(0, 0, 0, 0);
    other.resize(kViewSize);
    layout->addWidget(view);
    other.show();
    QVERIFY(QTest::qWaitForWindowExposed(&other));
    QTRY_VERIFY(view->surfaceWindow()->isExposed());
    QCOMPARE(view->centre(), centre);
    QVERIFY(m_w->frames->waitForCompleteFrame());
    checkPresentedMatchesHeadless(view, m_sample, QStringLiteral("reparented"));
    // And back, so that the fixture owns it again.
    m_w->window->layout()->addWidget(view);
    QVERIFY(m_w->frames->waitForCompleteFrame());
    finishView(*m_w);
}

// --- API -----------------------------------------------------------------------------------

void TstIrisSlideView::openErrorsLeaveTheViewUsable()
{
    showSample();
    IrisSlideView *view = m_w->view;
    QSignalSpy errors(view, &IrisSlideView::slideError);
    QSignalSpy closed(view, &IrisSlideView::slideClosed);

    QVERIFY(!view->openSlide(QStringLiteral("/nonexistent/iris/missing.svs")));
    QCOMPARE(errors.count(), 1);
    QVERIFY(!errors.first().first().toString().isEmpty());
    QCOMPARE(closed.count(), 1);
    QVERIFY(!view->hasSlide());
    QVERIFY(view->slidePath().isEmpty());
    QCOMPARE(view->magnification(), 0.0);
    // Input without a slide is harmless.
    QTest::keyClick(m_w->surface(), Qt::Key_Right);
    QTest::mouseDClick(m_w->surface(), Qt::LeftButton, {}, QPoint(50, 50));

    const QString bad = testDataSlide(QStringLiteral("bad"));
    if (!bad.isEmpty()) {
        for (const QFileInfo &file : QDir(bad).entryInfoList(QDir::Files)) {
            errors.clear();
            const bool opened = view->openSlide(file.absoluteFilePath());
            QVERIFY2(opened || errors.count() == 1, qPrintable(file.fileName()));
            // Let the tiles of a half-readable file load or fail (a failed tile is drawn as a
            // placeholder, so the frame is complete either way) before the next file replaces it.
            if (opened)
                QVERIFY2(m_w->frames->waitForCompleteFrame(), qPrintable(file.fileName()));
        }
    }

    errors.clear();
    QVERIFY(view->openSlide(m_sample));
    QVERIFY(m_w->frames->waitForCompleteFrame());
    QCOMPARE(errors.count(), 0);
}

void TstIrisSlideView::propertiesAndSignals()
{
    IrisSlideView *view = m_w->view;
    QSignalSpy opened(view, &IrisSlideView::slideOpened);
    QSignalSpy pathChanged(view, &IrisSlideView::slidePathChanged);
    QSignalSpy viewChanged(view, &IrisSlideView::viewChanged);
    QSignalSpy presented(view, &IrisSlideView::framePresented);
    showSample();

    QCOMPARE(opened.count(), 1);
    const auto info = opened.first().first().value<IrisSlideInfo>();
    QCOMPARE(info.path, m_sample);
    QCOMPARE(info.vendor, QStringLiteral("generic-tiff"));
    QCOMPARE(info.width, qint64(6000));
    QCOMPARE(info.height, qint64(4000));
    QVERIFY(info.levels.size() >= 2);
    QCOMPARE(info.levels.first().downsample, 1.0);
    QVERIFY(!info.properties.isEmpty());
    QCOMPARE(view->slideInfo().width, info.width);
    QCOMPARE(pathChanged.count(), 1);
    QCOMPARE(view->slidePath(), m_sample);
    QVERIFY(viewChanged.count() >= 1);

    QVERIFY(presented.count() >= 1);
    const auto metrics = presented.last().first().value<IrisFrameMetrics>();
    QVERIFY(metrics.serial > 0);
    QVERIFY(metrics.cpuMs >= 0);
    QVERIFY(metrics.tilesDrawn > 0);

    // Through the meta-object, as Designer and QML see them.
    viewChanged.clear();
    QVERIFY(view->setProperty("centre", QPointF(1000, 1200)));
    QCOMPARE(view->property("centre").toPointF(), QPointF(1000, 1200));
    QCOMPARE(viewChanged.count(), 1);
    QVERIFY(view->setProperty("downsample", 2.0));
    QCOMPARE(view->property("downsample").toDouble(), 2.0);
    QSignalSpy enhance(view, &IrisSlideView::enhanceChanged);
    QVERIFY(view->setProperty("enhance", false));
    QCOMPARE(enhance.count(), 1);
    QVERIFY(!view->enhance());
    QSignalSpy background(view, &IrisSlideView::backgroundColorChanged);
    QVERIFY(view->setProperty("backgroundColor", QColor(Qt::black)));
    QCOMPARE(background.count(), 1);

    // Budgets take effect with the next engine, made when the next slide opens.
    QVERIFY(view->setProperty("ramBudgetMB", 256));
    QVERIFY(view->setProperty("vramBudgetMB", 128));
    QCOMPARE(view->ramBudgetMB(), 256);
    QCOMPARE(view->vramBudgetMB(), 128);
    QVERIFY(view->openSlide(m_sample));
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), m_baselineEngines + 1);
    QVERIFY(m_w->frames->waitForCompleteFrame());
    QVERIFY(!view->enhance());
    QCOMPARE(view->backgroundColor(), QColor(Qt::black));

    QSignalSpy closed(view, &IrisSlideView::slideClosed);
    pathChanged.clear();
    view->setProperty("slidePath", QString());
    QCOMPARE(closed.count(), 1);
    QCOMPARE(pathChanged.count(), 1);
    QVERIFY(!view->hasSlide());
    QVERIFY(view->setProperty("slidePath", m_sample));
    QVERIFY(view->hasSlide());
}

void TstIrisSlideView::twoViewsOnTwoSlides()
{
    const QString second = secondSampleSlide();
    QVERIFY2(QFileInfo::exists(second), qPrintable(second));
    QWidget window;
    auto *layout = new QHBoxLayout(&window);
    layout->setContentsMargins(0, 0, 0, 0);
    layout->setSpacing(0);
    auto *a = new IrisSlideView;
    auto *b = new IrisSlideView;
    layout->addWidget(a);
    layout->addWidget(b);
    window.resize(640, 280);
    FrameWatcher framesA(a);
    FrameWatcher framesB(b);
    window.show();
    QVERIFY(QTest::qWaitForWindowExposed(&window));
    QVERIFY(a->openSlide(m_sample));
    QVERIFY(b->openSlide(second));
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), m_baselineEngines + 2);
    QVERIFY(framesA.waitForCompleteFrame());
    QVERIFY(framesB.waitForCompleteFrame());
    QCOMPARE(b->slideInfo().width, qint64(3000));

    const QPointF centreB = b->centre();
    const double downsampleB = b->downsample();
    a->zoomBy(2);
    a->panBy(QPointF(30, 20));
    QCOMPARE(b->centre(), centreB);
    QCOMPARE(b->downsample(), downsampleB);
    QVERIFY(framesA.waitForCompleteFrame());
    checkPresentedMatchesHeadless(a, m_sample, QStringLiteral("twoViews-a"));
    checkPresentedMatchesHeadless(b, second, QStringLiteral("twoViews-b"));
    QCOMPARE(a->validationMessageCount(), quint64(0));
    QCOMPARE(b->validationMessageCount(), quint64(0));
}

void TstIrisSlideView::closingWhileTilesLoad()
{
    m_w.reset();
    // Deleted at various moments after opening, zoomed far in (many tiles to load) and mid-zoom:
    // at once, after the zoom's first step, after the first frame presented, and after the
    // first complete frame of the zoomed view (its perimeter perhaps still loading). How many frames
    // come in between depends on the machine's speed, so no moment counts them.
    enum class Moment { AtOnce, ZoomStep, FirstFrame, CompleteFrame };
    for (const Moment moment : {Moment::AtOnce, Moment::ZoomStep, Moment::FirstFrame, Moment::CompleteFrame}) {
        auto w = std::make_unique<ViewWindow>();
        w->window->show();
        QVERIFY(QTest::qWaitForWindowExposed(w->window.get()));
        QVERIFY(w->view->openSlide(m_sample));
        w->view->setDownsample(0.5);
        w->view->panBy(QPointF(-300, -200));
        const QPointF p(240, 180);
        QSignalSpy zoomed(w->view, &IrisSlideView::viewChanged);
        QSignalSpy presented(w->view, &IrisSlideView::framePresented);
        QWheelEvent wheel(p, w->surface()->mapToGlobal(p), QPoint(), QPoint(0, 360), Qt::NoButton,
                          Qt::NoModifier, Qt::NoScrollPhase, false);
        QCoreApplication::sendEvent(w->surface(), &wheel);
        if (moment == Moment::ZoomStep)
            QVERIFY(zoomed.wait());
        if (moment == Moment::FirstFrame)
            QVERIFY(presented.wait());
        if (moment == Moment::CompleteFrame)
            QVERIFY(w->frames->waitForCompleteFrame());
        QCOMPARE(w->view->validationMessageCount(), quint64(0));
        w.reset();
        QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), m_baselineEngines);
    }
    // The view's own widget deleted directly while its window stays.
    ViewWindow w;
    w.window->show();
    QVERIFY(QTest::qWaitForWindowExposed(w.window.get()));
    QVERIFY(w.view->openSlide(m_sample));
    w.view->setDownsample(0.75);
    w.frames.reset();
    delete w.view;
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), m_baselineEngines);
    // No queued frame reaches the deleted view: the engine is gone, so every frame signal it
    // posted is in the queue now; deliver them all.
    QCoreApplication::sendPostedEvents();
    QCoreApplication::processEvents();
}

void TstIrisSlideView::turnsAndMirrors()
{
    showSample();
    IrisSlideView *view = m_w->view;
    view->setCentre(QPointF(2400, 1700));
    view->setDownsample(3.0);
    QVERIFY(m_w->frames->waitForCompleteFrame());
    QCOMPARE(view->rotation(), 0.0);

    // R: a quarter turn clockwise about the centre, animated, landing on 90 exactly.
    const QPointF centre = view->centre();
    QSignalSpy viewChanges(view, &IrisSlideView::viewChanged);
    QTest::keyClick(m_w->surface(), Qt::Key_R);
    QTRY_COMPARE(view->rotation(), 90.0);
    QVERIFY2(viewChanges.count() >= 2, "the turn was not animated");
    QVERIFY(length(view->centre() - centre) < 1e-6);
    // Clockwise: the slide's +x now points down the screen.
    const QPointF c = view->mapFromSlide(centre);
    const QPointF right = view->mapFromSlide(centre + QPointF(100, 0));
    QVERIFY2(std::abs(right.x() - c.x()) < 1e-6 && right.y() > c.y(), "not clockwise");
    QVERIFY(m_w->frames->waitForCompleteFrame());
    checkPresentedMatchesHeadless(view, m_sample, QStringLiteral("turned90"));

    // Shift+wheel turns 15° a notch about the pointer, whose slide point stays put.
    const QPointF p(130, 95);
    const QPointF under = view->mapToSlide(p);
    QWheelEvent wheel(p, m_w->surface()->mapToGlobal(p), QPoint(), QPoint(0, 120), Qt::NoButton,
                      Qt::ShiftModifier, Qt::NoScrollPhase, false);
    QCoreApplication::sendEvent(m_w->surface(), &wheel);
    QTRY_VERIFY(near(view->rotation(), 105, 1e-9));
    QVERIFY(length(view->mapFromSlide(under) - p) * m_w->dpr() <= 1e-6);
    QCOMPARE(view->downsample(), 3.0); // a turn zooms nothing
    // mapToSlide and mapFromSlide are inverses at any angle.
    for (const QPointF q : {QPointF(0, 0), QPointF(17.5, 203.25), QPointF(311, 7)})
        QVERIFY(length(view->mapFromSlide(view->mapToSlide(q)) - q) < 1e-6);
    QVERIFY(m_w->frames->waitForCompleteFrame());
    checkPresentedMatchesHeadless(view, m_sample, QStringLiteral("turned105"));

    // F mirrors the image left-right on screen: a point right of the centre goes left of it.
    const QPointF before = view->mapFromSlide(centre + QPointF(300, 200)) - view->mapFromSlide(centre);
    QTest::keyClick(m_w->surface(), Qt::Key_F);
    QTRY_VERIFY(view->isFlippedHorizontally());
    const QPointF after = view->mapFromSlide(centre + QPointF(300, 200)) - view->mapFromSlide(centre);
    QVERIFY2(std::abs(after.x() + before.x()) < 1e-6 && std::abs(after.y() - before.y()) < 1e-6,
             "F did not mirror the screen left-right");
    QVERIFY(m_w->frames->waitForCompleteFrame());
    checkPresentedMatchesHeadless(view, m_sample, QStringLiteral("turnedMirrored"));

    // Ctrl+drag turns with the pointer's angle about the centre: a quarter circle clockwise.
    const QPointF mid = QPointF(view->width(), view->height()) / 2;
    const double turned = view->rotation();
    const QPointF dragCentre = view->centre();
    QTest::mousePress(m_w->surface(), Qt::LeftButton, Qt::ControlModifier, mid.toPoint() + QPoint(80, 0));
    for (int k = 1; k <= 9; ++k) {
        const double a = k * 10 * 3.14159265358979323846 / 180;
        const QPointF at = QPointF(mid.toPoint()) + QPointF(80 * std::cos(a), 80 * std::sin(a));
        QMouseEvent move(QEvent::MouseMove, at, m_w->surface()->mapToGlobal(at), Qt::NoButton, Qt::LeftButton,
                         Qt::ControlModifier);
        QCoreApplication::sendEvent(m_w->surface(), &move);
    }
    QTest::mouseRelease(m_w->surface(), Qt::LeftButton, Qt::ControlModifier, mid.toPoint() + QPoint(0, 80));
    const double swept = iris::normalizedRotation(view->rotation() - turned);
    QVERIFY2(std::abs(swept - 90) < 1.5, qPrintable(QStringLiteral("turned by %1").arg(swept)));
    QVERIFY(length(view->centre() - dragCentre) < 1e-6); // about the view's centre

    // Shift+Home: upright and unmirrored again; setRotation and setFlipped set them directly.
    QTest::keyClick(m_w->surface(), Qt::Key_Home, Qt::ShiftModifier);
    QTRY_COMPARE(view->rotation(), 0.0);
    QVERIFY(!view->isFlippedHorizontally() && !view->isFlippedVertically());
    view->setRotation(-30);
    QCOMPARE(view->rotation(), 330.0);
    view->setFlipped(false, true);
    QVERIFY(view->isFlippedVertically());
    view->setView(QPointF(1000, 800), 2.0, 45);
    QCOMPARE(view->rotation(), 45.0);
    QCOMPARE(view->centre(), QPointF(1000, 800));
    QVERIFY(m_w->frames->waitForCompleteFrame());
    checkPresentedMatchesHeadless(view, m_sample, QStringLiteral("turned45flipped"));
}

// --- annotations -------------------------------------------------------------------------

void TstIrisSlideView::annotationsAreDrawnOverTheSlide()
{
    showSample();
    IrisSlideView *view = m_w->view;
    QVERIFY(m_w->frames->waitForCompleteFrame());
    QSignalSpy changed(view, &IrisSlideView::annotationsChanged);
    QVERIFY(view->annotationsVisible());
    auto store = std::make_shared<iris::AnnotationStore>();
    const QPointF c = view->centre();
    const double ds = view->downsample() * 30; // 30 device pixels either side at any scale
    iris::AnnotationObject r;
    r.kind = iris::AnnotationKind::Rectangle;
    r.box = {c.x() - ds, c.y() - ds, c.x() + ds, c.y() + ds};
    r.color = iris::Rgba8{255, 0, 0, 255};
    r.fill = true;
    r.fillOpacity = 1.0f;
    const auto id = store->add(r);
    QVERIFY(id.ok());
    const auto centreIsRed = [view] {
        const QImage img = grabPresented(view);
        const QColor p = img.pixelColor(img.width() / 2, img.height() / 2);
        return p.red() == 255 && p.green() == 0 && p.blue() == 0;
    };
    QVERIFY(!centreIsRed());
    view->setAnnotations(store);
    QCOMPARE(changed.count(), 1);
    QCOMPARE(view->annotations(), store);
    QTRY_VERIFY(centreIsRed());
    view->setAnnotationsVisible(false);
    QCOMPARE(changed.count(), 2);
    QTRY_VERIFY(!centreIsRed());
    view->setAnnotationsVisible(true);
    QTRY_VERIFY(centreIsRed());
    view->setSelectedAnnotation(*id);
    QCOMPARE(view->selectedAnnotation(), quint64(*id));
    QCOMPARE(changed.count(), 4);
    view->setAnnotations(nullptr);
    QCOMPARE(changed.count(), 5);
    QTRY_VERIFY(!centreIsRed());
    finishView(*m_w);
}

// Issue 14: a window edge dragged — hundreds of resizes, each handed to the window system
// and its events processed, as a drag delivers them — then the last size: the view presents a
// complete frame of exactly that size showing what the headless engine shows, and the
// validation layer said nothing throughout (finishView checks the count too).
void TstIrisSlideView::resizeStormEndsRightAndValid()
{
    showSample();
    IrisSlideView *view = m_w->view;
    view->setCentre(QPointF(2500, 1700));
    view->setDownsample(3);
    const QPointF centre = view->centre();
    int completeFrames = 0;
    const auto counter = connect(view, &IrisSlideView::framePresented, this,
                                 [&](const IrisFrameMetrics &metrics) { completeFrames += metrics.complete; });
    QElapsedTimer timer;
    timer.start();
    constexpr int kResizes = 300;
    for (int i = 0; i < kResizes; ++i) {
        m_w->window->resize(QSize(200 + (i * 37) % 500, 150 + (i * 23) % 350));
        QCoreApplication::processEvents();
    }
    const double seconds = timer.elapsed() / 1000.0;
    disconnect(counter);
    qInfo("%d resizes in %.2f s (%.0f a second), %d complete frames presented meanwhile", kResizes, seconds,
          kResizes / std::max(seconds, 1e-3), completeFrames);
    QCOMPARE(view->validationMessageCount(), quint64(0));
    m_w->window->resize(kViewSize);
    const QSize target = kViewSize * m_w->dpr();
    QTRY_COMPARE(view->targetSize(), target);
    QCOMPARE(view->centre(), centre);
    QVERIFY(m_w->frames->waitForCompleteFrame());
    QTRY_COMPARE(grabPresented(view).size(), target);
    checkPresentedMatchesHeadless(view, m_sample, QStringLiteral("after a resize storm"));
    QCOMPARE(view->validationMessageCount(), quint64(0));
}

// Issue 20: the widget's own frame timing (framePresented) while panning by whole device pixels
// within loaded tiles, at 1920 × 1080 device pixels, the figure iris-bench's settled frame
// stands for (BENCHMARKS.md). Reported, not judged (a benchmark is not a timed test), for the
// view on level 0's pixel grid (drawn exactly) and half a pixel off it (filtered). Each pan is
// made when the previous one's frame is presented, as a drag's motion events are answered. It
// checks that every pan is presented as a complete frame of the panned view, that whole-pixel
// pans keep the view on the grid, and that the validation layer stays silent.
void TstIrisSlideView::panningFrameTimesAreReported()
{
    showSample();
    IrisSlideView *view = m_w->view;
    const QSize device(1920, 1080);
    m_w->window->resize(QSize(qRound(device.width() / m_w->dpr()), qRound(device.height() / m_w->dpr())));
    QTRY_COMPARE(view->targetSize(), device);
    const auto median = [](std::vector<double> v) {
        std::sort(v.begin(), v.end());
        return v.empty() ? 0.0 : v[v.size() / 2];
    };
    struct Run {
        const char *what;
        double offset; // of the centre from level 0's pixel grid, in pixels
    };
    constexpr int kPans = 24;
    for (const Run run : {Run{"on the pixel grid (exact)", 0.0}, Run{"half a pixel off it (filtered)", 0.5}}) {
        // Whole device width and height even: centre 3000 puts pixel centres on texel centres.
        view->setDownsample(1);
        view->setCentre(QPointF(3000 + run.offset, 2000 + run.offset));
        QVERIFY(m_w->frames->waitForCompleteFrame());
        // Load the perimeter the pans reach: one pixel either way stays within it.
        QVERIFY(IrisWidget::engineOf(view)->waitForSettled(std::chrono::seconds(30)).ok());
        std::vector<double> intervals, cpu;
        int incomplete = 0;
        QPointF expected;
        bool waiting = false;
        const auto counter = connect(view, &IrisSlideView::framePresented, this, [&](const IrisFrameMetrics &m) {
            if (!waiting || m.centre != expected)
                return; // a frame of an earlier view
            waiting = false;
            intervals.push_back(m.intervalMs);
            cpu.push_back(m.cpuMs);
            incomplete += m.complete ? 0 : 1;
        });
        for (int pan = 1; pan <= kPans; ++pan) {
            const double step = (pan % 2 ? 1.0 : -1.0) / m_w->dpr(); // one device pixel
            view->panBy(QPointF(step, 0));
            expected = view->centre();
            waiting = true;
            QTRY_VERIFY_WITH_TIMEOUT(!waiting, 10000);
        }
        disconnect(counter);
        QCOMPARE(int(intervals.size()), kPans);
        QCOMPARE(incomplete, 0);
        const QPointF c = view->centre();
        QCOMPARE(c.x() - std::floor(c.x()), run.offset); // whole-pixel pans keep the offset
        qInfo("panning at %dx%d, %s: frame interval median %.1f ms, render thread %.2f ms a frame "
              "(%d pans; lavapipe with the validation layer on)",
              device.width(), device.height(), run.what, median(intervals), median(cpu), kPans);
    }
    QCOMPARE(view->validationMessageCount(), quint64(0));
}

// Issue 14: VK_ERROR_SURFACE_LOST_KHR at a present makes the view replace its native window
// (a new VkSurfaceKHR) and present again, with no error reported to the host; a lost device
// at a present is recovered by the engine itself (the view keeps its engine) and reported
// once as slideError. Either way the next complete frame matches the headless render, at the
// right size, with the validation layer silent.
void TstIrisSlideView::survivesLostSurfacesAndDevices()
{
    showSample();
    IrisSlideView *view = m_w->view;
    iris::Engine *engine = IrisWidget::engineOf(view);
    QVERIFY(engine);
    const int engines = IrisWidget::EngineHost::liveEngineCount();
    const int replacedBefore = IrisWidget::surfaceReplacementsOf(view);
    const uint32_t recoveredBefore = engine->device().recoveries;
    QSignalSpy errors(view, &IrisSlideView::slideError);
    constexpr int kRounds = 3;
    for (int round = 0; round < kRounds; ++round) {
        engine->injectFault(iris::Engine::InjectedFault::SurfaceLostAtPresent);
        view->setCentre(QPointF(1500 + 400 * round, 1200));
        view->setDownsample(2.0 + round);
        QTRY_COMPARE_WITH_TIMEOUT(IrisWidget::surfaceReplacementsOf(view), replacedBefore + round + 1, 20000);
        QTRY_VERIFY_WITH_TIMEOUT(view->surfaceWindow()->isExposed(), 20000);
        QVERIFY(m_w->frames->waitForCompleteFrame());
        QTRY_COMPARE(grabPresented(view).size(), view->targetSize());
        checkPresentedMatchesHeadless(view, m_sample, QStringLiteral("after a lost surface %1").arg(round));

        engine->injectFault(iris::Engine::InjectedFault::DeviceLostAtPresent);
        view->setCentre(QPointF(3500 - 300 * round, 2200));
        QTRY_COMPARE_WITH_TIMEOUT(engine->device().recoveries, recoveredBefore + round + 1, 20000);
        QVERIFY(m_w->frames->waitForCompleteFrame());
        checkPresentedMatchesHeadless(view, m_sample, QStringLiteral("after a lost device %1").arg(round));
    }
    QCOMPARE(IrisWidget::engineOf(view), engine); // recovered in place, not recreated by the widget
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), engines);
    QCOMPARE(errors.count(), kRounds); // once per lost device; a replaced surface is no error
    for (const QList<QVariant> &e : errors)
        QVERIFY2(e.at(0).toString().contains(QStringLiteral("graphics device was lost")), qPrintable(e.at(0).toString()));
    QCOMPARE(view->validationMessageCount(), quint64(0));
}

IRIS_WIDGET_TEST_MAIN(TstIrisSlideView)
#include "tst_irisslideview.moc"

