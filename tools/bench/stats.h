// Quartiles of a sample and small JSON helpers for iris-bench.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
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

inline std::string jnum(double v) {
    if (!std::isfinite(v)) return "null";
    char b[64];
    std::snprintf(b, sizeof b, "%.6g", v);
    return b;
}

inline std::string jquart(const Quartiles& q) {
    return "{\"p25\": " + jnum(q.p25) + ", \"median\": " + jnum(q.median) + ", \"p75\": " + jnum(q.p75) + "}";
}

inline std::string jstr(const std::string& s) {
    std::string o = "\"";
    for (char c : s) {
        if (c == '"' || c == '\\') o += '\\';
        if (c == '\n') { o += "\\n"; continue; }
        o += c;
    }
    return o + "\"";
}
