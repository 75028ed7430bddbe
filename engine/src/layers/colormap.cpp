// Colour maps: the built-ins (matplotlib's viridis, magma and jet; a grey ramp), user LUTs from
// text or a PNG strip, and the default class table of label maps.
#include <algorithm>
#include <charconv>
#include <cmath>

#include "layers/colormap_tables.h"
#include "layers/raster_readers.h"

namespace iris {

using namespace layers_detail;

namespace {

uint8_t code(double v) {
    return uint8_t(std::clamp(std::lround(255.0 * v), 0L, 255L));
}

ColorMap fromTable(const char* name, const double (&table)[256][3]) {
    ColorMap cm;
    cm.name = name;
    for (size_t i = 0; i < 256; ++i) cm.entries[i] = {code(table[i][0]), code(table[i][1]), code(table[i][2]), 255};
    return cm;
}

// One channel of a matplotlib LinearSegmentedColormap: (x, y0, y1) rows with increasing x; at x
// between two rows the value runs linearly from the first's y1 to the second's y0.
struct Segment {
    double x, y0, y1;
};
double segmented(std::span<const Segment> s, double x) {
    for (size_t i = 1; i < s.size(); ++i)
        if (x <= s[i].x) {
            const double f = (x - s[i - 1].x) / (s[i].x - s[i - 1].x);
            return s[i - 1].y1 + f * (s[i].y0 - s[i - 1].y1);
        }
    return s.back().y0;
}

} // namespace

ColorMap ColorMap::viridis() {
    return fromTable("viridis", kViridisData);
}

ColorMap ColorMap::magma() {
    return fromTable("magma", kMagmaData);
}

ColorMap ColorMap::jet() {
    // matplotlib's _jet_data (lib/matplotlib/_cm.py).
    static constexpr Segment red[] = {{0, 0, 0}, {0.35, 0, 0}, {0.66, 1, 1}, {0.89, 1, 1}, {1, 0.5, 0.5}};
    static constexpr Segment green[] = {{0, 0, 0},       {0.125, 0, 0}, {0.375, 1, 1},
                                        {0.64, 1, 1},    {0.91, 0, 0},  {1, 0, 0}};
    static constexpr Segment blue[] = {{0, 0.5, 0.5}, {0.11, 1, 1}, {0.34, 1, 1}, {0.65, 0, 0}, {1, 0, 0}};
    ColorMap cm;
    cm.name = "jet";
    for (size_t i = 0; i < 256; ++i) {
        const double x = double(i) / 255.0;
        cm.entries[i] = {code(segmented(red, x)), code(segmented(green, x)), code(segmented(blue, x)), 255};
    }
    return cm;
}

ColorMap ColorMap::gray() {
    ColorMap cm;
    cm.name = "gray";
    for (size_t i = 0; i < 256; ++i) cm.entries[i] = {uint8_t(i), uint8_t(i), uint8_t(i), 255};
    return cm;
}

std::optional<ColorMap> ColorMap::builtin(std::string_view name) {
    if (name == "viridis") return viridis();
    if (name == "magma") return magma();
    if (name == "jet") return jet();
    if (name == "gray" || name == "grey") return gray();
    return std::nullopt;
}

namespace {

Expected<ColorMap> fromText(std::string_view text, const std::string& name) {
    ColorMap cm;
    cm.name = name;
    size_t count = 0, lineNo = 0, pos = 0;
    while (pos < text.size()) {
        size_t end = text.find('\n', pos);
        if (end == std::string_view::npos) end = text.size();
        std::string_view line = text.substr(pos, end - pos);
        pos = end + 1;
        ++lineNo;
        int v[4] = {0, 0, 0, 255}, n = 0;
        size_t i = 0;
        auto skipSpace = [&] {
            while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r' || line[i] == ',')) ++i;
        };
        skipSpace();
        if (i == line.size() || line[i] == '#') continue;
        while (i < line.size()) {
            if (n == 4) return fail(Status::CorruptData, name, "line " + std::to_string(lineNo) + ": more than 4 numbers");
            const auto r = std::from_chars(line.data() + i, line.data() + line.size(), v[n]);
            if (r.ec != std::errc() || v[n] < 0 || v[n] > 255)
                return fail(Status::CorruptData, name,
                            "line " + std::to_string(lineNo) + ": expected integers 0..255 (\"r g b\" or \"r g b a\")");
            i = size_t(r.ptr - line.data());
            ++n;
            skipSpace();
        }
        if (n < 3) return fail(Status::CorruptData, name, "line " + std::to_string(lineNo) + ": fewer than 3 numbers");
        if (count == 256) return fail(Status::CorruptData, name, "more than 256 entries");
        cm.entries[count++] = {uint8_t(v[0]), uint8_t(v[1]), uint8_t(v[2]), uint8_t(v[3])};
    }
    if (count != 256)
        return fail(Status::CorruptData, name, std::to_string(count) + " entries; a colour map has exactly 256");
    return cm;
}

Expected<ColorMap> fromPngStrip(std::span<const uint8_t> bytes, const std::string& name) {
    RasterLoadOptions o;
    o.maxSide = 4096; // a strip is 256 pixels long: anything larger is refused early
    auto map = readPngRaster(bytes, name, o);
    if (!map) return map.error();
    const RasterLevel& l = map->levels.front();
    if (!((l.width == 256 && l.height == 1) || (l.width == 1 && l.height == 256)))
        return fail(Status::CorruptData, name,
                    "a colour-map PNG is a strip of 256x1 or 1x256 pixels, not " + std::to_string(l.width) + "x" +
                        std::to_string(l.height));
    ColorMap cm;
    cm.name = name;
    const bool wide = map->maxValue > 255; // a 16-bit grey strip
    for (size_t i = 0; i < 256; ++i) {
        if (map->kind == RasterKind::Rgba) {
            const uint8_t* p = &l.rgba[4 * i];
            cm.entries[i] = {p[0], p[1], p[2], p[3]};
        } else {
            const double g = l.scalar[i];
            const uint8_t c = wide ? uint8_t(std::lround(g / 257.0)) : uint8_t(g);
            cm.entries[i] = {c, c, c, 255};
        }
    }
    return cm;
}

} // namespace

Expected<ColorMap> ColorMap::fromMemory(std::span<const uint8_t> bytes, const std::string& name) {
    if (isPng(bytes)) return fromPngStrip(bytes, name);
    if (bytes.size() > (1u << 20)) return fail(Status::UnsupportedFormat, name, "too large for a colour-map text file");
    for (uint8_t b : bytes) // text: UTF-8 comments are fine, control characters other than tab/CR/LF are not
        if (b < 0x20 && b != '\t' && b != '\r' && b != '\n')
            return fail(Status::UnsupportedFormat, name, "neither a PNG strip nor a text colour map (binary bytes)");
    return fromText(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()), name);
}

Expected<ColorMap> ColorMap::fromFile(const std::string& path) {
    auto bytes = readWholeFile(path, 16u << 20);
    if (!bytes) return bytes.error();
    return fromMemory(*bytes, path);
}

std::vector<LabelClass> defaultLabelClasses(int count) {
    // matplotlib's tab20 palette: 20 colours told apart easily, each dark then light.
    static constexpr uint8_t kPalette[20][3] = {
        {31, 119, 180},  {174, 199, 232}, {255, 127, 14},  {255, 187, 120}, {44, 160, 44},
        {152, 223, 138}, {214, 39, 40},   {255, 152, 150}, {148, 103, 189}, {197, 176, 213},
        {140, 86, 75},   {196, 156, 148}, {227, 119, 194}, {247, 182, 210}, {127, 127, 127},
        {199, 199, 199}, {188, 189, 34},  {219, 219, 141}, {23, 190, 207},  {158, 218, 229}};
    std::vector<LabelClass> classes;
    for (int id = 0; id < std::clamp(count, 0, 65536); ++id) {
        if (id == 0) {
            classes.push_back({"background", {0, 0, 0, 0}, false});
            continue;
        }
        const uint8_t* c = kPalette[(id - 1) % 20];
        classes.push_back({"class " + std::to_string(id), {c[0], c[1], c[2], 255}, true});
    }
    return classes;
}

} // namespace iris
