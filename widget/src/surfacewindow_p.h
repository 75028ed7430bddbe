// Iris View widget — not API. The Vulkan-surface window that IrisSlideView embeds.
//
// It owns no rendering: the engine presents into its surface from the engine's render
// thread. The window reports the moments the surface's owner must act on, on the GUI
// thread, in this order over a lifetime:
//   exposedChanged(true)  – the surface exists and is on screen: bind or resume;
//   targetSizeChanged     – the size in device pixels changed (resize, screen, scale);
//   contentsLost          – an expose while on screen: the window system dropped pixels of
//                           the window (X11 without a compositor, when a window that covered
//                           it goes away), so the current frame must be presented again;
//   exposedChanged(false) – hidden or minimised: render nothing;
//   surfaceAboutToBeDestroyed – release the swapchain now, the VkSurfaceKHR dies next.
// Input events are handed to inputHandler, which forwards them to the widget.
#pragma once

#include <functional>

#include <QtCore/QSize>
#include <QtGui/QRegion>
#include <QtGui/QWindow>

namespace IrisWidget {

class SurfaceWindow : public QWindow {
    Q_OBJECT
public:
    SurfaceWindow();
    ~SurfaceWindow() override;

    // The size of the surface in device pixels: size() × devicePixelRatio().
    QSize targetSize() const;

    // Gets every input event first; returns true when it took the event.
    std::function<bool(QEvent *)> inputHandler;

Q_SIGNALS:
    void exposedChanged(bool exposed);
    void targetSizeChanged(QSize deviceSize);
    void contentsLost();
    void surfaceAboutToBeDestroyed();

protected:
    bool event(QEvent *event) override;
    void exposeEvent(QExposeEvent *event) override;
    void resizeEvent(QResizeEvent *event) override;

private:
    void checkTargetSize();
    static QRegion exposedRegion(const QExposeEvent *event);

    bool m_exposed = false;
    QSize m_lastTargetSize;
};

} // namespace IrisWidget
