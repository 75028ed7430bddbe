// Iris View demo — View › Rotate 90° Clockwise / Anticlockwise, Flip Horizontally /
// Vertically, Reset Rotation and Flips: actions on one IrisSlideView (the main window's, or
// the comparison's current view), their checks following it. The flips mirror the image as
// it is seen (left–right, top–bottom on screen), also when it is turned; the checks show
// the view's flips of the slide (isFlippedHorizontally/Vertically).
//
// The view itself turns on R / Shift+R (animated) and flips on F while it has focus; the menu
// carries Ctrl chords (Ctrl+R, Ctrl+Shift+R) so both work without clashing.
#pragma once

#include <QtCore/QObject>
#include <QtCore/QPointer>

#include <iris/IrisSlideView.h>

QT_BEGIN_NAMESPACE
class QAction;
class QMenu;
QT_END_NAMESPACE

class OrientationActions : public QObject {
    Q_OBJECT
public:
    explicit OrientationActions(QObject *parent = nullptr);

    // The view the actions act on (null: they are disabled).
    void setView(IrisSlideView *view);
    IrisSlideView *view() const { return m_view; }
    void addTo(QMenu *menu) const;

    QAction *rotateClockwise() const { return m_clockwise; }
    QAction *rotateAnticlockwise() const { return m_anticlockwise; }
    QAction *flipHorizontally() const { return m_flipH; }
    QAction *flipVertically() const { return m_flipV; }
    QAction *reset() const { return m_reset; }

private:
    // Mirrors the image as seen on screen, whatever its turn.
    void flipOnScreen(Qt::Orientation orientation);
    void sync();

    QPointer<IrisSlideView> m_view;
    QList<QMetaObject::Connection> m_connections;
    QAction *m_clockwise;
    QAction *m_anticlockwise;
    QAction *m_flipH;
    QAction *m_flipV;
    QAction *m_reset;
};
