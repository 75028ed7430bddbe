// tst_sample: the built-in sample slide written by iris-sample.
//
// Uses the CTest fixture slide ($IRIS_TEST_SAMPLE: 6000 x 4000, seed 7) and checks that
// OpenSlide 3.4.1 opens it as generic-tiff with the expected pyramid and resolution, that
// the level-0 tiles OpenSlide decodes match the generator's own pixels within JPEG
// tolerance, that output is deterministic per seed, and that bad arguments fail cleanly.

#include "sample_slide.h"

#include <openslide/openslide.h>

#include <QCryptographicHash>
#include <QDir>
#include <QFile>
#include <QProcess>
#include <QTemporaryDir>
#include <QtTest>

#include <cmath>
#include <cstdlib>
#include <vector>

namespace {

constexpr int64_t kWidth = 6000;
constexpr int64_t kHeight = 4000;
constexpr uint64_t kSeed = 7;
constexpr int kTile = iris::sample::kTileSize;

// JPEG tolerance for q90 4:2:0 tiles decoded by OpenSlide's libjpeg vs the RGB handed to
// TurboJPEG. Measured on this content: worst tile mean ~3.6, worst single channel ~45.
// A colour-space mix-up (e.g. YCbCr data declared RGB) gives tile means of 70+.
constexpr double kMaxTileMeanError = 5.0;   // mean |diff| over a tile's pixels and channels
constexpr double kMaxOverallMeanError = 3.0;  // mean over all tiles checked
constexpr int kMaxPixelError = 64;          // any single channel of any pixel

QString samplePath() { return qEnvironmentVariable("IRIS_TEST_SAMPLE"); }

QString outDir() {
  const QString dir = qEnvironmentVariable("IRIS_TEST_OUT");
  return dir.isEmpty() ? QDir::tempPath() : dir;
}

QByteArray sha256(const QString& path) {
  QFile f(path);
  if (!f.open(QIODevice::ReadOnly)) return {};
  QCryptographicHash h(QCryptographicHash::Sha256);
  h.addData(&f);
  return h.result();
}

struct RunResult {
  int exitCode = -1;
  bool crashed = false;
  QString stdErr;
};

RunResult runSample(const QStringList& args) {
  QProcess p;
  // iris-sample beside this program (the build's bin/ folder).
  p.start(QCoreApplication::applicationDirPath() + QStringLiteral("/iris-sample"), args);
  RunResult r;
  if (!p.waitForStarted(10000)) return r;
  p.waitForFinished(120000);
  r.crashed = p.exitStatus() != QProcess::NormalExit;
  r.exitCode = p.exitCode();
  r.stdErr = QString::fromLocal8Bit(p.readAllStandardError());
  return r;
}

QString slideProperty(openslide_t* s, const char* name) {
  const char* v = openslide_get_property_value(s, name);
  return v ? QString::fromUtf8(v) : QString();
}

}  // namespace

class TestSample : public QObject {
  Q_OBJECT

 private slots:
  void initTestCase() {
    QVERIFY2(!samplePath().isEmpty(), "IRIS_TEST_SAMPLE is not set (run through ctest)");
    QVERIFY2(QFile::exists(samplePath()), qPrintable("missing fixture slide " + samplePath()));
  }

  void openslideProperties() {
    const QByteArray path = samplePath().toLocal8Bit();
    QCOMPARE(QString::fromUtf8(openslide_detect_vendor(path.constData())),
             QStringLiteral("generic-tiff"));
    openslide_t* s = openslide_open(path.constData());
    QVERIFY(s);
    QVERIFY2(!openslide_get_error(s), openslide_get_error(s));
    QCOMPARE(slideProperty(s, OPENSLIDE_PROPERTY_NAME_VENDOR), QStringLiteral("generic-tiff"));

    const auto levels = iris::sample::pyramidLevels(kWidth, kHeight);
    QCOMPARE(levels.size(), size_t{6});  // 6000 3000 1500 750 375 188
    QCOMPARE(openslide_get_level_count(s), static_cast<int32_t>(levels.size()));
    for (int i = 0; i < static_cast<int>(levels.size()); ++i) {
      int64_t w = 0, h = 0;
      openslide_get_level_dimensions(s, i, &w, &h);
      QCOMPARE(w, levels[i].width);
      QCOMPARE(h, levels[i].height);
    }
    QCOMPARE(levels.back().width, int64_t{188});
    QCOMPARE(levels.back().height, int64_t{125});

    // Resolution: 40000 px/cm = 0.25 um/px. OpenSlide 3.4.1's generic-tiff reader does not
    // derive openslide.mpp-x/y itself (4.x does); it exposes the TIFF tags, from which the
    // mpp follows. Accept either, but the value must be 0.25.
    auto mppOf = [&](const char* mppName, const char* resName) {
      const QString mpp = slideProperty(s, mppName);
      if (!mpp.isEmpty()) return mpp.toDouble();
      if (slideProperty(s, "tiff.ResolutionUnit") != QStringLiteral("centimeter")) return 0.0;
      const double perCm = slideProperty(s, resName).toDouble();
      return perCm > 0 ? 10000.0 / perCm : 0.0;
    };
    QVERIFY(std::abs(mppOf(OPENSLIDE_PROPERTY_NAME_MPP_X, "tiff.XResolution") - 0.25) < 1e-6);
    QVERIFY(std::abs(mppOf(OPENSLIDE_PROPERTY_NAME_MPP_Y, "tiff.YResolution") - 0.25) < 1e-6);
    QVERIFY(slideProperty(s, OPENSLIDE_PROPERTY_NAME_COMMENT).contains(QStringLiteral("seed 7")));
    openslide_close(s);
  }

  void tilesMatchGenerator() {
    const QByteArray path = samplePath().toLocal8Bit();
    openslide_t* s = openslide_open(path.constData());
    QVERIFY(s);
    iris::sample::Options o;
    o.width = kWidth;
    o.height = kHeight;
    o.seed = kSeed;
    const int64_t tilesX = (kWidth + kTile - 1) / kTile, tilesY = (kHeight + kTile - 1) / kTile;

    // Every level-0 tile: glass, tissue, tissue edges, and the partial right/bottom edge
    // tiles. (384 tiles; the generator is fast enough.)
    std::vector<std::pair<int64_t, int64_t>> tiles;
    int tissue = 0;
    for (int64_t ty = 0; ty < tilesY; ++ty)
      for (int64_t tx = 0; tx < tilesX; ++tx) {
        tiles.emplace_back(tx, ty);
        if (!iris::sample::isGlassTile(o, tx, ty)) ++tissue;
      }
    qInfo("%d of %zu tiles hold tissue", tissue, tiles.size());
    QVERIFY2(tissue >= 40, "the sample has too little tissue");
    QVERIFY2(tissue <= static_cast<int>(tiles.size()) - 40, "the sample has too little glass");
    QVERIFY(iris::sample::isGlassTile(o, 0, 0));

    std::vector<uint32_t> argb(static_cast<size_t>(kTile) * kTile);
    std::vector<uint8_t> rgb;
    double sumAll = 0, worstMean = 0;
    int64_t countAll = 0;
    int worstPixel = 0;
    for (const auto& [tx, ty] : tiles) {
      openslide_read_region(s, argb.data(), tx * kTile, ty * kTile, 0, kTile, kTile);
      QVERIFY2(!openslide_get_error(s), openslide_get_error(s));
      QVERIFY(iris::sample::generateTile(o, tx, ty, rgb));
      const int w = static_cast<int>(std::min<int64_t>(kTile, kWidth - tx * kTile));
      const int h = static_cast<int>(std::min<int64_t>(kTile, kHeight - ty * kTile));
      double sum = 0;
      int worst = 0;
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          const uint32_t p = argb[static_cast<size_t>(y) * kTile + x];
          if ((p >> 24) != 0xffu) QFAIL("transparent pixel inside the slide");
          const int got[3] = {int(p >> 16 & 0xff), int(p >> 8 & 0xff), int(p & 0xff)};
          const uint8_t* want = &rgb[(static_cast<size_t>(y) * kTile + x) * 3];
          for (int c = 0; c < 3; ++c) {
            const int d = std::abs(got[c] - want[c]);
            sum += d;
            worst = std::max(worst, d);
          }
        }
      }
      const double mean = sum / (3.0 * w * h);
      sumAll += sum;
      countAll += 3LL * w * h;
      const QString where = QStringLiteral("tile (%1, %2) %3x%4: mean abs error %5, max %6")
                                .arg(tx).arg(ty).arg(w).arg(h).arg(mean, 0, 'f', 2).arg(worst);
      QVERIFY2(mean < kMaxTileMeanError, qPrintable(where));
      QVERIFY2(worst <= kMaxPixelError, qPrintable(where));
      worstMean = std::max(worstMean, mean);
      worstPixel = std::max(worstPixel, worst);
    }
    const double overall = sumAll / static_cast<double>(countAll);
    qInfo("overall mean abs error %.2f; worst tile mean %.2f; worst channel error %d", overall,
          worstMean, worstPixel);
    QVERIFY(overall < kMaxOverallMeanError);

    // Lower levels render as the same slide: the mean colour of level 2 equals that of level 0
    // over the same area (box-filtered pyramid), within a few levels.
    {
      const int64_t x0 = 2048, y0 = 1024, size = 1024;  // level-0 area
      std::vector<uint32_t> big(static_cast<size_t>(size) * size);
      std::vector<uint32_t> small(static_cast<size_t>(size / 4) * (size / 4));
      openslide_read_region(s, big.data(), x0, y0, 0, size, size);
      openslide_read_region(s, small.data(), x0, y0, 2, size / 4, size / 4);
      QVERIFY(!openslide_get_error(s));
      double m0[3] = {0, 0, 0}, m2[3] = {0, 0, 0};
      for (uint32_t p : big)
        for (int c = 0; c < 3; ++c) m0[c] += (p >> (16 - 8 * c)) & 0xff;
      for (uint32_t p : small)
        for (int c = 0; c < 3; ++c) m2[c] += (p >> (16 - 8 * c)) & 0xff;
      for (int c = 0; c < 3; ++c) {
        m0[c] /= static_cast<double>(big.size());
        m2[c] /= static_cast<double>(small.size());
        QVERIFY2(std::abs(m0[c] - m2[c]) < 3.0,
                 qPrintable(QStringLiteral("channel %1: level0 %2 level2 %3").arg(c).arg(m0[c]).arg(m2[c])));
      }
    }
    openslide_close(s);
  }

  void deterministicPerSeed() {
    QTemporaryDir dir(outDir() + QStringLiteral("/tst_sample-XXXXXX"));
    QVERIFY(dir.isValid());
    const QString a = dir.filePath(QStringLiteral("a.tiff"));
    const QString b = dir.filePath(QStringLiteral("b.tiff"));
    const QString c = dir.filePath(QStringLiteral("c.tiff"));
    const QStringList common = {QStringLiteral("--width"), QStringLiteral("1500"),
                                QStringLiteral("--height"), QStringLiteral("1100")};
    RunResult r = runSample(QStringList{"--out", a, "--seed", "3"} + common);
    QCOMPARE(r.exitCode, 0);
    r = runSample(QStringList{"--out", b, "--seed", "3", "--threads", "1"} + common);
    QCOMPARE(r.exitCode, 0);
    r = runSample(QStringList{"--out", c, "--seed", "4"} + common);
    QCOMPARE(r.exitCode, 0);
    const QByteArray ha = sha256(a), hb = sha256(b), hc = sha256(c);
    QVERIFY(!ha.isEmpty());
    QCOMPARE(ha, hb);  // same seed (and any thread count): byte-identical
    QVERIFY(ha != hc);  // another seed: another slide
  }

  void badArguments_data() {
    QTest::addColumn<QStringList>("args");
    QTest::addColumn<QString>("expected");  // part of the error message
    const QString tmp = outDir() + QStringLiteral("/tst_sample-bad.tiff");
    QTest::newRow("width 0") << QStringList{"--out", tmp, "--width", "0", "--height", "100"}
                             << QStringLiteral("width");
    QTest::newRow("height too big")
        << QStringList{"--out", tmp, "--width", "100", "--height", "1000001"} << QStringLiteral("height");
    QTest::newRow("not a number") << QStringList{"--out", tmp, "--width", "12x"} << QStringLiteral("width");
    QTest::newRow("unknown option") << QStringList{"--colour", "red"} << QStringLiteral("unknown");
    QTest::newRow("missing value") << QStringList{"--seed"} << QStringLiteral("missing");
    QTest::newRow("unwritable path")
        << QStringList{"--out", "/nonexistent/dir/x.tiff", "--width", "300", "--height", "300"}
        << QStringLiteral("/nonexistent/dir/x.tiff");
  }

  void badArguments() {
    QFETCH(QStringList, args);
    QFETCH(QString, expected);
    const RunResult r = runSample(args);
    QVERIFY(!r.crashed);
    QVERIFY2(r.exitCode != 0, qPrintable(r.stdErr));
    QVERIFY2(r.stdErr.contains(QStringLiteral("error")), qPrintable(r.stdErr));
    QVERIFY2(r.stdErr.contains(expected), qPrintable(r.stdErr));
    QVERIFY(!QFile::exists(QStringLiteral("/nonexistent/dir/x.tiff")));
  }

  void validateOptionsApi() {
    iris::sample::Options o;
    QVERIFY(iris::sample::validateOptions(o).ok);
    o.width = 0;
    QVERIFY(!iris::sample::validateOptions(o).ok);
    o.width = 1'000'001;
    QVERIFY(!iris::sample::validateOptions(o).ok);
    o.width = 1'000'000;
    QVERIFY(iris::sample::validateOptions(o).ok);
    o.quality = 0;
    QVERIFY(!iris::sample::validateOptions(o).ok);
    // Default pyramid: 50000 x 40000 down to one tile.
    const auto levels = iris::sample::pyramidLevels(50000, 40000);
    QCOMPARE(levels.size(), size_t{9});
    QVERIFY(levels.back().width <= kTile && levels.back().height <= kTile);
  }
};

QTEST_GUILESS_MAIN(TestSample)
#include "tst_sample.moc"
