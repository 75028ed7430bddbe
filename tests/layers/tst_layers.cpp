// Raster layers (iris/layers.h): the loaders over files of every format and sample type written
// here (libpng, libtiff, .npy by hand), malformed and hostile files each with the error it must
// give, the built-in colour maps' known entries and user LUTs, and the CPU reference of the
// shading (level pick, sampling, NaN, threshold, window, colour-map interpolation, opacity,
// label classes, RGBA maps, placement with rotation, the placed rectangle, the blend).
#include <QtTest>

#include <cmath>
#include <limits>
#include <unistd.h>

#include "iris/layers.h"
#include "raster_writers.h"

using namespace iris;
namespace rw = raster_writers;

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
using Px = std::array<uint8_t, 4>;

std::string outDir() {
    static const std::string dir = [] {
        QByteArray base = qgetenv("IRIS_TEST_OUT");
        std::string d = (base.isEmpty() ? std::string("/tmp") : base.toStdString()) + "/layers-" + std::to_string(getpid());
        QDir().mkpath(QString::fromStdString(d));
        return d;
    }();
    return dir;
}
std::string out(const std::string& file) {
    return outDir() + "/" + file;
}

// A failed load whose message names the file and matches `pattern`.
void expectError(const Expected<RasterMap>& m, Status status, const std::string& file, const char* pattern) {
    QVERIFY2(!m.ok(), file.c_str());
    const QString msg = QString::fromStdString(m.error().message());
    QVERIFY2(m.error().status() == status, qPrintable(QString("%1: %2").arg(statusName(m.error().status()), msg)));
    QVERIFY2(msg.contains(QString::fromStdString(file)), qPrintable(msg));
    QVERIFY2(msg.contains(QRegularExpression(pattern)), qPrintable(msg));
}

Expected<RasterMap> loadNpy(const std::string& file, const std::vector<uint8_t>& bytes, RasterLoadOptions o = {}) {
    rw::writeBytes(out(file), bytes);
    return loadRasterMap(out(file), o);
}

RasterMap scalarMap(std::vector<float> v, int w, int h) {
    auto m = fromHostMemory(std::span<const float>(v), w, h);
    return std::move(m).value();
}

// Sets a single-valued entry of IFD number `dir` of a little-endian classic TIFF (its main
// chain) to a LONG `value`.
bool patchTiffTag(std::vector<uint8_t>& tiff, unsigned tag, uint32_t value, int dir = 0) {
    auto u32 = [&](size_t at) { return tiff[at] | tiff[at + 1] << 8 | tiff[at + 2] << 16 | uint32_t(tiff[at + 3]) << 24; };
    uint32_t ifd = u32(4);
    for (int d = 0; d < dir; ++d) ifd = u32(ifd + 2 + 12 * size_t(tiff[ifd] | tiff[ifd + 1] << 8));
    const unsigned n = tiff[ifd] | tiff[ifd + 1] << 8;
    for (unsigned e = 0; e < n; ++e) {
        uint8_t* p = &tiff[ifd + 2 + 12 * e];
        if ((p[0] | p[1] << 8) == int(tag)) {
            p[2] = 4, p[3] = 0; // LONG
            std::memcpy(p + 8, &value, 4);
            return true;
        }
    }
    return false;
}

// Opaque grey map, opacity 1, window 0..255: the colour is the value rounded (tests the chain).
LayerStyle greyStyle() {
    LayerStyle s;
    s.colorMap = ColorMap::gray();
    s.opacity = 1;
    s.low = 0, s.high = 255;
    return s;
}

} // namespace

class TestLayers : public QObject {
    Q_OBJECT

private slots:

    // withRasterPyramid: halves until the coarsest side is at most the bound; scalar means skip
    // NaN, labels take the most frequent id (the smallest among equals), RGBA averages
    // premultiplied; odd edges average what they cover; a map with levels is left alone.
    void pyramidOfOneLevel() {
        // Scalar 5 × 3: the last column and row cover fewer pixels.
        const float nan = std::numeric_limits<float>::quiet_NaN();
        std::vector<float> v{1, 3, nan, nan, 7,   //
                             5, 7, nan, nan, 9,   //
                             2, 4, 6, 8, 10};
        auto m = iris::fromHostMemory(std::span<const float>(v), 5, 3);
        QVERIFY(m.ok());
        const iris::RasterMap p = iris::withRasterPyramid(*m, 1);
        QCOMPARE(int(p.levels.size()), 4); // 5x3, 3x2, 2x1, 1x1
        QCOMPARE(p.levels[1].width, 3);
        QCOMPARE(p.levels[1].height, 2);
        QCOMPARE(p.levels[1].scalar[0], 4.0f);       // (1 + 3 + 5 + 7) / 4
        QVERIFY(std::isnan(p.levels[1].scalar[1]));  // all four NaN
        QCOMPARE(p.levels[1].scalar[2], 8.0f);       // (7 + 9) / 2
        QCOMPARE(p.levels[1].scalar[3], 3.0f);       // (2 + 4) / 2
        QCOMPARE(p.levels[1].scalar[4], 7.0f);       // (6 + 8) / 2
        QCOMPARE(p.levels[3].width, 1);
        QVERIFY(iris::rasterMapProblem(p).empty());
        QCOMPARE(int(iris::withRasterPyramid(*m, 5).levels.size()), 1); // already within the bound
        QCOMPARE(int(iris::withRasterPyramid(p, 1).levels.size()), 4);  // levels given: as it is
        // Labels: 2 × 2 of {1, 2, 2, 1} → 1 (a tie, the smallest); {3, 3, 3, 0} → 3.
        std::vector<uint16_t> l{1, 2, 3, 3, 2, 1, 3, 0};
        auto lm = iris::fromHostMemory(std::span<const uint16_t>(l), 4, 2);
        QVERIFY(lm.ok());
        const iris::RasterMap lp = iris::withRasterPyramid(*lm, 2);
        QCOMPARE(int(lp.levels.size()), 2);
        QCOMPARE(lp.levels[1].label[0], uint16_t(1));
        QCOMPARE(lp.levels[1].label[1], uint16_t(3));
        // RGBA: opaque red and transparent anything → red at half alpha (premultiplied mean).
        std::vector<uint8_t> c{255, 0, 0, 255, 0, 255, 0, 0, 255, 0, 0, 255, 0, 0, 255, 0};
        auto cm = iris::fromHostMemoryRgba(std::span<const uint8_t>(c), 2, 2);
        QVERIFY(cm.ok());
        const iris::RasterMap cp = iris::withRasterPyramid(*cm, 1);
        const std::vector<uint8_t> want{255, 0, 0, 128};
        QCOMPARE(cp.levels[1].rgba, want);
    }
    // ---- colour maps ----
    void builtinColorMaps() {
        const ColorMap v = ColorMap::viridis(), m = ColorMap::magma(), j = ColorMap::jet(), g = ColorMap::gray();
        QCOMPARE(v.entries[0], (Rgba8{68, 1, 84, 255}));     // #440154
        QCOMPARE(v.entries[128], (Rgba8{33, 145, 140, 255})); // #21918c
        QCOMPARE(v.entries[255], (Rgba8{253, 231, 37, 255})); // #fde725
        QCOMPARE(m.entries[0], (Rgba8{0, 0, 4, 255}));        // #000004
        QCOMPARE(m.entries[128], (Rgba8{183, 55, 121, 255})); // #b73779
        QCOMPARE(m.entries[255], (Rgba8{252, 253, 191, 255})); // #fcfdbf
        QCOMPARE(j.entries[0], (Rgba8{0, 0, 128, 255}));
        QCOMPARE(j.entries[255], (Rgba8{128, 0, 0, 255}));
        // x = 128/255: red (x−0.35)/0.31, green 1, blue 1 − (x−0.34)/0.31, each round(255·v).
        QCOMPARE(j.entries[128], (Rgba8{125, 255, 122, 255}));
        QCOMPARE(j.entries[96], (Rgba8{22, 255, 225, 255})); // x = 0.3765: red 0.085, green 1, blue 0.882
        for (int i = 0; i < 256; ++i) QCOMPARE(g.entries[size_t(i)], (Rgba8{uint8_t(i), uint8_t(i), uint8_t(i), 255}));
        QCOMPARE(ColorMap::builtin("grey")->name, std::string("gray"));
        QCOMPARE(ColorMap::builtin("magma")->entries[7], m.entries[7]);
        QVERIFY(!ColorMap::builtin("parula"));
    }

    void userColorMaps() {
        std::string text = "# a ramp — from a model's legend\n\n";
        for (int i = 0; i < 256; ++i)
            text += std::to_string(255 - i) + " " + std::to_string(i) + " 7" + (i % 2 ? " 128" : "") + "\r\n";
        rw::writeBytes(out("ramp.lut"), std::vector<uint8_t>(text.begin(), text.end()));
        auto cm = ColorMap::fromFile(out("ramp.lut"));
        QVERIFY2(cm.ok(), cm.ok() ? "" : cm.error().message().c_str());
        QCOMPARE(cm->entries[0], (Rgba8{255, 0, 7, 255}));
        QCOMPARE(cm->entries[1], (Rgba8{254, 1, 7, 128}));

        rw::Png strip{256, 1, PNG_COLOR_TYPE_RGBA, 8};
        for (int i = 0; i < 256; ++i)
            strip.rows.insert(strip.rows.end(), {uint8_t(i), 9, uint8_t(255 - i), uint8_t(i)});
        QVERIFY(rw::writePng(out("strip.png"), strip));
        auto pc = ColorMap::fromFile(out("strip.png"));
        QVERIFY2(pc.ok(), pc.ok() ? "" : pc.error().message().c_str());
        QCOMPARE(pc->entries[200], (Rgba8{200, 9, 55, 200}));
        rw::Png column{1, 256, PNG_COLOR_TYPE_GRAY, 16};
        for (int i = 0; i < 256; ++i) column.rows.insert(column.rows.end(), {uint8_t(i), uint8_t(i)}); // i·257
        QVERIFY(rw::writePng(out("column16.png"), column));
        auto cc = ColorMap::fromFile(out("column16.png"));
        QVERIFY2(cc.ok(), cc.ok() ? "" : cc.error().message().c_str());
        QCOMPARE(cc->entries[77], (Rgba8{77, 77, 77, 255}));

        auto bad = [](const std::string& body, const char* pattern) {
            auto r = ColorMap::fromMemory(std::span(reinterpret_cast<const uint8_t*>(body.data()), body.size()), "x.lut");
            QVERIFY(!r.ok());
            QVERIFY2(QString::fromStdString(r.error().message()).contains(QRegularExpression(pattern)),
                     r.error().message().c_str());
            QVERIFY(QString::fromStdString(r.error().message()).startsWith("x.lut: "));
        };
        bad("1 2 3\n", "1 entries; a colour map has exactly 256");
        bad(text + "1 2 3\n", "more than 256");
        bad("1 2 256\n", "line 1: expected integers 0..255");
        bad("1 2\n", "line 1: fewer than 3");
        bad("1 2 3 4 5\n", "more than 4");
        bad(std::string("\x01\x02\x00", 3), "neither a PNG strip nor a text");
        rw::Png square{16, 16, PNG_COLOR_TYPE_GRAY, 8, false, std::vector<uint8_t>(256, 1)};
        QVERIFY(rw::writePng(out("square.png"), square));
        auto sq = ColorMap::fromFile(out("square.png"));
        QVERIFY(!sq.ok() && QString::fromStdString(sq.error().message()).contains("256x1 or 1x256"));
        QCOMPARE(ColorMap::fromFile(out("absent.lut")).error().status(), Status::NotFound);
    }

    // ---- .npy ----
    void npyEveryDtype() {
        // 3 rows × 2 columns: 0, 1, 2, 3, 4, 5 (and −2 in the signed types' last cell).
        struct Case {
            const char* descr;
            std::vector<uint8_t> data;
            float last;
        };
        std::vector<Case> cases = {
            {"<f4", rw::rawBytes(std::vector<float>{0, 1, 2, 3, 4, 5.5f}), 5.5f},
            {">f4", rw::rawBytes(std::vector<float>{0, 1, 2, 3, 4, 5.5f}, true), 5.5f},
            {"<f8", rw::rawBytes(std::vector<double>{0, 1, 2, 3, 4, -0.25}), -0.25f},
            {">f8", rw::rawBytes(std::vector<double>{0, 1, 2, 3, 4, -0.25}, true), -0.25f},
            {"<f2", rw::rawBytes(std::vector<uint16_t>{0, 0x3c00, 0x4000, 0x4200, 0x4400, 0xb800}), -0.5f},
            {"|u1", {0, 1, 2, 3, 4, 255}, 255},
            {"|i1", {0, 1, 2, 3, 4, 0xfe}, -2},
            {"|b1", {0, 1, 0, 1, 1, 1}, 1},
            {"<u2", rw::rawBytes(std::vector<uint16_t>{0, 1, 2, 3, 4, 65535}), 65535},
            {">u2", rw::rawBytes(std::vector<uint16_t>{0, 1, 2, 3, 4, 65535}, true), 65535},
            {"<i2", rw::rawBytes(std::vector<int16_t>{0, 1, 2, 3, 4, -2}), -2},
            {"<i4", rw::rawBytes(std::vector<int32_t>{0, 1, 2, 3, 4, -2}), -2},
            {">i4", rw::rawBytes(std::vector<int32_t>{0, 1, 2, 3, 4, -2}, true), -2},
            {"<u4", rw::rawBytes(std::vector<uint32_t>{0, 1, 2, 3, 4, 100000}), 100000},
            {"<i8", rw::rawBytes(std::vector<int64_t>{0, 1, 2, 3, 4, -2}), -2},
            {"<u8", rw::rawBytes(std::vector<uint64_t>{0, 1, 2, 3, 4, 7}), 7},
        };
        for (int version = 1; version <= 3; ++version)
            for (const Case& c : cases) {
                const std::string file = std::string("dtype-") + (c.descr + 1) + (c.descr[0] == '>' ? "be" : "") + "-v" +
                                         std::to_string(version) + ".npy";
                auto m = loadNpy(file, rw::npyBytes(c.descr, false, "(3, 2)", c.data, version));
                QVERIFY2(m.ok(), m.ok() ? file.c_str() : m.error().message().c_str());
                QCOMPARE(m->kind, RasterKind::Scalar);
                QCOMPARE(m->width(), 2);
                QCOMPARE(m->height(), 3);
                const auto& s = m->levels[0].scalar;
                if (std::string(c.descr) != "|b1") {
                    QCOMPARE(s[1], 1.0f);
                    QCOMPARE(s[4], 4.0f);
                }
                QCOMPARE(s[5], c.last);
                QCOMPARE(m->title, file);
            }
        // Fortran order: stored column by column.
        auto f = loadNpy("fortran.npy", rw::npyBytes("<f4", true, "(3, 2)", rw::rawBytes(std::vector<float>{0, 2, 4, 1, 3, 5})));
        QVERIFY(f.ok());
        QCOMPARE(f->levels[0].scalar, (std::vector<float>{0, 1, 2, 3, 4, 5}));
        // NaN is no data: kept, and left out of the range.
        auto n = loadNpy("nan.npy", rw::npyBytes("<f4", false, "(1, 3)", rw::rawBytes(std::vector<float>{kNaN, 0.25f, 0.75f})));
        QVERIFY(n.ok());
        QVERIFY(std::isnan(n->levels[0].scalar[0]));
        QCOMPARE(n->minValue, 0.25);
        QCOMPARE(n->maxValue, 0.75);
        // Labels.
        RasterLoadOptions lab;
        lab.asLabels = true;
        lab.title = "tissue classes";
        auto l = loadNpy("labels.npy", rw::npyBytes("<u2", false, "(2, 2)", rw::rawBytes(std::vector<uint16_t>{0, 3, 65535, 1})), lab);
        QVERIFY(l.ok());
        QCOMPARE(l->kind, RasterKind::Label);
        QCOMPARE(l->levels[0].label, (std::vector<uint16_t>{0, 3, 65535, 1}));
        QCOMPARE(l->maxValue, 65535.0);
        QCOMPARE(l->title, std::string("tissue classes"));
    }

    void npyMalformed() {
        const auto f4 = rw::rawBytes(std::vector<float>{1, 2, 3, 4, 5, 6});
        const auto good = rw::npyBytes("<f4", false, "(3, 2)", f4);
        const std::vector<uint8_t> truncated(good.begin(), good.end() - 3); // (resize trips gcc 12's -Wstringop-overflow under ASan)
        expectError(loadNpy("truncated.npy", truncated), Status::CorruptData, "truncated.npy", "truncated: 3x2 of '<f4' need 24 bytes");
        auto extra = good;
        extra.push_back(0);
        expectError(loadNpy("extra.npy", extra), Status::CorruptData, "extra.npy", "1 bytes after the array");
        std::vector<uint8_t> headerCut(good.begin(), good.begin() + 30);
        expectError(loadNpy("headercut.npy", headerCut), Status::CorruptData, "headercut.npy", "the header claims");
        expectError(loadNpy("preamble.npy", {0x93, 'N', 'U', 'M', 'P', 'Y', 1}), Status::CorruptData, "preamble.npy", "truncated .npy preamble");
        expectError(loadNpy("v4.npy", rw::npyBytes("<f4", false, "(3, 2)", f4, 4)), Status::UnsupportedFormat, "v4.npy", "version 4.0");
        expectError(loadNpy("3d.npy", rw::npyBytes("<f4", false, "(1, 3, 2)", f4)), Status::UnsupportedFormat, "3d.npy", "3 dimensions");
        expectError(loadNpy("1d.npy", rw::npyBytes("<f4", false, "(6,)", f4)), Status::UnsupportedFormat, "1d.npy", "1 dimensions");
        expectError(loadNpy("complex.npy", rw::npyBytes("<c8", false, "(3, 1)", f4)), Status::UnsupportedFormat, "complex.npy", "dtype '<c8'");
        auto replaced = [&](const std::string& from, const std::string& to) {
            auto b = good;
            auto it = std::search(b.begin(), b.end(), from.begin(), from.end());
            std::copy(to.begin(), to.end(), it);
            return b;
        };
        expectError(loadNpy("badorder.npy", replaced("False", "Xalse")), Status::CorruptData, "badorder.npy",
                    "'fortran_order' is neither True nor False");
        expectError(loadNpy("badkey.npy", replaced("'shape'", "'shapf'")), Status::CorruptData, "badkey.npy",
                    "unknown key 'shapf'");
        expectError(loadNpy("badshape.npy", rw::npyBytes("<f4", false, "(3, -2)", f4)), Status::CorruptData, "badshape.npy", "'shape' is not a tuple");
        expectError(loadNpy("structured.npy", replaced("'<f4'", "[('a'")), Status::CorruptData, "structured.npy",
                    "'descr' is not a string");
        // Infinity is refused, naming the pixel; so is a double beyond float32.
        expectError(loadNpy("inf.npy", rw::npyBytes("<f4", false, "(1, 3)", rw::rawBytes(std::vector<float>{0, 1, INFINITY}))),
                    Status::CorruptData, "inf.npy", R"(infinite value at \(2, 0\))");
        expectError(loadNpy("huge.npy", rw::npyBytes("<f8", false, "(1, 2)", rw::rawBytes(std::vector<double>{0, 1e300}))),
                    Status::CorruptData, "huge.npy", R"(value at \(1, 0\) is beyond float32)");
        // Labels: integers 0..65535 only.
        RasterLoadOptions lab;
        lab.asLabels = true;
        expectError(loadNpy("label-range.npy", rw::npyBytes("<i4", false, "(1, 2)", rw::rawBytes(std::vector<int32_t>{1, 70000})), lab),
                    Status::CorruptData, "label-range.npy", R"(label 70000 at \(1, 0\) is not a whole number in 0..65535)");
        expectError(loadNpy("label-float.npy", good, lab), Status::UnsupportedFormat, "label-float.npy", "integer values");
        // Huge dimensions: refused from the header, before any allocation (the data is absent).
        expectError(loadNpy("wide.npy", rw::npyBytes("<f4", false, "(1, 200000)", {})), Status::UnsupportedFormat, "wide.npy",
                    "over the limit of 131072 pixels a side");
        expectError(loadNpy("vast.npy", rw::npyBytes("<f4", false, "(99999999999999, 3)", {})), Status::UnsupportedFormat,
                    "vast.npy", "over the limit");
        expectError(loadNpy("gib.npy", rw::npyBytes("<f4", false, "(100000, 100000)", {})), Status::UnsupportedFormat,
                    "gib.npy", "40000000000 bytes decoded, over the limit of 1073741824");
        RasterLoadOptions small;
        small.maxBytes = 16;
        expectError(loadNpy("small-limit.npy", good, small), Status::UnsupportedFormat, "small-limit.npy", "24 bytes decoded, over the limit of 16");
    }

    void unknownAndMissingFiles() {
        expectError(loadNpy("text.npy", {'h', 'e', 'l', 'l', 'o'}), Status::UnsupportedFormat, "text.npy", "not a PNG, TIFF or NumPy");
        expectError(loadNpy("empty.png", {}), Status::CorruptData, "empty.png", "the file is empty");
        expectError(loadRasterMap(out("missing.npy")), Status::NotFound, "missing.npy", "No such file");
        expectError(loadRasterMap(outDir()), Status::NotAFile, outDir(), "not a regular file");
        // By content, not by name: an .npy called .png loads as .npy.
        auto m = loadNpy("really-npy.png", rw::npyBytes("|u1", false, "(1, 1)", {9}));
        QVERIFY(m.ok() && m->levels[0].scalar[0] == 9.0f);
    }

    // ---- PNG ----
    void pngEveryType() {
        // 8-bit grey → Scalar 0..255.
        rw::Png g8{3, 2, PNG_COLOR_TYPE_GRAY, 8, false, {0, 10, 255, 7, 8, 9}};
        QVERIFY(rw::writePng(out("g8.png"), g8));
        auto m = loadRasterMap(out("g8.png"));
        QVERIFY(m.ok());
        QCOMPARE(m->kind, RasterKind::Scalar);
        QCOMPARE(m->levels[0].scalar, (std::vector<float>{0, 10, 255, 7, 8, 9}));
        QCOMPARE(m->maxValue, 255.0);
        // 16-bit grey (big-endian in the file) → 0..65535; interlaced too.
        rw::Png g16{2, 2, PNG_COLOR_TYPE_GRAY, 16, true, {0x12, 0x34, 0xff, 0xff, 0, 1, 0x80, 0}};
        QVERIFY(rw::writePng(out("g16.png"), g16));
        m = loadRasterMap(out("g16.png"));
        QVERIFY(m.ok());
        QCOMPARE(m->levels[0].scalar, (std::vector<float>{0x1234, 65535, 1, 0x8000}));
        // 4-bit grey: scaled to 8 bits as a Scalar (15 → 255), kept as ids for labels.
        rw::Png g4{4, 1, PNG_COLOR_TYPE_GRAY, 4, false, {0x0f, 0x53}};
        QVERIFY(rw::writePng(out("g4.png"), g4));
        m = loadRasterMap(out("g4.png"));
        QVERIFY(m.ok());
        QCOMPARE(m->levels[0].scalar, (std::vector<float>{0, 255, 85, 51}));
        RasterLoadOptions lab;
        lab.asLabels = true;
        m = loadRasterMap(out("g4.png"), lab);
        QVERIFY(m.ok());
        QCOMPARE(m->kind, RasterKind::Label);
        QCOMPARE(m->levels[0].label, (std::vector<uint16_t>{0, 15, 5, 3}));
        // Palette with tRNS → Rgba; as labels, the indices.
        rw::Png pal{3, 1, PNG_COLOR_TYPE_PALETTE, 8, false, {0, 1, 2}};
        pal.palette = {{10, 20, 30}, {40, 50, 60}, {70, 80, 90}};
        pal.trnsAlpha = {0, 128};
        QVERIFY(rw::writePng(out("pal.png"), pal));
        m = loadRasterMap(out("pal.png"));
        QVERIFY(m.ok());
        QCOMPARE(m->kind, RasterKind::Rgba);
        QCOMPARE(m->levels[0].rgba, (std::vector<uint8_t>{10, 20, 30, 0, 40, 50, 60, 128, 70, 80, 90, 255}));
        m = loadRasterMap(out("pal.png"), lab);
        QVERIFY(m.ok());
        QCOMPARE(m->levels[0].label, (std::vector<uint16_t>{0, 1, 2}));
        // RGB 8 → opaque RGBA; RGBA 16 → rounded to 8 bits; grey+alpha → RGBA.
        rw::Png rgb{1, 2, PNG_COLOR_TYPE_RGB, 8, false, {1, 2, 3, 4, 5, 6}};
        QVERIFY(rw::writePng(out("rgb.png"), rgb));
        m = loadRasterMap(out("rgb.png"));
        QVERIFY(m.ok());
        QCOMPARE(m->levels[0].rgba, (std::vector<uint8_t>{1, 2, 3, 255, 4, 5, 6, 255}));
        rw::Png rgba16{1, 1, PNG_COLOR_TYPE_RGBA, 16, false, {0xff, 0xff, 0x80, 0x80, 0x00, 0x80, 0x7f, 0x7f}};
        QVERIFY(rw::writePng(out("rgba16.png"), rgba16));
        m = loadRasterMap(out("rgba16.png"));
        QVERIFY(m.ok());
        QCOMPARE(m->levels[0].rgba, (std::vector<uint8_t>{255, 128, 0, 127})); // 0x8080/257 = 128, 0x80/257 → 0
        rw::Png ga{2, 1, PNG_COLOR_TYPE_GRAY_ALPHA, 8, false, {9, 200, 10, 0}};
        QVERIFY(rw::writePng(out("ga.png"), ga));
        m = loadRasterMap(out("ga.png"));
        QVERIFY(m.ok());
        QCOMPARE(m->levels[0].rgba, (std::vector<uint8_t>{9, 9, 9, 200, 10, 10, 10, 0}));
        expectError(loadRasterMap(out("rgb.png"), lab), Status::UnsupportedFormat, "rgb.png", "single-channel");
    }

    void pngMalformed() {
        rw::Png g8{64, 64, PNG_COLOR_TYPE_GRAY, 8, false, std::vector<uint8_t>(64 * 64)};
        for (size_t i = 0; i < g8.rows.size(); ++i) g8.rows[i] = uint8_t(i * 7);
        QVERIFY(rw::writePng(out("whole.png"), g8));
        const auto bytes = rw::readBytes(out("whole.png"));
        // Truncated in the header, and in the image data.
        expectError(loadNpy("cut-header.png", std::vector<uint8_t>(bytes.begin(), bytes.begin() + 20)), Status::CorruptData,
                    "cut-header.png", "PNG header: the file ends early");
        expectError(loadNpy("cut-data.png", std::vector<uint8_t>(bytes.begin(), bytes.end() - 40)), Status::CorruptData,
                    "cut-data.png", "PNG data: ");
        // A corrupt CRC in IHDR.
        auto crc = bytes;
        crc[29] ^= 0xff;
        expectError(loadNpy("crc.png", crc), Status::CorruptData, "crc.png", "PNG header: .*CRC");
        // Huge dimensions stated in IHDR (with its CRC fixed up by libpng's writer: write one).
        rw::Png wide{200000, 1, PNG_COLOR_TYPE_GRAY, 8, false, std::vector<uint8_t>(200000)};
        QVERIFY(rw::writePng(out("wide.png"), wide));
        expectError(loadRasterMap(out("wide.png")), Status::UnsupportedFormat, "wide.png", "200000x1 pixels is over the limit of 131072");
        RasterLoadOptions small;
        small.maxBytes = 1000;
        expectError(loadRasterMap(out("whole.png"), small), Status::UnsupportedFormat, "whole.png", "16384 bytes decoded, over the limit of 1000");
    }

    // ---- TIFF ----
    void tiffEveryType() {
        using TI = rw::TiffImage;
        // float32 in strips, with NaN; the same tiled and deflated.
        std::vector<float> f(20 * 18);
        for (size_t i = 0; i < f.size(); ++i) f[i] = float(i) * 0.5f;
        f[7] = kNaN;
        TI fl{20, 18, 1, 32, SAMPLEFORMAT_IEEEFP};
        fl.data = rw::rawBytes(f);
        QVERIFY(rw::writeTiff(out("f32-strips.tif"), {fl}));
        TI ft = fl;
        ft.tile = 16, ft.compression = COMPRESSION_ADOBE_DEFLATE;
        QVERIFY(rw::writeTiff(out("f32-tiles.tif"), {ft}));
        for (const char* file : {"f32-strips.tif", "f32-tiles.tif"}) {
            auto m = loadRasterMap(out(file));
            QVERIFY2(m.ok(), m.ok() ? file : m.error().message().c_str());
            QCOMPARE(m->kind, RasterKind::Scalar);
            QCOMPARE(m->width(), 20);
            QCOMPARE(m->height(), 18);
            QVERIFY(std::isnan(m->levels[0].scalar[7]));
            QCOMPARE(m->levels[0].scalar[359], 179.5f);
            QCOMPARE(m->minValue, 0.0);
        }
        // 8/16/32-bit unsigned and signed integers, 64-bit float, 16-bit uint tiles.
        struct Int {
            uint16_t bps, format;
            std::vector<uint8_t> data;
            float last;
        };
        std::vector<Int> ints = {
            {8, SAMPLEFORMAT_UINT, {1, 2, 3, 250}, 250},
            {8, SAMPLEFORMAT_INT, {1, 2, 3, 0xfb}, -5},
            {16, SAMPLEFORMAT_UINT, rw::rawBytes(std::vector<uint16_t>{1, 2, 3, 60000}), 60000},
            {16, SAMPLEFORMAT_INT, rw::rawBytes(std::vector<int16_t>{1, 2, 3, -300}), -300},
            {32, SAMPLEFORMAT_UINT, rw::rawBytes(std::vector<uint32_t>{1, 2, 3, 1000000}), 1000000},
            {32, SAMPLEFORMAT_INT, rw::rawBytes(std::vector<int32_t>{1, 2, 3, -7}), -7},
            {64, SAMPLEFORMAT_IEEEFP, rw::rawBytes(std::vector<double>{1, 2, 3, 0.125}), 0.125f},
        };
        for (const Int& c : ints) {
            TI im{2, 2, 1, c.bps, c.format};
            im.data = c.data;
            const std::string file = "int" + std::to_string(c.bps) + "-" + std::to_string(c.format) + ".tif";
            QVERIFY(rw::writeTiff(out(file), {im}));
            auto m = loadRasterMap(out(file));
            QVERIFY2(m.ok(), m.ok() ? file.c_str() : m.error().message().c_str());
            QCOMPARE(m->levels[0].scalar, (std::vector<float>{1, 2, 3, c.last}));
        }
        // uint16 tiles as labels.
        TI lab{40, 20, 1, 16};
        lab.tile = 16;
        std::vector<uint16_t> ids(40 * 20);
        for (size_t i = 0; i < ids.size(); ++i) ids[i] = uint16_t(i % 5);
        lab.data = rw::rawBytes(ids);
        QVERIFY(rw::writeTiff(out("labels.tif"), {lab}));
        RasterLoadOptions asLabels;
        asLabels.asLabels = true;
        auto m = loadRasterMap(out("labels.tif"), asLabels);
        QVERIFY(m.ok());
        QCOMPARE(m->kind, RasterKind::Label);
        QCOMPARE(m->levels[0].label, ids);
        expectError(loadRasterMap(out("f32-strips.tif"), asLabels), Status::UnsupportedFormat, "f32-strips.tif", "integer samples");
        // RGB, RGBA (straight and premultiplied), palette.
        TI rgb{2, 1, 3, 8, SAMPLEFORMAT_UINT, PHOTOMETRIC_RGB};
        rgb.data = {1, 2, 3, 4, 5, 6};
        QVERIFY(rw::writeTiff(out("rgb.tif"), {rgb}));
        m = loadRasterMap(out("rgb.tif"));
        QVERIFY(m.ok());
        QCOMPARE(m->levels[0].rgba, (std::vector<uint8_t>{1, 2, 3, 255, 4, 5, 6, 255}));
        TI rgba{2, 1, 4, 8, SAMPLEFORMAT_UINT, PHOTOMETRIC_RGB};
        rgba.data = {10, 20, 30, 128, 50, 60, 70, 0};
        QVERIFY(rw::writeTiff(out("rgba.tif"), {rgba}));
        m = loadRasterMap(out("rgba.tif"));
        QVERIFY(m.ok());
        QCOMPARE(m->levels[0].rgba, rgba.data);
        rgba.extraSample = EXTRASAMPLE_ASSOCALPHA;
        QVERIFY(rw::writeTiff(out("rgba-assoc.tif"), {rgba}));
        m = loadRasterMap(out("rgba-assoc.tif"));
        QVERIFY(m.ok());
        QCOMPARE(m->levels[0].rgba, (std::vector<uint8_t>{20, 40, 60, 128, 0, 0, 0, 0}));
        TI pal{3, 1, 1, 8, SAMPLEFORMAT_UINT, PHOTOMETRIC_PALETTE};
        pal.colormap.assign(3 * 256, 0);
        pal.colormap[2] = 0xff00, pal.colormap[256 + 2] = 0x8000, pal.colormap[512 + 1] = 0x1234;
        pal.data = {0, 1, 2};
        QVERIFY(rw::writeTiff(out("palette.tif"), {pal}));
        m = loadRasterMap(out("palette.tif"));
        QVERIFY(m.ok());
        QCOMPARE(m->levels[0].rgba, (std::vector<uint8_t>{0, 0, 0, 255, 0, 0, 0x12, 255, 0xff, 0x80, 0, 255}));
        m = loadRasterMap(out("palette.tif"), asLabels);
        QVERIFY(m.ok());
        QCOMPARE(m->levels[0].label, (std::vector<uint16_t>{0, 1, 2}));
    }

    void tiffPyramids() {
        using TI = rw::TiffImage;
        const auto level = rw::floatLevel;
        // 3 levels of ≈ /2 with odd sizes, as SubIFDs and as an IFD chain; BigTIFF too.
        const std::vector<TI> levels = {level(101, 50, 1), level(51, 25, 2), level(25, 13, 3)};
        QVERIFY(rw::writeTiff(out("pyr-sub.tif"), levels, true));
        QVERIFY(rw::writeTiff(out("pyr-chain.tif"), levels, false, true));
        for (const char* file : {"pyr-sub.tif", "pyr-chain.tif"}) {
            auto m = loadRasterMap(out(file));
            QVERIFY2(m.ok(), m.ok() ? file : m.error().message().c_str());
            QCOMPARE(int(m->levels.size()), 3);
            QCOMPARE(m->levels[1].width, 51);
            QCOMPARE(m->levels[2].height, 13);
            QCOMPARE(m->levels[2].scalar[0], 3.0f);
            QCOMPARE(m->maxValue, 3.0);
        }
        // Not levels: an 8-bit RGB thumbnail (another kind), a mask, an image not smaller.
        TI thumb{10, 5, 3, 8, SAMPLEFORMAT_UINT, PHOTOMETRIC_RGB};
        thumb.data.assign(150, 1);
        TI mask = level(20, 10, 9);
        mask.subfileType = FILETYPE_REDUCEDIMAGE | FILETYPE_MASK;
        QVERIFY(rw::writeTiff(out("pyr-mixed.tif"), {level(100, 50, 1), thumb, level(100, 50, 7), mask, level(50, 25, 2)}));
        auto m = loadRasterMap(out("pyr-mixed.tif"));
        QVERIFY(m.ok());
        QCOMPARE(int(m->levels.size()), 2);
        QCOMPARE(m->levels[1].scalar[0], 2.0f);
        // A reduced level that does not decode fails the load, naming the file first and then
        // the level (found by fuzz_raster_map: the message began "NAME, level 1").
        TI l0{40, 20, 1, 8}, l1{20, 10, 1, 8};
        l0.data.assign(800, 1), l1.data.assign(200, 2);
        l0.rowsPerStrip = 20, l1.rowsPerStrip = 10; // one strip each: its offset sits in the IFD
        QVERIFY(rw::writeTiff(out("pyr-two.tif"), {l0, l1}));
        auto broken = rw::readBytes(out("pyr-two.tif"));
        QVERIFY(patchTiffTag(broken, 273, uint32_t(broken.size() - 4), 1));
        expectError(loadNpy("pyr-broken-level.tif", broken), Status::CorruptData, "pyr-broken-level.tif",
                    "pyr-broken-level.tif: level 1: the strip at row 0 does not decode");
        // Limits count every level.
        RasterLoadOptions small;
        small.maxBytes = 101 * 50 * 4 + 100;
        expectError(loadRasterMap(out("pyr-sub.tif"), small), Status::UnsupportedFormat, "pyr-sub.tif", "over the limit of 20300");
    }

    void tiffMalformed() {
        using TI = rw::TiffImage;
        TI fl{64, 64, 1, 32, SAMPLEFORMAT_IEEEFP};
        fl.rowsPerStrip = 8;
        fl.data = rw::rawBytes(std::vector<float>(64 * 64, 0.5f));
        QVERIFY(rw::writeTiff(out("good.tif"), {fl}));
        const auto bytes = rw::readBytes(out("good.tif"));
        // The data ends before the strips do (the IFD is at the end: keep it, cut the pixels).
        // libtiff writes the IFD after the data: truncating the file loses the directory.
        expectError(loadNpy("cut.tif", std::vector<uint8_t>(bytes.begin(), bytes.begin() + bytes.size() / 2)),
                    Status::CorruptData, "cut.tif", "not a readable TIFF");
        expectError(loadNpy("header-only.tif", {'I', 'I', 42, 0, 8, 0, 0, 0}), Status::CorruptData, "header-only.tif", "not a readable TIFF");
        // Strip data that stops short, the directory intact: one strip whose offset is moved
        // near the end of the file.
        TI single = fl;
        single.rowsPerStrip = 64;
        QVERIFY(rw::writeTiff(out("single.tif"), {single}));
        auto shortData = rw::readBytes(out("single.tif"));
        QVERIFY(patchTiffTag(shortData, 273, uint32_t(shortData.size() - 10)));
        expectError(loadNpy("short-data.tif", shortData), Status::CorruptData, "short-data.tif",
                    "the strip at row 0 does not decode");
        TI inf = fl;
        std::vector<float> v(64 * 64, 1);
        v[64 * 10 + 3] = -INFINITY;
        inf.data = rw::rawBytes(v);
        QVERIFY(rw::writeTiff(out("inf.tif"), {inf}));
        expectError(loadRasterMap(out("inf.tif")), Status::CorruptData, "inf.tif", R"(infinite value at \(3, 10\))");
        TI rgb12{4, 4, 3, 16, SAMPLEFORMAT_UINT, PHOTOMETRIC_RGB};
        rgb12.data.assign(4 * 4 * 6, 0);
        QVERIFY(rw::writeTiff(out("rgb16.tif"), {rgb12}));
        expectError(loadRasterMap(out("rgb16.tif")), Status::UnsupportedFormat, "rgb16.tif", "photometric 2, 3 sample\\(s\\) of 16 bits");
        // Huge dimensions in the directory (written for a 1-row image, then patched).
        TI one{8, 1, 1, 8};
        one.data.assign(8, 3);
        one.rowsPerStrip = 1;
        QVERIFY(rw::writeTiff(out("one.tif"), {one}));
        auto wide = rw::readBytes(out("one.tif"));
        QVERIFY(patchTiffTag(wide, 256, 200000));
        expectError(loadNpy("wide.tif", wide), Status::UnsupportedFormat, "wide.tif", "200000x1 pixels is over the limit");
    }

    // ---- host memory ----
    void hostMemory() {
        std::vector<float> v = {0, 1, kNaN, 3};
        auto m = fromHostMemory(std::span<const float>(v), 2, 2, "model");
        QVERIFY(m.ok());
        QCOMPARE(m->minValue, 0.0);
        QCOMPARE(m->maxValue, 3.0);
        QCOMPARE(m->title, std::string("model"));
        QCOMPARE(fromHostMemory(std::span<const float>(v), 3, 2).error().status(), Status::InvalidArgument);
        QVERIFY(QString::fromStdString(fromHostMemory(std::span<const float>(v), 3, 2).error().message()).contains("needs 6 elements, given 4"));
        v[1] = INFINITY;
        QVERIFY(QString::fromStdString(fromHostMemory(std::span<const float>(v), 2, 2).error().message()).contains("infinite value at (1, 0)"));
        QVERIFY(!fromHostMemory(std::span<const float>(v), 0, 4).ok());
        std::vector<uint16_t> ids = {1, 2, 3};
        auto l = fromHostMemory(std::span<const uint16_t>(ids), 3, 1);
        QVERIFY(l.ok() && l->kind == RasterKind::Label && l->minValue == 1 && l->maxValue == 3);
        std::vector<uint8_t> px = {1, 2, 3, 4};
        QVERIFY(fromHostMemoryRgba(px, 1, 1).ok());
        // A pyramid: levels must get smaller.
        std::vector<RasterLevel> levels(2);
        levels[0] = {4, 4, std::vector<float>(16, 1), {}, {}};
        levels[1] = {4, 2, std::vector<float>(8, 2), {}, {}};
        auto p = fromHostMemory(RasterKind::Scalar, levels);
        QVERIFY(p.ok() && p->levels.size() == 2);
        levels[1] = {4, 4, std::vector<float>(16, 2), {}, {}};
        auto q = fromHostMemory(RasterKind::Scalar, levels);
        QVERIFY(!q.ok() && QString::fromStdString(q.error().message()).contains("level 1 (4x4) is not smaller than level 0"));
        levels[1] = {2, 2, {}, std::vector<uint16_t>(4, 2), {}};
        auto k = fromHostMemory(RasterKind::Scalar, levels);
        QVERIFY(!k.ok() && QString::fromStdString(k.error().message()).contains("needs 4 float values"));
    }

    // ---- placement and level choice ----
    void placement() {
        const Placement s = Placement::spanning(10, 5, 2240, 1120);
        QCOMPARE(s.toSlide(1, 1), (std::array<double, 2>{224, 224}));
        QCOMPARE(*s.toMap(448, 112), (std::array<double, 2>{2, 0.5}));
        const Placement r = Placement::scaleRotateOffset(2, 3, 90, 100, 0);
        QCOMPARE(r.toSlide(1, 0), (std::array<double, 2>{100, 2})); // x axis turns down (clockwise on screen)
        QCOMPARE(r.toSlide(0, 1), (std::array<double, 2>{97, 0}));
        const Placement t = Placement::scaleRotateOffset(1.5, 0.5, 33, -7, 11);
        for (auto [x, y] : {std::array<double, 2>{0.25, 9}, {100, -3}}) {
            auto [sx, sy] = t.toSlide(x, y);
            auto back = *t.toMap(sx, sy);
            QVERIFY(std::fabs(back[0] - x) < 1e-9 && std::fabs(back[1] - y) < 1e-9);
        }
        Placement singular;
        singular.m = {1, 2, 0, 2, 4, 0};
        QVERIFY(!singular.toMap(1, 1));
        const Box2 b = r.bounds(10, 4); // x: 100 − 3·4 .. 100, y: 0 .. 20
        QCOMPARE(b, (Box2{88, 0, 100, 20}));
    }

    void levelChoice() {
        std::vector<RasterLevel> levels = {{100, 80, std::vector<float>(8000, 0), {}, {}},
                                           {50, 40, std::vector<float>(2000, 1), {}, {}},
                                           {17, 13, std::vector<float>(221, 2), {}, {}}};
        const RasterMap map = fromHostMemory(RasterKind::Scalar, levels).value();
        const Placement p = Placement::spanning(100, 80, 1000, 800); // 10 level-0 pixels a map pixel
        QCOMPARE(chooseRasterLevel(map, p, 1), 0);
        QCOMPARE(chooseRasterLevel(map, p, 10), 0);   // exactly one screen pixel
        QCOMPARE(chooseRasterLevel(map, p, 10.5), 1); // level 0 would be minified
        QCOMPARE(chooseRasterLevel(map, p, 20), 1);
        QCOMPARE(chooseRasterLevel(map, p, 20.01), 2);
        QCOMPARE(chooseRasterLevel(map, p, 1e6), 2);  // the coarsest when none reaches 1 px
        QCOMPARE(chooseRasterLevel(map, p, 0), 0);
        // Level 2's pixel: 1000/17 = 58.8 by 800/13 = 61.5; the smaller counts.
        QCOMPARE(chooseRasterLevel(map, p, 58.8), 2);
        // Rotation does not change a pixel's size.
        QCOMPARE(chooseRasterLevel(map, Placement::scaleRotateOffset(10, 10, 45, 0, 0), 15), 1);
        // Shading picks the level's value.
        LayerStyle st = greyStyle();
        st.low = 0, st.high = 2;
        QCOMPARE(shadeLayerAt(map, p, st, 500, 400, 1)[0], uint8_t(0));
        QCOMPARE(shadeLayerAt(map, p, st, 500, 400, 15)[0], uint8_t(128)); // t = 0.5 → entry 127.5
        QCOMPARE(shadeLayerAt(map, p, st, 500, 400, 100)[0], uint8_t(255));
    }

    // ---- shading ----
    void scalarSampling() {
        // 2 × 2 map spanning a 20 × 20 slide: values 0 10 / 20 NaN.
        const RasterMap map = scalarMap({0, 10, 20, 30}, 2, 2);
        const Placement p = Placement::spanning(2, 2, 20, 20);
        LayerStyle st = greyStyle();
        st.sampling = LayerSampling::Nearest;
        QCOMPARE(shadeLayerAt(map, p, st, 9.99, 0, 1), (Px{0, 0, 0, 255}));
        QCOMPARE(shadeLayerAt(map, p, st, 10, 0, 1), (Px{10, 10, 10, 255}));
        QCOMPARE(shadeLayerAt(map, p, st, 19.9, 19.9, 1), (Px{30, 30, 30, 255}));
        st.sampling = LayerSampling::Bilinear;
        // At pixel centres the value itself; between them the interpolation; at the edges clamped.
        QCOMPARE(shadeLayerAt(map, p, st, 5, 5, 1)[0], uint8_t(0));
        QCOMPARE(shadeLayerAt(map, p, st, 10, 5, 1)[0], uint8_t(5));
        QCOMPARE(shadeLayerAt(map, p, st, 10, 10, 1)[0], uint8_t(15));
        QCOMPARE(shadeLayerAt(map, p, st, 0, 0, 1)[0], uint8_t(0));
        QCOMPARE(shadeLayerAt(map, p, st, 12.5, 5, 1)[0], uint8_t(8)); // 7.5 → 8
        // Outside the placed rectangle: nothing, on every side; the far edges are open.
        for (auto [x, y] : {std::array<double, 2>{-0.001, 5}, {20, 5}, {5, 20}, {5, -1}, {1e300, 0}})
            QCOMPARE(shadeLayerAt(map, p, st, x, y, 1), (Px{0, 0, 0, 0}));
        // NaN in any tap used: nothing, even at weight 0 (pixel (0,0)'s centre, bilinear).
        const RasterMap nan = scalarMap({0, kNaN, 20, 30}, 2, 2);
        QCOMPARE(shadeLayerAt(nan, p, st, 5, 5, 1), (Px{0, 0, 0, 0}));
        QCOMPARE(shadeLayerAt(nan, p, st, 12, 12, 1), (Px{0, 0, 0, 0}));
        QCOMPARE(shadeLayerAt(nan, p, st, 15, 15, 1), (Px{30, 30, 30, 255})); // its taps are all (1, 1)
        st.sampling = LayerSampling::Nearest;
        QCOMPARE(shadeLayerAt(nan, p, st, 5, 5, 1), (Px{0, 0, 0, 255}));
        QCOMPARE(shadeLayerAt(nan, p, st, 15, 5, 1), (Px{0, 0, 0, 0}));
    }

    void thresholdWindowOpacity() {
        const RasterMap map = scalarMap({0.1f, 0.5f, 0.9f, 1.0f}, 4, 1);
        const Placement p; // identity: pixel i covers [i, i+1)
        LayerStyle st;
        st.colorMap = ColorMap::gray();
        st.opacity = 1;
        st.sampling = LayerSampling::Nearest;
        // Default window: the map's range 0.1..1.0.
        QCOMPARE(shadeLayerAt(map, p, st, 0.5, 0.5, 1), (Px{0, 0, 0, 255}));
        QCOMPARE(shadeLayerAt(map, p, st, 3.5, 0.5, 1), (Px{255, 255, 255, 255}));
        // (0.5 − 0.1)/0.9 · 255 = 113.33 → between entries 113 and 114 → 113.33 → 113.
        QCOMPARE(shadeLayerAt(map, p, st, 1.5, 0.5, 1)[0], uint8_t(113));
        // Threshold on the value: below is transparent, equal is drawn.
        st.threshold = 0.5;
        QCOMPARE(shadeLayerAt(map, p, st, 0.5, 0.5, 1), (Px{0, 0, 0, 0}));
        QCOMPARE(shadeLayerAt(map, p, st, 1.5, 0.5, 1)[3], uint8_t(255));
        // Window clamps: below low → entry 0, above high → entry 255.
        st.threshold = -INFINITY;
        st.low = 0.5, st.high = 0.9;
        QCOMPARE(shadeLayerAt(map, p, st, 0.5, 0.5, 1)[0], uint8_t(0));
        QCOMPARE(shadeLayerAt(map, p, st, 3.5, 0.5, 1)[0], uint8_t(255));
        // A degenerate window is a step at `high`.
        st.low = st.high = double(0.9f);
        QCOMPARE(shadeLayerAt(map, p, st, 1.5, 0.5, 1)[0], uint8_t(0));
        QCOMPARE(shadeLayerAt(map, p, st, 2.5, 0.5, 1)[0], uint8_t(255));
        // Colour-map interpolation between entries, alpha included.
        ColorMap two = ColorMap::gray();
        two.entries[0] = {0, 0, 0, 0};
        two.entries[1] = {100, 50, 3, 200};
        st.colorMap = two;
        st.low = 0, st.high = 255;
        const RasterMap half = scalarMap({0.5f}, 1, 1);
        QCOMPARE(shadeLayerAt(half, p, st, 0.5, 0.5, 1), (Px{50, 25, 2, 100})); // 1.5 → 2; alpha 100
        // Opacity scales alpha: 0.5 × 255 = 127.5 → 128; 0 → nothing; > 1 clamps.
        st = greyStyle();
        st.opacity = 0.5;
        QCOMPARE(shadeLayerAt(map, p, st, 0.5, 0.5, 1)[3], uint8_t(128));
        st.opacity = 0.3;
        QCOMPARE(shadeLayerAt(map, p, st, 0.5, 0.5, 1)[3], uint8_t(77)); // 76.5 → 77
        st.opacity = 7;
        QCOMPARE(shadeLayerAt(map, p, st, 0.5, 0.5, 1)[3], uint8_t(255));
        st.opacity = 0;
        QCOMPARE(shadeLayerAt(map, p, st, 0.5, 0.5, 1), (Px{0, 0, 0, 0}));
        st.opacity = 1;
        st.visible = false;
        QCOMPARE(shadeLayerAt(map, p, st, 0.5, 0.5, 1), (Px{0, 0, 0, 0}));
    }

    void labelMaps() {
        std::vector<uint16_t> ids = {0, 1, 2, 7};
        const RasterMap map = fromHostMemory(std::span<const uint16_t>(ids), 2, 2).value();
        const Placement p = Placement::spanning(2, 2, 2, 2);
        LayerStyle st;
        st.opacity = 1;
        st.classes = defaultLabelClasses(3);
        QCOMPARE(st.classes[0].visible, false);
        QCOMPARE(st.classes[1].color, (Rgba8{31, 119, 180, 255}));
        // Always nearest, whatever the style's sampling: the boundary stays sharp.
        QCOMPARE(shadeLayerAt(map, p, st, 0.5, 0.5, 1), (Px{0, 0, 0, 0}));          // background
        QCOMPARE(shadeLayerAt(map, p, st, 1.01, 0.5, 1), (Px{31, 119, 180, 255})); // class 1
        QCOMPARE(shadeLayerAt(map, p, st, 0.5, 1.5, 1), (Px{174, 199, 232, 255}));
        QCOMPARE(shadeLayerAt(map, p, st, 1.5, 1.5, 1), (Px{0, 0, 0, 0}));          // id 7 beyond the table
        st.classes[1].visible = false;
        QCOMPARE(shadeLayerAt(map, p, st, 1.5, 0.5, 1), (Px{0, 0, 0, 0}));
        st.classes[2].color.a = 128;
        st.opacity = 0.5;
        QCOMPARE(shadeLayerAt(map, p, st, 0.5, 1.5, 1)[3], uint8_t(64)); // 0.5·128 = 64
    }

    void rgbaMaps() {
        // Opaque red beside transparent green: bilinear on premultiplied values stays red.
        const std::vector<uint8_t> px = {255, 0, 0, 255, 0, 255, 0, 0};
        const RasterMap map = fromHostMemoryRgba(px, 2, 1).value();
        const Placement p;
        LayerStyle st;
        st.opacity = 1;
        QCOMPARE(shadeLayerAt(map, p, st, 1.0, 0.5, 1), (Px{255, 0, 0, 128})); // alpha 0.5 → 127.5 → 128
        QCOMPARE(shadeLayerAt(map, p, st, 1.5, 0.5, 1), (Px{0, 0, 0, 0}));
        st.sampling = LayerSampling::Nearest;
        QCOMPARE(shadeLayerAt(map, p, st, 1.5, 0.5, 1), (Px{0, 255, 0, 0}));
        QCOMPARE(shadeLayerAt(map, p, st, 0.2, 0.5, 1), (Px{255, 0, 0, 255}));
    }

    void rotatedPlacement() {
        // A 4 × 2 map (values = x + 10·y), turned 90° clockwise and moved right by 2: map (x, y)
        // lands on slide (2 − y, x), so the map's columns run down the slide.
        std::vector<float> v(8);
        for (int i = 0; i < 8; ++i) v[size_t(i)] = float(i % 4 + 10 * (i / 4));
        const RasterMap map = scalarMap(v, 4, 2);
        const Placement p = Placement::scaleRotateOffset(1, 1, 90, 2, 0);
        LayerStyle st = greyStyle();
        st.sampling = LayerSampling::Nearest;
        QCOMPARE(shadeLayerAt(map, p, st, 1.5, 3.5, 1)[0], uint8_t(3));  // map (3.5, 0.5)
        QCOMPARE(shadeLayerAt(map, p, st, 0.5, 0.5, 1)[0], uint8_t(10)); // map (0.5, 1.5)
        QCOMPARE(shadeLayerAt(map, p, st, 2.5, 1, 1), (Px{0, 0, 0, 0}));
        QCOMPARE(shadeLayerAt(map, p, st, 1.5, 4.5, 1), (Px{0, 0, 0, 0}));
        // 45° clockwise about the map's origin at (10, 10): its x axis runs down-right, its y axis
        // down-left; points above the origin or right of it at the same height are outside.
        const Placement d = Placement::scaleRotateOffset(1, 1, 45, 10, 10);
        QCOMPARE(shadeLayerAt(map, d, st, 10.0, 9.5, 1), (Px{0, 0, 0, 0}));
        QCOMPARE(shadeLayerAt(map, d, st, 10.5, 10.0, 1), (Px{0, 0, 0, 0}));
        QCOMPARE(shadeLayerAt(map, d, st, 10.0, 10.0 + 0.9 * std::sqrt(2.0), 1)[3], uint8_t(255)); // map (0.9, 0.9)
    }

    void blending() {
        QCOMPARE(blendOver({10, 20, 30}, {200, 100, 0, 0}), (std::array<uint8_t, 3>{10, 20, 30}));
        QCOMPARE(blendOver({10, 20, 30}, {200, 100, 0, 255}), (std::array<uint8_t, 3>{200, 100, 0}));
        QCOMPARE(blendOver({0, 0, 0}, {255, 255, 255, 128}), (std::array<uint8_t, 3>{128, 128, 128}));
        // Every alpha, a grid of colours: round-to-nearest of the real blend.
        for (int a = 0; a < 256; ++a)
            for (int s = 0; s < 256; s += 15)
                for (int d = 0; d < 256; d += 17) {
                    const double exact = (s * a + d * (255.0 - a)) / 255.0;
                    const auto got = blendOver({uint8_t(d), 0, 0}, {uint8_t(s), 0, 0, uint8_t(a)})[0];
                    QVERIFY2(std::fabs(got - exact) <= 0.5, qPrintable(QString("a %1 s %2 d %3").arg(a).arg(s).arg(d)));
                }
    }
};

QTEST_APPLESS_MAIN(TestLayers)
#include "tst_layers.moc"
