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

ZoomAnimator::ZoomAnimator(std::function<void(double, QPointF)> step, std::function<void(double, QPointF)> turn,
                           QObject *parent)
    : QObject(parent)
    , m_step(std::move(step))
    , m_turn(std::move(turn))
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
    start(anchor, std::log(factor), 0);
}

void ZoomAnimator::rotateBy(double degrees, QPointF anchor)
{
    if (!std::isfinite(degrees) || degrees == 0 || !m_turn)
        return;
    if (m_durationMs <= 0) {
        m_turn(degrees, anchor);
        return;
    }
    start(anchor, 0, degrees);
}

void ZoomAnimator::start(QPointF anchor, double logFactor, double degrees)
{
    double remainingLog = 0, remainingDegrees = 0;
    if (m_timer.isActive()) {
        if ((anchor - m_anchor).manhattanLength() > 0.5) {
            finish();
        } else {
            remainingLog = m_logFactor * (1 - m_appliedEased);
            remainingDegrees = m_degrees * (1 - m_appliedEased);
            m_timer.stop();
        }
    }
    m_anchor = anchor;
    m_logFactor = remainingLog + logFactor;
    m_degrees = remainingDegrees + degrees;
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
    const double turn = m_degrees * (eased - m_appliedEased);
    m_appliedEased = eased;
    if (delta != 0)
        m_step(std::exp(delta), m_anchor);
    if (turn != 0 && m_turn)
        m_turn(turn, m_anchor);
}

} // namespace IrisWidget
