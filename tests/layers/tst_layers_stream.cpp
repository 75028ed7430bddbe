// Streamed raster maps (iris/layers.h: RasterPixelSource, RasterLevel::source, readRasterRegion,
// RasterLoadOptions::streamAbove): a TIFF over streamAbove is left in its file and read a tile or
// strip at a time. Every streamed map here is compared with the same file loaded into memory
// (and withRasterPyramid of it): level sizes, every pixel of every level byte for byte (the
// coarser levels made on demand and the first held level made band-wise against the in-memory
// reduction), the value range, random sub-rectangles and the CPU shading at random points. Then
// pyramidal files, errors found at load (a tile that does not decode, an infinite value, a label
// out of range), a file cut short after the load, concurrent reads, a host-made streamed level,
// and a map of 800 MB decoded (128 MB in a debug build) loaded within a small resident size.
#include <QElapsedTimer>
#include <QFileInfo>
#include <QRegularExpression>
#include <QTemporaryDir>
#include <QtTest>

#include <sys/types.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <set>
#include <thread>

#include "iris/layers.h"
#include "raster_writers.h"

using namespace iris;
namespace rw = raster_writers;

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
using Px = std::array<uint8_t, 4>;

int bppOf(RasterKind k) {
    return k == RasterKind::Label ? 2 : 4;
}

uint32_t mix(uint32_t x, uint32_t y, uint32_t s = 0) {
    uint32_t h = x * 0x9E3779B1u ^ (y + 0x7F4A7C15u) * 0x85EBCA77u ^ (s + 1) * 0xC2B2AE3Du;
    h ^= h >> 15;
    h *= 0x2C1B3C6Du;
    h ^= h >> 12;
    h *= 0x297A2D39u;
    h ^= h >> 15;
    return h;
}

// A test image of one kind: its pixels in the map's layout (float, uint16 or RGBA8) and the TIFF
// that stores them.
struct TestImage {
    RasterKind kind = RasterKind::Scalar;
    int32_t w = 0, h = 0;
    std::vector<uint8_t> pixels; // the map's layout
    float minV = 0, maxV = 0;
};

TestImage makeImage(RasterKind kind, int32_t w, int32_t h, uint32_t seed = 0) {
    TestImage im;
    im.kind = kind, im.w = w, im.h = h;
    const size_t n = size_t(w) * size_t(h);
    im.pixels.resize(n * size_t(bppOf(kind)));
    for (int32_t y = 0; y < h; ++y)
        for (int32_t x = 0; x < w; ++x) {
            const size_t i = size_t(y) * size_t(w) + size_t(x);
            const uint32_t ux = uint32_t(x), uy = uint32_t(y);
            switch (kind) {
            case RasterKind::Scalar: {
                float v = float(mix(ux, uy, seed) % 4096) / 64.0f - 10.0f + float(x % 200) * 0.05f;
                // Holes: a block (whole 2 × 2s and 4 × 4s: NaN in the coarser levels too) and
                // scattered pixels.
                if ((x >= 200 && x < 520 && y >= 300 && y < 420) || mix(ux, uy, seed + 1) % 53 == 0) v = kNaN;
                if (x == w - 1 && y == h - 1) v = 1234.5f;
                if (x == 3 && y == h - 1) v = -777.25f;
                std::memcpy(&im.pixels[4 * i], &v, 4);
                break;
            }
            case RasterKind::Label: {
                uint16_t id = uint16_t(((x / 40) + (y / 30) * 3) % 12);
                if (mix(ux, uy, seed + 2) % 17 == 0) id = uint16_t(mix(ux, uy, seed + 3) % 20);
                if (x == w - 1 && y == h - 1) id = 300;
                std::memcpy(&im.pixels[2 * i], &id, 2);
                break;
            }
            case RasterKind::Rgba: {
                uint8_t* p = &im.pixels[4 * i];
                p[0] = uint8_t(x & 255), p[1] = uint8_t(y & 255), p[2] = uint8_t(mix(ux, uy, seed + 4));
                p[3] = (x > 600 && x < 800) ? 255 : mix(ux, uy, seed + 5) % 4 == 0 ? 0 : uint8_t(mix(ux, uy, seed + 6));
                break;
            }
            }
        }
    return im;
}

rw::TiffImage tiffOf(const TestImage& im, uint32_t tile, uint32_t rowsPerStrip) {
    rw::TiffImage t;
    t.width = uint32_t(im.w), t.height = uint32_t(im.h);
    switch (im.kind) {
    case RasterKind::Scalar: t.spp = 1, t.bps = 32, t.format = SAMPLEFORMAT_IEEEFP; break;
    case RasterKind::Label: t.spp = 1, t.bps = 16, t.format = SAMPLEFORMAT_UINT; break;
    case RasterKind::Rgba: t.spp = 4, t.bps = 8, t.format = SAMPLEFORMAT_UINT, t.photometric = PHOTOMETRIC_RGB; break;
    }
    t.tile = tile;
    t.rowsPerStrip = rowsPerStrip;
    t.compression = COMPRESSION_ADOBE_DEFLATE;
    t.data = im.pixels;
    return t;
}

uint64_t levelBytes(RasterKind k, const RasterLevel& l) {
    return uint64_t(l.width) * uint64_t(l.height) * uint64_t(bppOf(k));
}

// The whole level read through readRasterRegion; empty (and a test failure) on an error.
std::vector<uint8_t> readLevel(const RasterMap& m, int level) {
    const RasterLevel& l = m.levels[size_t(level)];
    std::vector<uint8_t> out(size_t(levelBytes(m.kind, l)));
    const Result r = readRasterRegion(m, level, 0, 0, l.width, l.height, out.data());
    if (!r.ok()) {
        QTest::qFail(qPrintable(QString("reading level %1 whole: %2").arg(level).arg(QString::fromStdString(r.message()))),
                     __FILE__, __LINE__);
        return {};
    }
    return out;
}

// The held bytes of a held level (what the map holds, not through readRasterRegion).
std::vector<uint8_t> heldBytes(RasterKind k, const RasterLevel& l) {
    switch (k) {
    case RasterKind::Scalar: {
        std::vector<uint8_t> b(l.scalar.size() * 4);
        std::memcpy(b.data(), l.scalar.data(), b.size());
        return b;
    }
    case RasterKind::Label: {
        std::vector<uint8_t> b(l.label.size() * 2);
        std::memcpy(b.data(), l.label.data(), b.size());
        return b;
    }
    case RasterKind::Rgba: return l.rgba;
    }
    return {};
}

// The first pixel where two buffers of one level differ, for a message; "" when equal.
QString firstDifference(RasterKind k, const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, int32_t width) {
    if (a.size() != b.size()) return QString("sizes %1 and %2").arg(a.size()).arg(b.size());
    const size_t bpp = size_t(bppOf(k));
    for (size_t i = 0; i < a.size(); i += bpp)
        if (std::memcmp(&a[i], &b[i], bpp) != 0) {
            const size_t p = i / bpp;
            auto show = [&](const std::vector<uint8_t>& v) {
                if (k == RasterKind::Scalar) {
                    float f;
                    std::memcpy(&f, &v[i], 4);
                    return QString::number(double(f));
                }
                if (k == RasterKind::Label) {
                    uint16_t id;
                    std::memcpy(&id, &v[i], 2);
                    return QString::number(id);
                }
                return QString("%1,%2,%3,%4").arg(v[i]).arg(v[i + 1]).arg(v[i + 2]).arg(v[i + 3]);
            };
            return QString("pixel (%1, %2): %3 vs %4").arg(p % size_t(width)).arg(p / size_t(width)).arg(show(a), show(b));
        }
    return {};
}

// The rectangle (x, y, w, h) of a whole level's bytes.
std::vector<uint8_t> cut(const std::vector<uint8_t>& level, int32_t levelW, int bpp, int32_t x, int32_t y, int32_t w,
                         int32_t h) {
    std::vector<uint8_t> out(size_t(w) * size_t(h) * size_t(bpp));
    for (int32_t r = 0; r < h; ++r)
        std::memcpy(&out[size_t(r) * size_t(w) * size_t(bpp)],
                    &level[(size_t(y + r) * size_t(levelW) + size_t(x)) * size_t(bpp)], size_t(w) * size_t(bpp));
    return out;
}

bool sameValue(double a, double b) {
    return (std::isnan(a) && std::isnan(b)) || a == b;
}

// A failed load whose message names the file and matches `pattern`.
void expectError(const Expected<RasterMap>& m, Status status, const std::string& file, const QString& pattern) {
    QVERIFY2(!m.ok(), file.c_str());
    const QString msg = QString::fromStdString(m.error().message());
    QVERIFY2(m.error().status() == status, qPrintable(QString("%1: %2").arg(statusName(m.error().status()), msg)));
    QVERIFY2(msg.contains(QString::fromStdString(file)), qPrintable(msg));
    QVERIFY2(msg.contains(QRegularExpression(pattern)), qPrintable(msg + "  [wanted: " + pattern + "]"));
}

std::vector<LayerStyle> stylesFor(RasterKind k) {
    std::vector<LayerStyle> out;
    LayerStyle s;
    s.opacity = 1;
    if (k == RasterKind::Label) {
        s.classes = defaultLabelClasses(301);
        out.push_back(s);
        return out;
    }
    s.sampling = LayerSampling::Bilinear;
    out.push_back(s);
    s.sampling = LayerSampling::Nearest;
    if (k == RasterKind::Scalar) s.threshold = 5; // some values below: nothing
    out.push_back(s);
    return out;
}

// `streamed` against `held` (a map of held levels: the reference): the same levels and sizes,
// every level byte for byte, the range, random sub-rectangles and the shading at random points.
void compareWithHeld(const RasterMap& streamed, const RasterMap& held, uint32_t seed) {
    QCOMPARE(streamed.kind, held.kind);
    const auto sizes = [](const RasterMap& m) {
        QStringList out;
        for (const RasterLevel& l : m.levels) out << QString("%1x%2%3").arg(l.width).arg(l.height).arg(l.streamed() ? "s" : "");
        return out.join(' ');
    };
    QVERIFY2(streamed.levels.size() == held.levels.size(), qPrintable(sizes(streamed) + " vs " + sizes(held)));
    for (size_t k = 0; k < held.levels.size(); ++k) {
        QCOMPARE(streamed.levels[k].width, held.levels[k].width);
        QCOMPARE(streamed.levels[k].height, held.levels[k].height);
        QVERIFY(!held.levels[k].streamed());
    }
    QVERIFY2(sameValue(streamed.minValue, held.minValue),
             qPrintable(QString("min %1 vs %2").arg(streamed.minValue).arg(held.minValue)));
    QVERIFY2(sameValue(streamed.maxValue, held.maxValue),
             qPrintable(QString("max %1 vs %2").arg(streamed.maxValue).arg(held.maxValue)));
    QCOMPARE(streamed.decodedBytes(), held.decodedBytes());

    const int bpp = bppOf(held.kind);
    std::vector<std::vector<uint8_t>> ref(held.levels.size());
    for (size_t k = 0; k < held.levels.size(); ++k) {
        ref[k] = heldBytes(held.kind, held.levels[k]);
        const std::vector<uint8_t> viaRead = readLevel(held, int(k));
        QVERIFY(viaRead == ref[k]); // the held path of readRasterRegion
        const std::vector<uint8_t> s = readLevel(streamed, int(k));
        QVERIFY2(s == ref[k], qPrintable(QString("level %1 (%2x%3, %4): %5")
                                             .arg(k)
                                             .arg(held.levels[k].width)
                                             .arg(held.levels[k].height)
                                             .arg(streamed.levels[k].streamed() ? "streamed" : "held")
                                             .arg(firstDifference(held.kind, s, ref[k], held.levels[k].width))));
    }

    // Sub-rectangles: random ones, 1 × 1s, the edges, tile and strip borders.
    std::mt19937 rng(seed);
    for (size_t k = 0; k < held.levels.size(); ++k) {
        const int32_t W = held.levels[k].width, H = held.levels[k].height;
        std::vector<std::array<int32_t, 4>> rects = {
            {0, 0, 1, 1},         {W - 1, H - 1, 1, 1}, {W - 1, 0, 1, H},      {0, H - 1, W, 1},
            {250, 250, 12, 12},   {255, 0, 2, H},       {0, 36, W, 2},         {W - 7, H - 5, 7, 5},
            {W / 2, H / 2, 1, 1}, {1, 1, W - 2, H - 2}, {0, 0, W, 1},          {511, 511, 3, 3},
        };
        for (int i = 0; i < 60; ++i) {
            const int32_t w = 1 + int32_t(rng() % uint32_t(std::min(W, i % 3 == 0 ? 8 : 400)));
            const int32_t h = 1 + int32_t(rng() % uint32_t(std::min(H, i % 3 == 1 ? 8 : 400)));
            rects.push_back({int32_t(rng() % uint32_t(W - w + 1)), int32_t(rng() % uint32_t(H - h + 1)), w, h});
        }
        for (auto [x, y, w, h] : rects) {
            if (x < 0 || y < 0 || w < 1 || h < 1 || x + w > W || y + h > H) continue;
            std::vector<uint8_t> got(size_t(w) * size_t(h) * size_t(bpp), 0xcd);
            const Result r = readRasterRegion(streamed, int(k), x, y, w, h, got.data());
            QVERIFY2(r.ok(), r.message().c_str());
            QVERIFY2(got == cut(ref[k], W, bpp, x, y, w, h),
                     qPrintable(QString("level %1: the region %2x%3 at (%4, %5)").arg(k).arg(w).arg(h).arg(x).arg(y)));
        }
        // Outside the level: refused, not read.
        std::vector<uint8_t> one(16);
        QCOMPARE(readRasterRegion(streamed, int(k), W, 0, 1, 1, one.data()).status(), Status::InvalidArgument);
        QCOMPARE(readRasterRegion(streamed, int(k), 0, H - 1, 1, 2, one.data()).status(), Status::InvalidArgument);
        QCOMPARE(readRasterRegion(streamed, int(k), -1, 0, 1, 1, one.data()).status(), Status::InvalidArgument);
        QCOMPARE(readRasterRegion(streamed, int(k), 0, 0, 0, 1, one.data()).status(), Status::InvalidArgument);
    }
    std::vector<uint8_t> one(16);
    QCOMPARE(readRasterRegion(streamed, int(held.levels.size()), 0, 0, 1, 1, one.data()).status(),
             Status::InvalidArgument);

    // The CPU reference of the shading, at random points and several magnifications.
    const Placement id{};
    const int32_t W = held.width(), H = held.height();
    std::set<int> levelsSeen;
    for (const LayerStyle& style : stylesFor(held.kind)) {
        int drawn = 0, total = 0;
        for (double ds : {1.0, 1.7, 3.0, 8.0}) {
            const int level = chooseRasterLevel(held, id, ds);
            QCOMPARE(chooseRasterLevel(streamed, id, ds), level);
            levelsSeen.insert(level);
            // Random points, visited band by band as a view would (a streamed level keeps a few
            // blocks: in random order each tap would decode a tile again), and the corners.
            std::vector<std::pair<double, double>> points;
            for (int i = 0; i < 1000; ++i)
                points.push_back({std::uniform_real_distribution<double>(0, W)(rng),
                                  std::uniform_real_distribution<double>(0, H)(rng)});
            std::sort(points.begin(), points.end(), [](const auto& p, const auto& q) {
                return std::pair(int(p.second) / 64, p.first) < std::pair(int(q.second) / 64, q.first);
            });
            for (int i = 0; i < 4; ++i) points.push_back({(i & 1) ? W - 0.01 : 0.01, (i & 2) ? H - 0.01 : 0.01});
            for (auto [x, y] : points) {
                const Px a = shadeLayerAt(streamed, id, style, x, y, ds);
                const Px b = shadeLayerAt(held, id, style, x, y, ds);
                QVERIFY2(a == b, qPrintable(QString("(%1, %2) at downsample %3: %4,%5,%6,%7 vs %8,%9,%10,%11")
                                                .arg(x)
                                                .arg(y)
                                                .arg(ds)
                                                .arg(a[0])
                                                .arg(a[1])
                                                .arg(a[2])
                                                .arg(a[3])
                                                .arg(b[0])
                                                .arg(b[1])
                                                .arg(b[2])
                                                .arg(b[3])));
                drawn += b[3] != 0, ++total;
            }
        }
        QVERIFY2(drawn > total / 4, qPrintable(QString("only %1 of %2 drawn").arg(drawn).arg(total))); // not all nothing
    }
    QCOMPARE(int(levelsSeen.size()), int(held.levels.size())); // every level shaded
}

// The tiles (or strips) of a TIFF's first image: offset and byte count of each.
struct Chunk {
    uint64_t offset = 0, bytes = 0;
};
std::vector<Chunk> chunksOf(const std::string& path) {
    std::vector<Chunk> out;
    TIFF* tif = TIFFOpen(path.c_str(), "r");
    if (!tif) return out;
    const bool tiled = TIFFIsTiled(tif);
    uint64_t *offsets = nullptr, *counts = nullptr;
    TIFFGetField(tif, tiled ? TIFFTAG_TILEOFFSETS : TIFFTAG_STRIPOFFSETS, &offsets);
    TIFFGetField(tif, tiled ? TIFFTAG_TILEBYTECOUNTS : TIFFTAG_STRIPBYTECOUNTS, &counts);
    const uint32_t n = tiled ? TIFFNumberOfTiles(tif) : TIFFNumberOfStrips(tif);
    if (offsets && counts)
        for (uint32_t i = 0; i < n; ++i) out.push_back({offsets[i], counts[i]});
    TIFFClose(tif);
    return out;
}

bool overwrite(const std::string& path, uint64_t at, uint64_t n, uint8_t value) {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    if (!f) return false;
    f.seekp(std::streamoff(at));
    const std::vector<char> junk(n, char(value));
    f.write(junk.data(), std::streamsize(n));
    return bool(f);
}

// A host-made level computed from (x, y) on each read; counts its reads and any read outside.
class FnSource : public RasterPixelSource {
public:
    FnSource(int32_t w, int32_t h, std::function<float(int32_t, int32_t)> f) : w_(w), h_(h), f_(std::move(f)) {}
    Result read(int32_t x, int32_t y, int32_t w, int32_t h, void* out) const override {
        reads++;
        if (x < 0 || y < 0 || w <= 0 || h <= 0 || int64_t(x) + w > w_ || int64_t(y) + h > h_) {
            outside++;
            return Result(Status::InvalidArgument, "outside");
        }
        auto* o = static_cast<float*>(out);
        for (int32_t r = 0; r < h; ++r)
            for (int32_t c = 0; c < w; ++c) o[size_t(r) * size_t(w) + size_t(c)] = f_(x + c, y + r);
        return {};
    }
    mutable std::atomic<int64_t> reads{0}, outside{0};

private:
    int32_t w_, h_;
    std::function<float(int32_t, int32_t)> f_;
};

// The big label map: constant tiles of 256, a pattern in the first and the last tile.
struct BigLabels {
    int32_t W, H;
    uint16_t at(int32_t x, int32_t y) const {
        const int32_t tx = x / 256, ty = y / 256;
        if ((tx == (W - 1) / 256 && ty == (H - 1) / 256) || (tx == 0 && ty == 0))
            return uint16_t(100 + (x * 3 + y * 5) % 900);
        return uint16_t(1 + (tx * 7 + ty * 3) % 40);
    }
};

// withRasterPyramid's label rule, from the definition: the most frequent id of the 2 × 2
// (fewer at an odd edge), the smallest among equals.
uint16_t labelAtLevel(const BigLabels& g, const std::vector<std::pair<int32_t, int32_t>>& sizes, int k, int32_t x,
                      int32_t y) {
    if (k == 0) return g.at(x, y);
    uint16_t ids[4];
    int n = 0;
    for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx)
            if (2 * x + dx < sizes[size_t(k - 1)].first && 2 * y + dy < sizes[size_t(k - 1)].second)
                ids[n++] = labelAtLevel(g, sizes, k - 1, 2 * x + dx, 2 * y + dy);
    uint16_t best = 0;
    int bestCount = 0;
    for (int i = 0; i < n; ++i) {
        int c = 0;
        for (int j = 0; j < n; ++j) c += ids[j] == ids[i];
        if (c > bestCount || (c == bestCount && ids[i] < best)) best = ids[i], bestCount = c;
    }
    return best;
}

uint64_t peakRssBytes() {
    std::ifstream f("/proc/self/status");
    std::string line;
    while (std::getline(f, line))
        if (line.rfind("VmHWM:", 0) == 0) return uint64_t(std::stoull(line.substr(6))) * 1024;
    return 0;
}

} // namespace

class TestLayersStream : public QObject {
    Q_OBJECT

    QTemporaryDir dir_;
    std::string path(const std::string& file) const { return dir_.filePath(QString::fromStdString(file)).toStdString(); }

    // Writes `im` as a TIFF, loads it held and streamed (each streamAbove given) and compares.
    void streamAgainstHeld(const TestImage& im, uint32_t tile, uint32_t rowsPerStrip, const std::string& file) {
        QVERIFY(rw::writeTiff(path(file), {tiffOf(im, tile, rowsPerStrip)}));
        const bool labels = im.kind == RasterKind::Label;
        auto held = loadRasterMap(path(file), {.asLabels = labels});
        QVERIFY2(held.ok(), held.ok() ? "" : held.error().message().c_str());
        QVERIFY(!held->streamed()); // small: the default reads it into memory
        QCOMPARE(int(held->levels.size()), 1);
        QVERIFY(heldBytes(im.kind, held->levels[0]) == im.pixels); // the reference is the file's data
        const RasterMap pyramid = withRasterPyramid(*held);
        QVERIFY(std::max(pyramid.levels.back().width, pyramid.levels.back().height) <= 512);
        QVERIFY(pyramid.levels.size() >= 3);

        // 0: every level streamed (the coarser ones made on demand from the finer); 8 × the third
        // level's bytes: the third held, made band by band from the streamed second.
        const uint64_t l2 = levelBytes(im.kind, pyramid.levels[2]);
        for (uint64_t streamAbove : {uint64_t(0), 8 * l2}) {
            const QString what = QString("%1, streamAbove %2").arg(QString::fromStdString(file)).arg(streamAbove);
            auto s = loadRasterMap(path(file), {.asLabels = labels, .streamAbove = streamAbove});
            QVERIFY2(s.ok(), s.ok() ? "" : s.error().message().c_str());
            QVERIFY2(s->streamed(), qPrintable(what));
            QCOMPARE(s->kind, im.kind);
            QCOMPARE(s->title, file);
            const RasterLevel& l0 = s->levels[0];
            QVERIFY(l0.streamed());
            QVERIFY(l0.scalar.empty() && l0.label.empty() && l0.rgba.empty());
            QCOMPARE(l0.width, im.w);
            QCOMPARE(l0.height, im.h);
            // Streamed exactly the levels over streamAbove / 8 (at least 1 byte); held the rest.
            const uint64_t heldLimit = std::max<uint64_t>(streamAbove / 8, 1);
            uint64_t resident = 0;
            for (size_t k = 0; k < s->levels.size(); ++k) {
                const RasterLevel& l = s->levels[k];
                const bool big = levelBytes(im.kind, l) > heldLimit;
                QVERIFY2(l.streamed() == big, qPrintable(what + QString(": level %1").arg(k)));
                if (l.streamed()) QVERIFY(l.scalar.empty() && l.label.empty() && l.rgba.empty());
                else resident += levelBytes(im.kind, l);
            }
            QCOMPARE(s->residentBytes(), resident);
            if (streamAbove) QVERIFY(!s->levels[2].streamed());
            QVERIFY2(rasterMapProblem(*s).empty(), rasterMapProblem(*s).c_str());
            compareWithHeld(*s, pyramid, uint32_t(streamAbove) + uint32_t(im.w));
            if (QTest::currentTestFailed()) {
                qWarning("%s", qPrintable(what));
                return;
            }
            // withRasterPyramid leaves a map with levels as it is.
            QCOMPARE(withRasterPyramid(*s).levels.size(), s->levels.size());
        }
    }

private slots:
    void initTestCase() { QVERIFY(dir_.isValid()); }

    // A map far over the held limit, streamed, a few MB held (first, so that the process's peak
    // memory before it is low).
    void bigMapStaysSmall() {
        // 20000 × 20000 (800 MB decoded) with the default options in an optimised build; a
        // debug build decodes ~100 ns a pixel, so there it is 8000 × 8000 (128 MB) over a lowered
        // streamAbove of 64 MiB (32 MB and more streamed, 8 MB held).
#ifdef NDEBUG
        const int32_t W = 20000, H = 20000;
        const RasterLoadOptions options{.asLabels = true};
#else
        const int32_t W = 8000, H = 8000;
        const RasterLoadOptions options{.asLabels = true, .streamAbove = uint64_t(64) << 20};
#endif
        QVERIFY(uint64_t(W) * uint64_t(H) * 2 > options.streamAbove);
        const BigLabels g{W, H};
        const std::string file = path("big-labels.tif");
        QElapsedTimer timer;
        timer.start();
        int minId = 65536, maxId = -1;
        {
            TIFF* tif = TIFFOpen(file.c_str(), "w");
            QVERIFY(tif);
            TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, uint32_t(W));
            TIFFSetField(tif, TIFFTAG_IMAGELENGTH, uint32_t(H));
            TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, uint16_t(1));
            TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, uint16_t(16));
            TIFFSetField(tif, TIFFTAG_SAMPLEFORMAT, uint16_t(SAMPLEFORMAT_UINT));
            TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, uint16_t(PHOTOMETRIC_MINISBLACK));
            TIFFSetField(tif, TIFFTAG_PLANARCONFIG, uint16_t(PLANARCONFIG_CONTIG));
            TIFFSetField(tif, TIFFTAG_COMPRESSION, uint16_t(COMPRESSION_ADOBE_DEFLATE));
            TIFFSetField(tif, TIFFTAG_ZIPQUALITY, 1);
            TIFFSetField(tif, TIFFTAG_TILEWIDTH, uint32_t(256));
            TIFFSetField(tif, TIFFTAG_TILELENGTH, uint32_t(256));
            std::vector<uint16_t> tile(256 * 256);
            bool ok = true;
            for (int32_t ty = 0; ty < H && ok; ty += 256)
                for (int32_t tx = 0; tx < W && ok; tx += 256) {
                    const bool constant = g.at(tx, ty) < 100; // not a pattern tile
                    if (constant) std::fill(tile.begin(), tile.end(), g.at(tx, ty));
                    for (int32_t y = 0; y < 256; ++y)
                        for (int32_t x = 0; x < 256; ++x) {
                            const bool in = tx + x < W && ty + y < H;
                            if (constant && in) continue;
                            const uint16_t v = in ? g.at(tx + x, ty + y) : 0;
                            tile[size_t(y) * 256 + size_t(x)] = v;
                            if (in) minId = std::min<int>(minId, v), maxId = std::max<int>(maxId, v);
                        }
                    if (constant) minId = std::min<int>(minId, tile[0]), maxId = std::max<int>(maxId, tile[0]);
                    ok = TIFFWriteTile(tif, tile.data(), uint32_t(tx), uint32_t(ty), 0, 0) >= 0;
                }
            TIFFClose(tif);
            QVERIFY(ok);
        }
        const qint64 writeMs = timer.restart();
        QVERIFY(QFileInfo(QString::fromStdString(file)).size() < (qint64(64) << 20));

        const uint64_t rssBefore = peakRssBytes();
        auto m = loadRasterMap(file, options);
        const qint64 loadMs = timer.restart();
        QVERIFY2(m.ok(), m.ok() ? "" : m.error().message().c_str());
        const uint64_t rssGrowth = peakRssBytes() - rssBefore;
        qInfo("write %lld ms, load %lld ms, peak RSS grew %llu MiB; %zu levels, resident %llu bytes", writeMs, loadMs,
              (unsigned long long)(rssGrowth >> 20), m->levels.size(), (unsigned long long)m->residentBytes());
        QVERIFY(m->streamed());
        QVERIFY(m->levels[0].streamed());
        QCOMPARE(m->width(), W);
        QVERIFY(m->decodedBytes() >= uint64_t(W) * uint64_t(H) * 2);
        QVERIFY(m->residentBytes() < (uint64_t(40) << 20));
        QVERIFY(m->residentBytes() > 0); // the small levels are held
        QVERIFY(std::max(m->levels.back().width, m->levels.back().height) <= 512);
        // The process's peak grew by far less than the map (the caches: 64 MiB for the file's
        // level and 32 MiB for each streamed coarser one; meaningful for the large map only).
        if (m->decodedBytes() > (uint64_t(512) << 20))
            QVERIFY2(rssGrowth < m->decodedBytes() / 2,
                     qPrintable(QString("peak RSS grew by %1 MiB").arg(rssGrowth >> 20)));
        QCOMPARE(m->minValue, double(minId));
        QCOMPARE(m->maxValue, double(maxId));
        QVERIFY(rasterMapProblem(*m).empty());

        std::vector<std::pair<int32_t, int32_t>> sizes;
        for (const RasterLevel& l : m->levels) sizes.push_back({l.width, l.height});
        for (size_t k = 1; k < sizes.size(); ++k) {
            QCOMPARE(sizes[k].first, (sizes[k - 1].first + 1) / 2);
            QCOMPARE(sizes[k].second, (sizes[k - 1].second + 1) / 2);
        }

        // The far corner, and the first tile.
        std::vector<uint16_t> got(300 * 300);
        for (auto [x0, y0] : {std::pair{W - 300, H - 300}, std::pair{0, 0}}) {
            QVERIFY(readRasterRegion(*m, 0, x0, y0, 300, 300, got.data()).ok());
            for (int32_t y = 0; y < 300; ++y)
                for (int32_t x = 0; x < 300; ++x)
                    QCOMPARE(got[size_t(y) * 300 + size_t(x)], g.at(x0 + x, y0 + y));
        }
        // Every level at a few points, against the rule from its definition.
        std::mt19937 rng(71);
        for (size_t k = 0; k < sizes.size(); ++k)
            for (int i = 0; i < 30; ++i) {
                const int32_t x = i == 0 ? sizes[k].first - 1 : int32_t(rng() % uint32_t(sizes[k].first));
                const int32_t y = i == 0 ? sizes[k].second - 1 : int32_t(rng() % uint32_t(sizes[k].second));
                uint16_t v = 0;
                QVERIFY(readRasterRegion(*m, int(k), x, y, 1, 1, &v).ok());
                QCOMPARE(v, labelAtLevel(g, sizes, int(k), x, y));
            }

        // Four threads over far-apart regions of the three finest levels: more tiles than the
        // caches keep, so blocks are evicted and produced again while others read.
        std::atomic<int> failures{0}, mismatches{0};
        std::vector<std::thread> threads;
        for (int t = 0; t < 4; ++t)
            threads.emplace_back([&, t] {
                std::mt19937 r(uint32_t(700 + t));
                std::vector<uint16_t> buf;
                for (int i = 0; i < 30; ++i) {
                    const int k = int(r() % 3);
                    const int32_t w = 1 + int32_t(r() % 400), h = 1 + int32_t(r() % 400);
                    const int32_t x = int32_t(r() % uint32_t(sizes[size_t(k)].first - w + 1));
                    const int32_t y = int32_t(r() % uint32_t(sizes[size_t(k)].second - h + 1));
                    buf.assign(size_t(w) * size_t(h), 0);
                    if (!readRasterRegion(*m, k, x, y, w, h, buf.data()).ok()) {
                        ++failures;
                        continue;
                    }
                    // A sample of the pixels against the rule.
                    const int step = k == 0 ? 3 : 7;
                    for (int32_t yy = 0; yy < h; yy += step)
                        for (int32_t xx = 0; xx < w; xx += step)
                            if (buf[size_t(yy) * size_t(w) + size_t(xx)] != labelAtLevel(g, sizes, k, x + xx, y + yy)) {
                                ++mismatches;
                                yy = h;
                                break;
                            }
                }
            });
        for (auto& t : threads) t.join();
        QCOMPARE(failures.load(), 0);
        QCOMPARE(mismatches.load(), 0);
        qInfo("checks %lld ms", timer.elapsed());
    }

    // Each kind, tiled and stripped, streamed against held.
    void streamedEqualsHeld_data() {
        QTest::addColumn<int>("kind");
        QTest::addColumn<bool>("tiled");
        for (RasterKind k : {RasterKind::Scalar, RasterKind::Label, RasterKind::Rgba})
            for (bool tiled : {true, false})
                QTest::newRow(qPrintable(QString("%1 %2").arg(QString::fromLatin1(rasterKindName(k)), QString::fromLatin1(tiled ? "tiles" : "strips"))))
                    << int(k) << tiled;
    }
    void streamedEqualsHeld() {
        QFETCH(int, kind);
        QFETCH(bool, tiled);
        const RasterKind k = RasterKind(kind);
        const TestImage im = tiled ? makeImage(k, 1500, 1100) : makeImage(k, 1499, 1101, 7);
        streamAgainstHeld(im, tiled ? 256 : 0, 37,
                          std::string(rasterKindName(k)) + (tiled ? "-tiles" : "-strips") + ".tif");
    }

    // A pyramidal file: its levels used as they are, SubIFDs or a chain of IFDs; one that
    // stops above 512 a side is extended below its last level.
    void pyramidFile() {
        const TestImage a = makeImage(RasterKind::Scalar, 1500, 1100, 11);
        const TestImage b = makeImage(RasterKind::Scalar, 740, 545, 12); // not /2: the file's sizes count
        const TestImage c = makeImage(RasterKind::Scalar, 370, 270, 13);
        const std::vector<rw::TiffImage> levels = {tiffOf(a, 256, 0), tiffOf(b, 128, 0), tiffOf(c, 0, 16)};
        QVERIFY(rw::writeTiff(path("pyr-sub.tif"), levels, true));
        QVERIFY(rw::writeTiff(path("pyr-chain.tif"), levels, false, true));
        for (const char* file : {"pyr-sub.tif", "pyr-chain.tif"}) {
            auto held = loadRasterMap(path(file));
            QVERIFY2(held.ok(), held.ok() ? file : held.error().message().c_str());
            QCOMPARE(int(held->levels.size()), 3);
            QVERIFY(heldBytes(RasterKind::Scalar, held->levels[1]) == b.pixels);
            const uint64_t l2 = uint64_t(370) * 270 * 4;
            for (uint64_t streamAbove : {uint64_t(0), 8 * l2}) {
                auto s = loadRasterMap(path(file), {.streamAbove = streamAbove});
                QVERIFY2(s.ok(), s.ok() ? file : s.error().message().c_str());
                QVERIFY(s->levels[0].streamed());
                QVERIFY(s->levels[1].streamed());
                QCOMPARE(s->levels[2].streamed(), streamAbove == 0);
                QCOMPARE(s->levels[1].width, 740);
                QCOMPARE(s->levels[1].height, 545);
                QCOMPARE(s->levels[2].width, 370);
                compareWithHeld(*s, *held, 99);
                if (QTest::currentTestFailed()) {
                    qWarning("%s, streamAbove %llu", file, (unsigned long long)streamAbove);
                    return;
                }
            }
        }

        // Labels in two levels, the last over 512: the streamed map adds 525 × 325 and 263 × 163 below
        // it (as withRasterPyramid of that level alone would), the held load takes the file as it is.
        const TestImage la = makeImage(RasterKind::Label, 2100, 1300, 21);
        const TestImage lb = makeImage(RasterKind::Label, 1050, 650, 22);
        QVERIFY(rw::writeTiff(path("pyr-labels.tif"), {tiffOf(la, 512, 0), tiffOf(lb, 0, 50)}, true));
        auto held = loadRasterMap(path("pyr-labels.tif"), {.asLabels = true});
        QVERIFY(held.ok());
        QCOMPARE(int(held->levels.size()), 2);
        auto last = fromHostMemory(std::span<const uint16_t>(held->levels[1].label), 1050, 650);
        QVERIFY(last.ok());
        RasterMap want = *held;
        const RasterMap below = withRasterPyramid(*last);
        QCOMPARE(int(below.levels.size()), 3);
        want.levels.push_back(below.levels[1]);
        want.levels.push_back(below.levels[2]);
        QCOMPARE(want.levels[2].width, 525);
        QCOMPARE(want.levels[2].height, 325);
        QCOMPARE(want.levels[3].width, 263);
        auto s = loadRasterMap(path("pyr-labels.tif"), {.asLabels = true, .streamAbove = 1});
        QVERIFY2(s.ok(), s.ok() ? "" : s.error().message().c_str());
        QVERIFY(s->levels[0].streamed() && s->levels[1].streamed());
        compareWithHeld(*s, want, 5);
    }

    // A file that does not hold up is refused at the load, naming the file and the place.
    void errorsAtLoad() {
        // A tile in the middle that does not decode (its deflate bytes overwritten).
        const TestImage f = makeImage(RasterKind::Scalar, 1500, 1100, 31);
        QVERIFY(rw::writeTiff(path("bad-tile.tif"), {tiffOf(f, 256, 0)}));
        const std::vector<Chunk> tiles = chunksOf(path("bad-tile.tif"));
        QCOMPARE(int(tiles.size()), 6 * 5);
        const int bad = 2 * 6 + 3; // tile (3, 2): pixels from (768, 512)
        QVERIFY(overwrite(path("bad-tile.tif"), tiles[bad].offset, std::min<uint64_t>(tiles[bad].bytes, 64), 0xff));
        for (uint64_t streamAbove : {uint64_t(0), uint64_t(1) << 20})
            expectError(loadRasterMap(path("bad-tile.tif"), {.streamAbove = streamAbove}), Status::CorruptData,
                        path("bad-tile.tif"), R"(the tile at \(768, 512\) does not decode)");
        expectError(loadRasterMap(path("bad-tile.tif")), Status::CorruptData, path("bad-tile.tif"),
                    R"(the tile at \(768, 512\) does not decode)"); // the held reader says the same
        // A strip.
        const TestImage g = makeImage(RasterKind::Label, 1499, 1101, 32);
        QVERIFY(rw::writeTiff(path("bad-strip.tif"), {tiffOf(g, 0, 37)}));
        const std::vector<Chunk> strips = chunksOf(path("bad-strip.tif"));
        QCOMPARE(int(strips.size()), (1101 + 36) / 37);
        QVERIFY(overwrite(path("bad-strip.tif"), strips[10].offset, 64, 0xff));
        for (uint64_t streamAbove : {uint64_t(0), uint64_t(1) << 20})
            expectError(loadRasterMap(path("bad-strip.tif"), {.asLabels = true, .streamAbove = streamAbove}),
                        Status::CorruptData, path("bad-strip.tif"), R"(the strip at \(0, 370\) does not decode)");

        // An infinite value in the middle of a streamed level: the pixel named, as the held
        // reader names it.
        TestImage inf = makeImage(RasterKind::Scalar, 1500, 1100, 33);
        const float infinity = -std::numeric_limits<float>::infinity();
        std::memcpy(&inf.pixels[4 * (size_t(555) * 1500 + 777)], &infinity, 4);
        QVERIFY(rw::writeTiff(path("inf.tif"), {tiffOf(inf, 256, 0)}));
        QVERIFY(rw::writeTiff(path("inf-strips.tif"), {tiffOf(inf, 0, 37)}));
        for (const char* file : {"inf.tif", "inf-strips.tif"}) {
            for (uint64_t streamAbove : {uint64_t(0), uint64_t(1) << 20})
                expectError(loadRasterMap(path(file), {.streamAbove = streamAbove}), Status::CorruptData, path(file),
                            R"(an infinite value at \(777, 555\))");
            expectError(loadRasterMap(path(file)), Status::CorruptData, path(file), R"(an infinite value at \(777, 555\))");
        }

        // A label out of 0..65535 (32-bit integers taken as labels).
        rw::TiffImage big{1300, 900, 1, 32, SAMPLEFORMAT_UINT};
        std::vector<uint32_t> ids(size_t(1300) * 900);
        for (size_t i = 0; i < ids.size(); ++i) ids[i] = mix(uint32_t(i), 1) % 30;
        ids[size_t(666) * 1300 + 1001] = 70000;
        big.data = rw::rawBytes(ids);
        big.tile = 128, big.compression = COMPRESSION_ADOBE_DEFLATE;
        QVERIFY(rw::writeTiff(path("label-range.tif"), {big}));
        for (uint64_t streamAbove : {uint64_t(0), uint64_t(1) << 20})
            expectError(loadRasterMap(path("label-range.tif"), {.asLabels = true, .streamAbove = streamAbove}),
                        Status::CorruptData, path("label-range.tif"), R"(label 70000 at \(1001, 666\))");
        expectError(loadRasterMap(path("label-range.tif"), {.asLabels = true}), Status::CorruptData,
                    path("label-range.tif"), R"(label 70000 at \(1001, 666\))");
        // The same file without the bad value streams.
        ids[size_t(666) * 1300 + 1001] = 7;
        big.data = rw::rawBytes(ids);
        QVERIFY(rw::writeTiff(path("label-ok.tif"), {big}));
        auto ok = loadRasterMap(path("label-ok.tif"), {.asLabels = true, .streamAbove = 0});
        QVERIFY2(ok.ok(), ok.ok() ? "" : ok.error().message().c_str());
        QVERIFY(ok->streamed());
        QCOMPARE(ok->minValue, 0.0);
        QCOMPARE(ok->maxValue, 29.0);
    }

    // The file cut short after the load: what is lost reads as an error, never a crash;
    // the shading draws nothing there.
    void fileChangedAfterLoad() {
        const TestImage im = makeImage(RasterKind::Scalar, 1500, 1100, 41);
        const std::string file = path("cut-later.tif");
        QVERIFY(rw::writeTiff(file, {tiffOf(im, 256, 0)}));
        auto held = loadRasterMap(file);
        QVERIFY(held.ok());
        const RasterMap pyramid = withRasterPyramid(*held);
        auto s = loadRasterMap(file, {.streamAbove = 0});
        QVERIFY2(s.ok(), s.ok() ? "" : s.error().message().c_str());
        QCOMPARE(int(s->levels.size()), 3);
        const std::vector<Chunk> tiles = chunksOf(file);
        QCOMPARE(int(tiles.size()), 30);
        const uint64_t size = QFileInfo(QString::fromStdString(file)).size();
        const uint64_t half = size / 2;
        QVERIFY(tiles[0].offset + tiles[0].bytes <= half && tiles[1].offset + tiles[1].bytes <= half);
        QVERIFY(tiles[29].offset >= half && tiles[28].offset >= half);
        const std::vector<uint8_t> ref0 = heldBytes(RasterKind::Scalar, pyramid.levels[0]);

        // Read before the cut (cached).
        std::vector<uint8_t> got(100 * 100 * 4);
        QVERIFY(readRasterRegion(*s, 0, 10, 10, 100, 100, got.data()).ok());
        QVERIFY(got == cut(ref0, 1500, 4, 10, 10, 100, 100));

        QCOMPARE(::truncate(file.c_str(), off_t(half)), 0);

        // The lost half: tiles 28 and 29 (x from 1024, y from 1024), and the coarser levels over them.
        for (int pass = 0; pass < 2; ++pass) { // the error is not remembered as pixels
            const Result r = readRasterRegion(*s, 0, 1400, 1050, 100, 50, got.data());
            QVERIFY(!r.ok());
            QVERIFY2(QString::fromStdString(r.message()).contains(QString::fromStdString(file)), r.message().c_str());
            QVERIFY2(QString::fromStdString(r.message()).contains("(1280, 1024)"), r.message().c_str());
            QVERIFY(!readRasterRegion(*s, 1, 700, 520, 50, 30, got.data()).ok());
            QVERIFY(!readRasterRegion(*s, 2, 370, 270, 5, 5, got.data()).ok());
        }
        // The kept half: what was read before, and tile (1, 0) read for the first time.
        QVERIFY(readRasterRegion(*s, 0, 10, 10, 100, 100, got.data()).ok());
        QVERIFY(got == cut(ref0, 1500, 4, 10, 10, 100, 100));
        QVERIFY(readRasterRegion(*s, 0, 300, 20, 50, 50, got.data()).ok());
        QVERIFY(cut(got, 50, 4, 0, 0, 50, 50) == cut(ref0, 1500, 4, 300, 20, 50, 50));

        // The shading draws nothing where the pixels are lost (the held map draws something).
        LayerStyle st;
        st.opacity = 1;
        st.sampling = LayerSampling::Nearest;
        int checked = 0;
        for (int i = 0; i < 200 && checked < 20; ++i) {
            const double x = 1300.5 + i, y = 1060.5 + (i % 30);
            if (x >= 1500) break;
            for (double ds : {1.0, 3.0}) {
                if (shadeLayerAt(pyramid, {}, st, x, y, ds)[3] == 0) continue;
                QCOMPARE(shadeLayerAt(*s, {}, st, x, y, ds), (Px{0, 0, 0, 0}));
                ++checked;
            }
        }
        QVERIFY(checked >= 10);
        // … and still draws the kept half as before.
        QCOMPARE(shadeLayerAt(*s, {}, st, 50.5, 50.5, 1), shadeLayerAt(pyramid, {}, st, 50.5, 50.5, 1));
    }

    // Concurrent reads of one streamed map, from blocks nobody has read yet: all equal the held data.
    void concurrentReads() {
        for (RasterKind k : {RasterKind::Scalar, RasterKind::Rgba}) {
            const TestImage im = makeImage(k, 1500, 1100, 51);
            const std::string file = path(std::string("threads-") + rasterKindName(k) + ".tif");
            QVERIFY(rw::writeTiff(file, {tiffOf(im, k == RasterKind::Scalar ? 256 : 0, 37)}));
            auto held = loadRasterMap(file);
            QVERIFY(held.ok());
            const RasterMap pyramid = withRasterPyramid(*held);
            auto s = loadRasterMap(file, {.streamAbove = 0});
            QVERIFY(s.ok());
            QCOMPARE(s->levels.size(), pyramid.levels.size());
            std::vector<std::vector<uint8_t>> ref;
            for (const RasterLevel& l : pyramid.levels) ref.push_back(heldBytes(k, l));
            const int bpp = bppOf(k);
            std::atomic<int> failures{0}, mismatches{0};
            std::atomic<int64_t> pixels{0};
            std::vector<std::thread> threads;
            for (int t = 0; t < 4; ++t)
                threads.emplace_back([&, t] {
                    std::mt19937 rng(uint32_t(1000 + t));
                    std::vector<uint8_t> buf;
                    for (int i = 0; i < 400; ++i) {
                        const int level = int(rng() % uint32_t(ref.size()));
                        const int32_t W = pyramid.levels[size_t(level)].width, H = pyramid.levels[size_t(level)].height;
                        const int32_t w = 1 + int32_t(rng() % uint32_t(std::min(W, 300)));
                        const int32_t h = 1 + int32_t(rng() % uint32_t(std::min(H, 300)));
                        const int32_t x = int32_t(rng() % uint32_t(W - w + 1)), y = int32_t(rng() % uint32_t(H - h + 1));
                        buf.assign(size_t(w) * size_t(h) * size_t(bpp), 0);
                        if (!readRasterRegion(*s, level, x, y, w, h, buf.data()).ok()) {
                            ++failures;
                            continue;
                        }
                        if (buf != cut(ref[size_t(level)], W, bpp, x, y, w, h)) ++mismatches;
                        pixels += int64_t(w) * h;
                    }
                });
            for (auto& t : threads) t.join();
            QCOMPARE(failures.load(), 0);
            QCOMPARE(mismatches.load(), 0);
            QVERIFY(pixels.load() > 1000000);
        }
    }

    // A host's streamed level: scanned for its range and its values, and a pyramid made
    // from it equal to the one made from the same data held.
    void hostStreamedLevel() {
        const auto value = [](int32_t x, int32_t y) {
            if ((x / 97 + y / 89) % 11 == 0 || mix(uint32_t(x), uint32_t(y), 61) % 29 == 0) return kNaN;
            return float(int((uint32_t(x) * 7u + uint32_t(y) * 13u + mix(uint32_t(x), uint32_t(y), 62) % 50u) % 1000u)) *
                       0.01f -
                   2.0f;
        };
        const int32_t W = 3000, H = 2000;
        auto src = std::make_shared<FnSource>(W, H, value);
        RasterLevel l;
        l.width = W, l.height = H, l.source = src;
        auto m = fromHostMemory(RasterKind::Scalar, {l}, "host");
        QVERIFY2(m.ok(), m.ok() ? "" : m.error().message().c_str());
        QVERIFY(src->reads.load() > 0); // scanned
        std::vector<float> all(size_t(W) * size_t(H));
        for (int32_t y = 0; y < H; ++y)
            for (int32_t x = 0; x < W; ++x) all[size_t(y) * size_t(W) + size_t(x)] = value(x, y);
        auto held = fromHostMemory(std::span<const float>(all), W, H);
        QVERIFY(held.ok());
        QCOMPARE(m->minValue, held->minValue);
        QCOMPARE(m->maxValue, held->maxValue);
        QCOMPARE(m->minValue, -2.0);
        QVERIFY(m->streamed());
        QCOMPARE(m->residentBytes(), uint64_t(0));
        const RasterMap sp = withRasterPyramid(*m);
        const RasterMap hp = withRasterPyramid(*held);
        QCOMPARE(int(sp.levels.size()), 4); // 3000, 1500, 750, 375
        QVERIFY(!sp.levels[1].streamed()); // 6 MB: held, made from the source band by band
        compareWithHeld(sp, hp, 61);
        if (QTest::currentTestFailed()) return;
        QCOMPARE(src->outside.load(), int64_t(0));

        // An infinite value anywhere in it: refused, naming the pixel.
        for (auto [ix, iy] : {std::pair{1234, 1777}, std::pair{2999, 1999}, std::pair{0, 0}}) {
            auto infSrc = std::make_shared<FnSource>(W, H, [&value, ix = ix, iy = iy](int32_t x, int32_t y) {
                return x == ix && y == iy ? std::numeric_limits<float>::infinity() : value(x, y);
            });
            RasterLevel bad;
            bad.width = W, bad.height = H, bad.source = infSrc;
            auto r = fromHostMemory(RasterKind::Scalar, {bad});
            QVERIFY(!r.ok());
            QCOMPARE(r.error().status(), Status::InvalidArgument);
            const QString msg = QString::fromStdString(r.error().message());
            QVERIFY2(msg.contains(QString("an infinite value at (%1, %2)").arg(ix).arg(iy)), qPrintable(msg));
        }
        // A streamed level that holds pixels too, or of the wrong kind's size: not a map.
        RasterLevel both = l;
        both.scalar.assign(size_t(W) * size_t(H), 0.f);
        QCOMPARE(fromHostMemory(RasterKind::Scalar, {both}).error().status(), Status::InvalidArgument);

        // Large enough that the coarser level is streamed as well (over 32 MiB): 8200 × 4200,
        // its second level 4100 × 2100 made on demand, the third held. Checked against the rule.
        const int32_t BW = 8200, BH = 4200;
        auto bigSrc = std::make_shared<FnSource>(BW, BH, value);
        RasterLevel bl;
        bl.width = BW, bl.height = BH, bl.source = bigSrc;
        auto bm = fromHostMemory(RasterKind::Scalar, {bl});
        QVERIFY(bm.ok());
        const RasterMap bp = withRasterPyramid(*bm);
        QVERIFY(bp.levels[1].streamed());
        QVERIFY(!bp.levels[2].streamed());
        QCOMPARE(bp.levels[2].width, 2050);
        QVERIFY(std::max(bp.levels.back().width, bp.levels.back().height) <= 512);
        QVERIFY(bp.residentBytes() < (uint64_t(12) << 20));
        const auto reduce = [](const float* v, int n) {
            double sum = 0;
            int m = 0;
            for (int i = 0; i < n; ++i)
                if (!std::isnan(v[i])) sum += v[i], ++m;
            return m ? float(sum / m) : kNaN;
        };
        const auto level1 = [&](int32_t x, int32_t y) {
            float v[4];
            int n = 0;
            for (int dy = 0; dy < 2; ++dy)
                for (int dx = 0; dx < 2; ++dx) v[n++] = value(2 * x + dx, 2 * y + dy);
            return reduce(v, n);
        };
        std::mt19937 rng(62);
        for (int i = 0; i < 40; ++i) {
            const int32_t x = int32_t(rng() % (4100 - 64)), y = int32_t(rng() % (2100 - 64));
            std::vector<float> got(64 * 64);
            QVERIFY(readRasterRegion(bp, 1, x, y, 64, 64, got.data()).ok());
            for (int32_t r = 0; r < 64; ++r)
                for (int32_t c = 0; c < 64; ++c) {
                    const float want = level1(x + c, y + r), g = got[size_t(r) * 64 + size_t(c)];
                    QVERIFY2(std::memcmp(&want, &g, 4) == 0, qPrintable(QString("level 1 (%1, %2): %3 vs %4")
                                                                            .arg(x + c)
                                                                            .arg(y + r)
                                                                            .arg(double(g))
                                                                            .arg(double(want))));
                }
            const int32_t x2 = x / 2, y2 = y / 2;
            float v[4] = {level1(2 * x2, 2 * y2), level1(2 * x2 + 1, 2 * y2), level1(2 * x2, 2 * y2 + 1),
                          level1(2 * x2 + 1, 2 * y2 + 1)};
            const float want2 = reduce(v, 4), got2 = bp.levels[2].scalar[size_t(y2) * 2050 + size_t(x2)];
            QVERIFY(std::memcmp(&want2, &got2, 4) == 0);
        }
        QCOMPARE(bigSrc->outside.load(), int64_t(0));
    }

};

QTEST_APPLESS_MAIN(TestLayersStream)
#include "tst_layers_stream.moc"
