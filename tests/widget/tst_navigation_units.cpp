// tst_navigation_units: the widget's input logic without a GPU or a display.
//
// ViewNavigator drives a recording NavigationTarget here, so that what each gesture asks of
// the view is checked exactly: drags pass their deltas through, a released drag glides with
// the hand's speed and decays, wheel notches zoom by exact totals about a fixed anchor,
// keys map to fields, zoom, fit and presets, and chords are left to shortcuts. Also the
// magnification rule (objective power, else 10 µm / mpp) and the frames-per-second meter.

#include <cmath>
#include <memory>

#include <QtGui/QKeyEvent>
#include <QtGui/QMouseEvent>
#include <QtGui/QPointingDevice>
#include <QtGui/QWheelEvent>
#include <QtTest/QSignalSpy>
#include <QtTest/QTest>

#include <iris/IrisSlideInfo.h>

#include "fpsmeter_p.h"
#include "magnification_p.h"
#include "navigator_p.h"

using IrisWidget::KineticPanner;
using IrisWidget::ViewNavigator;
using IrisWidget::ZoomAnimator;

namespace {

struct Recorder final : IrisWidget::NavigationTarget {
    bool slide = true;
    QPointF panned;          // sum of pan() deltas
    int pans = 0;
    QPoint fields;
    double zoomed = 1;       // product of zoom() factors
    int zooms = 0;
    QList<QPointF> anchors;
    QList<double> factors;
    int fits = 0;
    QList<int> presets;
    double turned = 0;       // sum of rotate() angles
    int turns = 0;
    QList<QPointF> turnAnchors;
    int flips = 0;
    int resets = 0;

    bool canNavigate() const override { return slide; }
    void pan(QPointF d) override { panned += d; ++pans; }
    void panFields(int x, int y) override { fields += QPoint(x, y); }
    void zoom(double f, QPointF a) override
    {
        zoomed *= f;
        ++zooms;
        anchors << a;
        factors << f;
    }
    void rotate(double degrees, QPointF a) override
    {
        turned += degrees;
        ++turns;
        turnAnchors << a;
    }
    void flip() override { ++flips; }
    void resetOrientation() override { ++resets; }
    QPointF viewportCentre() const override { return {320, 240}; }
    void fit() override { ++fits; }
    void showMagnificationPreset(int i) override { presets << i; }
};

std::unique_ptr<QMouseEvent> mouse(QEvent::Type type, QPointF pos, Qt::MouseButton button,
                                   Qt::MouseButtons buttons, quint64 timestamp,
                                   Qt::KeyboardModifiers modifiers = {})
{
    auto e = std::make_unique<QMouseEvent>(type, pos, pos, pos, button, buttons, modifiers);
    e->setTimestamp(timestamp);
    return e;
}

std::unique_ptr<QWheelEvent> wheel(QPointF pos, QPoint angle, QPoint pixels = {},
                                   Qt::ScrollPhase phase = Qt::NoScrollPhase,
                                   Qt::KeyboardModifiers modifiers = Qt::NoModifier)
{
    return std::make_unique<QWheelEvent>(pos, pos, pixels, angle, Qt::NoButton, modifiers, phase, false);
}

bool near(double a, double b, double tolerance = 1e-12)
{
    return std::abs(a - b) <= tolerance * std::max(1.0, std::abs(b));
}

} // namespace

class TstNavigationUnits : public QObject {
    Q_OBJECT
private Q_SLOTS:
    void dragPassesDeltasThrough();
    void dragNeedsTheLeftButtonAndASlide();
    void releaseWhileMovingGlidesWithTheHandsSpeed();
    void releaseAfterAPauseDoesNotGlide();
    void wheelNotchesZoomByExactTotalsAboutTheAnchor();
    void wheelAboutAnotherAnchorFinishesTheFirst();
    void trackpadPixelsZoomAtOnce();
    void doubleClickZoomsAboutThePointer();
    void keys_data();
    void keys();
    void chordsAreLeftToShortcuts();
    void turnKeysAnimateExactRightAngles();
    void shiftWheelTurnsAboutThePointer();
    void ctrlDragTurnsWithThePointersAngle();
    void flipAndResetKeys();
    void magnificationRule();
    void alignedToLevelPixels();
    void fpsMeter();
};

void TstNavigationUnits::dragPassesDeltasThrough()
{
    Recorder target;
    ViewNavigator nav(&target);
    auto press = mouse(QEvent::MouseButtonPress, {10, 10}, Qt::LeftButton, Qt::LeftButton, 1000);
    QVERIFY(nav.mousePress(press.get()));
    QVERIFY(nav.isDragging());
    for (int i = 1; i <= 5; ++i) {
        auto move = mouse(QEvent::MouseMove, {10.0 + 7 * i, 10.0 - 3 * i}, Qt::NoButton, Qt::LeftButton, 1000 + 10 * i);
        QVERIFY(nav.mouseMove(move.get()));
    }
    auto release = mouse(QEvent::MouseButtonRelease, {45, -5}, Qt::LeftButton, Qt::NoButton, 2000);
    QVERIFY(nav.mouseRelease(release.get()));
    QVERIFY(!nav.isDragging());
    QCOMPARE(target.panned, QPointF(35, -15));
    QVERIFY(!nav.kineticPanner().isActive()); // let go a second later
}

void TstNavigationUnits::dragNeedsTheLeftButtonAndASlide()
{
    Recorder target;
    ViewNavigator nav(&target);
    auto right = mouse(QEvent::MouseButtonPress, {10, 10}, Qt::RightButton, Qt::RightButton, 1);
    QVERIFY(!nav.mousePress(right.get()));
    auto move = mouse(QEvent::MouseMove, {50, 50}, Qt::NoButton, Qt::RightButton, 2);
    QVERIFY(!nav.mouseMove(move.get()));
    QCOMPARE(target.pans, 0);

    target.slide = false;
    auto left = mouse(QEvent::MouseButtonPress, {10, 10}, Qt::LeftButton, Qt::LeftButton, 3);
    QVERIFY(!nav.mousePress(left.get()));
    auto w = wheel({1, 1}, {0, 120});
    QVERIFY(!nav.wheel(w.get()));
    QKeyEvent key(QEvent::KeyPress, Qt::Key_Right, Qt::NoModifier);
    QVERIFY(!nav.keyPress(&key));
}

void TstNavigationUnits::releaseWhileMovingGlidesWithTheHandsSpeed()
{
    Recorder target;
    ViewNavigator nav(&target);
    // 12 px every 10 ms to the right: 1200 px/s.
    auto press = mouse(QEvent::MouseButtonPress, {0, 0}, Qt::LeftButton, Qt::LeftButton, 5000);
    nav.mousePress(press.get());
    for (int i = 1; i <= 15; ++i) {
        auto move = mouse(QEvent::MouseMove, {12.0 * i, 0}, Qt::NoButton, Qt::LeftButton, 5000 + 10 * i);
        nav.mouseMove(move.get());
    }
    auto release = mouse(QEvent::MouseButtonRelease, {180, 0}, Qt::LeftButton, Qt::NoButton, 5155);
    nav.mouseRelease(release.get());
    QVERIFY(nav.kineticPanner().isActive());
    QVERIFY(near(nav.kineticPanner().velocity().x(), 1200, 1e-9));
    QCOMPARE(nav.kineticPanner().velocity().y(), 0.0);

    QSignalSpy finished(&nav.kineticPanner(), &KineticPanner::finished);
    QVERIFY(finished.wait(5000));
    const double glide = target.panned.x() - 180;
    const double theoretical = 1200 * KineticPanner::kTimeConstantS;
    // It stops at kStopSpeed, short of the full integral by kStopSpeed × τ.
    QVERIFY2(glide > theoretical - KineticPanner::kStopSpeed * KineticPanner::kTimeConstantS - 1 && glide <= theoretical + 1e-9,
             qPrintable(QString::number(glide)));
    QVERIFY(target.pans > 10); // smooth: many small steps
    QCOMPARE(target.panned.y(), 0.0);

    // A new press stops a glide at once.
    auto again = mouse(QEvent::MouseButtonPress, {0, 0}, Qt::LeftButton, Qt::LeftButton, 9000);
    for (int i = 1; i <= 5; ++i) {
        auto move = mouse(QEvent::MouseMove, {0, 20.0 * i}, Qt::NoButton, Qt::LeftButton, 9000 + 10 * i);
        if (i == 1)
            nav.mousePress(again.get());
        nav.mouseMove(move.get());
    }
    auto up = mouse(QEvent::MouseButtonRelease, {0, 100}, Qt::LeftButton, Qt::NoButton, 9051);
    nav.mouseRelease(up.get());
    QVERIFY(nav.kineticPanner().isActive());
    auto stop = mouse(QEvent::MouseButtonPress, {0, 100}, Qt::LeftButton, Qt::LeftButton, 9060);
    nav.mousePress(stop.get());
    QVERIFY(!nav.kineticPanner().isActive());
}

void TstNavigationUnits::releaseAfterAPauseDoesNotGlide()
{
    Recorder target;
    ViewNavigator nav(&target);
    auto press = mouse(QEvent::MouseButtonPress, {0, 0}, Qt::LeftButton, Qt::LeftButton, 100);
    nav.mousePress(press.get());
    for (int i = 1; i <= 5; ++i) {
        auto move = mouse(QEvent::MouseMove, {30.0 * i, 0}, Qt::NoButton, Qt::LeftButton, 100 + 10 * i);
        nav.mouseMove(move.get());
    }
    auto release = mouse(QEvent::MouseButtonRelease, {150, 0}, Qt::LeftButton, Qt::NoButton,
                         150 + KineticPanner::kStaleMs + 1);
    nav.mouseRelease(release.get());
    QVERIFY(!nav.kineticPanner().isActive());

    // Kinetic panning switched off: never.
    nav.setKineticEnabled(false);
    nav.mousePress(press.get());
    for (int i = 1; i <= 5; ++i) {
        auto move = mouse(QEvent::MouseMove, {30.0 * i, 0}, Qt::NoButton, Qt::LeftButton, 100 + 10 * i);
        nav.mouseMove(move.get());
    }
    auto quick = mouse(QEvent::MouseButtonRelease, {150, 0}, Qt::LeftButton, Qt::NoButton, 151);
    nav.mouseRelease(quick.get());
    QVERIFY(!nav.kineticPanner().isActive());
}

void TstNavigationUnits::wheelNotchesZoomByExactTotalsAboutTheAnchor()
{
    Recorder target;
    ViewNavigator nav(&target);
    const QPointF anchor(123.5, 77.25);
    auto notch = wheel(anchor, {0, 120});
    QVERIFY(nav.wheel(notch.get()));
    QVERIFY(nav.zoomAnimator().isActive());
    auto notch2 = wheel(anchor, {0, 120});
    nav.wheel(notch2.get()); // mid-animation: adds to what remains
    QSignalSpy finished(&nav.zoomAnimator(), &ZoomAnimator::finished);
    QVERIFY(finished.wait(2000));
    QVERIFY(near(target.zoomed, std::pow(ViewNavigator::kWheelNotchFactor, 2), 1e-12));
    QVERIFY(target.zooms >= 3); // animated in steps
    for (const QPointF &a : std::as_const(target.anchors))
        QCOMPARE(a, anchor);

    // Out by half a notch (high-resolution wheels send fractions).
    target.zoomed = 1;
    auto half = wheel(anchor, {0, -60});
    nav.wheel(half.get());
    nav.zoomAnimator().finish();
    QVERIFY(near(target.zoomed, 1 / std::sqrt(ViewNavigator::kWheelNotchFactor), 1e-12));
}

void TstNavigationUnits::wheelAboutAnotherAnchorFinishesTheFirst()
{
    Recorder target;
    ViewNavigator nav(&target);
    auto first = wheel({10, 10}, {0, 120});
    nav.wheel(first.get());
    auto second = wheel({300, 200}, {0, 120});
    nav.wheel(second.get());
    // The first zoom was completed about its own anchor before the second began.
    double aboutFirst = 1;
    for (int i = 0; i < target.anchors.size(); ++i) {
        if (target.anchors[i] == QPointF(10, 10))
            aboutFirst *= target.factors[i];
    }
    QVERIFY(near(aboutFirst, ViewNavigator::kWheelNotchFactor, 1e-12));
    nav.zoomAnimator().finish();
    QVERIFY(near(target.zoomed, std::pow(ViewNavigator::kWheelNotchFactor, 2), 1e-12));
    QCOMPARE(target.anchors.last(), QPointF(300, 200));
}

void TstNavigationUnits::trackpadPixelsZoomAtOnce()
{
    Recorder target;
    ViewNavigator nav(&target);
    auto pixels = wheel({50, 60}, {0, 90}, {0, 90}, Qt::ScrollUpdate);
    QVERIFY(nav.wheel(pixels.get()));
    QCOMPARE(target.zooms, 1);
    QVERIFY(!nav.zoomAnimator().isActive());
    QVERIFY(near(target.zoomed, std::exp2(90 / ViewNavigator::kPixelsPerDoubling)));
    QCOMPARE(target.anchors.first(), QPointF(50, 60));
}

void TstNavigationUnits::doubleClickZoomsAboutThePointer()
{
    Recorder target;
    ViewNavigator nav(&target);
    auto dbl = mouse(QEvent::MouseButtonDblClick, {40, 30}, Qt::LeftButton, Qt::LeftButton, 10);
    QVERIFY(nav.mouseDoubleClick(dbl.get()));
    nav.zoomAnimator().finish();
    QVERIFY(near(target.zoomed, 2));
    auto shifted = mouse(QEvent::MouseButtonDblClick, {40, 30}, Qt::LeftButton, Qt::LeftButton, 20, Qt::ShiftModifier);
    nav.mouseDoubleClick(shifted.get());
    nav.zoomAnimator().finish();
    QVERIFY(near(target.zoomed, 1));
    for (const QPointF &a : std::as_const(target.anchors))
        QCOMPARE(a, QPointF(40, 30));
}

void TstNavigationUnits::keys_data()
{
    QTest::addColumn<int>("key");
    QTest::addColumn<QPoint>("fields");
    QTest::addColumn<double>("zoom");
    QTest::addColumn<int>("fits");
    QTest::addColumn<int>("preset");
    QTest::newRow("right") << int(Qt::Key_Right) << QPoint(1, 0) << 1.0 << 0 << -1;
    QTest::newRow("left") << int(Qt::Key_Left) << QPoint(-1, 0) << 1.0 << 0 << -1;
    QTest::newRow("up") << int(Qt::Key_Up) << QPoint(0, -1) << 1.0 << 0 << -1;
    QTest::newRow("down") << int(Qt::Key_Down) << QPoint(0, 1) << 1.0 << 0 << -1;
    QTest::newRow("plus") << int(Qt::Key_Plus) << QPoint() << 2.0 << 0 << -1;
    QTest::newRow("equal") << int(Qt::Key_Equal) << QPoint() << 2.0 << 0 << -1;
    QTest::newRow("minus") << int(Qt::Key_Minus) << QPoint() << 0.5 << 0 << -1;
    QTest::newRow("0") << int(Qt::Key_0) << QPoint() << 1.0 << 1 << -1;
    QTest::newRow("home") << int(Qt::Key_Home) << QPoint() << 1.0 << 1 << -1;
    QTest::newRow("1") << int(Qt::Key_1) << QPoint() << 1.0 << 0 << 0;
    QTest::newRow("4") << int(Qt::Key_4) << QPoint() << 1.0 << 0 << 3;
}

void TstNavigationUnits::keys()
{
    QFETCH(int, key);
    QFETCH(QPoint, fields);
    QFETCH(double, zoom);
    QFETCH(int, fits);
    QFETCH(int, preset);
    Recorder target;
    ViewNavigator nav(&target);
    QKeyEvent e(QEvent::KeyPress, key, Qt::NoModifier);
    QVERIFY(nav.keyPress(&e));
    nav.zoomAnimator().finish();
    QCOMPARE(target.fields, fields);
    QVERIFY(near(target.zoomed, zoom));
    if (zoom != 1)
        QCOMPARE(target.anchors.first(), target.viewportCentre());
    QCOMPARE(target.fits, fits);
    QCOMPARE(target.presets, preset < 0 ? QList<int>() : QList<int>{preset});
}

void TstNavigationUnits::chordsAreLeftToShortcuts()
{
    Recorder target;
    ViewNavigator nav(&target);
    for (const auto modifier : {Qt::ControlModifier, Qt::AltModifier, Qt::MetaModifier}) {
        QKeyEvent e(QEvent::KeyPress, Qt::Key_Right, modifier);
        QVERIFY(!nav.keyPress(&e));
    }
    QKeyEvent other(QEvent::KeyPress, Qt::Key_A, Qt::NoModifier);
    QVERIFY(!nav.keyPress(&other));
    QKeyEvent keypad(QEvent::KeyPress, Qt::Key_Plus, Qt::KeypadModifier);
    QVERIFY(nav.keyPress(&keypad));
    QCOMPARE(target.fields, QPoint());
}

void TstNavigationUnits::magnificationRule()
{
    IrisSlideInfo info;
    info.objectivePower = 20;
    info.mppX = info.mppY = 0.25;
    QCOMPARE(info.effectiveObjectivePower(), 20.0); // stated power wins
    info.objectivePower = 0;
    QCOMPARE(info.effectiveObjectivePower(), 40.0); // 10 µm / 0.25 µm
    info.mppX = 0.5;
    info.mppY = 0;
    QCOMPARE(info.effectiveObjectivePower(), 20.0);
    info.mppX = 0;
    QCOMPARE(info.effectiveObjectivePower(), 0.0);
}

// At a level's own downsample the preset's view moves (under half a pixel) so that every
// target pixel's centre maps to a level pixel's centre: checked through the engine's own map
// (ViewTransform::toSlide) at pixels across the target, turned by right angles and flipped,
// odd and even sizes, levels at 1, 4 and 16; other views are left alone.
void TstNavigationUnits::alignedToLevelPixels()
{
    iris::SlideInfo info;
    info.width = 100000;
    info.height = 80000;
    for (const double ds : {1.0, 4.0, 16.0, 48.33})
        info.levels.push_back(iris::LevelInfo{.width = int64_t(100000 / ds), .height = int64_t(80000 / ds),
                                              .downsample = ds});
    const auto onCentres = [](const iris::View &v, int w, int h, double lds) {
        const iris::ViewTransform t = iris::ViewTransform::of(v, w, h);
        for (const int x : {0, 1, w / 2, w - 1})
            for (const int y : {0, 1, h / 3, h - 1}) {
                const auto [sx, sy] = t.toSlide(x + 0.5, y + 0.5);
                const double fx = sx / lds - std::floor(sx / lds), fy = sy / lds - std::floor(sy / lds);
                if (fx != 0.5 || fy != 0.5)
                    return false;
            }
        return true;
    };
    int moved = 0;
    for (const double ds : {1.0, 4.0, 16.0})
        for (const double rotation : {0.0, 90.0, 180.0, 270.0})
            for (const bool flip : {false, true})
                for (const QSize size : {QSize(640, 480), QSize(641, 480), QSize(640, 481), QSize(333, 777)}) {
                    const iris::View v{.centerX = 31234.567, .centerY = 20001.2345, .downsample = ds,
                                       .rotation = rotation, .flipH = flip};
                    const iris::View a = IrisWidget::alignedToLevelPixels(info, v, size.width(), size.height());
                    const QString what = QStringLiteral("ds %1, %2°, flip %3, %4×%5")
                                             .arg(ds).arg(rotation).arg(flip).arg(size.width()).arg(size.height());
                    QVERIFY2(onCentres(a, size.width(), size.height(), ds), qPrintable(what));
                    QVERIFY2(std::abs(a.centerX - v.centerX) <= 0.5 * ds && std::abs(a.centerY - v.centerY) <= 0.5 * ds,
                             qPrintable(what));
                    QCOMPARE(a.downsample, v.downsample);
                    QCOMPARE(a.rotation, v.rotation);
                    QCOMPARE(a.flipH, v.flipH);
                    QCOMPARE(IrisWidget::alignedToLevelPixels(info, a, size.width(), size.height()), a); // stays
                    moved += a != v;
                }
    QVERIFY(moved > 0);
    // Between levels (2.5), turned by 30°, or with no target: unchanged.
    const iris::View between{.centerX = 1000.3, .centerY = 700.6, .downsample = 2.5};
    QCOMPARE(IrisWidget::alignedToLevelPixels(info, between, 640, 480), between);
    const iris::View turned{.centerX = 1000.3, .centerY = 700.6, .downsample = 1, .rotation = 30};
    QCOMPARE(IrisWidget::alignedToLevelPixels(info, turned, 640, 480), turned);
    const iris::View plain{.centerX = 1000.3, .centerY = 700.6, .downsample = 1};
    QCOMPARE(IrisWidget::alignedToLevelPixels(info, plain, 0, 0), plain);
    // A level at 48.33: moved within half a pixel (its product may round; the centres are
    // then within a rounding error of the level's, which is all the engine can show).
    const iris::View odd{.centerX = 31234.567, .centerY = 20001.2345, .downsample = 48.33};
    const iris::View oddAligned = IrisWidget::alignedToLevelPixels(info, odd, 640, 480);
    QVERIFY(std::abs(oddAligned.centerX - odd.centerX) <= 0.5 * 48.33);
    QVERIFY(oddAligned != odd);
}

void TstNavigationUnits::fpsMeter()
{
    IrisWidget::FpsMeter meter;
    for (int i = 0; i < 40; ++i)
        meter.add(16.0);
    QVERIFY(near(meter.fps(), 62.5));
    QCOMPARE(meter.add(2000), 0.0); // a pause restarts the run
    QVERIFY(near(meter.add(10), 100));
}

void TstNavigationUnits::turnKeysAnimateExactRightAngles()
{
    Recorder target;
    ViewNavigator nav(&target);
    QKeyEvent r(QEvent::KeyPress, Qt::Key_R, Qt::NoModifier);
    QVERIFY(nav.keyPress(&r));
    QVERIFY(nav.zoomAnimator().isActive()); // animated, like a zoom
    QSignalSpy finished(&nav.zoomAnimator(), &ZoomAnimator::finished);
    QVERIFY(finished.wait(2000));
    QVERIFY(target.turns >= 2);
    QVERIFY(near(target.turned, ViewNavigator::kKeyTurnDegrees, 1e-9));
    for (const QPointF &a : std::as_const(target.turnAnchors))
        QCOMPARE(a, target.viewportCentre());
    QKeyEvent shiftR(QEvent::KeyPress, Qt::Key_R, Qt::ShiftModifier);
    QVERIFY(nav.keyPress(&shiftR));
    nav.zoomAnimator().finish();
    QVERIFY(near(target.turned, 0, 1e-9));
    QCOMPARE(target.zoomed, 1.0); // a turn zooms nothing
}

void TstNavigationUnits::shiftWheelTurnsAboutThePointer()
{
    Recorder target;
    ViewNavigator nav(&target);
    const QPointF anchor(100, 50);
    auto notch = wheel(anchor, {0, 120}, {}, Qt::NoScrollPhase, Qt::ShiftModifier);
    QVERIFY(nav.wheel(notch.get()));
    auto back = wheel(anchor, {0, -60}, {}, Qt::NoScrollPhase, Qt::ShiftModifier);
    QVERIFY(nav.wheel(back.get()));
    nav.zoomAnimator().finish();
    QVERIFY(near(target.turned, ViewNavigator::kWheelNotchDegrees / 2, 1e-9));
    QCOMPARE(target.zooms, 0);
    for (const QPointF &a : std::as_const(target.turnAnchors))
        QCOMPARE(a, anchor);
}

void TstNavigationUnits::ctrlDragTurnsWithThePointersAngle()
{
    Recorder target;
    ViewNavigator nav(&target);
    const QPointF c = target.viewportCentre();
    // From straight right of the centre to straight below it: a quarter turn clockwise, in
    // steps, across the ±180° wrap too (then on to straight left and above).
    auto press = mouse(QEvent::MouseButtonPress, c + QPointF(100, 0), Qt::LeftButton, Qt::LeftButton, 10,
                       Qt::ControlModifier);
    QVERIFY(nav.mousePress(press.get()));
    QVERIFY(nav.isDragging());
    const QList<QPointF> path{{70.7, 70.7}, {0, 100}, {-100, 1}, {-100, -1}, {0, -100}};
    int t = 20;
    for (const QPointF &p : path) {
        auto move = mouse(QEvent::MouseMove, c + p, Qt::NoButton, Qt::LeftButton, quint64(t += 10), Qt::ControlModifier);
        QVERIFY(nav.mouseMove(move.get()));
    }
    QVERIFY(near(target.turned, 270, 1e-6));
    QCOMPARE(target.pans, 0);
    auto release = mouse(QEvent::MouseButtonRelease, c + QPointF(0, -100), Qt::LeftButton, Qt::NoButton, 200);
    QVERIFY(nav.mouseRelease(release.get()));
    QVERIFY(!nav.isDragging());
    QVERIFY(!nav.kineticPanner().isActive()); // a turn never glides
    for (const QPointF &a : std::as_const(target.turnAnchors))
        QCOMPARE(a, c);
}

void TstNavigationUnits::flipAndResetKeys()
{
    Recorder target;
    ViewNavigator nav(&target);
    QKeyEvent f(QEvent::KeyPress, Qt::Key_F, Qt::NoModifier);
    QVERIFY(nav.keyPress(&f));
    QCOMPARE(target.flips, 1);
    QKeyEvent reset(QEvent::KeyPress, Qt::Key_Home, Qt::ShiftModifier);
    QVERIFY(nav.keyPress(&reset));
    QCOMPARE(target.resets, 1);
    QCOMPARE(target.fits, 0); // Shift+Home resets the orientation only
}

QTEST_MAIN(TstNavigationUnits)
#include "tst_navigation_units.moc"
