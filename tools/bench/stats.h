// Quartiles of a sample, for iris-bench.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

struct Quartiles {
    double p25 = NAN, median = NAN, p75 = NAN;
    size_t n = 0;
};

inline double percentile(std::vector<double> v, double p) {
    if (v.empty()) return NAN;
    std::sort(v.begin(), v.end());
    const double pos = p * double(v.size() - 1);
    const size_t i = size_t(pos);
    const double f = pos - double(i);
    return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

inline Quartiles quartiles(const std::vector<double>& v) {
    return {percentile(v, 0.25), percentile(v, 0.5), percentile(v, 0.75), v.size()};
}
