#include "zoomanimator_p.h"

#include <algorithm>
#include <cmath>

#include <QtCore/QEasingCurve>

namespace IrisWidget {

namespace {
double ease(double t)
{
    static const QEasingCurve curve(QEasingCurve::OutCubic);
    return curve.valueForProgress(std::clamp(t, 0.0, 1.0));
}
} // namespace

ZoomAnimator::ZoomAnimator(std::function<void(double, QPointF)> step, QObject *parent)
    : QObject(parent)
    , m_step(std::move(step))
{
    m_timer.setInterval(16);
    m_timer.setTimerType(Qt::PreciseTimer);
    connect(&m_timer, &QTimer::timeout, this, &ZoomAnimator::tick);
}

void ZoomAnimator::zoomBy(double factor, QPointF anchor)
{
    if (!(factor > 0) || !std::isfinite(factor) || factor == 1)
        return;
    if (m_durationMs <= 0) {
        m_step(factor, anchor);
        return;
    }
    double remaining = 0;
    if (m_timer.isActive()) {
        if ((anchor - m_anchor).manhattanLength() > 0.5) {
            finish();
        } else {
            remaining = m_logFactor * (1 - m_appliedEased);
            m_timer.stop();
        }
    }
    m_anchor = anchor;
    m_logFactor = remaining + std::log(factor);
    m_appliedEased = 0;
    m_clock.start();
    m_timer.start();
}

void ZoomAnimator::finish()
{
    if (!m_timer.isActive())
        return;
    applyUpTo(1);
    m_timer.stop();
    Q_EMIT finished();
}

void ZoomAnimator::cancel()
{
    if (!m_timer.isActive())
        return;
    m_timer.stop();
    Q_EMIT finished();
}

void ZoomAnimator::tick()
{
    const double progress = double(m_clock.elapsed()) / m_durationMs;
    if (progress >= 1) {
        finish();
        return;
    }
    applyUpTo(ease(progress));
}

void ZoomAnimator::applyUpTo(double eased)
{
    const double delta = m_logFactor * (eased - m_appliedEased);
    m_appliedEased = eased;
    if (delta != 0)
        m_step(std::exp(delta), m_anchor);
}

} // namespace IrisWidget
