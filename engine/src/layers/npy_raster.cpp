// NumPy .npy → a Scalar (or Label) map. Hand-written: no Debian package reads .npy from C++
// (libcnpy and xtensor's loader are not packaged for Debian 12, and both trust the header).
//
// The format (numpy.lib.format): "\x93NUMPY", major and minor version bytes, the header's
// length (2 bytes little-endian in 1.0, 4 bytes in 2.0 and 3.0), the header: a Python dict
// literal {'descr': '<f4', 'fortran_order': False, 'shape': (H, W), } padded with spaces and a
// newline (3.0 allows UTF-8 in it; only the three keys matter here), then the raw values.
// Taken: 2-D shapes; descr of byte order '<', '>', '|' or '=' and kind f (2, 4, 8 bytes), i or u
// (1, 2, 4, 8) or b1; C or Fortran order. Everything else is refused with what it was.
#include <bit>
#include <cmath>
#include <cstring>
#include <optional>

#include "layers/raster_readers.h"

namespace iris::layers_detail {

namespace {

// The dict literal, parsed as far as the three keys need: a small cursor over it.
struct HeaderParser {
    std::string_view s;
    size_t i = 0;

    void space() {
        while (i < s.size() && (s[i] == ' ' || s[i] == '\t' || s[i] == '\n' || s[i] == '\r')) ++i;
    }
    bool eat(char c) {
        space();
        if (i < s.size() && s[i] == c) {
            ++i;
            return true;
        }
        return false;
    }
    std::optional<std::string> string() {
        space();
        if (i >= s.size() || (s[i] != '\'' && s[i] != '"')) return std::nullopt;
        const char q = s[i++];
        const size_t end = s.find(q, i);
        if (end == std::string_view::npos) return std::nullopt;
        std::string out(s.substr(i, end - i));
        i = end + 1;
        return out;
    }
    std::optional<bool> boolean() {
        space();
        if (s.substr(i, 4) == "True") return i += 4, true;
        if (s.substr(i, 5) == "False") return i += 5, false;
        return std::nullopt;
    }
    // A tuple of non-negative integers (an 'L' suffix, from Python 2 writers, is allowed).
    std::optional<std::vector<uint64_t>> tuple() {
        if (!eat('(')) return std::nullopt;
        std::vector<uint64_t> dims;
        while (true) {
            if (eat(')')) return dims;
            space();
            if (i >= s.size() || s[i] < '0' || s[i] > '9' || dims.size() >= 32) return std::nullopt;
            uint64_t v = 0;
            while (i < s.size() && s[i] >= '0' && s[i] <= '9') {
                if (v > (uint64_t(1) << 59)) return std::nullopt; // beyond any shape numpy writes
                v = v * 10 + uint64_t(s[i++] - '0');
            }
            if (i < s.size() && s[i] == 'L') ++i;
            dims.push_back(v);
            if (!eat(',')) {
                if (eat(')')) return dims;
                return std::nullopt;
            }
        }
    }
};

struct Header {
    std::string descr;
    bool fortran = false;
    std::vector<uint64_t> shape;
};

// Parses the dict; "" on success, else what is wrong.
std::string parseHeader(std::string_view text, Header& h) {
    HeaderParser p{text};
    if (!p.eat('{')) return "the header is not a dict ('{' expected)";
    bool haveDescr = false, haveOrder = false, haveShape = false;
    while (!p.eat('}')) {
        auto key = p.string();
        if (!key) return "the header's dict has a key that is not a string";
        if (!p.eat(':')) return "the header's dict lacks ':' after '" + *key + "'";
        if (*key == "descr") {
            auto v = p.string();
            if (!v) return "'descr' is not a string (structured dtypes are not maps)";
            h.descr = *v, haveDescr = true;
        } else if (*key == "fortran_order") {
            auto v = p.boolean();
            if (!v) return "'fortran_order' is neither True nor False";
            h.fortran = *v, haveOrder = true;
        } else if (*key == "shape") {
            auto v = p.tuple();
            if (!v) return "'shape' is not a tuple of integers";
            h.shape = *v, haveShape = true;
        } else {
            return "the header has an unknown key '" + *key + "'";
        }
        if (!p.eat(',')) {
            if (p.eat('}')) break;
            return "the header's dict lacks ',' or '}' after '" + *key + "'";
        }
    }
    if (!haveDescr || !haveOrder || !haveShape) return "the header lacks 'descr', 'fortran_order' or 'shape'";
    return {};
}

} // namespace

Expected<RasterMap> readNpyRaster(std::span<const uint8_t> bytes, const std::string& name,
                                  const RasterLoadOptions& options) {
    if (bytes.size() < 10) return fail(Status::CorruptData, name, "truncated .npy preamble");
    const int major = bytes[6], minor = bytes[7];
    if (major < 1 || major > 3 || minor != 0)
        return fail(Status::UnsupportedFormat, name,
                    ".npy version " + std::to_string(major) + "." + std::to_string(minor) + " (1.0, 2.0 and 3.0 are read)");
    const size_t lenBytes = major == 1 ? 2 : 4;
    if (bytes.size() < 8 + lenBytes) return fail(Status::CorruptData, name, "truncated .npy preamble");
    uint64_t headerLen = bytes[8] | uint64_t(bytes[9]) << 8;
    if (lenBytes == 4) headerLen |= uint64_t(bytes[10]) << 16 | uint64_t(bytes[11]) << 24;
    const uint64_t dataStart = 8 + lenBytes + headerLen;
    if (dataStart > bytes.size())
        return fail(Status::CorruptData, name,
                    "the header claims " + std::to_string(headerLen) + " bytes; the file has " +
                        std::to_string(bytes.size()));
    Header h;
    const std::string_view text(reinterpret_cast<const char*>(bytes.data()) + 8 + lenBytes, size_t(headerLen));
    if (std::string why = parseHeader(text, h); !why.empty()) return fail(Status::CorruptData, name, why);

    // dtype
    const std::string& d = h.descr;
    if (d.size() < 3 || std::string_view("<>|=").find(d[0]) == std::string_view::npos)
        return fail(Status::UnsupportedFormat, name, "dtype '" + d + "' (a byte order and a kind expected, e.g. '<f4')");
    Sample el{};
    const std::string kindSize = d.substr(1);
    static const struct {
        const char* text;
        SampleKind kind;
        int size;
    } kTypes[] = {{"f2", SampleKind::Float, 2}, {"f4", SampleKind::Float, 4}, {"f8", SampleKind::Float, 8}, {"i1", SampleKind::Int, 1},
                  {"i2", SampleKind::Int, 2},   {"i4", SampleKind::Int, 4},   {"i8", SampleKind::Int, 8},   {"u1", SampleKind::Uint, 1},
                  {"u2", SampleKind::Uint, 2},  {"u4", SampleKind::Uint, 4},  {"u8", SampleKind::Uint, 8},  {"b1", SampleKind::Bool, 1}};
    bool known = false;
    for (const auto& t : kTypes)
        if (kindSize == t.text) el.kind = t.kind, el.size = t.size, known = true;
    if (!known)
        return fail(Status::UnsupportedFormat, name,
                    "dtype '" + d + "' (float f2/f4/f8, integer i1..i8, u1..u8 and bool b1 are read)");
    const bool little = d[0] == '<' || (d[0] != '>' && std::endian::native == std::endian::little);
    el.swap = el.size > 1 && little != (std::endian::native == std::endian::little);
    if (options.asLabels && (el.kind == SampleKind::Float))
        return fail(Status::UnsupportedFormat, name, "a label map needs integer values, not dtype '" + d + "'");

    // shape
    if (h.shape.size() != 2)
        return fail(Status::UnsupportedFormat, name,
                    "an array of " + std::to_string(h.shape.size()) + " dimensions (a map is 2-D: (height, width))");
    const uint64_t height = h.shape[0], width = h.shape[1];
    const Limits limits = Limits::of(options);
    const int bpp = options.asLabels ? 2 : 4;
    if (width > uint64_t(kMaxRasterSide) * 2 || height > uint64_t(kMaxRasterSide) * 2) // keeps the sums small
        return fail(Status::UnsupportedFormat, name,
                    "an array of " + std::to_string(height) + "x" + std::to_string(width) + " is over the limit of " +
                        std::to_string(limits.maxSide) + " a side");
    if (Result r = checkLevelSize(int64_t(width), int64_t(height), bpp, 0, limits, name); !r) return r;
    const uint64_t count = width * height, need = count * uint64_t(el.size), have = bytes.size() - dataStart;
    if (have < need)
        return fail(Status::CorruptData, name,
                    "truncated: " + std::to_string(height) + "x" + std::to_string(width) + " of '" + d + "' need " +
                        std::to_string(need) + " bytes of data, the file has " + std::to_string(have));
    if (have > need)
        return fail(Status::CorruptData, name,
                    std::to_string(have - need) + " bytes after the array's data (a wrong shape or dtype?)");

    RasterMap map;
    map.kind = options.asLabels ? RasterKind::Label : RasterKind::Scalar;
    RasterLevel l;
    l.width = int32_t(width), l.height = int32_t(height);
    if (options.asLabels) l.label.resize(size_t(count));
    else l.scalar.resize(size_t(count));
    const uint8_t* data = bytes.data() + dataStart;
    for (uint64_t y = 0; y < height; ++y)
        for (uint64_t x = 0; x < width; ++x) {
            const uint64_t src = h.fortran ? x * height + y : y * width + x;
            const double v = el(data + src * uint64_t(el.size));
            if (Result r = storeValue(map.kind, l, x, y, v, name); !r) return r;
        }
    map.levels.push_back(std::move(l));
    if (Result r = finishMap(map, name, options.title); !r) return r;
    return map;
}

} // namespace iris::layers_detail
