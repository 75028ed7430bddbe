#include "navigator_p.h"

#include <cmath>

#include <QtCore/QLineF>
#include <QtGui/QKeyEvent>
#include <QtGui/QMouseEvent>
#include <QtGui/QWheelEvent>

namespace IrisWidget {

ViewNavigator::ViewNavigator(NavigationTarget *target, QObject *parent)
    : QObject(parent)
    , m_target(target)
    , m_kinetic([target](QPointF delta) { target->pan(delta); })
    , m_zoom([target](double factor, QPointF anchor) { target->zoom(factor, anchor); },
             [target](double degrees, QPointF anchor) { target->rotate(degrees, anchor); })
{
}

void ViewNavigator::setKineticEnabled(bool on)
{
    m_kineticEnabled = on;
    if (!on)
        m_kinetic.stop();
}

void ViewNavigator::stopMotion()
{
    m_kinetic.stop();
    m_zoom.cancel();
    m_turning = false;
    setDragging(false);
}

namespace {
// The pointer's angle about the view's centre, degrees clockwise on screen (y points down).
double angleAbout(QPointF pos, QPointF centre)
{
    return std::atan2(pos.y() - centre.y(), pos.x() - centre.x()) * (180.0 / 3.14159265358979323846);
}
} // namespace

void ViewNavigator::setDragging(bool dragging)
{
    if (m_dragging == dragging)
        return;
    m_dragging = dragging;
    Q_EMIT draggingChanged(dragging);
}

bool ViewNavigator::mousePress(const QMouseEvent *event)
{
    if (event->button() != Qt::LeftButton || !m_target->canNavigate())
        return false;
    m_kinetic.reset();
    m_zoom.finish();
    m_lastPos = event->position();
    if (event->modifiers() & Qt::ControlModifier) {
        m_turning = true;
        m_lastAngle = angleAbout(m_lastPos, m_target->viewportCentre());
        return true;
    }
    m_kinetic.track(m_lastPos, event->timestamp());
    setDragging(true);
    return true;
}

bool ViewNavigator::mouseMove(const QMouseEvent *event)
{
    if (m_turning) {
        if (!(event->buttons() & Qt::LeftButton)) {
            m_turning = false;
            return false;
        }
        const QPointF centre = m_target->viewportCentre();
        // Near the centre the angle is noise: wait for the pointer to move out.
        if (QLineF(event->position(), centre).length() < 8)
            return true;
        const double angle = angleAbout(event->position(), centre);
        double delta = angle - m_lastAngle;
        if (delta > 180)
            delta -= 360;
        else if (delta < -180)
            delta += 360;
        m_lastAngle = angle;
        if (delta != 0)
            m_target->rotate(delta, centre);
        return true;
    }
    if (!m_dragging)
        return false;
    if (!(event->buttons() & Qt::LeftButton)) { // the release went elsewhere
        setDragging(false);
        return false;
    }
    const QPointF pos = event->position();
    const QPointF delta = pos - m_lastPos;
    m_lastPos = pos;
    m_kinetic.track(pos, event->timestamp());
    if (!delta.isNull())
        m_target->pan(delta);
    return true;
}

bool ViewNavigator::mouseRelease(const QMouseEvent *event)
{
    if (event->button() == Qt::LeftButton && m_turning) {
        m_turning = false;
        return true;
    }
    if (event->button() != Qt::LeftButton || !m_dragging)
        return false;
    const QPointF delta = event->position() - m_lastPos;
    if (!delta.isNull()) {
        m_kinetic.track(event->position(), event->timestamp());
        m_target->pan(delta);
    }
    setDragging(false);
    if (m_kineticEnabled)
        m_kinetic.release(event->timestamp());
    else
        m_kinetic.reset();
    return true;
}

bool ViewNavigator::mouseDoubleClick(const QMouseEvent *event)
{
    if (event->button() != Qt::LeftButton || !m_target->canNavigate())
        return false;
    m_kinetic.stop();
    const double factor = (event->modifiers() & Qt::ShiftModifier) ? 1 / kDoubleClickFactor : kDoubleClickFactor;
    m_zoom.zoomBy(factor, event->position());
    return true;
}

bool ViewNavigator::wheel(const QWheelEvent *event)
{
    if (!m_target->canNavigate())
        return false;
    m_kinetic.stop();
    if (event->modifiers() & Qt::ShiftModifier) {
        // Shift+wheel turns (X11 and Windows report Shift+wheel as a vertical delta; macOS
        // as a horizontal one).
        const QPoint angle = event->angleDelta();
        const int eighths = angle.y() != 0 ? angle.y() : angle.x();
        if (eighths != 0)
            m_zoom.rotateBy(eighths / 120.0 * kWheelNotchDegrees, event->position());
        return true;
    }
    const QPoint pixels = event->pixelDelta();
    if (!pixels.isNull() && event->phase() != Qt::NoScrollPhase) {
        // A trackpad: its deltas arrive in a smooth stream already; follow them directly.
        const double steps = pixels.y() != 0 ? pixels.y() : pixels.x();
        m_zoom.finish();
        m_target->zoom(std::exp2(steps / kPixelsPerDoubling), event->position());
        return true;
    }
    const QPoint angle = event->angleDelta();
    const int eighths = angle.y() != 0 ? angle.y() : angle.x();
    if (eighths == 0)
        return true;
    const double notches = eighths / 120.0;
    m_zoom.zoomBy(std::pow(kWheelNotchFactor, notches), event->position());
    return true;
}

bool ViewNavigator::nativeGesture(const QNativeGestureEvent *event)
{
    if (!m_target->canNavigate())
        return false;
    switch (event->gestureType()) {
    case Qt::BeginNativeGesture:
        m_kinetic.stop();
        m_zoom.finish();
        return true;
    case Qt::ZoomNativeGesture:
        // value() is the change of scale since the previous event of the pinch.
        if (event->value() > -1)
            m_target->zoom(1 + event->value(), event->position());
        return true;
    case Qt::RotateNativeGesture:
        // value() is the change of angle since the previous event, degrees anticlockwise
        // (QNativeGestureEvent); the slide turns with the fingers.
        m_target->rotate(-event->value(), event->position());
        return true;
    case Qt::SmartZoomNativeGesture:
        m_zoom.zoomBy(kDoubleClickFactor, event->position());
        return true;
    case Qt::EndNativeGesture:
        return true;
    default:
        return false;
    }
}

bool ViewNavigator::keyPress(const QKeyEvent *event)
{
    if (!m_target->canNavigate())
        return false;
    // Leave chords to shortcuts; Shift and Keypad are part of typing + and digits.
    if (event->modifiers() & (Qt::ControlModifier | Qt::AltModifier | Qt::MetaModifier))
        return false;
    const bool shift = event->modifiers() & Qt::ShiftModifier;
    const auto zoomAboutCentre = [this](double factor) {
        m_kinetic.stop();
        m_zoom.zoomBy(factor, m_target->viewportCentre());
    };
    const auto panFields = [this](int x, int y) {
        m_kinetic.stop();
        m_zoom.finish();
        m_target->panFields(x, y);
    };
    switch (event->key()) {
    case Qt::Key_Left:
        panFields(-1, 0);
        return true;
    case Qt::Key_Right:
        panFields(1, 0);
        return true;
    case Qt::Key_Up:
        panFields(0, -1);
        return true;
    case Qt::Key_Down:
        panFields(0, 1);
        return true;
    case Qt::Key_Plus:
    case Qt::Key_Equal:
        zoomAboutCentre(kKeyZoomFactor);
        return true;
    case Qt::Key_Minus:
    case Qt::Key_Underscore:
        zoomAboutCentre(1 / kKeyZoomFactor);
        return true;
    case Qt::Key_Home:
        if (shift) {
            stopMotion();
            m_target->resetOrientation();
            return true;
        }
        [[fallthrough]];
    case Qt::Key_0:
        stopMotion();
        m_target->fit();
        return true;
    case Qt::Key_R:
        m_kinetic.stop();
        m_zoom.rotateBy(shift ? -kKeyTurnDegrees : kKeyTurnDegrees, m_target->viewportCentre());
        return true;
    case Qt::Key_F:
        stopMotion();
        m_target->flip();
        return true;
    case Qt::Key_1:
    case Qt::Key_2:
    case Qt::Key_3:
    case Qt::Key_4:
        stopMotion();
        m_target->showMagnificationPreset(event->key() - Qt::Key_1);
        return true;
    default:
        return false;
    }
}

} // namespace IrisWidget
