// Not API: what the two annotation formats share (geojson.cpp, asap_xml.cpp).
#pragma once

#include <algorithm>
#include <atomic>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "iris/annotations.h"

namespace iris::ann {

// Limits a hostile or broken file runs into before it exhausts memory or the stack.
constexpr size_t kMaxVerticesPerObject = 2'000'000;
constexpr int kMaxJsonDepth = 64;

// Byte offset → 1-based line, by binary search over the newline offsets (built once).
class LineIndex {
public:
    explicit LineIndex(std::string_view text) {
        for (size_t i = 0; i < text.size(); ++i)
            if (text[i] == '\n') newlines_.push_back(i);
    }
    size_t line(size_t offset) const {
        return size_t(std::lower_bound(newlines_.begin(), newlines_.end(), offset) - newlines_.begin()) + 1;
    }
    size_t column(size_t offset) const {
        const size_t l = line(offset);
        return l == 1 ? offset + 1 : offset - newlines_[l - 2];
    }

private:
    std::vector<size_t> newlines_;
};

// A double as the shortest text that reads back exactly.
inline std::string formatDouble(double v) {
    char buf[32];
    auto r = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, r.ptr);
}

// A whole string as a double ("" or trailing junk: none). A comma stands for the decimal point
// when there is no dot (ASAP files written under a comma-decimal locale have them).
inline std::optional<double> parseDouble(std::string_view s) {
    std::string t(s);
    t.erase(0, t.find_first_not_of(" \t\r\n"));
    t.erase(t.find_last_not_of(" \t\r\n") + 1);
    if (t.find('.') == std::string::npos) std::replace(t.begin(), t.end(), ',', '.');
    if (!t.empty() && t[0] == '+') t.erase(0, 1);
    double v = 0;
    auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    if (t.empty() || r.ec != std::errc() || r.ptr != t.data() + t.size()) return std::nullopt;
    return v;
}

// A double narrowed to float without undefined behaviour: out of float's range gives ±inf (which
// annotationProblem then refuses for widths and opacities).
inline float toFloat(double v) {
    if (std::isnan(v)) return NAN;
    if (v > 3.4e38) return INFINITY;
    if (v < -3.4e38) return -INFINITY;
    return float(v);
}

inline std::string hexColor(Rgba8 c) {
    char buf[16];
    if (c.a == 255) std::snprintf(buf, sizeof buf, "#%02X%02X%02X", c.r, c.g, c.b);
    else std::snprintf(buf, sizeof buf, "#%02X%02X%02X%02X", c.r, c.g, c.b, c.a);
    return buf;
}
inline std::optional<Rgba8> parseHexColor(std::string_view s) {
    if (s.empty() || s[0] != '#' || (s.size() != 7 && s.size() != 9)) return std::nullopt;
    uint8_t v[4] = {0, 0, 0, 255};
    for (size_t i = 0; i * 2 + 1 < s.size(); ++i) {
        unsigned x = 0;
        auto r = std::from_chars(s.data() + 1 + i * 2, s.data() + 3 + i * 2, x, 16);
        if (r.ec != std::errc() || r.ptr != s.data() + 3 + i * 2) return std::nullopt;
        v[i] = uint8_t(x);
    }
    return Rgba8{v[0], v[1], v[2], v[3]};
}

inline bool cancelled(const ReadControl& c) { return c.cancel && c.cancel->load(std::memory_order_relaxed); }
// relaxed: the flag carries no data; the reader only has to see it eventually.

inline size_t vertexCount(const AnnotationObject& o) {
    size_t n = o.points.size();
    for (const auto& p : o.polygons) {
        n += p.outer.size();
        for (const auto& h : p.holes) n += h.size();
    }
    return n;
}

} // namespace iris::ann
