// Iris View widget — not API. Hands input that reached the embedded surface window to
// the widget's own event handlers, with positions mapped into the widget's coordinates.
//
// A window container's QWindow receives input directly from the platform and the widget
// hierarchy never sees it; forwarding keeps IrisSlideView's handlers (and a subclass's
// overrides) the one place where input is interpreted, and lets unhandled keys propagate
// to the widget's parents as usual.
#pragma once

#include <QtCore/qglobal.h>

QT_BEGIN_NAMESPACE
class QEvent;
class QWidget;
QT_END_NAMESPACE

namespace IrisWidget {

// Sends event (received by the window inside container) to target, a widget that
// contains container. Returns whether target accepted it.
bool forwardInputEvent(QEvent *event, QWidget *container, QWidget *target);

} // namespace IrisWidget
