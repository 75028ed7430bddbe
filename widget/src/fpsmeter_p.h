// Iris View widget — not API. Frames per second over the recent frames of continuous
// rendering. The engine sleeps while nothing changes, so a long pause starts a new run
// instead of dragging the figure down.
#pragma once

#include <array>
#include <cstddef>

namespace IrisWidget {

class FpsMeter {
public:
    static constexpr double kPauseMs = 500; // a longer interval ends a run of frames

    // Adds a frame that came intervalMs after the previous one; returns the current rate.
    double add(double intervalMs)
    {
        if (!(intervalMs > 0) || intervalMs > kPauseMs) {
            m_count = 0;
            m_sum = 0;
            m_next = 0;
            return m_fps = 0;
        }
        if (m_count == m_intervals.size())
            m_sum -= m_intervals[m_next];
        else
            ++m_count;
        m_intervals[m_next] = intervalMs;
        m_sum += intervalMs;
        m_next = (m_next + 1) % m_intervals.size();
        return m_fps = 1000.0 * double(m_count) / m_sum;
    }
    double fps() const { return m_fps; }

private:
    std::array<double, 16> m_intervals{};
    std::size_t m_count = 0;
    std::size_t m_next = 0;
    double m_sum = 0;
    double m_fps = 0;
};

} // namespace IrisWidget
