// Iris View demo — the status bar's live figures: magnification, the pointer's position on
// the slide in µm (pixels when the slide states no resolution), and frames per second.
#pragma once

#include <QtCore/QElapsedTimer>
#include <QtCore/QObject>
#include <QtCore/QTimer>

#include <iris/IrisFrameMetrics.h>

QT_BEGIN_NAMESPACE
class QLabel;
class QStatusBar;
QT_END_NAMESPACE
class IrisSlideView;

class ViewStatus : public QObject {
    Q_OBJECT
public:
    ViewStatus(IrisSlideView *view, QStatusBar *bar);

    QString magnificationText() const;
    QString positionText() const;
    QString fpsText() const;

private:
    void updateMagnification();
    void updatePosition(const QPointF &slidePos);
    void updateFps(const IrisFrameMetrics &metrics);
    void reset();

    IrisSlideView *m_view;
    QLabel *m_magnification;
    QLabel *m_position;
    QLabel *m_fps;
    QTimer m_idle; // the engine renders only while something changes
};
