// The .iris reader (issue 7, "Reader" and "Tests"), through the public API only.
//
//   * conformance: every file the reference encoders wrote (testdata/slides/iris/) opens with
//     the source slide's dimensions, levels, mpp and magnification; frames at downsample 1
//     match OpenSlide's read_region of the source .svs within JPEG tolerance (RGB PSNR over
//     the frame's slide pixels ≥ kMinPsnr dB, and no more than kMaxPsnrLoss below what a
//     quality-90 4:2:2 encode of the reference region itself reaches); associated images
//     match OpenSlide's (≥ kMinImagePsnr dB).
//   * validation: one copy of a valid fixture per rule, with exactly that rule broken,
//     written to $IRIS_TEST_OUT/iris/; open() refuses it with the rule's own message, and the
//     engine then opens and renders a good slide.
//   * tolerance: what a reader must accept (a newer minor version with longer array entries,
//     the schema's reading of X_EXTENT, NULL_TILE, a PNG associated image, a file known by
//     its magic alone), and tile failures (corrupt JPEG, AVIF) that must not stop rendering
//     but show in Engine::error().
//   * robustness: every structural byte of a small file corrupted in turn; open() either
//     accepts or refuses, never crashes (run it under the asan preset).
#include <QtTest>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <openslide.h>
#include <png.h>
#include <turbojpeg.h>

#include <iris/engine.h>
#include <iris/environment.h>

#include "iris_test_util.h"

using namespace std::chrono_literals;
namespace fs = std::filesystem;
using namespace iris_test;

namespace {

constexpr uint32_t kW = 320, kH = 240;               // the offscreen target
constexpr std::array<float, 3> kBackground{0.2f, 0.4f, 0.6f};
// JPEG tolerance. The files hold quality-90 JPEG with 4:2:2 chroma; on H&E tissue that alone
// costs 29-31 dB of RGB PSNR against the source (chroma is halved), 40+ dB on glass. A frame
// must reach the floor, and lose at most kMaxPsnrLoss against a quality-90 4:2:2 encode of
// the reference region itself (libjpeg-turbo, the reference encoder's settings): what the
// format can give, so the reader adds no error of its own. A one-pixel shift gives < 20 dB,
// swapped channels less still.
constexpr double kMinPsnr = 28.0;        // dB, frames vs OpenSlide at downsample 1 (RGB, slide pixels)
constexpr double kMaxPsnrLoss = 0.5;     // dB below the reference region's own encode
constexpr double kMinLevel1Psnr = 25.0;  // dB, the level-1 check (see there)
constexpr double kMinImagePsnr = 30.0;   // dB, associated images (re-encoded JPEG) vs OpenSlide's
constexpr auto kFrameTimeout = 60s;

Ife load(const char* name) { return Ife{readAll(fixture(name))}; }

// ---- images ---------------------------------------------------------------------------

std::optional<iris::Image> openslideRegion(const fs::path& slide, int level, int64_t x0, int64_t y0, uint32_t w,
                                           uint32_t h, std::string* why) {
    openslide_t* osr = openslide_open(slide.c_str());
    if (!osr || openslide_get_error(osr)) {
        *why = "OpenSlide cannot open " + slide.string();
        if (osr) openslide_close(osr);
        return std::nullopt;
    }
    std::vector<uint32_t> argb(size_t(w) * h);
    openslide_read_region(osr, argb.data(), x0, y0, level, w, h);
    if (const char* e = openslide_get_error(osr)) {
        *why = std::string("read_region: ") + e;
        openslide_close(osr);
        return std::nullopt;
    }
    openslide_close(osr);
    iris::Image img;
    img.width = w;
    img.height = h;
    img.rgba.resize(argb.size() * 4);
    for (size_t i = 0; i < argb.size(); ++i) {
        const uint32_t p = argb[i];
        img.rgba[4 * i + 0] = uint8_t(p >> 16);
        img.rgba[4 * i + 1] = uint8_t(p >> 8);
        img.rgba[4 * i + 2] = uint8_t(p);
        img.rgba[4 * i + 3] = uint8_t(p >> 24); // opaque inside the slide, 0 outside
    }
    return img;
}

std::optional<iris::Image> openslideAssociated(const fs::path& slide, const std::string& name) {
    openslide_t* osr = openslide_open(slide.c_str());
    if (!osr) return std::nullopt;
    int64_t w = 0, h = 0;
    openslide_get_associated_image_dimensions(osr, name.c_str(), &w, &h);
    if (w <= 0 || h <= 0) {
        openslide_close(osr);
        return std::nullopt;
    }
    std::vector<uint32_t> argb(size_t(w) * size_t(h));
    openslide_read_associated_image(osr, name.c_str(), argb.data());
    const bool ok = openslide_get_error(osr) == nullptr;
    openslide_close(osr);
    if (!ok) return std::nullopt;
    iris::Image img;
    img.width = uint32_t(w);
    img.height = uint32_t(h);
    img.rgba.resize(argb.size() * 4);
    for (size_t i = 0; i < argb.size(); ++i) {
        img.rgba[4 * i + 0] = uint8_t(argb[i] >> 16);
        img.rgba[4 * i + 1] = uint8_t(argb[i] >> 8);
        img.rgba[4 * i + 2] = uint8_t(argb[i]);
        img.rgba[4 * i + 3] = uint8_t(argb[i] >> 24);
    }
    return img;
}

std::array<uint8_t, 3> backgroundBytes() {
    std::array<uint8_t, 3> out{};
    for (int c = 0; c < 3; ++c) out[size_t(c)] = uint8_t(std::lround(kBackground[size_t(c)] * 255.0f));
    return out;
}

bool isBackground(const iris::Image& img, uint32_t x, uint32_t y) {
    const auto bg = backgroundBytes();
    const uint8_t* p = img.rgba.data() + (size_t(y) * img.width + x) * 4;
    for (int c = 0; c < 3; ++c) {
        if (std::abs(int(p[c]) - int(bg[size_t(c)])) > 1) return false;
    }
    return true;
}

Bytes encodePng(uint32_t w, uint32_t h, const std::vector<uint8_t>& rgba) {
    png_image p;
    std::memset(&p, 0, sizeof p);
    p.version = PNG_IMAGE_VERSION;
    p.width = w;
    p.height = h;
    p.format = PNG_FORMAT_RGBA;
    png_alloc_size_t size = 0;
    if (!png_image_write_to_memory(&p, nullptr, &size, 0, rgba.data(), 0, nullptr)) return {};
    Bytes out(size);
    if (!png_image_write_to_memory(&p, out.data(), &size, 0, rgba.data(), 0, nullptr)) return {};
    out.resize(size);
    return out;
}

// ---- the validation rules -------------------------------------------------------------

struct Rule {
    const char* name;    // also the file name: broken-<name>.iris
    const char* fixture; // the valid file it starts from
    std::function<void(Ife&)> breakIt;
    iris::Status status;
    const char* phrase;  // the message must contain it
};

const std::vector<Rule>& rules() {
    using S = iris::Status;
    static const std::vector<Rule> r = {
        {"magic", "small.v1.0.iris", [](Ife& f) { f.b[0] ^= 0xFF; }, S::UnsupportedFormat, "not an Iris file: its magic bytes"},
        {"header-recovery-tag", "small.v1.0.iris", [](Ife& f) { put(f.b, 4, 0x5502, 2); }, S::CorruptData,
         "FILE_HEADER's recovery tag is 0x5502, expected 0x5501"},
        {"block-recovery-tag", "small.v1.0.iris", [](Ife& f) { put(f.b, f.tileTable() + 8, 0x5504, 2); }, S::CorruptData,
         "has recovery tag 0x5504 (METADATA), expected 0x5502 for TILE_TABLE"},
        {"validation-not-offset", "small.v1.0.iris",
         [](Ife& f) { put(f.b, f.layerExtents(), f.layerExtents() + 1, 8); }, S::CorruptData,
         "LAYER_EXTENTS block at byte 2074 (from TILE_TABLE.LAYER_EXTENTS_OFFSET) fails validation: its VALIDATION field "
         "is 2075"},
        {"block-offset-past-eof", "small.v1.0.iris", [](Ife& f) { put(f.b, 30, f.b.size() + 1000, 8); }, S::CorruptData,
         "FILE_HEADER.METADATA_OFFSET points to byte 5337, past the end of the file"},
        {"block-straddles-eof", "small.v1.0.iris", [](Ife& f) { put(f.b, 22, f.b.size() - 20, 8); }, S::CorruptData,
         "FILE_HEADER.TILE_TABLE_OFFSET points to byte 4317, past the end of the file (4337 bytes)"},
        {"file-size-wrong", "small.v1.0.iris", [](Ife& f) { put(f.b, 6, f.b.size() - 1, 8); }, S::CorruptData,
         "FILE_SIZE says 4336 bytes but the file has 4337"},
        {"truncated", "CMU-1-Small-Region.v1.0.iris", [](Ife& f) { f.b.erase(f.b.end() - std::min<ptrdiff_t>(100000, ptrdiff_t(f.b.size())), f.b.end()); }, S::CorruptData,
         "the file is truncated: FILE_SIZE says 1742694 bytes but only 1642694 are present"},
        {"shorter-than-header", "small.v1.0.iris", [](Ife& f) { f.b.resize(20); }, S::CorruptData,
         "less than the 38-byte FILE_HEADER"},
        {"tile-past-eof", "small.v1.0.iris", [](Ife& f) { put(f.b, f.tileEntry(0), f.b.size() - 10, 5); }, S::CorruptData,
         "tile 0 (layer 0, x 0, y 0) lies past the end of the file"},
        {"tile-past-eof-by-size", "CMU-1-Small-Region.v1.0.iris",
         [](Ife& f) { put(f.b, f.tileEntry(50) + 5, f.b.size() - f.tileOffset(50) + 1, 3); }, S::CorruptData,
         "tile 50 (layer 0, x 5, y 5) lies past the end of the file"},
        {"attribute-sizes-sum", "small.v1.0.iris",
         [](Ife& f) {
             const uint64_t e = f.attributeSizes() + 16 + 2; // entry 0, VALUE_SIZE
             put(f.b, e, f.u(e, 4) + 1, 4);
         },
         S::CorruptData, "the attribute sizes add up to 1142 bytes but ATTRIBUTE_BYTES holds 1141 bytes"},
        {"scales-decrease", "tcga-cr-7395-01a-01-ts1.v1.0.iris", [](Ife& f) { putF32(f.b, f.layer(1) + 8, 0.5f); },
         S::CorruptData, "layer scales must strictly increase from layer 0 (the lowest resolution), but layer 1 has SCALE 0.5"},
        {"scales-equal", "tcga-cr-7395-01a-01-ts1.v1.0.iris", [](Ife& f) { putF32(f.b, f.layer(1) + 8, 1.0f); },
         S::CorruptData, "layer scales must strictly increase"},
        {"scale-nan", "tcga-cr-7395-01a-01-ts1.v1.0.iris",
         [](Ife& f) { putF32(f.b, f.layer(0) + 8, std::numeric_limits<float>::quiet_NaN()); }, S::CorruptData,
         "a scale must be a positive finite number"},
        {"tile-length-512", "CMU-1-Small-Region.v1.1.iris", [](Ife& f) { put(f.b, f.tileTable() + 44, 512, 2); },
         S::UnsupportedFormat, "its TILE_LENGTH is 512 pixels; this reader supports only 256-pixel tiles"},
        {"extents-2e40-tiles", "small.v1.0.iris",
         [](Ife& f) {
             put(f.b, f.layer(0), 1u << 20, 4);
             put(f.b, f.layer(0) + 4, 1u << 20, 4);
         },
         S::CorruptData, "TILE_OFFSETS holds 1 entries but the layer extents need 1099511627776 tiles"},
        {"extents-beyond-any-slide", "small.v1.0.iris", [](Ife& f) { put(f.b, f.layer(0), 0x80000000u, 4); },
         S::CorruptData, "layer 0 is 2147483648x1 tiles (2147483648 tiles), beyond any slide"},
        {"extents-zero", "small.v1.0.iris", [](Ife& f) { put(f.b, f.layer(0) + 4, 0, 4); }, S::CorruptData,
         "layer 0 is 1x0 tiles: X_TILES and Y_TILES must be at least 1"},
        {"extents-disagree-with-scale", "tcga-cr-7395-01a-01-ts1.v1.0.iris",
         [](Ife& f) { putF32(f.b, f.layer(1) + 8, 8.0f); }, S::CorruptData, "the layer extents disagree"},
        {"x-extent-fits-no-layer", "tcga-cr-7395-01a-01-ts1.v1.0.iris",
         [](Ife& f) { put(f.b, f.tileTable() + 36, 100000, 4); }, S::CorruptData,
         "X_EXTENT x Y_EXTENT (100000x1783) fits neither"},
        {"tile-count-mismatch", "tcga-cr-7395-01a-01-ts1.v1.0.iris",
         [](Ife& f) { put(f.b, f.tileOffsets() + 12, 314, 4); }, S::CorruptData,
         "TILE_OFFSETS holds 314 entries but the layer extents need 315 tiles"},
        {"stride-below-entry", "small.v1.0.iris", [](Ife& f) { put(f.b, f.tileOffsets() + 10, 7, 2); }, S::CorruptData,
         "the TILE_OFFSETS array at byte 2050 has STRIDE 7, less than the 8 bytes of an entry"},
        {"array-past-eof", "small.v1.0.iris", [](Ife& f) { put(f.b, f.attributeSizes() + 12, 0x10000000, 4); },
         S::CorruptData, "the ATTRIBUTE_SIZES array at byte 3005 (268435456 entries of STRIDE 6 bytes) runs past the end of "
                         "the file"},
        {"image-bytes-validation", "small.v1.0.iris",
         [](Ife& f) { put(f.b, f.imageEntry(0), f.u(f.imageEntry(0), 8) + 1, 8); }, S::CorruptData,
         "(from IMAGES entry 0) fails validation"},
        {"image-past-eof", "small.v1.0.iris",
         [](Ife& f) {
             const uint64_t ib = f.u(f.imageEntry(0), 8);
             put(f.b, ib + 12, 0x01000000, 4); // IMAGE_SIZE
         },
         S::CorruptData, "associated image 0 (IMAGE_BYTES at byte 2202, 9-byte title and 16777216-byte image) runs past "
                         "the end of the file"},
        {"icc-past-eof", "small.v1.0.iris", [](Ife& f) { put(f.b, f.metadata() + 32, f.b.size() - 5, 8); },
         S::CorruptData, "METADATA.ICC_COLOR_OFFSET points to byte 4332, past the end of the file"},
        {"mandatory-block-missing", "small.v1.0.iris", [](Ife& f) { put(f.b, 22, kNull, 8); }, S::CorruptData,
         "the TILE_TABLE block is missing (FILE_HEADER.TILE_TABLE_OFFSET is NULL_OFFSET)"},
        {"major-version-2", "small.v1.0.iris", [](Ife& f) { put(f.b, 14, 2, 2); }, S::UnsupportedFormat,
         "it is Iris File Extension version 2.0; this reader reads version 1.x"},
        {"encoding-undefined", "small.v1.0.iris", [](Ife& f) { f.b[f.tileTable() + 10] = 0; }, S::CorruptData,
         "TILE_TABLE.ENCODING is 0 (undefined)"},
        {"encoding-iris-reserved", "small.v1.0.iris", [](Ife& f) { f.b[f.tileTable() + 10] = 1; }, S::UnsupportedFormat,
         "reserved IRIS codec"},
        {"encrypted", "small.v1.0.iris",
         [](Ife& f) {
             const uint64_t at = f.b.size();
             append(f.b, at, 8);
             append(f.b, 0x5503, 2);
             put(f.b, f.tileTable() + 12, at, 8);
             f.fixFileSize();
         },
         S::UnsupportedFormat, "its tiles are encrypted (a CIPHER block at byte 4337)"},
    };
    return r;
}

} // namespace

class TestIrisReader : public QObject {
    Q_OBJECT

    struct Log {
        std::mutex mutex;
        std::vector<std::string> errors;
    };
    std::shared_ptr<Log> log_ = std::make_shared<Log>();
    std::unique_ptr<iris::Engine> e_;

    std::optional<iris::Frame> render(double x0, double y0, double ds, std::string* why) {
        return renderAt(*e_, x0, y0, ds, kW, kH, kFrameTimeout, why);
    }

    fs::path write(const std::string& name, const Bytes& b) {
        const fs::path p = outDir() / name;
        if (!writeAll(p, b)) return {};
        return p;
    }

    // The engine is still usable: a good .iris file opens and renders a complete frame.
    void checkStillUsable() {
        const iris::Result r = e_->open(fixture("CMU-1-Small-Region.v1.0.iris").string());
        QVERIFY2(r.ok(), describe(r).c_str());
        QVERIFY2(e_->error().ok(), describe(e_->error()).c_str());
        std::string why;
        QVERIFY2(render(1003, 1517, 1.0, &why).has_value(), why.c_str());
        QVERIFY2(e_->error().ok(), describe(e_->error()).c_str());
    }

private slots:
    void initTestCase() {
        if (!irisDir()) QSKIP("no test data: set IRIS_TESTDATA (a folder holding slides/iris/)");
        iris::EngineConfig c;
        c.validation = true;
        c.loaderThreads = 2;
        c.background = kBackground;
        std::shared_ptr<Log> log = log_;
        c.log = [log](iris::LogLevel level, std::string_view line) {
            if (level != iris::LogLevel::Error) return;
            std::lock_guard lock(log->mutex);
            log->errors.emplace_back(line);
        };
        auto tuning = iris::tuningFromEnvironment();
        QVERIFY2(tuning.ok(), describe(tuning.error()).c_str());
        c.tuning = *tuning;
        auto e = iris::Engine::create(c);
        QVERIFY2(e.ok(), describe(e.error()).c_str());
        e_ = std::move(e.value());
        QVERIFY(e_->bindOffscreen(kW, kH).ok());
    }

    void cleanupTestCase() {
        if (!e_) return;
        e_->close();
        QCOMPARE(e_->validationMessageCount(), uint64_t(0));
        e_.reset();
    }

    // ---- conformance ------------------------------------------------------------------

    void conformance_data() {
        QTest::addColumn<QString>("file");
        QTest::addColumn<QString>("source");
        QTest::addColumn<qint64>("width");
        QTest::addColumn<qint64>("height");
        QTest::addColumn<int>("levels");
        QTest::addColumn<double>("downsample1"); // level 1's, 0 when single-level
        QTest::addColumn<double>("mpp");
        QTest::addColumn<double>("magnification");
        QTest::addColumn<QStringList>("images");
        const QStringList cmuImages{"label", "macro", "thumbnail"};
        QTest::newRow("CMU v1.0") << "CMU-1-Small-Region.v1.0.iris"
                                  << "CMU-1-Small-Region.svs" << qint64(2220) << qint64(2967) << 1 << 0.0 << 0.499
                                  << 20.0 << cmuImages;
        QTest::newRow("CMU v1.1") << "CMU-1-Small-Region.v1.1.iris"
                                  << "CMU-1-Small-Region.svs" << qint64(2220) << qint64(2967) << 1 << 0.0 << 0.499
                                  << 20.0 << cmuImages;
        QTest::newRow("tcga v1.0") << "tcga-cr-7395-01a-01-ts1.v1.0.iris"
                                   << "tcga-cr-7395-01a-01-ts1.svs" << qint64(4443) << qint64(3567) << 2 << 2.0005
                                   << 0.0 << 0.0 << QStringList{"thumbnail"};
        QTest::newRow("small v1.0") << "small.v1.0.iris"
                                    << "small.svs" << qint64(16) << qint64(16) << 1 << 0.0 << 0.499 << 20.0
                                    << QStringList{"thumbnail"};
    }
    void conformance() {
        QFETCH(QString, file);
        QFETCH(QString, source);
        QFETCH(qint64, width);
        QFETCH(qint64, height);
        QFETCH(int, levels);
        QFETCH(double, downsample1);
        QFETCH(double, mpp);
        QFETCH(double, magnification);
        QFETCH(QStringList, images);
        const fs::path path = fixture(file.toUtf8().constData());
        const fs::path src = sourceSlide(source.toUtf8().constData());

        const iris::Result r = e_->open(path.string());
        QVERIFY2(r.ok(), describe(r).c_str());
        const auto info = e_->slideInfo();
        QVERIFY(info.has_value());
        QCOMPARE(QString::fromStdString(info->vendor), QString("iris"));
        QCOMPARE(qint64(info->width), width);
        QCOMPARE(qint64(info->height), height);
        QCOMPARE(int(info->levels.size()), levels);
        QCOMPARE(qint64(info->levels[0].width), width);
        QCOMPARE(qint64(info->levels[0].height), height);
        QCOMPARE(info->levels[0].downsample, 1.0);
        // The same levels as OpenSlide's, within a pixel, downsample within 0.001.
        openslide_t* osr = openslide_open(src.c_str());
        QVERIFY2(osr, src.c_str());
        QCOMPARE(openslide_get_level_count(osr), levels);
        for (int l = 0; l < levels; ++l) {
            int64_t w = 0, h = 0;
            openslide_get_level_dimensions(osr, l, &w, &h);
            const iris::LevelInfo& li = info->levels[size_t(l)];
            QVERIFY2(std::abs(li.width - w) <= 1 && std::abs(li.height - h) <= 1,
                     qPrintable(QString("level %1: %2x%3, OpenSlide %4x%5").arg(l).arg(li.width).arg(li.height).arg(w).arg(h)));
            QVERIFY2(std::abs(li.downsample - openslide_get_level_downsample(osr, l)) < 1e-3,
                     qPrintable(QString("level %1 downsample %2").arg(l).arg(li.downsample, 0, 'f', 6)));
            QCOMPARE(li.tilesX, (li.width + 255) / 256);
            QCOMPARE(li.tilesY, (li.height + 255) / 256);
        }
        openslide_close(osr);
        if (levels > 1) {
            QVERIFY2(std::abs(info->levels[1].downsample - downsample1) < 1e-3,
                     qPrintable(QString::number(info->levels[1].downsample, 'f', 6)));
            QVERIFY(info->levels[1].downsample != 2.0); // non-integer scale kept as is
        }
        QVERIFY2(std::abs(info->mppX - mpp) < 1e-6 && std::abs(info->mppY - mpp) < 1e-6,
                 qPrintable(QString("mpp %1 x %2").arg(info->mppX).arg(info->mppY)));
        QVERIFY2(std::abs(info->objectivePower - magnification) < 1e-6, qPrintable(QString::number(info->objectivePower)));
        for (const iris::LevelInfo& li : info->levels) {
            // Per level: the slide's mpp grows and its magnification shrinks with the downsample.
            QVERIFY(std::abs(li.mppX - mpp * li.downsample) < 1e-6 && std::abs(li.mppY - mpp * li.downsample) < 1e-6);
            QVERIFY(std::abs(li.magnification - (magnification > 0 ? magnification / li.downsample : 0)) < 1e-6);
        }
        QVERIFY(info->iccProfile.empty()); // the fixtures carry none (iris.icc-profile-bytes 0)

        // Properties: sorted, unique; the reader's own and the attributes as stored.
        auto prop = [&](const std::string& k) -> std::optional<std::string> {
            for (const auto& kv : info->properties) {
                if (kv.first == k) return kv.second;
            }
            return std::nullopt;
        };
        for (size_t i = 1; i < info->properties.size(); ++i) {
            QVERIFY(info->properties[i - 1].first < info->properties[i].first);
        }
        QCOMPARE(QString::fromStdString(prop("iris.encoding").value_or("")), QString("JPEG"));
        QCOMPARE(QString::fromStdString(prop("iris.version").value_or("")),
                 file.contains("v1.1") ? QString("1.1") : QString("1.0"));
        QCOMPARE(QString::fromStdString(prop("iris.icc-profile-bytes").value_or("")), QString("0"));
        QCOMPARE(QString::fromStdString(prop("iris.attributes.format").value_or("")), QString("FREE_TEXT"));
        QVERIFY(prop("tiff.ImageDescription").has_value());
        if (mpp > 0) QCOMPARE(QString::fromStdString(prop("aperio.MPP").value_or("")), QString("0.4990"));

        // Associated images: the names, and the pixels of OpenSlide's within JPEG tolerance.
        QStringList names;
        for (const auto& n : info->associatedImages) names << QString::fromStdString(n);
        names.sort();
        QCOMPARE(names, images);
        for (const QString& n : images) {
            auto img = e_->readAssociatedImage(n.toStdString());
            QVERIFY2(img.ok(), describe(img.error()).c_str());
            auto ref = openslideAssociated(src, n.toStdString());
            QVERIFY(ref.has_value());
            QCOMPARE(img->width, ref->width);
            QCOMPARE(img->height, ref->height);
            bool opaque = true;
            for (size_t i = 3; i < img->rgba.size(); i += 4) opaque = opaque && img->rgba[i] == 255;
            QVERIFY(opaque);
            const double p = psnr(*img, *ref, nullptr);
            qInfo("%s %s: PSNR %.2f dB against OpenSlide", qPrintable(file), qPrintable(n), p);
            QVERIFY2(p >= kMinImagePsnr, qPrintable(QString("associated image %1: PSNR %2 dB").arg(n).arg(p)));
        }
        QVERIFY(!e_->readAssociatedImage("no-such-image").ok());

        // Frames at downsample 1 against read_region: the top-left corner, an interior area
        // across tile seams, and the bottom-right corner with the edge tiles' padding. The
        // origins are multiples of 16, so that a JPEG encode of the reference frame has the
        // blocks of the file's tiles (see honestPsnr()).
        auto down16 = [](int64_t v) { return std::max<int64_t>(0, v / 16 * 16); };
        std::vector<std::pair<int64_t, int64_t>> origins = {
            {0, 0},
            {down16(width / 2 - 131), down16(height / 2 - 97)},
            {down16(width - kW + 40), down16(height - kH + 30)}};
        origins.erase(std::unique(origins.begin(), origins.end()), origins.end()); // a small slide: one place
        for (const auto& [x0, y0] : origins) {
            std::string why;
            auto frame = render(double(x0), double(y0), 1.0, &why);
            QVERIFY2(frame.has_value(), why.c_str());
            auto ref = openslideRegion(src, 0, x0, y0, kW, kH, &why);
            QVERIFY2(ref.has_value(), why.c_str());
            auto inside = [&](uint32_t x, uint32_t y) {
                return x0 + int64_t(x) < width && y0 + int64_t(y) < height;
            };
            uint64_t n = 0;
            const double p = psnr(frame->image, *ref, inside, &n);
            const double honest = honestPsnr(*ref, inside);
            qInfo("%s at (%lld, %lld), downsample 1: PSNR %.2f dB over %llu px; a quality-90 4:2:2 encode of the "
                  "reference itself: %.2f dB",
                  qPrintable(file), (long long)x0, (long long)y0, p, (unsigned long long)n, honest);
            QVERIFY2(p >= kMinPsnr && p >= honest - kMaxPsnrLoss,
                     qPrintable(QString("PSNR %1 dB at (%2, %3); needed %4 dB and at least %5 dB (the reference's own "
                                        "encode) less %6 dB")
                                    .arg(p).arg(x0).arg(y0).arg(kMinPsnr).arg(honest).arg(kMaxPsnrLoss)));
            // Outside the slide: the background, untouched by the edge tiles' padding.
            uint64_t notBg = 0;
            for (uint32_t y = 0; y < kH; ++y) {
                for (uint32_t x = 0; x < kW; ++x) {
                    if (!inside(x, y) && !isBackground(frame->image, x, y)) ++notBg;
                }
            }
            QCOMPARE(notBg, uint64_t(0));
        }
        // Level 1 where there is one, drawn 1:1 at its own downsample: against the level's
        // exact pixels (read from the level's origin, where OpenSlide 3.4.1 does not
        // resample, and cropped). The encoder read this level through read_region at
        // level-0 coordinates round(x · 2.00045), which OpenSlide resamples by a fraction of
        // a pixel, so only the floor applies here: a wrong level or offset gives < 20 dB.
        if (levels > 1) {
            const double ds = info->levels[1].downsample;
            const int64_t lx = 1024, ly = 768;
            std::string why;
            auto frame = render(double(lx) * ds, double(ly) * ds, ds, &why);
            QVERIFY2(frame.has_value(), why.c_str());
            auto big = openslideRegion(src, 1, 0, 0, uint32_t(lx) + kW, uint32_t(ly) + kH, &why);
            QVERIFY2(big.has_value(), why.c_str());
            iris::Image ref;
            ref.width = kW;
            ref.height = kH;
            ref.rgba.resize(size_t(kW) * kH * 4);
            for (uint32_t y = 0; y < kH; ++y) {
                std::memcpy(&ref.rgba[size_t(y) * kW * 4], &big->rgba[((size_t(ly) + y) * big->width + size_t(lx)) * 4],
                            size_t(kW) * 4);
            }
            const double p = psnr(frame->image, ref, nullptr);
            qInfo("%s level 1 (downsample %.5f) at level pixel (%lld, %lld): PSNR %.2f dB", qPrintable(file), ds,
                  (long long)lx, (long long)ly, p);
            QVERIFY2(p >= kMinLevel1Psnr, qPrintable(QString("level 1: PSNR %1 dB").arg(p)));
        }
        // The whole slide fitted: every level's tiles decode.
        std::string why;
        const iris::View fit = e_->fitView();
        QVERIFY2(render(fit.centerX - kW * 0.5 * fit.downsample, fit.centerY - kH * 0.5 * fit.downsample, fit.downsample,
                        &why)
                     .has_value(),
                 why.c_str());
        QVERIFY2(e_->error().ok(), describe(e_->error()).c_str());
    }

    // ---- validation rules ---------------------------------------------------------------

    void validationRule_data() {
        QTest::addColumn<int>("index");
        for (size_t i = 0; i < rules().size(); ++i) QTest::newRow(rules()[i].name) << int(i);
    }
    void validationRule() {
        QFETCH(int, index);
        const Rule& rule = rules()[size_t(index)];
        Ife f = load(rule.fixture);
        QVERIFY(!f.b.empty());
        rule.breakIt(f);
        const std::string name = std::string("broken-") + rule.name + ".iris";
        const fs::path p = write(name, f.b);
        QVERIFY(!p.empty());
        const iris::Result r = e_->open(p.string());
        qInfo("%s → %s", name.c_str(), describe(r).c_str());
        QVERIFY2(!r.ok(), "open() accepted the broken file");
        QCOMPARE(QString(iris::statusName(r.status())), QString(iris::statusName(rule.status)));
        QVERIFY2(r.message().find("'" + name + "'") != std::string::npos, "the message does not name the file");
        QVERIFY2(r.message().find(rule.phrase) != std::string::npos,
                 qPrintable(QString("expected \"%1\" in \"%2\"").arg(rule.phrase, QString::fromStdString(r.message()))));
        QVERIFY(!e_->slideInfo().has_value());
        checkStillUsable();
    }

    // ---- what must be tolerated ---------------------------------------------------------

    // A file of a newer minor version whose arrays have longer entries (fields this reader
    // does not know) reads exactly like the original.
    void newerMinorVersionLongerEntries() {
        Ife f = load("CMU-1-Small-Region.v1.1.iris");
        put(f.b, 16, 9, 2); // version 1.9
        put(f.b, f.tileTable() + 28, f.appendWiderArray(f.layerExtents(), 6), 8);
        put(f.b, f.tileTable() + 20, f.appendWiderArray(f.tileOffsets(), 4), 8);
        put(f.b, f.attributes() + 13, f.appendWiderArray(f.attributeSizes(), 3), 8);
        put(f.b, f.metadata() + 24, f.appendWiderArray(f.images(), 8), 8);
        f.fixFileSize();
        const fs::path p = write("newer-minor-wider-entries.iris", f.b);

        QVERIFY(e_->open(fixture("CMU-1-Small-Region.v1.1.iris").string()).ok());
        const iris::SlideInfo ref = *e_->slideInfo();
        std::string why;
        auto refFrame = render(1003, 1517, 1.0, &why);
        QVERIFY2(refFrame.has_value(), why.c_str());
        auto refLabel = e_->readAssociatedImage("label");
        QVERIFY(refLabel.ok());

        const iris::Result r = e_->open(p.string());
        QVERIFY2(r.ok(), describe(r).c_str());
        const iris::SlideInfo info = *e_->slideInfo();
        QCOMPARE(info.width, ref.width);
        QCOMPARE(info.height, ref.height);
        QCOMPARE(info.levels.size(), ref.levels.size());
        QCOMPARE(info.mppX, ref.mppX);
        QVERIFY(info.associatedImages == ref.associatedImages);
        QCOMPARE(info.properties.size(), ref.properties.size());
        for (size_t i = 0; i < info.properties.size(); ++i) {
            QCOMPARE(QString::fromStdString(info.properties[i].first), QString::fromStdString(ref.properties[i].first));
            if (info.properties[i].first != "iris.version") {
                QCOMPARE(QString::fromStdString(info.properties[i].second), QString::fromStdString(ref.properties[i].second));
            }
        }
        auto frame = render(1003, 1517, 1.0, &why);
        QVERIFY2(frame.has_value(), why.c_str());
        QVERIFY(frame->image.rgba == refFrame->image.rgba);
        auto label = e_->readAssociatedImage("label");
        QVERIFY(label.ok());
        QVERIFY(label->rgba == refLabel->rgba);
        QVERIFY2(e_->error().ok(), describe(e_->error()).c_str());
    }

    // X_EXTENT/Y_EXTENT as the schema reads them (the highest-resolution layer's size)
    // instead of the reference encoder's (the lowest's): the same slide.
    void schemaReadingOfExtent() {
        Ife f = load("tcga-cr-7395-01a-01-ts1.v1.0.iris");
        QCOMPARE(f.u(f.tileTable() + 36, 4), uint64_t(2221));
        put(f.b, f.tileTable() + 36, 4443, 4);
        put(f.b, f.tileTable() + 40, 3567, 4);
        const fs::path p = write("extent-schema-reading.iris", f.b);
        QVERIFY(e_->open(fixture("tcga-cr-7395-01a-01-ts1.v1.0.iris").string()).ok());
        const iris::SlideInfo ref = *e_->slideInfo();
        const iris::Result r = e_->open(p.string());
        QVERIFY2(r.ok(), describe(r).c_str());
        const iris::SlideInfo info = *e_->slideInfo();
        QCOMPARE(info.width, int64_t(4443));
        QCOMPARE(info.height, int64_t(3567));
        QCOMPARE(info.levels.size(), ref.levels.size());
        for (size_t l = 0; l < info.levels.size(); ++l) {
            QCOMPARE(info.levels[l].width, ref.levels[l].width);
            QCOMPARE(info.levels[l].height, ref.levels[l].height);
            QCOMPARE(info.levels[l].downsample, ref.levels[l].downsample);
        }
    }

    // A file found by its magic bytes, whatever its name.
    void detectedByMagic() {
        const fs::path p = write("renamed-slide.dat", readAll(fixture("small.v1.0.iris")));
        const iris::Result r = e_->open(p.string());
        QVERIFY2(r.ok(), describe(r).c_str());
        QCOMPARE(QString::fromStdString(e_->slideInfo()->vendor), QString("iris"));
    }

    // NULL_TILE: a tile with no data is drawn as empty (transparent: the background shows),
    // and is no error.
    void nullTile() {
        Ife f = load("CMU-1-Small-Region.v1.0.iris");
        const uint64_t tile = 1 * 9 + 1; // (1, 1) of the 9×12 grid
        put(f.b, f.tileEntry(tile), 0xFFFFFFFFFFull, 5);
        const fs::path p = write("null-tile.iris", f.b);

        QVERIFY(e_->open(fixture("CMU-1-Small-Region.v1.0.iris").string()).ok());
        std::string why;
        auto ref = render(200, 200, 1.0, &why);
        QVERIFY2(ref.has_value(), why.c_str());
        const iris::Result r = e_->open(p.string());
        QVERIFY2(r.ok(), describe(r).c_str());
        auto frame = render(200, 200, 1.0, &why);
        QVERIFY2(frame.has_value(), why.c_str());
        QVERIFY2(e_->error().ok(), describe(e_->error()).c_str());
        uint64_t wrong = 0;
        for (uint32_t y = 0; y < kH; ++y) {
            for (uint32_t x = 0; x < kW; ++x) {
                const bool inTile = 200 + x >= 256 && 200 + x < 512 && 200 + y >= 256 && 200 + y < 512;
                const size_t i = (size_t(y) * kW + x) * 4;
                if (inTile) {
                    wrong += !isBackground(frame->image, x, y);
                } else {
                    wrong += std::memcmp(&frame->image.rgba[i], &ref->image.rgba[i], 4) != 0;
                }
            }
        }
        QCOMPARE(wrong, uint64_t(0));
    }

    // An associated image stored as PNG decodes losslessly, straight alpha kept.
    void pngAssociatedImage() {
        Ife f = load("small.v1.0.iris");
        constexpr uint32_t w = 40, h = 30;
        std::vector<uint8_t> rgba(size_t(w) * h * 4);
        for (uint32_t y = 0; y < h; ++y) {
            for (uint32_t x = 0; x < w; ++x) {
                uint8_t* px = &rgba[(size_t(y) * w + x) * 4];
                px[0] = uint8_t(x * 6);
                px[1] = uint8_t(y * 8);
                px[2] = uint8_t(255 - x * 3);
                px[3] = uint8_t(x < 20 ? 255 : 128);
            }
        }
        const Bytes png = encodePng(w, h, rgba);
        QVERIFY(!png.empty());
        // A new IMAGE_BYTES block at the end: title "label", then the PNG.
        const uint64_t at = f.b.size();
        append(f.b, at, 8);
        append(f.b, 0x550B, 2);
        append(f.b, 5, 2);
        append(f.b, png.size(), 4);
        for (char c : std::string("label")) f.b.push_back(uint8_t(c));
        f.b.insert(f.b.end(), png.begin(), png.end());
        const uint64_t e = f.imageEntry(0);
        put(f.b, e, at, 8);
        put(f.b, e + 8, w, 4);
        put(f.b, e + 12, h, 4);
        f.b[e + 16] = 1; // PNG
        f.b[e + 17] = 4; // R8G8B8A8
        f.fixFileSize();
        const fs::path p = write("png-label.iris", f.b);
        const iris::Result r = e_->open(p.string());
        QVERIFY2(r.ok(), describe(r).c_str());
        QVERIFY(e_->slideInfo()->associatedImages == std::vector<std::string>{"label"});
        auto img = e_->readAssociatedImage("label");
        QVERIFY2(img.ok(), describe(img.error()).c_str());
        QCOMPARE(img->width, w);
        QCOMPARE(img->height, h);
        QVERIFY(img->rgba == rgba);

        // An AVIF one is refused clearly.
        f.b[e + 16] = 3;
        const fs::path p2 = write("avif-label.iris", f.b);
        QVERIFY(e_->open(p2.string()).ok());
        auto avif = e_->readAssociatedImage("label");
        QVERIFY(!avif.ok());
        QCOMPARE(QString(iris::statusName(avif.error().status())), QString(iris::statusName(iris::Status::UnsupportedFormat)));
        QVERIFY2(avif.error().message().find("AVIF-encoded images are not supported in this build") != std::string::npos,
                 avif.error().message().c_str());
    }

    // ---- tile failures: rendering completes, Engine::error() says why -------------------

    void badTile_data() {
        QTest::addColumn<QString>("kind");
        QTest::addColumn<int>("status");
        QTest::addColumn<QString>("phrase");
        QTest::newRow("JPEG header overwritten") << "header" << int(iris::Status::CorruptData)
                                                 << "Cannot decode tile (1, 1) of level 0";
        QTest::newRow("JPEG data overwritten") << "data" << int(iris::Status::CorruptData) << "the JPEG data is corrupt";
        QTest::newRow("AVIF tiles") << "avif" << int(iris::Status::UnsupportedFormat)
                                    << "AVIF-encoded tiles are not supported in this build";
    }
    void badTile() {
        QFETCH(QString, kind);
        QFETCH(int, status);
        QFETCH(QString, phrase);
        Ife f = load("CMU-1-Small-Region.v1.0.iris");
        const uint64_t tile = 1 * 9 + 1;
        const uint64_t off = f.tileOffset(tile), size = f.tileSize(tile);
        if (kind == "header") {
            for (uint64_t i = 2; i < 40; ++i) f.b[off + i] = 0x5A;
        } else if (kind == "data") {
            std::mt19937 rng(7);
            for (uint64_t i = size / 3; i < size; ++i) f.b[off + i] = uint8_t(rng());
        } else {
            f.b[f.tileTable() + 10] = 3;
        }
        const fs::path p = write("bad-tile-" + kind.toStdString() + ".iris", f.b);
        const iris::Result r = e_->open(p.string());
        QVERIFY2(r.ok(), describe(r).c_str());
        iris::View v;
        v.centerX = 200 + kW * 0.5;
        v.centerY = 200 + kH * 0.5;
        v.downsample = 1;
        e_->setView(v);
        const auto t0 = std::chrono::steady_clock::now();
        const iris::Result w = e_->waitForFrame(kFrameTimeout);
        QVERIFY2(w.ok(), describe(w).c_str());
        QVERIFY(std::chrono::steady_clock::now() - t0 < kFrameTimeout);
        auto frame = e_->readFrame();
        QVERIFY(frame.ok());
        QVERIFY(frame->complete);
        const iris::Result err = e_->error();
        qInfo("engine error: %s", describe(err).c_str());
        QVERIFY(!err.ok());
        QCOMPARE(int(err.status()), status);
        QVERIFY2(err.message().find(phrase.toStdString()) != std::string::npos, err.message().c_str());
        QVERIFY2(err.message().find(p.filename().string()) != std::string::npos, err.message().c_str());
        std::lock_guard lock(log_->mutex);
        QVERIFY(!log_->errors.empty());
        log_->errors.clear();
    }

    // ---- robustness ---------------------------------------------------------------------

    // Every byte of small.v1.0.iris outside its tile and image streams, corrupted in two
    // ways in turn: open() accepts or refuses with CorruptData/UnsupportedFormat, and never
    // reads out of bounds (ASan) or crashes. Accepted files are rendered.
    void structuralCorruption() {
        const Ife base = load("small.v1.0.iris");
        std::vector<bool> payload(base.b.size(), false);
        for (uint64_t i = base.tileOffset(0); i < base.tileOffset(0) + base.tileSize(0); ++i) payload[i] = true;
        const uint64_t ib = base.u(base.imageEntry(0), 8);
        for (uint64_t i = ib + 16 + base.u(ib + 10, 2); i < ib + 16 + base.u(ib + 10, 2) + base.u(ib + 12, 4); ++i)
            payload[i] = true;
        const uint64_t ab = base.u(base.attributes() + 21, 8); // attribute strings are free text
        for (uint64_t i = ab + 14; i < ab + 14 + base.u(ab + 10, 4); ++i) payload[i] = true;
        int accepted = 0, refused = 0;
        const fs::path p = outDir() / "fuzz.iris";
        for (uint64_t i = 0; i < base.b.size(); ++i) {
            if (payload[i]) continue;
            for (int way = 0; way < 2; ++way) {
                Bytes b = base.b;
                b[i] = way == 0 ? uint8_t(b[i] ^ 0x01) : uint8_t(b[i] ^ 0x80);
                QVERIFY(writeAll(p, b));
                const iris::Result r = e_->open(p.string());
                if (r.ok()) {
                    ++accepted;
                    (void)e_->waitForFrame(kFrameTimeout); // may fail: a bad tile is reported, not fatal
                } else {
                    ++refused;
                    QVERIFY2(r.status() == iris::Status::CorruptData || r.status() == iris::Status::UnsupportedFormat,
                             describe(r).c_str());
                    QVERIFY2(r.message().find("'fuzz.iris'") != std::string::npos, r.message().c_str());
                }
            }
        }
        qInfo("%d corrupted files accepted, %d refused", accepted, refused);
        QVERIFY(refused > 0);
        e_->clearError();
        std::lock_guard lock(log_->mutex);
        log_->errors.clear();
    }
};

QTEST_GUILESS_MAIN(TestIrisReader)
#include "tst_iris_reader.moc"
