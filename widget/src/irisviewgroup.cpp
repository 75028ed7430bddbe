#include "iris/IrisViewGroup.h"

#include <cmath>
#include <numbers>
#include <optional>

#include <QtCore/QEvent>
#include <QtCore/QPointer>
#include <QtCore/QScopedValueRollback>
#include <QtGui/QWindow>

#include "iris/IrisSlideView.h"
#include "logging_p.h"
#include "viewgroupmath_p.h"

// --- pose maths (viewgroupmath_p.h) ------------------------------------------------------

namespace IrisWidget::ViewGroupMath {

namespace {

// A 2 × 2 matrix [a b; c d] acting on column vectors (x, y).
struct Mat2 {
    double a = 1, b = 0, c = 0, d = 1;

    QPointF operator*(QPointF p) const { return {a * p.x() + b * p.y(), c * p.x() + d * p.y()}; }
    Mat2 operator*(const Mat2 &m) const
    {
        return {a * m.a + b * m.c, a * m.b + b * m.d, c * m.a + d * m.c, c * m.b + d * m.d};
    }
    Mat2 scaled(double k) const { return {a * k, b * k, c * k, d * k}; }
    double determinant() const { return a * d - b * c; }
    Mat2 inverted() const
    {
        const double det = determinant();
        return {d / det, -b / det, -c / det, a / det};
    }
};

// Clockwise on screen: with y down, (1, 0) turned by 90° points down, (0, 1).
Mat2 turn(double degrees)
{
    const double radians = degrees * std::numbers::pi / 180.0;
    const double c = std::cos(radians);
    const double s = std::sin(radians);
    return {c, -s, s, c};
}

Mat2 flips(bool horizontally, bool vertically)
{
    return {horizontally ? -1.0 : 1.0, 0, 0, vertically ? -1.0 : 1.0};
}

// A: the member's slide (level-0 pixels) to the group frame, without the translation.
Mat2 placementMatrix(const Placement &placement)
{
    const IrisViewOffset &o = placement.offset;
    return (turn(o.rotation) * flips(o.mirrored, false)).scaled(o.scale * placement.unit);
}

// What a view shows about its centre: slide pixels to logical screen pixels.
Mat2 screenMatrix(const ViewPose &view)
{
    return (turn(view.rotation) * flips(view.flipH, view.flipV)).scaled(1.0 / view.downsample);
}

// σ: a single flip reverses the sense of turns.
double turnSense(bool flipH, bool flipV)
{
    return flipH != flipV ? -1.0 : 1.0;
}

} // namespace

double normalizedDegrees(double degrees)
{
    double r = std::fmod(degrees, 360.0);
    if (r < 0)
        r += 360.0;
    return r >= 360.0 ? 0.0 : r; // fmod of a tiny negative number plus 360 can round to 360
}

double signedDegrees(double degrees)
{
    const double r = normalizedDegrees(degrees);
    return r > 180.0 ? r - 360.0 : r;
}

double physicalUnit(double mppX, double mppY)
{
    if (!(mppX > 0) || !(mppY > 0) || !std::isfinite(mppX) || !std::isfinite(mppY))
        return 0;
    return std::sqrt(mppX * mppY);
}

QPointF toGroup(const Placement &placement, QPointF slidePos)
{
    return placementMatrix(placement) * slidePos + placement.offset.translation;
}

QPointF fromGroup(const Placement &placement, QPointF groupPos)
{
    return placementMatrix(placement).inverted() * (groupPos - placement.offset.translation);
}

QPointF correspondingPoint(QPointF slidePos, const Placement &from, const Placement &to)
{
    return fromGroup(to, toGroup(from, slidePos));
}

GroupPose groupPoseOf(const ViewPose &view, const Placement &placement)
{
    const IrisViewOffset &o = placement.offset;
    GroupPose group;
    // F = F_g·M, and M is its own inverse: F_g = F·M.
    group.flipH = view.flipH != o.mirrored;
    group.flipV = view.flipV;
    group.rotation = normalizedDegrees(view.rotation - turnSense(group.flipH, group.flipV) * o.rotation);
    group.scale = view.downsample * o.scale * placement.unit;
    group.centre = toGroup(placement, view.centre);
    return group;
}

ViewPose viewPoseFor(const GroupPose &group, const Placement &placement)
{
    const IrisViewOffset &o = placement.offset;
    ViewPose view;
    view.flipH = group.flipH != o.mirrored;
    view.flipV = group.flipV;
    view.rotation = normalizedDegrees(group.rotation + turnSense(group.flipH, group.flipV) * o.rotation);
    view.downsample = group.scale / (o.scale * placement.unit);
    view.centre = fromGroup(placement, group.centre);
    return view;
}

IrisViewOffset offsetFor(const ViewPose &view, double unit, const GroupPose &group)
{
    IrisViewOffset o;
    // The view's flips are the group's times the mirror, up to a half turn (both flips).
    const bool viewOdd = view.flipH != view.flipV;
    const bool groupOdd = group.flipH != group.flipV;
    o.mirrored = viewOdd != groupOdd;
    const bool expectedH = group.flipH != o.mirrored;
    const bool expectedV = group.flipV;
    double rotation = view.rotation;
    if (view.flipH != expectedH || view.flipV != expectedV)
        rotation += 180.0; // Rot(r)·F = Rot(r + 180°)·(both flips)·F
    o.rotation = signedDegrees(turnSense(group.flipH, group.flipV) * (rotation - group.rotation));
    o.scale = group.scale / (view.downsample * unit);
    const Placement untranslated{unit, o};
    o.translation = group.centre - placementMatrix(untranslated) * view.centre;
    return o;
}

bool showSame(const ViewPose &a, const ViewPose &b, double pixels, double relative)
{
    const QPointF dc = a.centre - b.centre;
    if (std::hypot(dc.x(), dc.y()) > pixels)
        return false;
    const Mat2 ma = screenMatrix(a);
    const Mat2 mb = screenMatrix(b);
    const double norm = std::max({std::abs(ma.a), std::abs(ma.b), std::abs(ma.c), std::abs(ma.d)});
    const double tolerance = relative * norm;
    return std::abs(ma.a - mb.a) <= tolerance && std::abs(ma.b - mb.b) <= tolerance
        && std::abs(ma.c - mb.c) <= tolerance && std::abs(ma.d - mb.d) <= tolerance;
}

} // namespace IrisWidget::ViewGroupMath

// --- the group -----------------------------------------------------------------------------

using namespace IrisWidget::ViewGroupMath;

class IrisViewGroupPrivate {
    Q_DECLARE_PUBLIC(IrisViewGroup)
public:
    struct Member {
        IrisSlideView *key = nullptr; // compared only (destroyed() hands over a dying object)
        QPointer<IrisSlideView> view;
        IrisViewOffset offset;
        bool linked = true;
        // The pose the group last gave it: the view's report of it is not a move of its own.
        std::optional<ViewPose> given;
        // Opened while its surface was not shown: the widget fits the slide when it is first
        // shown, and that fit must not move the group.
        bool awaitingFit = false;
        bool crosshairShown = false; // by the group (a host's own cross-hair is left alone)
        QPointer<QWindow> surface; // watched for the pointer leaving
        QList<QMetaObject::Connection> connections;
    };

    explicit IrisViewGroupPrivate(IrisViewGroup *q) : q_ptr(q) {}

    Member *find(const IrisSlideView *view);
    const Member *find(const IrisSlideView *view) const;
    static bool showsSlide(const Member &m) { return m.view && m.view->hasSlide(); }
    IrisViewGroup::Units units() const;
    Placement placementOf(const Member &m) const;
    static ViewPose poseOf(const IrisSlideView *view);
    // The group's view as a linked member with a slide shows it (the one that moved last,
    // else the first), leaving out `excluding`; none when there is no such member.
    std::optional<GroupPose> groupPose(const Member *excluding) const;
    void give(Member &m, const GroupPose &pose);
    void giveAll(const GroupPose &pose, const Member *except);

    void onViewChanged(IrisSlideView *view);
    void onSlideOpened(IrisSlideView *view);
    void onCursorMoved(IrisSlideView *view, const QPointF &slidePos);
    void onPointerLeft(const QWindow *surface);
    void onTakenHold(const QWindow *surface);
    void updateCrosshairs();
    static void clearCrosshair(Member &m);
    void forget(const QObject *view);
    void detach(Member &m);

    IrisViewGroup *q_ptr;
    QList<Member> members;
    bool propagating = false; // giving a pose: the members' viewChanged() are ours
    bool crosshairs = true;
    QPointer<IrisSlideView> driver; // the member the group followed last
    // The pointer: the member it is over and where (logical pixels); null when over none.
    QPointer<IrisSlideView> hovered;
    QPointF hoveredPos;
};

IrisViewGroupPrivate::Member *IrisViewGroupPrivate::find(const IrisSlideView *view)
{
    for (Member &m : members) {
        if (m.key == view)
            return &m;
    }
    return nullptr;
}

const IrisViewGroupPrivate::Member *IrisViewGroupPrivate::find(const IrisSlideView *view) const
{
    return const_cast<IrisViewGroupPrivate *>(this)->find(view);
}

IrisViewGroup::Units IrisViewGroupPrivate::units() const
{
    for (const Member &m : members) {
        if (!m.linked || !showsSlide(m))
            continue;
        const IrisSlideInfo info = m.view->slideInfo();
        if (physicalUnit(info.mppX, info.mppY) == 0)
            return IrisViewGroup::Pixels;
    }
    return IrisViewGroup::Micrometres;
}

Placement IrisViewGroupPrivate::placementOf(const Member &m) const
{
    Placement placement;
    placement.offset = m.offset;
    if (units() == IrisViewGroup::Micrometres && showsSlide(m)) {
        const IrisSlideInfo info = m.view->slideInfo();
        placement.unit = physicalUnit(info.mppX, info.mppY);
    }
    return placement;
}

ViewPose IrisViewGroupPrivate::poseOf(const IrisSlideView *view)
{
    ViewPose pose;
    pose.centre = view->centre();
    pose.downsample = view->downsample() * view->devicePixelRatioF();
    pose.rotation = view->rotation();
    pose.flipH = view->isFlippedHorizontally();
    pose.flipV = view->isFlippedVertically();
    return pose;
}

std::optional<GroupPose> IrisViewGroupPrivate::groupPose(const Member *excluding) const
{
    const Member *source = nullptr;
    if (driver) {
        const Member *m = find(driver.data());
        if (m && m != excluding && m->linked && showsSlide(*m) && !m->awaitingFit)
            source = m;
    }
    for (const Member &m : members) {
        if (source)
            break;
        if (&m != excluding && m.linked && showsSlide(m) && !m.awaitingFit)
            source = &m;
    }
    if (!source)
        return std::nullopt;
    return groupPoseOf(poseOf(source->view), placementOf(*source));
}

void IrisViewGroupPrivate::give(Member &m, const GroupPose &pose)
{
    if (!m.linked || !showsSlide(m))
        return;
    const ViewPose target = viewPoseFor(pose, placementOf(m));
    if (!std::isfinite(target.centre.x()) || !std::isfinite(target.centre.y()) || !(target.downsample > 0)
        || !std::isfinite(target.downsample)) {
        return;
    }
    m.given = target;
    IrisSlideView *view = m.view;
    if (showSame(poseOf(view), target))
        return;
    const QScopedValueRollback<bool> guard(propagating, true);
    view->setView(target.centre, target.downsample / view->devicePixelRatioF(), target.rotation, target.flipH,
                  target.flipV);
}

void IrisViewGroupPrivate::giveAll(const GroupPose &pose, const Member *except)
{
    // By index: giving a pose runs the members' signal handlers, which never add or remove
    // members, but a reference must not outlive a change of the list either way.
    for (qsizetype i = 0; i < members.size(); ++i) {
        if (&members[i] != except)
            give(members[i], pose);
    }
}

void IrisViewGroupPrivate::onViewChanged(IrisSlideView *view)
{
    if (propagating)
        return;
    Member *m = find(view);
    if (!m || !m->view || !m->linked || !showsSlide(*m)) {
        if (m && m->view == hovered)
            updateCrosshairs();
        return;
    }
    const ViewPose now = poseOf(view);
    if (m->given && showSame(now, *m->given))
        return; // the pose the group gave it, reported later
    m->given.reset();
    if (m->awaitingFit) {
        // The widget's fit on first showing: the view takes the group's pose instead.
        m->awaitingFit = false;
        if (const std::optional<GroupPose> pose = groupPose(m)) {
            give(*m, *pose);
            updateCrosshairs();
            return;
        }
    }
    driver = view;
    giveAll(groupPoseOf(now, placementOf(*m)), m);
    updateCrosshairs();
}

void IrisViewGroupPrivate::onSlideOpened(IrisSlideView *view)
{
    Member *m = find(view);
    if (!m || !m->linked)
        return;
    m->given.reset();
    const QWindow *surface = view->surfaceWindow();
    m->awaitingFit = !surface || !surface->isExposed();
    // The new slide may change the group's units: every other member takes the pose again.
    if (const std::optional<GroupPose> pose = groupPose(m)) {
        giveAll(*pose, nullptr);
    }
    updateCrosshairs();
}

void IrisViewGroupPrivate::onCursorMoved(IrisSlideView *view, const QPointF &slidePos)
{
    const Member *m = find(view);
    if (!m || !m->view)
        return;
    hovered = view;
    hoveredPos = view->mapFromSlide(slidePos);
    updateCrosshairs();
}

void IrisViewGroupPrivate::onPointerLeft(const QWindow *surface)
{
    for (const Member &m : std::as_const(members)) {
        if (m.surface == surface && m.view == hovered) {
            hovered.clear();
            updateCrosshairs();
            return;
        }
    }
}

void IrisViewGroupPrivate::onTakenHold(const QWindow *surface)
{
    // The user takes hold of one view (press, wheel, gesture, key) while another may still be
    // gliding or animating a zoom or turn: that one's next step would be given to this view
    // and end its drag or animation (a setter stops the view's own motion). So the others'
    // motion ends first. setCentre() to where it is stops a view's motion and changes nothing.
    const Member *held = nullptr;
    for (const Member &m : std::as_const(members)) {
        if (m.surface == surface)
            held = &m;
    }
    if (!held || !held->linked)
        return;
    const QScopedValueRollback<bool> guard(propagating, true);
    for (const Member &m : std::as_const(members)) {
        if (&m != held && m.linked && showsSlide(m))
            m.view->stopMotion();
    }
}

void IrisViewGroupPrivate::updateCrosshairs()
{
    const Member *source = hovered ? find(hovered.data()) : nullptr;
    const bool show = crosshairs && source && source->linked && showsSlide(*source);
    const QPointF slidePos = show ? hovered->mapToSlide(hoveredPos) : QPointF();
    const Placement from = show ? placementOf(*source) : Placement();
    for (Member &m : members) {
        if (!m.view)
            continue;
        if (show && &m != source && m.linked && showsSlide(m)) {
            const QPointF there = correspondingPoint(slidePos, from, placementOf(m));
            if (std::isfinite(there.x()) && std::isfinite(there.y())) {
                m.view->setCrosshair(there);
                m.crosshairShown = true;
                continue;
            }
        }
        clearCrosshair(m);
    }
}

void IrisViewGroupPrivate::clearCrosshair(Member &m)
{
    if (m.crosshairShown && m.view)
        m.view->clearCrosshair();
    m.crosshairShown = false;
}

void IrisViewGroupPrivate::detach(Member &m)
{
    for (const QMetaObject::Connection &c : std::as_const(m.connections))
        QObject::disconnect(c);
    m.connections.clear();
    if (m.surface)
        m.surface->removeEventFilter(q_ptr);
}

void IrisViewGroupPrivate::forget(const QObject *view)
{
    Q_Q(IrisViewGroup);
    for (qsizetype i = 0; i < members.size(); ++i) {
        if (static_cast<const QObject *>(members[i].key) != view)
            continue;
        IrisSlideView *key = members[i].key;
        detach(members[i]);
        members.removeAt(i);
        Q_EMIT q->viewRemoved(key); // a pointer to compare with only: the view is being destroyed
        return;
    }
}

// --- IrisViewGroup ---------------------------------------------------------------------------

IrisViewGroup::IrisViewGroup(QObject *parent)
    : QObject(parent)
    , d_ptr(new IrisViewGroupPrivate(this))
{
}

IrisViewGroup::~IrisViewGroup()
{
    Q_D(IrisViewGroup);
    for (IrisViewGroupPrivate::Member &m : d->members) {
        d->detach(m);
        d->clearCrosshair(m);
    }
}

void IrisViewGroup::addView(IrisSlideView *view, bool linked)
{
    Q_D(IrisViewGroup);
    if (!view || d->find(view))
        return;
    IrisViewGroupPrivate::Member m;
    m.key = view;
    m.view = view;
    m.linked = linked;
    m.surface = view->surfaceWindow();
    m.connections << connect(view, &IrisSlideView::viewChanged, this, [d, view] { d->onViewChanged(view); })
                  << connect(view, &IrisSlideView::slideOpened, this, [d, view] { d->onSlideOpened(view); })
                  << connect(view, &IrisSlideView::slideClosed, this, [d] { d->updateCrosshairs(); })
                  << connect(view, &IrisSlideView::cursorMoved, this,
                             [d, view](const QPointF &slidePos) { d->onCursorMoved(view, slidePos); })
                  << connect(view, &QObject::destroyed, this, [d](QObject *object) { d->forget(object); });
    if (m.surface)
        m.surface->installEventFilter(this);
    d->members.append(m);
    IrisViewGroupPrivate::Member &added = d->members.last();
    if (linked && IrisViewGroupPrivate::showsSlide(added)) {
        const QWindow *surface = view->surfaceWindow();
        added.awaitingFit = !surface || !surface->isExposed();
        if (const std::optional<GroupPose> pose = d->groupPose(&added))
            d->giveAll(*pose, nullptr); // the new member, and the others should the units change
    }
    d->updateCrosshairs();
    Q_EMIT viewAdded(view);
}

void IrisViewGroup::removeView(IrisSlideView *view)
{
    Q_D(IrisViewGroup);
    IrisViewGroupPrivate::Member *m = d->find(view);
    if (!m)
        return;
    d->detach(*m);
    d->clearCrosshair(*m);
    d->members.removeAt(m - d->members.data());
    if (d->hovered == view)
        d->hovered.clear();
    d->updateCrosshairs();
    Q_EMIT viewRemoved(view);
}

bool IrisViewGroup::contains(const IrisSlideView *view) const
{
    Q_D(const IrisViewGroup);
    return d->find(view) != nullptr;
}

QList<IrisSlideView *> IrisViewGroup::views() const
{
    Q_D(const IrisViewGroup);
    QList<IrisSlideView *> list;
    for (const IrisViewGroupPrivate::Member &m : d->members) {
        if (m.view)
            list << m.view.data();
    }
    return list;
}

bool IrisViewGroup::isLinked(const IrisSlideView *view) const
{
    Q_D(const IrisViewGroup);
    const IrisViewGroupPrivate::Member *m = d->find(view);
    return m && m->linked;
}

void IrisViewGroup::setLinked(IrisSlideView *view, bool linked)
{
    Q_D(IrisViewGroup);
    IrisViewGroupPrivate::Member *m = d->find(view);
    if (!m || m->linked == linked)
        return;
    m->given.reset();
    m->awaitingFit = false;
    // Linked now, so that its unit is the one the group will use with it.
    m->linked = linked;
    bool captured = false;
    if (linked && IrisViewGroupPrivate::showsSlide(*m)) {
        if (const std::optional<GroupPose> pose = d->groupPose(m)) {
            m->offset = offsetFor(IrisViewGroupPrivate::poseOf(view), d->placementOf(*m).unit, *pose);
            captured = true;
        }
    }
    // The group's units may have changed with it (a slide without mpp): every linked member
    // takes the group's view again (no change where they did not).
    if (const std::optional<GroupPose> pose = d->groupPose(linked ? m : nullptr))
        d->giveAll(*pose, nullptr);
    d->updateCrosshairs();
    Q_EMIT linkedChanged(view, linked);
    if (captured)
        Q_EMIT offsetChanged(view);
}

IrisViewOffset IrisViewGroup::offset(const IrisSlideView *view) const
{
    Q_D(const IrisViewGroup);
    const IrisViewGroupPrivate::Member *m = d->find(view);
    return m ? m->offset : IrisViewOffset();
}

void IrisViewGroup::setOffset(IrisSlideView *view, const IrisViewOffset &offset)
{
    Q_D(IrisViewGroup);
    IrisViewGroupPrivate::Member *m = d->find(view);
    if (!m || !(offset.scale > 0) || !std::isfinite(offset.scale) || !std::isfinite(offset.rotation)
        || !std::isfinite(offset.translation.x()) || !std::isfinite(offset.translation.y())) {
        return;
    }
    if (m->offset == offset)
        return;
    m->offset = offset;
    if (m->linked) {
        if (const std::optional<GroupPose> pose = d->groupPose(m))
            d->give(*m, *pose);
    }
    d->updateCrosshairs();
    Q_EMIT offsetChanged(view);
}

void IrisViewGroup::setOffset(IrisSlideView *view, const QPointF &translation, double rotation, double scale)
{
    setOffset(view, IrisViewOffset{translation, rotation, scale, false});
}

IrisViewGroup::Units IrisViewGroup::units() const
{
    Q_D(const IrisViewGroup);
    return d->units();
}

bool IrisViewGroup::crosshairsEnabled() const
{
    Q_D(const IrisViewGroup);
    return d->crosshairs;
}

void IrisViewGroup::setCrosshairsEnabled(bool on)
{
    Q_D(IrisViewGroup);
    if (d->crosshairs == on)
        return;
    d->crosshairs = on;
    d->updateCrosshairs();
    Q_EMIT crosshairsEnabledChanged(on);
}

bool IrisViewGroup::eventFilter(QObject *watched, QEvent *event)
{
    Q_D(IrisViewGroup);
    switch (event->type()) {
    case QEvent::Leave:
        d->onPointerLeft(qobject_cast<QWindow *>(watched));
        break;
    case QEvent::MouseButtonPress:
    case QEvent::MouseButtonDblClick:
    case QEvent::Wheel:
    case QEvent::NativeGesture:
    case QEvent::TouchBegin:
    case QEvent::KeyPress:
        d->onTakenHold(qobject_cast<QWindow *>(watched));
        break;
    default:
        break;
    }
    return QObject::eventFilter(watched, event);
}
