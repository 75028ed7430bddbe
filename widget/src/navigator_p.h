// Iris View widget — not API. Turns input events into view changes.
//
//   left drag        pans; the image point under the pointer stays under it
//   drag release     with speed, glides on and decelerates (KineticPanner)
//   Ctrl+left drag   turns the slide about the view's centre, following the pointer's angle
//   wheel            zooms about the pointer, animated (ZoomAnimator); trackpad pixel
//                    deltas and pinch gestures zoom at once, following the fingers
//   Shift+wheel      turns the slide about the pointer, 15° a notch, animated; a trackpad's
//                    rotate gesture turns it at once, following the fingers
//   double click     zooms 2× about the pointer (Shift: 0.5×)
//   arrows           move exactly one field (one target width or height)
//   + / −            zoom 2× / 0.5× about the centre; 0 or Home fits; 1–4: 5×, 10×, 20×, 40×
//   R / Shift+R      turn 90° clockwise / anticlockwise about the centre, animated
//   F                mirrors the image left-right; Shift+Home: rotation 0 and no mirroring
//
// Positions are logical widget pixels; the target converts them to device pixels.
#pragma once

#include <QtCore/QObject>
#include <QtCore/QPointF>

#include "autotest_p.h"
#include "kineticpanner_p.h"
#include "zoomanimator_p.h"

QT_BEGIN_NAMESPACE
class QKeyEvent;
class QMouseEvent;
class QNativeGestureEvent;
class QWheelEvent;
QT_END_NAMESPACE

namespace IrisWidget {

// What the navigator drives (IrisSlideViewPrivate in the widget, a recorder in tests).
class NavigationTarget {
public:
    virtual ~NavigationTarget() = default;
    virtual bool canNavigate() const = 0;                 // a slide is open
    virtual void pan(QPointF logicalDelta) = 0;           // the image moves by this much
    virtual void panFields(int fieldsX, int fieldsY) = 0; // (1, 0) shows the next field to the right
    virtual void zoom(double factor, QPointF logicalAnchor) = 0;
    virtual void rotate(double degrees, QPointF logicalAnchor) = 0; // clockwise on screen
    virtual void flip() = 0;                                        // mirror left-right on screen
    virtual void resetOrientation() = 0;                            // rotation 0, no flips
    virtual QPointF viewportCentre() const = 0;           // logical pixels
    virtual void fit() = 0;
    virtual void showMagnificationPreset(int index) = 0;  // index into kMagnificationPresets
};

class IRIS_WIDGET_AUTOTEST_EXPORT ViewNavigator : public QObject {
    Q_OBJECT
public:
    explicit ViewNavigator(NavigationTarget *target, QObject *parent = nullptr);

    // Each returns whether it used the event.
    bool mousePress(const QMouseEvent *event);
    bool mouseMove(const QMouseEvent *event);
    bool mouseRelease(const QMouseEvent *event);
    bool mouseDoubleClick(const QMouseEvent *event);
    bool wheel(const QWheelEvent *event);
    bool keyPress(const QKeyEvent *event);
    bool nativeGesture(const QNativeGestureEvent *event);

    // Ends any glide and drops any zoom still animating (before fit, open, close, …).
    void stopMotion();
    bool isMoving() const { return m_kinetic.isActive() || m_zoom.isActive(); }
    bool isDragging() const { return m_dragging || m_turning; }

    void setKineticEnabled(bool on);
    bool kineticEnabled() const { return m_kineticEnabled; }
    ZoomAnimator &zoomAnimator() { return m_zoom; }
    KineticPanner &kineticPanner() { return m_kinetic; }

    static constexpr double kWheelNotchFactor = 1.2599210498948732; // 2^(1/3): three notches double
    static constexpr double kPixelsPerDoubling = 300;                // trackpad pixel deltas
    static constexpr double kKeyZoomFactor = 2;
    static constexpr double kDoubleClickFactor = 2;
    static constexpr double kWheelNotchDegrees = 15;
    static constexpr double kKeyTurnDegrees = 90;

Q_SIGNALS:
    void draggingChanged(bool dragging);

private:
    void setDragging(bool dragging);

    NavigationTarget *m_target;
    KineticPanner m_kinetic;
    ZoomAnimator m_zoom;
    QPointF m_lastPos;
    bool m_dragging = false;
    bool m_turning = false; // a Ctrl+drag turns: m_lastAngle is the pointer's about the centre
    double m_lastAngle = 0;
    bool m_kineticEnabled = true;
};

} // namespace IrisWidget
