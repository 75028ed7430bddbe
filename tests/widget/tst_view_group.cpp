// tst_view_group: IrisViewGroup, linked views.
//
//   TstViewGroupMath   the pose maths (viewgroupmath_p.h) on numbers alone: round trips,
//                      captured offsets, flips and half turns, units (ctest widget.view_group.maths,
//                      no display: run with -maths)
//   TstViewGroup       real IrisSlideViews on an X display (Xvfb in CI) with lavapipe and the
//                      validation layers on: followers follow pans, drags, zooms, an animated
//                      zoom and a glide step by step, turns and flips; offsets hold across
//                      unlink/relink; slides of different mpp meet in physical size; one
//                      change is one viewChanged per view; the cursor cross-hair; views
//                      removed or destroyed leave the group (ctest widget.view_group)
//
// What a follower must show is checked through the widget's own mapToSlide/mapFromSlide, not
// through the group's maths: a slide point that a follower shows at a widget position moves on
// screen exactly as the leader's image moves.

#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>

#include <QtCore/QElapsedTimer>
#include <QtCore/QFileInfo>
#include <QtCore/QScopedPointer>
#include <QtGui/QCursor>
#include <QtGui/QScreen>
#include <QtGui/QWindow>
#include <QtTest/QSignalSpy>
#include <QtTest/QTest>
#include <QtWidgets/QApplication>
#include <QtWidgets/QHBoxLayout>

#include <iris/IrisSlideView.h>
#include <iris/IrisViewGroup.h>

#include "enginehost_p.h"
#include "navigator_p.h"
#include "viewgroupmath_p.h"
#include "widget_test_support.h"

Q_DECLARE_METATYPE(IrisViewOffset)
Q_DECLARE_METATYPE(IrisWidget::ViewGroupMath::ViewPose)
Q_DECLARE_METATYPE(IrisWidget::ViewGroupMath::GroupPose)

using namespace iriswidgettest;
using namespace IrisWidget::ViewGroupMath;

namespace {

bool near(double a, double b, double tolerance)
{
    return std::abs(a - b) <= tolerance;
}

double distance(QPointF a, QPointF b)
{
    return std::hypot(a.x() - b.x(), a.y() - b.y());
}

QString text(QPointF p)
{
    return QStringLiteral("(%1, %2)").arg(p.x(), 0, 'f', 4).arg(p.y(), 0, 'f', 4);
}

QString text(const ViewPose &v)
{
    return QStringLiteral("centre %1 ds %2 rot %3 flips %4%5")
        .arg(text(v.centre))
        .arg(v.downsample, 0, 'g', 10)
        .arg(v.rotation, 0, 'f', 6)
        .arg(v.flipH ? QStringLiteral("H") : QStringLiteral("-"))
        .arg(v.flipV ? QStringLiteral("V") : QStringLiteral("-"));
}

// Screen position (logical, about the view's centre) of a slide point under a view pose: the
// widget's contract written out once more, independently of the group's code.
QPointF onScreen(const ViewPose &v, QPointF p)
{
    QPointF d = p - v.centre;
    if (v.flipH)
        d.setX(-d.x());
    if (v.flipV)
        d.setY(-d.y());
    const double r = v.rotation * std::numbers::pi / 180.0;
    return QPointF(d.x() * std::cos(r) - d.y() * std::sin(r), d.x() * std::sin(r) + d.y() * std::cos(r))
        / v.downsample;
}

// The same for a group pose and a group point.
QPointF onScreen(const GroupPose &g, QPointF p)
{
    return onScreen(ViewPose{g.centre, g.scale, g.rotation, g.flipH, g.flipV}, p);
}

} // namespace

// --- the maths --------------------------------------------------------------------------------

class TstViewGroupMath : public QObject {
    Q_OBJECT

private Q_SLOTS:
    void degrees();
    void units();
    void placementMapsPoints();
    void memberAndGroupShowTheSame_data();
    void memberAndGroupShowTheSame();
    void capturedOffsetReproducesTheView_data();
    void capturedOffsetReproducesTheView();
    void flipsOfTheGroupReverseOffsetTurns();
    void halfTurnWithBothFlipsShowsTheSame();
    void correspondingPoints();
};

void TstViewGroupMath::degrees()
{
    QCOMPARE(normalizedDegrees(0), 0.0);
    QCOMPARE(normalizedDegrees(360), 0.0);
    QCOMPARE(normalizedDegrees(-90), 270.0);
    QCOMPARE(normalizedDegrees(725), 5.0);
    QVERIFY(normalizedDegrees(-1e-15) < 360.0);
    QCOMPARE(signedDegrees(270), -90.0);
    QCOMPARE(signedDegrees(180), 180.0);
    QCOMPARE(signedDegrees(-180), 180.0);
    QCOMPARE(signedDegrees(-30), -30.0);
}

void TstViewGroupMath::units()
{
    QCOMPARE(physicalUnit(0.25, 0.25), 0.25);
    QCOMPARE(physicalUnit(0.25, 1.0), 0.5); // square pixels on screen: the geometric mean
    QCOMPARE(physicalUnit(0, 0.25), 0.0);
    QCOMPARE(physicalUnit(0.25, 0), 0.0);
    QCOMPARE(physicalUnit(-1, 0.25), 0.0);
    QCOMPARE(physicalUnit(std::nan(""), 0.25), 0.0);
}

void TstViewGroupMath::placementMapsPoints()
{
    // Identity offset: only the unit.
    QCOMPARE(toGroup(Placement{0.5, {}}, QPointF(10, 20)), QPointF(5, 10));
    // 90° clockwise (y down): +x of the slide points along +y of the group.
    const Placement turned{1.0, IrisViewOffset{QPointF(100, 0), 90, 2, false}};
    const QPointF g = toGroup(turned, QPointF(3, 0));
    QVERIFY2(distance(g, QPointF(100, 6)) < 1e-12, qPrintable(text(g)));
    QVERIFY(distance(fromGroup(turned, g), QPointF(3, 0)) < 1e-12);
    // Mirrored before the turn: +x becomes −x, then the turn.
    const Placement mirrored{1.0, IrisViewOffset{QPointF(0, 0), 90, 1, true}};
    QVERIFY(distance(toGroup(mirrored, QPointF(1, 0)), QPointF(0, -1)) < 1e-12);
    QVERIFY(distance(toGroup(mirrored, QPointF(0, 1)), QPointF(-1, 0)) < 1e-12);
}

void TstViewGroupMath::memberAndGroupShowTheSame_data()
{
    QTest::addColumn<double>("unit");
    QTest::addColumn<IrisViewOffset>("offset");
    QTest::addColumn<GroupPose>("group");
    const GroupPose plain{QPointF(1500, 900), 2.5, 0, false, false};
    QTest::newRow("identity") << 1.0 << IrisViewOffset{} << plain;
    QTest::newRow("µm") << 0.25 << IrisViewOffset{} << plain;
    QTest::newRow("offset") << 0.5 << IrisViewOffset{QPointF(-300, 120), 33, 1.2, false} << plain;
    QTest::newRow("mirrored") << 0.5 << IrisViewOffset{QPointF(40, 1), -70, 0.8, true} << plain;
    for (int flipsOfGroup = 0; flipsOfGroup < 4; ++flipsOfGroup) {
        const GroupPose turned{QPointF(-20, 7000), 0.3, 250, (flipsOfGroup & 1) != 0, (flipsOfGroup & 2) != 0};
        for (bool mirror : {false, true}) {
            QTest::addRow("group flips %d, mirror %d", flipsOfGroup, int(mirror))
                << 0.499 << IrisViewOffset{QPointF(12, -34), 15, 1.5, mirror} << turned;
        }
    }
}

// A member shown by viewPoseFor puts every slide point where the group's view puts the
// corresponding group point, and groupPoseOf takes it back.
void TstViewGroupMath::memberAndGroupShowTheSame()
{
    QFETCH(double, unit);
    QFETCH(IrisViewOffset, offset);
    QFETCH(GroupPose, group);
    const Placement placement{unit, offset};
    const ViewPose member = viewPoseFor(group, placement);
    for (const QPointF p : {QPointF(0, 0), QPointF(1000, 0), QPointF(0, 1000), QPointF(-321, 4567)}) {
        const QPointF viaMember = onScreen(member, p);
        const QPointF viaGroup = onScreen(group, toGroup(placement, p));
        QVERIFY2(distance(viaMember, viaGroup) < 1e-6,
                 qPrintable(QStringLiteral("slide point %1: member %2, group %3 (%4)")
                                .arg(text(p), text(viaMember), text(viaGroup), text(member))));
    }
    const GroupPose back = groupPoseOf(member, placement);
    QVERIFY(distance(back.centre, group.centre) < 1e-9);
    QVERIFY(near(back.scale, group.scale, 1e-12 * group.scale));
    QVERIFY(near(back.rotation, group.rotation, 1e-9));
    QCOMPARE(back.flipH, group.flipH);
    QCOMPARE(back.flipV, group.flipV);
}

void TstViewGroupMath::capturedOffsetReproducesTheView_data()
{
    QTest::addColumn<ViewPose>("view");
    QTest::addColumn<double>("unit");
    QTest::addColumn<GroupPose>("group");
    int row = 0;
    for (int viewFlips = 0; viewFlips < 4; ++viewFlips) {
        for (int groupFlips = 0; groupFlips < 4; ++groupFlips) {
            const ViewPose view{QPointF(2000, 1300), 1.7, 40.0 * row, (viewFlips & 1) != 0, (viewFlips & 2) != 0};
            const GroupPose group{QPointF(-5, 880), 0.4, 300 - 13.0 * row, (groupFlips & 1) != 0,
                                  (groupFlips & 2) != 0};
            QTest::addRow("view flips %d, group flips %d", viewFlips, groupFlips) << view << 0.25 << group;
            ++row;
        }
    }
}

// Relinking: the captured offset makes the view's present pose the group's, exactly.
void TstViewGroupMath::capturedOffsetReproducesTheView()
{
    QFETCH(ViewPose, view);
    QFETCH(double, unit);
    QFETCH(GroupPose, group);
    const IrisViewOffset offset = offsetFor(view, unit, group);
    QVERIFY(offset.rotation > -180 && offset.rotation <= 180);
    QVERIFY(offset.scale > 0);
    const ViewPose shown = viewPoseFor(group, Placement{unit, offset});
    QVERIFY2(showSame(shown, view, 1e-6, 1e-9), qPrintable(text(shown) + QStringLiteral(" vs ") + text(view)));
}

// A view flipped horizontally turns the other way: a member with an offset of +30° shows
// −30° relative to the group while the group is flipped once, +30° when flipped twice.
void TstViewGroupMath::flipsOfTheGroupReverseOffsetTurns()
{
    const Placement placement{1.0, IrisViewOffset{QPointF(), 30, 1, false}};
    QCOMPARE(viewPoseFor(GroupPose{QPointF(), 1, 100, false, false}, placement).rotation, 130.0);
    QCOMPARE(viewPoseFor(GroupPose{QPointF(), 1, 100, true, false}, placement).rotation, 70.0);
    QCOMPARE(viewPoseFor(GroupPose{QPointF(), 1, 100, false, true}, placement).rotation, 70.0);
    QCOMPARE(viewPoseFor(GroupPose{QPointF(), 1, 100, true, true}, placement).rotation, 130.0);
    // A mirrored offset toggles the member's horizontal flip.
    const ViewPose mirrored = viewPoseFor(GroupPose{QPointF(), 1, 0, false, true},
                                          Placement{1.0, IrisViewOffset{QPointF(), 0, 1, true}});
    QVERIFY(mirrored.flipH && mirrored.flipV);
}

void TstViewGroupMath::halfTurnWithBothFlipsShowsTheSame()
{
    const ViewPose a{QPointF(10, 20), 2, 30, false, false};
    const ViewPose b{QPointF(10, 20), 2, 210, true, true};
    QVERIFY(showSame(a, b));
    QVERIFY(!showSame(a, ViewPose{QPointF(10, 20), 2, 30, true, false}));
    QVERIFY(!showSame(a, ViewPose{QPointF(10, 20), 2, 30.001, false, false}));
    QVERIFY(!showSame(a, ViewPose{QPointF(10, 20), 2.000001, 30, false, false}));
    QVERIFY(!showSame(a, ViewPose{QPointF(10, 20.01), 2, 30, false, false}));
    QVERIFY(showSame(a, ViewPose{QPointF(10, 20), 2, 390, false, false}));
}

void TstViewGroupMath::correspondingPoints()
{
    // Slide a at 0.25 µm/px, slide b at 0.5 µm/px placed 100 µm to the right: b's pixel
    // (0, 0) lies under a's pixel (400, 0).
    const Placement a{0.25, {}};
    const Placement b{0.5, IrisViewOffset{QPointF(100, 0), 0, 1, false}};
    QVERIFY(distance(correspondingPoint(QPointF(400, 0), a, b), QPointF(0, 0)) < 1e-9);
    QVERIFY(distance(correspondingPoint(QPointF(600, 40), a, b), QPointF(100, 20)) < 1e-9);
    QVERIFY(distance(correspondingPoint(QPointF(100, 20), b, a), QPointF(600, 40)) < 1e-9);
}

// --- real views -------------------------------------------------------------------------------

namespace {

constexpr QSize kViewSize(360, 270);

// A top-level window with `count` views side by side, each kViewSize.
struct ViewRow {
    std::unique_ptr<QWidget> window = std::make_unique<QWidget>();
    QList<IrisSlideView *> views;

    explicit ViewRow(int count)
    {
        auto *layout = new QHBoxLayout(window.get());
        layout->setContentsMargins(0, 0, 0, 0);
        layout->setSpacing(0);
        for (int i = 0; i < count; ++i) {
            auto *view = new IrisSlideView;
            view->setFixedSize(kViewSize);
            layout->addWidget(view);
            views << view;
        }
    }
    IrisSlideView *operator[](qsizetype i) const { return views[i]; }
};

ViewPose poseOf(const IrisSlideView *view)
{
    return ViewPose{view->centre(), view->downsample() * view->devicePixelRatioF(), view->rotation(),
                    view->isFlippedHorizontally(), view->isFlippedVertically()};
}

// Logical widget positions spread over a view.
const QPointF kProbes[] = {{60, 50}, {300, 40}, {180, 135}, {30, 250}, {330, 220}};

// Where the follower shows each probe's slide point now (logical widget positions).
struct Marks {
    QList<QPointF> slidePoints;
    QList<QPointF> widgetPositions;
};

Marks mark(const IrisSlideView *view)
{
    Marks m;
    for (const QPointF p : kProbes) {
        m.slidePoints << view->mapToSlide(p);
        m.widgetPositions << p;
    }
    return m;
}

// Whether each marked slide point is now shown at `expected(old position)`, within `tolerance`
// logical pixels; *why says which one is not.
template <class F>
bool marksMoved(const IrisSlideView *view, const Marks &marks, F expected, double tolerance, QString *why)
{
    for (qsizetype i = 0; i < marks.slidePoints.size(); ++i) {
        const QPointF now = view->mapFromSlide(marks.slidePoints[i]);
        const QPointF want = expected(marks.widgetPositions[i]);
        if (distance(now, want) > tolerance) {
            *why = QStringLiteral("slide point %1 is at %2, expected %3")
                       .arg(text(marks.slidePoints[i]), text(now), text(want));
            return false;
        }
    }
    return true;
}

// Runs `change` and checks that the follower's image moved on screen exactly as the leader's
// did: every slide point the follower showed at a widget position q is now where the leader
// shows the slide point it showed at q (the two views have the same size).
template <class F>
bool sameScreenMotion(const IrisSlideView *leader, const IrisSlideView *follower, F change, QString *why)
{
    const Marks before = mark(leader);
    const Marks followerBefore = mark(follower);
    change();
    for (qsizetype i = 0; i < before.slidePoints.size(); ++i) {
        const QPointF want = leader->mapFromSlide(before.slidePoints[i]);
        const QPointF now = follower->mapFromSlide(followerBefore.slidePoints[i]);
        if (distance(now, want) > 1e-6) {
            *why = QStringLiteral("probe %1: the follower shows its point at %2, the leader at %3")
                       .arg(text(before.widgetPositions[i]), text(now), text(want));
            return false;
        }
    }
    return true;
}

} // namespace

class TstViewGroup : public QObject {
    Q_OBJECT

private Q_SLOTS:
    void initTestCase();
    void cleanup();
    void cleanupTestCase();

    void newMemberTakesTheGroupsView();
    void followsPansAndDrags();
    void followsZoomsStepByStep();
    void followsGlideStepByStep();
    void takingHoldOfAnotherViewEndsTheGlide();
    void followsTurnsAndFlips();
    void oneChangeIsOneViewChangedPerView();
    void unlinkedViewMovesAloneAndRelinkKeepsTheAlignment();
    void setOffsetPlacesTheSlide();
    void differentMppMeetInPhysicalSize();
    void withoutMppTheDownsampleIsMatched();
    void crosshairFollowsThePointer();
    void removedAndDestroyedViewsLeave();
    void viewOpenedBeforeShownTakesTheGroupsView();

private:
    // Shows a row of views, opens a slide in each and waits until each is bound and showing.
    void showRow(ViewRow &row, const QStringList &slides);

    QString m_sample;
    QString m_second;
    std::unique_ptr<ViewRow> m_row;
};

void TstViewGroup::initTestCase()
{
    QCOMPARE(QGuiApplication::platformName(), QStringLiteral("xcb"));
    IrisSlideView::setVulkanValidation(true);
    // The X server's own pointer away from the windows (shown at the top left): its real
    // enter and leave events must not mix with the synthesised ones.
    QCursor::setPos(QGuiApplication::primaryScreen()->geometry().bottomRight());
    m_sample = sampleSlide();
    m_second = secondSampleSlide();
    QVERIFY2(QFileInfo::exists(m_sample), qPrintable(QStringLiteral("no sample slide at '%1'").arg(m_sample)));
    QVERIFY2(QFileInfo::exists(m_second), qPrintable(QStringLiteral("no second sample at '%1'").arg(m_second)));
}

void TstViewGroup::cleanup()
{
    if (m_row) {
        for (IrisSlideView *view : std::as_const(m_row->views)) {
            QVERIFY2(view->validationMessageCount() == 0,
                     qPrintable(QStringLiteral("%1 Vulkan validation messages (see the log above)")
                                    .arg(view->validationMessageCount())));
        }
    }
    m_row.reset();
}

void TstViewGroup::cleanupTestCase()
{
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 0);
}

void TstViewGroup::showRow(ViewRow &row, const QStringList &slides)
{
    row.window->show();
    QVERIFY(QTest::qWaitForWindowExposed(row.window.get()));
    for (qsizetype i = 0; i < row.views.size(); ++i) {
        IrisSlideView *view = row[i];
        QVERIFY(view->isRendererAvailable());
        QTRY_VERIFY(view->surfaceWindow()->isExposed());
        QVERIFY2(view->openSlide(slides.value(i, m_sample)), qPrintable(slides.value(i, m_sample)));
        FrameWatcher frames(view);
        QVERIFY(frames.waitForCompleteFrame());
    }
}

void TstViewGroup::newMemberTakesTheGroupsView()
{
    m_row = std::make_unique<ViewRow>(2);
    showRow(*m_row, {m_sample, m_second});
    IrisSlideView *a = (*m_row)[0];
    IrisSlideView *b = (*m_row)[1];
    a->setView(QPointF(2100, 1400), 1.5, 0);
    QVERIFY(!near(b->downsample(), 1.5, 1e-3)); // fitted to a smaller slide

    IrisViewGroup group;
    QSignalSpy added(&group, &IrisViewGroup::viewAdded);
    group.addView(a);
    group.addView(b);
    group.addView(b); // once only
    QCOMPARE(added.count(), 2);
    QCOMPARE(group.views(), (QList<IrisSlideView *>{a, b}));
    QVERIFY(group.isLinked(a) && group.isLinked(b));
    QCOMPARE(group.units(), IrisViewGroup::Micrometres); // both samples state 0.25 µm/px
    // Same mpp, identity offsets: b shows the same pixel coordinates at the same scale.
    QVERIFY2(distance(b->centre(), a->centre()) < 1e-6, qPrintable(text(b->centre())));
    QVERIFY(near(b->downsample(), a->downsample(), 1e-12));
    for (const QPointF p : kProbes)
        QVERIFY(distance(b->mapToSlide(p), a->mapToSlide(p)) < 1e-6);
}

void TstViewGroup::followsPansAndDrags()
{
    m_row = std::make_unique<ViewRow>(3);
    showRow(*m_row, {m_sample, m_second, m_sample});
    IrisSlideView *a = (*m_row)[0];
    IrisSlideView *b = (*m_row)[1];
    IrisSlideView *c = (*m_row)[2];
    IrisViewGroup group;
    for (IrisSlideView *view : {a, b, c})
        group.addView(view);
    a->setView(QPointF(1200, 900), 2.0, 0);

    // Programmatic pan of the first: the others' images move by the same screen distance.
    Marks marksB = mark(b);
    Marks marksC = mark(c);
    const QPointF delta(37, -21);
    a->panBy(delta);
    QString why;
    const auto shifted = [delta](QPointF p) { return p + delta; };
    QVERIFY2(marksMoved(b, marksB, shifted, 1e-6, &why), qPrintable(why));
    QVERIFY2(marksMoved(c, marksC, shifted, 1e-6, &why), qPrintable(why));

    // A drag with the mouse on the second view (no glide): the first and third follow.
    a->setKineticPanning(false);
    b->setKineticPanning(false);
    Marks marksA = mark(a);
    marksC = mark(c);
    QWindow *surface = b->surfaceWindow();
    QPoint p(100, 100);
    QTest::mousePress(surface, Qt::LeftButton, {}, p);
    for (int i = 0; i < 5; ++i) {
        p += QPoint(-12, 8);
        QTest::mouseMove(surface, p, 10);
    }
    QTest::mouseRelease(surface, Qt::LeftButton, {}, p, 10);
    const QPointF dragged(-60, 40);
    const auto draggedBy = [dragged](QPointF q) { return q + dragged; };
    QVERIFY2(marksMoved(a, marksA, draggedBy, 1e-6, &why), qPrintable(why));
    QVERIFY2(marksMoved(c, marksC, draggedBy, 1e-6, &why), qPrintable(why));
}

void TstViewGroup::followsZoomsStepByStep()
{
    m_row = std::make_unique<ViewRow>(2);
    showRow(*m_row, {m_sample, m_second});
    IrisSlideView *a = (*m_row)[0];
    IrisSlideView *b = (*m_row)[1];
    IrisViewGroup group;
    group.addView(a);
    group.addView(b);
    a->setView(QPointF(1500, 1000), 4.0, 0);

    // zoomBy about the centre: b's image scales about its centre too.
    Marks marks = mark(b);
    a->zoomBy(2);
    const QPointF middle(kViewSize.width() / 2.0, kViewSize.height() / 2.0);
    QString why;
    QVERIFY2(marksMoved(b, marks, [&](QPointF q) { return middle + 2 * (q - middle); }, 1e-6, &why),
             qPrintable(why));

    // An animated wheel zoom on b: a follows every step, not only the last.
    int steps = 0;
    int mismatches = 0;
    QString firstMismatch;
    connect(b, &IrisSlideView::viewChanged, this, [&] {
        ++steps;
        if (!showSame(poseOf(a), poseOf(b), 1e-6, 1e-9)) {
            if (mismatches++ == 0)
                firstMismatch = text(poseOf(a)) + QStringLiteral(" vs ") + text(poseOf(b));
        }
    });
    const QPointF at(250, 80);
    const QPointF underB = b->mapToSlide(at);
    const double before = b->downsample();
    QWheelEvent wheel(at, b->surfaceWindow()->mapToGlobal(at), QPoint(), QPoint(0, 120), Qt::NoButton,
                      Qt::NoModifier, Qt::NoScrollPhase, false);
    QCoreApplication::sendEvent(b->surfaceWindow(), &wheel);
    QTRY_VERIFY(b->downsample() < before && near(b->mapFromSlide(underB).x(), at.x(), 0.01)
                && steps >= 2 && showSame(poseOf(a), poseOf(b), 1e-6, 1e-9)
                && near(b->downsample(), before / IrisWidget::ViewNavigator::kWheelNotchFactor, 1e-3 * before));
    QVERIFY2(mismatches == 0, qPrintable(QStringLiteral("%1 of %2 steps differ; first: %3")
                                             .arg(mismatches)
                                             .arg(steps)
                                             .arg(firstMismatch)));
    disconnect(b, &IrisSlideView::viewChanged, this, nullptr);
}

void TstViewGroup::followsGlideStepByStep()
{
    m_row = std::make_unique<ViewRow>(2);
    showRow(*m_row, {m_sample, m_second});
    IrisSlideView *a = (*m_row)[0];
    IrisSlideView *b = (*m_row)[1];
    IrisViewGroup group;
    group.addView(a);
    group.addView(b);
    a->setView(QPointF(3000, 2000), 2.0, 0);
    QVERIFY(a->kineticPanning());

    int leaderSteps = 0;
    int followerSteps = 0;
    int mismatches = 0;
    QElapsedTimer sinceLastStep;
    sinceLastStep.start();
    connect(b, &IrisSlideView::viewChanged, this, [&] { ++followerSteps; });
    connect(a, &IrisSlideView::viewChanged, this, [&] {
        ++leaderSteps;
        sinceLastStep.restart();
        if (!showSame(poseOf(a), poseOf(b), 1e-6, 1e-9))
            ++mismatches;
    });

    // 20 logical px every 16 ms, released while moving: it glides on.
    const QPointF c0 = a->centre();
    QPoint p(60, 130);
    QWindow *surface = a->surfaceWindow();
    QTest::mousePress(surface, Qt::LeftButton, {}, p);
    for (int i = 0; i < 8; ++i) {
        p += QPoint(20, 0);
        QTest::mouseMove(surface, p, 16);
    }
    QTest::mouseRelease(surface, Qt::LeftButton, {}, p, 1);
    const double dragged = (c0.x() - a->centre().x()) / (a->downsample() * a->devicePixelRatioF());
    const int stepsAtRelease = leaderSteps;
    // The glide: more steps after the release, the image further than the drag took it,
    // and then no step for 400 ms (stopped).
    QTRY_VERIFY_WITH_TIMEOUT(leaderSteps > stepsAtRelease + 3
                                 && (c0.x() - a->centre().x()) / (a->downsample() * a->devicePixelRatioF())
                                        > dragged + 10
                                 && sinceLastStep.elapsed() > 400,
                             10000);
    QCOMPARE(mismatches, 0);
    QCOMPARE(followerSteps, leaderSteps); // every step, once
    QVERIFY(showSame(poseOf(a), poseOf(b), 1e-6, 1e-9));
    disconnect(a, &IrisSlideView::viewChanged, this, nullptr);
    disconnect(b, &IrisSlideView::viewChanged, this, nullptr);
}

// A flick on a, then a drag on b while a still glides: b's drag must not be ended by a's
// next glide step (the group gives it to b, and a setter ends b's drag); a stops instead.
void TstViewGroup::takingHoldOfAnotherViewEndsTheGlide()
{
    m_row = std::make_unique<ViewRow>(2);
    showRow(*m_row, {m_sample, m_second});
    IrisSlideView *a = (*m_row)[0];
    IrisSlideView *b = (*m_row)[1];
    IrisViewGroup group;
    group.addView(a);
    group.addView(b);
    a->setView(QPointF(3000, 2000), 2.0, 0);
    b->setKineticPanning(false); // b's own release stops where it lets go

    QElapsedTimer sinceLastStep;
    sinceLastStep.start();
    connect(a, &IrisSlideView::viewChanged, this, [&] { sinceLastStep.restart(); });
    const QPointF c0 = a->centre();
    const double scale = a->downsample() * a->devicePixelRatioF();
    QPoint p(60, 130);
    QTest::mousePress(a->surfaceWindow(), Qt::LeftButton, {}, p);
    for (int i = 0; i < 8; ++i) {
        p += QPoint(20, 0);
        QTest::mouseMove(a->surfaceWindow(), p, 16);
    }
    QTest::mouseRelease(a->surfaceWindow(), Qt::LeftButton, {}, p, 1);
    const double dragged = (c0.x() - a->centre().x()) / scale;
    QTRY_VERIFY((c0.x() - a->centre().x()) / scale > dragged + 5); // gliding

    // Hold b and drag it 30 px to the left, slowly enough for glide steps to come between.
    QPoint q(200, 120);
    QTest::mousePress(b->surfaceWindow(), Qt::LeftButton, {}, q);
    const Marks held = mark(b);
    for (int i = 0; i < 5; ++i) {
        q += QPoint(-6, 0);
        QTest::mouseMove(b->surfaceWindow(), q, 40);
    }
    QString why;
    QVERIFY2(marksMoved(b, held, [](QPointF r) { return r + QPointF(-30, 0); }, 1e-6, &why), qPrintable(why));
    QTest::mouseRelease(b->surfaceWindow(), Qt::LeftButton, {}, q, 10);
    // a followed the drag and glides no more.
    QTRY_VERIFY(sinceLastStep.elapsed() > 300);
    QVERIFY(showSame(poseOf(a), poseOf(b), 1e-6, 1e-9));
    QVERIFY2(marksMoved(b, held, [](QPointF r) { return r + QPointF(-30, 0); }, 1e-6, &why), qPrintable(why));
    disconnect(a, &IrisSlideView::viewChanged, this, nullptr);
}

void TstViewGroup::followsTurnsAndFlips()
{
    m_row = std::make_unique<ViewRow>(2);
    showRow(*m_row, {m_sample, m_second});
    IrisSlideView *a = (*m_row)[0];
    IrisSlideView *b = (*m_row)[1];
    IrisViewGroup group;
    group.addView(a);
    group.addView(b);
    a->setView(QPointF(1400, 1100), 2.0, 0);

    // A turn about a widget point of a: b turns by as much about the same widget point.
    const QPointF anchor(90, 200);
    Marks marks = mark(b);
    a->rotateBy(30, anchor);
    QVERIFY(near(a->rotation(), 30, 1e-9));
    QVERIFY(near(b->rotation(), 30, 1e-9));
    const auto turnedAbout = [anchor](double degrees) {
        return [anchor, degrees](QPointF q) {
            const double r = degrees * std::numbers::pi / 180.0;
            const QPointF d = q - anchor;
            return anchor + QPointF(d.x() * std::cos(r) - d.y() * std::sin(r), d.x() * std::sin(r) + d.y() * std::cos(r));
        };
    };
    QString why;
    QVERIFY2(marksMoved(b, marks, turnedAbout(30), 1e-6, &why), qPrintable(why));

    // Widget positions show the same slide points in both (same mpp, identity offsets):
    // the group's model of a turned view is the widget's.
    for (const QPointF q : kProbes)
        QVERIFY2(distance(a->mapToSlide(q), b->mapToSlide(q)) < 1e-6, qPrintable(text(q)));

    // Flips, from either view.
    b->setFlippedHorizontally(true);
    QVERIFY(a->isFlippedHorizontally());
    QVERIFY(showSame(poseOf(a), poseOf(b)));
    a->setFlippedVertically(true);
    QVERIFY(showSame(poseOf(a), poseOf(b)));
    for (const QPointF q : kProbes)
        QVERIFY2(distance(a->mapToSlide(q), b->mapToSlide(q)) < 1e-6, qPrintable(text(q)));

    // setView and resetOrientation.
    b->setView(QPointF(900, 700), 1.0, 275);
    QVERIFY(showSame(poseOf(a), poseOf(b)));
    a->resetOrientation();
    QVERIFY(near(b->rotation(), 0, 1e-9) && !b->isFlippedHorizontally() && !b->isFlippedVertically());
    QVERIFY(showSame(poseOf(a), poseOf(b)));
}

void TstViewGroup::oneChangeIsOneViewChangedPerView()
{
    m_row = std::make_unique<ViewRow>(3);
    showRow(*m_row, {m_sample, m_second, m_second});
    IrisViewGroup group;
    for (IrisSlideView *view : std::as_const(m_row->views))
        group.addView(view);
    QList<QSignalSpy *> spies;
    for (IrisSlideView *view : std::as_const(m_row->views))
        spies << new QSignalSpy(view, &IrisSlideView::viewChanged);
    const auto counts = [&] {
        // Anything queued (a bounced change would be) has its chance to run.
        QCoreApplication::sendPostedEvents();
        QCoreApplication::processEvents();
        QList<int> list;
        for (QSignalSpy *spy : std::as_const(spies)) {
            list << int(spy->count());
            spy->clear();
        }
        return list;
    };
    const QList<int> once{1, 1, 1};
    for (qsizetype leader = 0; leader < m_row->views.size(); ++leader) {
        IrisSlideView *view = (*m_row)[leader];
        view->setCentre(view->centre() + QPointF(50, 30));
        QCOMPARE(counts(), once);
        view->setDownsample(view->downsample() * 0.8);
        QCOMPARE(counts(), once);
        view->rotateBy(10);
        QCOMPARE(counts(), once);
        view->setView(view->centre(), view->downsample() * 1.1, view->rotation() + 5);
        QCOMPARE(counts(), once);
        view->setFlippedHorizontally(!view->isFlippedHorizontally());
        QCOMPARE(counts(), once);
        // A turn and a flip at once reach every follower as one change too.
        view->setView(view->centre(), view->downsample(), view->rotation() + 20, !view->isFlippedHorizontally(),
                      !view->isFlippedVertically());
        QCOMPARE(counts(), once);
        // Setting what is already shown changes nothing anywhere.
        view->setCentre(view->centre());
        QCOMPARE(counts(), (QList<int>{0, 0, 0}));
    }
    qDeleteAll(spies);
}

void TstViewGroup::unlinkedViewMovesAloneAndRelinkKeepsTheAlignment()
{
    m_row = std::make_unique<ViewRow>(2);
    showRow(*m_row, {m_sample, m_second});
    IrisSlideView *a = (*m_row)[0];
    IrisSlideView *b = (*m_row)[1];
    IrisViewGroup group;
    group.addView(a);
    group.addView(b);
    a->setView(QPointF(2500, 1500), 2.0, 0);
    QSignalSpy linked(&group, &IrisViewGroup::linkedChanged);
    QSignalSpy offsets(&group, &IrisViewGroup::offsetChanged);

    // Unlinked, b is aligned by hand; a stays where it is, and b does not follow a.
    group.setLinked(b, false);
    QCOMPARE(linked.count(), 1);
    QVERIFY(!group.isLinked(b));
    QSignalSpy aChanges(a, &IrisSlideView::viewChanged);
    QSignalSpy bChanges(b, &IrisSlideView::viewChanged);
    b->panBy(QPointF(-80, 45));
    b->rotateBy(-25, QPointF(100, 100));
    b->zoomBy(1.5);
    QCOMPARE(aChanges.count(), 0);
    const ViewPose aligned = poseOf(b);
    a->panBy(QPointF(10, 10));
    QCOMPARE(bChanges.count(), 3);
    QVERIFY(showSame(poseOf(b), aligned));

    // Relinked: nothing moves, the offset now holds the alignment.
    aChanges.clear();
    bChanges.clear();
    group.setLinked(b, true);
    QCOMPARE(offsets.count(), 1);
    QCOMPARE(aChanges.count(), 0);
    QCOMPARE(bChanges.count(), 0);
    const IrisViewOffset offset = group.offset(b);
    QVERIFY2(near(offset.rotation, -25, 1e-9), qPrintable(QString::number(offset.rotation)));
    QVERIFY2(near(offset.scale, 1.5, 1e-9), qPrintable(QString::number(offset.scale)));
    QVERIFY(!offset.mirrored);

    // Moving either moves the other by the same on screen, turn and zoom included.
    Marks marks = mark(b);
    a->panBy(QPointF(33, -12));
    QString why;
    QVERIFY2(marksMoved(b, marks, [](QPointF q) { return q + QPointF(33, -12); }, 1e-6, &why), qPrintable(why));
    marks = mark(a);
    b->panBy(QPointF(-7, 19));
    QVERIFY2(marksMoved(a, marks, [](QPointF q) { return q + QPointF(-7, 19); }, 1e-6, &why), qPrintable(why));
    a->rotateBy(40);
    QVERIFY(near(b->rotation(), normalizedDegrees(a->rotation() - 25), 1e-9));
    QVERIFY(near(b->downsample() * 1.5, a->downsample(), 1e-9 * a->downsample()));
    QCOMPARE(group.offset(b), offset); // following does not change the offset

    // Flips and turns from either side move both images alike on screen, although b is
    // turned and magnified against a (a flip reverses the sense of b's extra turn).
    QVERIFY2(sameScreenMotion(a, b, [a] { a->setFlippedHorizontally(true); }, &why), qPrintable(why));
    QVERIFY2(sameScreenMotion(b, a, [b] { b->setFlippedVertically(true); }, &why), qPrintable(why));
    QVERIFY2(sameScreenMotion(b, a, [b] { b->setFlippedHorizontally(false); }, &why), qPrintable(why));
    QVERIFY2(sameScreenMotion(a, b, [a] { a->rotateBy(-65, QPointF(40, 220)); }, &why), qPrintable(why));
    QVERIFY2(sameScreenMotion(b, a, [b] { b->rotateBy(12, QPointF(300, 30)); }, &why), qPrintable(why));
    QVERIFY2(sameScreenMotion(a, b, [a] { a->resetOrientation(); }, &why), qPrintable(why));
    QCOMPARE(group.offset(b), offset);

    // Unlink, realign, relink again: the new alignment replaces the old.
    group.setLinked(b, false);
    b->rotateBy(25);
    group.setLinked(b, true);
    QVERIFY(near(group.offset(b).rotation, 0, 1e-9));
    a->zoomBy(0.5);
    QVERIFY(near(b->rotation(), a->rotation(), 1e-9));
}

void TstViewGroup::setOffsetPlacesTheSlide()
{
    m_row = std::make_unique<ViewRow>(2);
    showRow(*m_row, {m_sample, m_second});
    IrisSlideView *a = (*m_row)[0];
    IrisSlideView *b = (*m_row)[1];
    IrisViewGroup group;
    group.addView(a);
    group.addView(b);
    a->setView(QPointF(2000, 1000), 1.0, 10);

    // b's slide 100 µm to the right in the group (0.25 µm/px: 400 px), turned 90°, 2× larger.
    QSignalSpy offsets(&group, &IrisViewGroup::offsetChanged);
    QSignalSpy aChanges(a, &IrisSlideView::viewChanged);
    group.setOffset(b, QPointF(100, 0), 90, 2);
    QCOMPARE(offsets.count(), 1);
    QCOMPARE(aChanges.count(), 0); // the others stay
    QVERIFY(near(b->rotation(), 100, 1e-9));
    QVERIFY(near(b->downsample(), a->downsample() / 2, 1e-12));
    // g = 2·0.25·Rot(90°)·p + (100, 0): the group point a shows at its centre,
    // (2000, 1000) · 0.25 = (500, 250) µm, is b's (g − t) / 0.5 turned back by 90°.
    const QPointF expected(250 / 0.5, -(500 - 100) / 0.5);
    QVERIFY2(distance(b->centre(), expected) < 1e-6, qPrintable(text(b->centre())));
    group.setOffset(b, IrisViewOffset{QPointF(100, 0), 90, 0, false}); // no scale: ignored
    QCOMPARE(offsets.count(), 1);
}

void TstViewGroup::differentMppMeetInPhysicalSize()
{
    const QString svs = testDataSlide(QStringLiteral("aperio/CMU-1-Small-Region.svs"));
    if (svs.isEmpty())
        QSKIP("the shared test data (aperio/CMU-1-Small-Region.svs, 0.499 µm/px) is not there");
    m_row = std::make_unique<ViewRow>(2);
    showRow(*m_row, {m_sample, svs});
    IrisSlideView *a = (*m_row)[0];
    IrisSlideView *b = (*m_row)[1];
    const double mppA = a->slideInfo().mppX;
    const double mppB = b->slideInfo().mppX;
    QVERIFY2(mppA > 0 && mppB > 0 && !near(mppA, mppB, 0.05),
             qPrintable(QStringLiteral("%1 vs %2").arg(mppA).arg(mppB)));
    IrisViewGroup group;
    group.addView(a);
    group.addView(b);
    QCOMPARE(group.units(), IrisViewGroup::Micrometres);

    // The same µm per device pixel, so a distance on screen is the same length of tissue.
    const auto micronsPerPixel = [](const IrisSlideView *view) {
        return view->downsample() * std::sqrt(view->slideInfo().mppX * view->slideInfo().mppY);
    };
    a->setView(QPointF(2000, 1600), 3.0, 0);
    QVERIFY2(near(micronsPerPixel(a), micronsPerPixel(b), 1e-9 * micronsPerPixel(a)),
             qPrintable(QStringLiteral("%1 vs %2 µm/px").arg(micronsPerPixel(a)).arg(micronsPerPixel(b))));
    // The centres are the same place in µm (identity offsets: the slides' origins meet).
    QVERIFY(distance(a->centre() * mppA, b->centre() * mppB) < 1e-6);
    b->zoomBy(2);
    QVERIFY(near(micronsPerPixel(a), micronsPerPixel(b), 1e-9 * micronsPerPixel(a)));
    const QPointF p(50, 60), q(300, 200);
    const double micronsA = distance(a->mapToSlide(p), a->mapToSlide(q)) * mppA;
    const double micronsB = distance(b->mapToSlide(p), b->mapToSlide(q)) * mppB;
    QVERIFY2(near(micronsA, micronsB, 1e-6 * micronsA), qPrintable(QStringLiteral("%1 vs %2").arg(micronsA).arg(micronsB)));
}

void TstViewGroup::withoutMppTheDownsampleIsMatched()
{
    const QString noMpp = testDataSlide(QStringLiteral("aperio/tcga-cr-7395-01a-01-ts1.svs"));
    if (noMpp.isEmpty())
        QSKIP("the shared test data (aperio/tcga-cr-7395-01a-01-ts1.svs, no mpp) is not there");
    m_row = std::make_unique<ViewRow>(2);
    showRow(*m_row, {m_sample, noMpp});
    IrisSlideView *a = (*m_row)[0];
    IrisSlideView *b = (*m_row)[1];
    QCOMPARE(b->slideInfo().mppX, 0.0);
    IrisViewGroup group;
    group.addView(a);
    group.addView(b);
    QCOMPARE(group.units(), IrisViewGroup::Pixels);
    a->setView(QPointF(1000, 800), 2.5, 0);
    QVERIFY(near(b->downsample(), 2.5, 1e-12));
    QVERIFY(distance(b->centre(), QPointF(1000, 800)) < 1e-6);
    // Unlinking the slide without mpp leaves the others in µm.
    group.setLinked(b, false);
    QCOMPARE(group.units(), IrisViewGroup::Micrometres);
}

void TstViewGroup::crosshairFollowsThePointer()
{
    m_row = std::make_unique<ViewRow>(3);
    showRow(*m_row, {m_sample, m_second, m_sample});
    IrisSlideView *a = (*m_row)[0];
    IrisSlideView *b = (*m_row)[1];
    IrisSlideView *c = (*m_row)[2];
    auto group = std::make_unique<IrisViewGroup>();
    for (IrisSlideView *view : {a, b, c})
        group->addView(view);
    group->setLinked(c, false);
    QVERIFY(!a->hasCrosshair() && !b->hasCrosshair() && !c->hasCrosshair());

    // Over a: the linked b shows the cross-hair, a itself and the unlinked c do not.
    QSignalSpy moved(a, &IrisSlideView::cursorMoved);
    QTest::mouseMove(a->surfaceWindow(), QPoint(120, 90));
    QTRY_VERIFY(moved.count() > 0);
    QVERIFY(b->hasCrosshair());
    QVERIFY(!a->hasCrosshair());
    QVERIFY(!c->hasCrosshair());

    // Over b: it moves to a.
    QSignalSpy movedB(b, &IrisSlideView::cursorMoved);
    QTest::mouseMove(b->surfaceWindow(), QPoint(40, 40));
    QTRY_VERIFY(movedB.count() > 0);
    QVERIFY(a->hasCrosshair());
    QVERIFY(!b->hasCrosshair());

    // The pointer leaves b: gone everywhere.
    QEvent leave(QEvent::Leave);
    QCoreApplication::sendEvent(b->surfaceWindow(), &leave);
    QVERIFY(!a->hasCrosshair() && !b->hasCrosshair() && !c->hasCrosshair());

    // Switched off, none appear.
    group->setCrosshairsEnabled(false);
    QTest::mouseMove(a->surfaceWindow(), QPoint(150, 100));
    QTRY_VERIFY(moved.count() > 1);
    QVERIFY(!b->hasCrosshair());
    group->setCrosshairsEnabled(true);
    QVERIFY(b->hasCrosshair()); // the pointer is still over a

    // Unlinking the view with the cross-hair takes it away, relinking brings it back; the
    // group's end takes them all.
    group->setLinked(b, false);
    QVERIFY(!b->hasCrosshair());
    group->setLinked(b, true);
    QVERIFY(b->hasCrosshair());
    group.reset();
    QVERIFY(!a->hasCrosshair() && !b->hasCrosshair() && !c->hasCrosshair());
}

void TstViewGroup::removedAndDestroyedViewsLeave()
{
    m_row = std::make_unique<ViewRow>(3);
    showRow(*m_row, {m_sample, m_second, m_sample});
    IrisSlideView *a = (*m_row)[0];
    IrisSlideView *b = (*m_row)[1];
    IrisSlideView *c = (*m_row)[2];
    IrisViewGroup group;
    for (IrisSlideView *view : {a, b, c})
        group.addView(view);
    QSignalSpy removed(&group, &IrisViewGroup::viewRemoved);

    group.removeView(c);
    QCOMPARE(removed.count(), 1);
    QVERIFY(!group.contains(c));
    const ViewPose cBefore = poseOf(c);
    a->panBy(QPointF(20, 20));
    QVERIFY(showSame(poseOf(c), cBefore)); // no longer follows
    QVERIFY(showSame(poseOf(a), poseOf(b)));

    // A destroyed member leaves by itself; the rest go on.
    m_row->views.removeOne(b);
    QVERIFY(b->validationMessageCount() == 0);
    delete b;
    QCOMPARE(removed.count(), 2);
    QCOMPARE(group.views(), QList<IrisSlideView *>{a});
    a->panBy(QPointF(-5, 3)); // nothing left to follow: no crash
    a->zoomBy(2);
    QTest::mouseMove(a->surfaceWindow(), QPoint(100, 100));
    QCoreApplication::processEvents();
    QVERIFY(!a->hasCrosshair());
}

// A view that opens its slide before it is on screen fits itself when first shown (the
// widget's contract); that fit must not move the group: the view takes the group's view.
void TstViewGroup::viewOpenedBeforeShownTakesTheGroupsView()
{
    m_row = std::make_unique<ViewRow>(1);
    showRow(*m_row, {m_sample});
    IrisSlideView *a = (*m_row)[0];
    a->setView(QPointF(1800, 1200), 1.25, 20);

    ViewRow later(1);
    IrisSlideView *b = later[0];
    QVERIFY(b->openSlide(m_second)); // not shown yet
    IrisViewGroup group;
    group.addView(a);
    group.addView(b);
    QSignalSpy aChanges(a, &IrisSlideView::viewChanged);
    QSignalSpy bChanges(b, &IrisSlideView::viewChanged);
    later.window->move(kViewSize.width() + 20, 0);
    later.window->show();
    QVERIFY(QTest::qWaitForWindowExposed(later.window.get()));
    FrameWatcher frames(b);
    QVERIFY(frames.waitForCompleteFrame());
    QTRY_VERIFY(bChanges.count() > 0); // it fitted itself …
    QCOMPARE(aChanges.count(), 0);    // … without moving a
    QVERIFY2(showSame(poseOf(b), poseOf(a), 1e-6, 1e-9), qPrintable(text(poseOf(b)) + QStringLiteral(" vs ") + text(poseOf(a))));
    // From then on it leads like any other.
    b->panBy(QPointF(12, 12));
    QCOMPARE(aChanges.count(), 1);
    QVERIFY(showSame(poseOf(b), poseOf(a), 1e-6, 1e-9));
    QVERIFY(b->validationMessageCount() == 0);
}

// --- main -------------------------------------------------------------------------------------

// The maths need no display; with -maths only they run (ctest widget.view_group.maths).
int main(int argc, char *argv[])
{
    QStringList arguments;
    bool mathsOnly = false;
    for (int i = 0; i < argc; ++i) {
        if (qstrcmp(argv[i], "-maths") == 0)
            mathsOnly = true;
        else
            arguments << QString::fromLocal8Bit(argv[i]);
    }
    QScopedPointer<QCoreApplication> app;
    if (mathsOnly) {
        app.reset(new QCoreApplication(argc, argv));
        TstViewGroupMath maths;
        return QTest::qExec(&maths, arguments);
    }
    const QString reason = missingDisplayReason();
    if (!reason.isEmpty()) {
        std::fprintf(stderr, "SKIP: %s\n", qPrintable(reason));
        return kSkipExitCode;
    }
    app.reset(new QApplication(argc, argv));
    TstViewGroup views;
    QTEST_SET_MAIN_SOURCE_PATH
    return QTest::qExec(&views, arguments);
}

#include "tst_view_group.moc"
