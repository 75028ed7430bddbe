// Iris View widget — not API. Smooth zoom and turn: a zoom request (a wheel notch, a key, a
// double click) or a turn (R, Shift+wheel) is spread over ~150 ms with an ease-out curve,
// each tick applying the next part of the factor (or angle) about the same anchor. Since
// every part keeps the anchor's image point fixed, so does the whole. Requests that arrive
// mid-way about the same anchor add to what remains; a request about another anchor first
// completes the running one.
#pragma once

#include <functional>

#include <QtCore/QElapsedTimer>
#include <QtCore/QObject>
#include <QtCore/QPointF>
#include <QtCore/QTimer>

#include "autotest_p.h"

namespace IrisWidget {

class IRIS_WIDGET_AUTOTEST_EXPORT ZoomAnimator : public QObject {
    Q_OBJECT
public:
    // step receives (factor, anchor) increments, turn (degrees, anchor) increments; anchor in
    // logical pixels.
    explicit ZoomAnimator(std::function<void(double, QPointF)> step,
                          std::function<void(double, QPointF)> turn = {}, QObject *parent = nullptr);

    void zoomBy(double factor, QPointF anchor);
    void rotateBy(double degrees, QPointF anchor);
    // Applies whatever zoom remains at once.
    void finish();
    // Drops whatever zoom remains.
    void cancel();
    bool isActive() const { return m_timer.isActive(); }
    void setDuration(int ms) { m_durationMs = ms; }
    int duration() const { return m_durationMs; }

Q_SIGNALS:
    void finished();

private:
    void tick();
    void applyUpTo(double progress);
    void start(QPointF anchor, double logFactor, double degrees);

    std::function<void(double, QPointF)> m_step;
    std::function<void(double, QPointF)> m_turn;
    QTimer m_timer;
    QElapsedTimer m_clock;
    int m_durationMs = 150;
    QPointF m_anchor;
    double m_logFactor = 0;   // the whole zoom of the running animation, as ln(factor)
    double m_degrees = 0;     // the whole turn of the running animation
    double m_appliedEased = 0; // how much of it (on the eased 0…1 scale) was applied
};

} // namespace IrisWidget
