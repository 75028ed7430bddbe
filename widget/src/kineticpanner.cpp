#include "kineticpanner_p.h"

#include <cmath>

namespace IrisWidget {

KineticPanner::KineticPanner(std::function<void(QPointF)> step, QObject *parent)
    : QObject(parent)
    , m_step(std::move(step))
{
    m_timer.setInterval(16);
    m_timer.setTimerType(Qt::PreciseTimer);
    connect(&m_timer, &QTimer::timeout, this, &KineticPanner::tick);
}

void KineticPanner::track(QPointF pos, quint64 timestampMs)
{
    if (!m_samples.isEmpty() && timestampMs < m_samples.last().t)
        m_samples.clear(); // the clock went backwards (a new device): start over
    m_samples.append({pos, timestampMs});
    while (m_samples.size() > 2 && timestampMs - m_samples.first().t > kWindowMs)
        m_samples.removeFirst();
}

bool KineticPanner::release(quint64 timestampMs)
{
    stop();
    const QList<Sample> samples = std::exchange(m_samples, {});
    if (samples.size() < 2)
        return false;
    const Sample &first = samples.first();
    const Sample &last = samples.last();
    if (timestampMs > last.t + kStaleMs || last.t <= first.t)
        return false;
    const double dt = double(last.t - first.t) / 1000.0;
    QPointF v = (last.pos - first.pos) / dt;
    const double speed = std::hypot(v.x(), v.y());
    if (speed < kMinSpeed)
        return false;
    if (speed > kMaxSpeed)
        v *= kMaxSpeed / speed;
    m_velocity = v;
    m_clock.start();
    m_timer.start();
    return true;
}

void KineticPanner::stop()
{
    if (!m_timer.isActive())
        return;
    m_timer.stop();
    m_velocity = {};
    Q_EMIT finished();
}

void KineticPanner::reset()
{
    stop();
    m_samples.clear();
}

void KineticPanner::tick()
{
    const double dt = double(m_clock.restart()) / 1000.0;
    // Exact integral of v·e^(−t/τ) over this tick, then decay.
    const double decay = std::exp(-dt / kTimeConstantS);
    const QPointF distance = m_velocity * kTimeConstantS * (1 - decay);
    m_velocity *= decay;
    m_step(distance);
    if (std::hypot(m_velocity.x(), m_velocity.y()) < kStopSpeed)
        stop();
}

} // namespace IrisWidget
