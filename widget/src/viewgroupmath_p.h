// Iris View widget — not API. IrisViewGroup's pose maths: pure functions of numbers, no
// views, so that the tests check them without a window.
//
// Frames (y points down, angles are clockwise on screen):
//   * a member's slide: level-0 pixels p;
//   * the group frame: g = A·p + t, with A = k·u·Rot(θ)·M, where (t, θ, k, M) is the member's
//     offset (M swaps left and right when it is mirrored) and u its unit (µm per pixel when
//     the group matches physical size, else 1);
//   * a view about its centre c: screen = (1/d)·Rot(r)·F·(p − c), in logical pixels, with d
//     the level-0 pixels per logical pixel and F its flips (applied before the turn:
//     IrisSlideView's contract);
//   * the group's view, the same in the group frame: screen = (1/s)·Rot(R)·F_g·(g − G).
//
// A member shows the group's view when both agree for every p:
//     (1/d)·Rot(r)·F = (1/s)·Rot(R)·F_g·A   and   c = A⁻¹·(G − t).
// A flip reverses turns (F_g·Rot(θ) = Rot(σ·θ)·F_g, σ = det F_g = −1 for exactly one flip), so
//     r = R + σ·θ,   F = F_g·M,   d = s / (k·u).
// Two flips are a half turn; poses are compared by what they show (the matrix), not by
// their fields.
#pragma once

#include <QtCore/QPointF>

#include "autotest_p.h"
#include "iris/IrisViewGroup.h"

namespace IrisWidget::ViewGroupMath {

// What a view shows: IrisSlideView's centre(), rotation() and flips, and its downsample()
// × device pixel ratio (level-0 pixels per logical pixel).
struct ViewPose {
    QPointF centre;
    double downsample = 1;
    double rotation = 0;
    bool flipH = false;
    bool flipV = false;
};

// The group's view in the group frame: scale is group units per logical pixel.
struct GroupPose {
    QPointF centre;
    double scale = 1;
    double rotation = 0;
    bool flipH = false;
    bool flipV = false;
};

// A member's slide in the group frame: its unit (see above) and offset.
struct Placement {
    double unit = 1;
    IrisViewOffset offset;
};

// Degrees into [0, 360), and into (−180, 180].
IRIS_WIDGET_AUTOTEST_EXPORT double normalizedDegrees(double degrees);
IRIS_WIDGET_AUTOTEST_EXPORT double signedDegrees(double degrees);

// µm per level-0 pixel of a slide, √(mppX·mppY); 0 when it does not state both.
IRIS_WIDGET_AUTOTEST_EXPORT double physicalUnit(double mppX, double mppY);

// A slide point to the group frame and back.
IRIS_WIDGET_AUTOTEST_EXPORT QPointF toGroup(const Placement &placement, QPointF slidePos);
IRIS_WIDGET_AUTOTEST_EXPORT QPointF fromGroup(const Placement &placement, QPointF groupPos);
// The point of the `to` slide that lies where slidePos of the `from` slide lies.
IRIS_WIDGET_AUTOTEST_EXPORT QPointF correspondingPoint(QPointF slidePos, const Placement &from, const Placement &to);

// The group's view that a member's view shows, and the member's view that shows a group's view.
IRIS_WIDGET_AUTOTEST_EXPORT GroupPose groupPoseOf(const ViewPose &view, const Placement &placement);
IRIS_WIDGET_AUTOTEST_EXPORT ViewPose viewPoseFor(const GroupPose &group, const Placement &placement);

// The offset under which `view` (of a slide of this unit) shows `group` as it is: what
// relinking captures. Its rotation is in (−180, 180]; mirrored when exactly one of the two
// is flipped an odd number of times relative to the other.
IRIS_WIDGET_AUTOTEST_EXPORT IrisViewOffset offsetFor(const ViewPose &view, double unit, const GroupPose &group);

// Whether two views show the same thing: centres within `pixels` level-0 pixels, and the
// linear parts (turn, flips, downsample) equal within a relative `relative`. A turn of 180°
// with both flips shows the same as neither.
IRIS_WIDGET_AUTOTEST_EXPORT bool showSame(const ViewPose &a, const ViewPose &b, double pixels = 1e-6,
                                          double relative = 1e-9);

} // namespace IrisWidget::ViewGroupMath
