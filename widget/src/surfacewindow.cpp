#include "surfacewindow_p.h"

#include <QtGui/QExposeEvent>
#include <QtGui/QPlatformSurfaceEvent>
#include <QtGui/QScreen>

#include "logging_p.h"

namespace IrisWidget {

SurfaceWindow::SurfaceWindow()
{
    setSurfaceType(QSurface::VulkanSurface);
    setCursor(Qt::OpenHandCursor);
    // A moved window (another screen) may change the device-pixel ratio.
    connect(this, &QWindow::screenChanged, this, [this](QScreen *screen) {
        if (screen) {
            connect(screen, &QScreen::logicalDotsPerInchChanged, this, &SurfaceWindow::checkTargetSize,
                    Qt::UniqueConnection);
        }
        checkTargetSize();
    });
    if (QScreen *s = screen()) {
        connect(s, &QScreen::logicalDotsPerInchChanged, this, &SurfaceWindow::checkTargetSize,
                Qt::UniqueConnection);
    }
}

SurfaceWindow::~SurfaceWindow() = default;

QSize SurfaceWindow::targetSize() const
{
    return size() * devicePixelRatio();
}

bool SurfaceWindow::event(QEvent *event)
{
    switch (event->type()) {
    case QEvent::MouseButtonPress:
    case QEvent::MouseButtonRelease:
    case QEvent::MouseButtonDblClick:
    case QEvent::MouseMove:
    case QEvent::Wheel:
    case QEvent::KeyPress:
    case QEvent::KeyRelease:
    case QEvent::NativeGesture:
    case QEvent::ContextMenu:
    case QEvent::DragEnter:
    case QEvent::DragMove:
    case QEvent::DragLeave:
    case QEvent::Drop:
        if (inputHandler && inputHandler(event))
            return true;
        break;
    case QEvent::PlatformSurface:
        if (static_cast<QPlatformSurfaceEvent *>(event)->surfaceEventType()
            == QPlatformSurfaceEvent::SurfaceAboutToBeDestroyed) {
            qCDebug(lcIrisWidget) << "surface about to be destroyed";
            if (m_exposed) {
                m_exposed = false;
                Q_EMIT exposedChanged(false);
            }
            Q_EMIT surfaceAboutToBeDestroyed();
            m_lastTargetSize = {};
        }
        break;
    case QEvent::ScreenChangeInternal:
        checkTargetSize();
        break;
    default:
        break;
    }
    return QWindow::event(event);
}

void SurfaceWindow::exposeEvent(QExposeEvent *event)
{
    // An expose may also follow a change of devicePixelRatio (Qt sends one then).
    const bool exposed = isExposed();
    if (exposed)
        checkTargetSize();
    if (exposed != m_exposed) {
        m_exposed = exposed;
        qCDebug(lcIrisWidget) << "surface" << (exposed ? "exposed" : "hidden") << targetSize();
        Q_EMIT exposedChanged(exposed);
    } else if (exposed && !exposedRegion(event).isEmpty()) {
        // Qt creates the window without a background, so an X server without a compositor
        // leaves whatever covered the region in it; nothing else will present again while
        // the view stands still.
        qCDebug(lcIrisWidget) << "surface contents lost" << exposedRegion(event).boundingRect();
        Q_EMIT contentsLost();
    }
}

QRegion SurfaceWindow::exposedRegion(const QExposeEvent *event)
{
    // Qt 6 deprecates QExposeEvent::region() in favour of QPaintEvent, which QWindow gets only
    // where the platform plugin synthesises it; the expose's region is what xcb reports, and
    // the one signal this window has that the X server dropped its pixels.
    QT_WARNING_PUSH
    QT_WARNING_DISABLE_DEPRECATED
    return event->region();
    QT_WARNING_POP
}

void SurfaceWindow::resizeEvent(QResizeEvent *)
{
    checkTargetSize();
}

void SurfaceWindow::checkTargetSize()
{
    const QSize size = targetSize();
    if (size == m_lastTargetSize || size.isEmpty())
        return;
    m_lastTargetSize = size;
    Q_EMIT targetSizeChanged(size);
}

} // namespace IrisWidget
