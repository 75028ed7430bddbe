// Iris View widget — not API. Kinetic panning: a drag released with speed keeps gliding
// and decelerates exponentially (time constant ~325 ms, as touch UIs do).
//
// Velocity is estimated from the input events' own timestamps over the last 100 ms of the
// drag, so it follows the hand and not the event loop. A release more than 50 ms after the
// last move means the hand had stopped: no glide.
#pragma once

#include <functional>

#include <QtCore/QElapsedTimer>
#include <QtCore/QList>
#include <QtCore/QObject>
#include <QtCore/QPointF>
#include <QtCore/QTimer>

#include "autotest_p.h"

namespace IrisWidget {

class IRIS_WIDGET_AUTOTEST_EXPORT KineticPanner : public QObject {
    Q_OBJECT
public:
    // step receives each glide increment in logical pixels (like a drag delta).
    explicit KineticPanner(std::function<void(QPointF)> step, QObject *parent = nullptr);

    // Records the pointer position of a drag at an event timestamp (ms).
    void track(QPointF pos, quint64 timestampMs);
    // The drag ended at timestampMs: glide if the pointer was still moving; true if so.
    bool release(quint64 timestampMs);
    // Ends any glide.
    void stop();
    // Ends any glide and forgets the drag's samples.
    void reset();
    bool isActive() const { return m_timer.isActive(); }
    QPointF velocity() const { return m_velocity; } // logical pixels per second

    static constexpr double kTimeConstantS = 0.325;
    static constexpr double kMinSpeed = 60;    // px/s: slower releases do not glide
    static constexpr double kStopSpeed = 8;    // px/s: the glide ends here
    static constexpr double kMaxSpeed = 8000;  // px/s: clamp against bursts of events
    static constexpr quint64 kWindowMs = 100;  // velocity is measured over this much of the drag
    static constexpr quint64 kStaleMs = 50;    // a release this long after the last move: no glide

Q_SIGNALS:
    void finished();

private:
    void tick();

    struct Sample {
        QPointF pos;
        quint64 t;
    };
    std::function<void(QPointF)> m_step;
    QList<Sample> m_samples;
    QPointF m_velocity;
    QTimer m_timer;
    QElapsedTimer m_clock;
};

} // namespace IrisWidget
