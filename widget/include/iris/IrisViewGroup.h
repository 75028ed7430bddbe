// Iris View widget — IrisViewGroup, linked views: moving, zooming, turning or flipping one
// IrisSlideView moves the others, like slides on a double-headed microscope.
//
// The group places every member's slide in one shared frame, the group frame, by the
// member's offset (IrisViewOffset):
//
//     g = scale · Rot(rotation) · Mirror · (unit · p) + translation
//
// where p is a level-0 pixel of the member's slide, unit is the slide's µm per pixel while
// the group matches physical size (every linked slide states its mpp; pixels are drawn
// square, so unit = √(mppX · mppY)) and 1 otherwise (the group then matches downsample), and
// Mirror swaps left and right when the offset is mirrored. Rotation is degrees clockwise as
// seen on screen. The group frame is in µm, or level-0 pixels when a linked slide states no
// mpp; the identity offset (the default) lays every slide's origin on the others'.
//
// A linked member shows the group's view: the same group point at its centre, the same
// group units per logical pixel, the same turn and flips, each mapped through its own offset
// (a member with offset rotation 30° is shown turned 30° further clockwise; with scale 2 it is
// magnified twice as much). A change of any linked member's view (a drag, a glide step, an
// animated zoom step, a turn, a flip, a setter) is carried to the other linked members once:
// their own resulting viewChanged() is not carried back. Taking hold of a linked member (a
// press, wheel, gesture or key on it) ends the others' glides and animations first, so that
// their next step does not end the new drag.
//
// Unlinking a member (setLinked(view, false)) lets it be moved alone, to align it by hand;
// relinking it keeps the alignment: its offset becomes whatever makes its present view the
// group's view. setOffset() places a member directly (a registration result, for example).
//
// While the pointer is over a linked member, the other linked members show a cross-hair
// (IrisSlideView::setCrosshair) at the corresponding point of their slide; it goes when the
// pointer leaves. Views that are destroyed leave the group by themselves; the group holds
// no ownership of its views.
#pragma once

#include <QtCore/QList>
#include <QtCore/QObject>
#include <QtCore/QPointF>
#include <QtCore/QScopedPointer>

#include "iris/IrisWidgetGlobal.h"

class IrisSlideView;
class IrisViewGroupPrivate;

// Where a member's slide lies in the group frame (see IrisViewGroup.h's header comment).
struct IRIS_WIDGET_EXPORT IrisViewOffset {
    QPointF translation;   // group units: µm while the group matches physical size, else level-0 pixels
    double rotation = 0;   // degrees clockwise, (−180, 180] when the group computes it
    double scale = 1;      // > 0; 2 shows the member's slide twice as large as the group's view
    bool mirrored = false; // left and right swapped before the turn

    friend bool operator==(const IrisViewOffset &a, const IrisViewOffset &b)
    {
        return a.translation == b.translation && a.rotation == b.rotation && a.scale == b.scale
            && a.mirrored == b.mirrored;
    }
    friend bool operator!=(const IrisViewOffset &a, const IrisViewOffset &b) { return !(a == b); }
};

class IRIS_WIDGET_EXPORT IrisViewGroup : public QObject {
    Q_OBJECT
    Q_PROPERTY(bool crosshairsEnabled READ crosshairsEnabled WRITE setCrosshairsEnabled NOTIFY crosshairsEnabledChanged)

public:
    // What the group frame's units are: µm when every linked slide states its mpp, else
    // level-0 pixels (see the header comment).
    enum Units { Micrometres, Pixels };
    Q_ENUM(Units)

    explicit IrisViewGroup(QObject *parent = nullptr);
    ~IrisViewGroup() override;

    // Adds a view (once; adding it again changes nothing) with the identity offset. Linked, it
    // takes the group's present view at once (when another linked member shows a slide).
    void addView(IrisSlideView *view, bool linked = true);
    // Takes the view out (its cross-hair cleared); the view keeps its present view.
    void removeView(IrisSlideView *view);
    bool contains(const IrisSlideView *view) const;
    QList<IrisSlideView *> views() const; // in the order they were added

    bool isLinked(const IrisSlideView *view) const;
    // Unlinked, the view moves alone and shows no cross-hair. Relinked, it keeps its present
    // view and its offset becomes the one that makes that the group's view (when another
    // linked member shows a slide; otherwise the offset is kept).
    void setLinked(IrisSlideView *view, bool linked);

    // The identity offset for views not in the group.
    IrisViewOffset offset(const IrisSlideView *view) const;
    // Places the view's slide in the group frame; a linked view moves to the group's view
    // through the new offset at once. A scale that is not a positive number is ignored.
    void setOffset(IrisSlideView *view, const IrisViewOffset &offset);
    void setOffset(IrisSlideView *view, const QPointF &translation, double rotation, double scale = 1);

    Units units() const;

    // The cross-hair in the other linked views while the pointer is over one (on by default).
    bool crosshairsEnabled() const;
    void setCrosshairsEnabled(bool on);

Q_SIGNALS:
    void viewAdded(IrisSlideView *view);
    void viewRemoved(IrisSlideView *view);
    void linkedChanged(IrisSlideView *view, bool linked);
    // The offset changed (setOffset, or captured when the view was relinked).
    void offsetChanged(IrisSlideView *view);
    void crosshairsEnabledChanged(bool on);

protected:
    // Watches each member's surface window for the pointer leaving it, and for input that
    // takes hold of it (the others' glides and animations then end).
    bool eventFilter(QObject *watched, QEvent *event) override;

private:
    Q_DECLARE_PRIVATE(IrisViewGroup)
    Q_DISABLE_COPY_MOVE(IrisViewGroup)
    QScopedPointer<IrisViewGroupPrivate> d_ptr;
};
