#include "eventforwarding_p.h"

#include <QtCore/QCoreApplication>
#include <QtGui/QContextMenuEvent>
#include <QtGui/QDropEvent>
#include <QtGui/QKeyEvent>
#include <QtGui/QMouseEvent>
#include <QtGui/QWheelEvent>
#include <QtWidgets/QWidget>

namespace IrisWidget {

namespace {

template <class E>
bool deliver(E &copy, const QEvent *original, QWidget *target)
{
    copy.setTimestamp(static_cast<const QInputEvent *>(original)->timestamp());
    copy.setAccepted(false);
    QCoreApplication::sendEvent(target, &copy);
    return copy.isAccepted();
}

} // namespace

bool forwardInputEvent(QEvent *event, QWidget *container, QWidget *target)
{
    const auto toTarget = [&](const QPointF &windowPos) { return container->mapTo(target, windowPos); };

    switch (event->type()) {
    case QEvent::MouseButtonPress:
    case QEvent::MouseButtonRelease:
    case QEvent::MouseButtonDblClick:
    case QEvent::MouseMove: {
        const auto *e = static_cast<QMouseEvent *>(event);
        QMouseEvent copy(e->type(), toTarget(e->position()), e->scenePosition(), e->globalPosition(),
                         e->button(), e->buttons(), e->modifiers(), e->pointingDevice());
        return deliver(copy, event, target);
    }
    case QEvent::Wheel: {
        const auto *e = static_cast<QWheelEvent *>(event);
        QWheelEvent copy(toTarget(e->position()), e->globalPosition(), e->pixelDelta(), e->angleDelta(),
                         e->buttons(), e->modifiers(), e->phase(), e->inverted(), e->source(),
                         e->pointingDevice());
        return deliver(copy, event, target);
    }
    case QEvent::NativeGesture: {
        const auto *e = static_cast<QNativeGestureEvent *>(event);
        QNativeGestureEvent copy(e->gestureType(), e->pointingDevice(), e->fingerCount(),
                                 toTarget(e->position()), e->scenePosition(), e->globalPosition(),
                                 e->value(), e->delta());
        return deliver(copy, event, target);
    }
    case QEvent::ContextMenu: {
        const auto *e = static_cast<QContextMenuEvent *>(event);
        QContextMenuEvent copy(e->reason(), container->mapTo(target, e->pos()), e->globalPos(), e->modifiers());
        return deliver(copy, event, target);
    }
    case QEvent::DragEnter:
    case QEvent::DragMove:
    case QEvent::Drop: {
        // Drops over the slide reach the widget and, unless it takes them, its parents
        // (a main window that opens dropped files).
        auto *e = static_cast<QDropEvent *>(event);
        const QPoint pos = container->mapTo(target, e->position().toPoint());
        const auto answer = [e](const QDropEvent &copy) {
            e->setDropAction(copy.dropAction());
            e->setAccepted(copy.isAccepted());
            return copy.isAccepted();
        };
        if (event->type() == QEvent::Drop) {
            QDropEvent copy(pos, e->possibleActions(), e->mimeData(), e->buttons(), e->modifiers());
            copy.setAccepted(false);
            QCoreApplication::sendEvent(target, &copy);
            return answer(copy);
        }
        if (event->type() == QEvent::DragEnter) {
            QDragEnterEvent copy(pos, e->possibleActions(), e->mimeData(), e->buttons(), e->modifiers());
            copy.setAccepted(false);
            QCoreApplication::sendEvent(target, &copy);
            return answer(copy);
        }
        QDragMoveEvent copy(pos, e->possibleActions(), e->mimeData(), e->buttons(), e->modifiers());
        copy.setAccepted(false);
        QCoreApplication::sendEvent(target, &copy);
        return answer(copy);
    }
    case QEvent::DragLeave: {
        QDragLeaveEvent copy;
        QCoreApplication::sendEvent(target, &copy);
        return true;
    }
    case QEvent::KeyPress:
    case QEvent::KeyRelease: {
        // Keys carry no position: the event itself can go on, and its acceptance comes back.
        event->setAccepted(false);
        QCoreApplication::sendEvent(target, event);
        return event->isAccepted();
    }
    default:
        return false;
    }
}

} // namespace IrisWidget
