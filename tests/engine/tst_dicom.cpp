// DICOM WSI source (issue 15, "Local DICOM WSI"): slide/dicom_source read directly, tile by tile,
// against the TIFF they were made from, read through the direct TIFF source (slide/tiff_source).
//
// Test slides are made at test time by OrthancWSIDicomizer (Debian orthanc-wsi) into
// $IRIS_TEST_OUT/dicom/: from the sample slide ($IRIS_TEST_SAMPLE) and from the shared test slides.
//   * JPEG frames transferred without re-encoding (--reencode=0): every tile equals the TIFF's
//     byte for byte (YBR_FULL_422 frames of the sample, RGB 240×240 frames of CMU-1-Small-Region),
//     with a level split over several files (--max-size=1).
//   * JPEG 2000 lossless (240, 120×80 and 512×512 frames) and uncompressed (256, 128×64): byte
//     for byte.
//   * JPEG re-encoded: within a JPEG tolerance.
//   * the two dicom-boxes files of the shared test data (made by PixelMed's TIFFToDicom from
//     aperio/small.svs, JPEG frames copied): metadata, and pixels equal small.svs's.
//   * errors: a non-WSI DICOM file, an unsupported transfer syntax, hostile values, truncated
//     files, a missing file of a split level, a folder without DICOM: clear errors, no crash.
//   * through the public Engine: a DICOM folder opens and renders as the TIFF does.
#include <QtTest>

#include <cstdlib>
#include <algorithm>
#include <fstream>
#include <random>

#include <dcmtk/config/osconfig.h>

#include <dcmtk/dcmdata/dcdatset.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>

#include "slide/dicom_source.h"
#include "slide/slide_source.h"
#include "slide/tiff_source.h"
#include "test_support.h"

using namespace iristest;
namespace fs = std::filesystem;
using iris::kTileBytes;
using iris::kTileSize;

namespace {

#define CHECKED(call)                                                                                                  \
    do {                                                                                                               \
        call;                                                                                                          \
        if (QTest::currentTestFailed()) return;                                                                        \
    } while (0)

fs::path dicomOut() {
    const fs::path d = testOutDir() / "dicom";
    fs::create_directories(d);
    return d;
}

// Runs OrthancWSIDicomizer on `source` into a fresh folder `name` under dicomOut().
std::optional<fs::path> dicomize(const std::string& name, const fs::path& source, const std::string& options,
                                 std::string* why) {
    const fs::path out = dicomOut() / name;
    fs::remove_all(out);
    fs::create_directories(out);
    const std::string cmd = "OrthancWSIDicomizer --threads=1 --folder='" + out.string() + "' " + options + " '" +
                            source.string() + "' > '" + out.string() + ".log' 2>&1";
    if (std::system(cmd.c_str()) != 0) {
        *why = "OrthancWSIDicomizer failed: " + cmd + " (see " + out.string() + ".log)";
        return std::nullopt;
    }
    return out;
}

std::unique_ptr<iris::SlideSource> openOrFail(const fs::path& p, std::string* why) {
    auto r = iris::openSlideSource(p.string());
    if (!r.ok()) {
        *why = "cannot open " + p.string() + ": " + describe(r.error());
        return nullptr;
    }
    return std::move(*r);
}

struct TileDiff {
    uint64_t tiles = 0; // tiles compared
    uint64_t differingTiles = 0;
    int maxAbs = 0;    // largest channel difference
    double sumAbs = 0; // over every compared channel
    uint64_t channels = 0;
    double dicomSeconds = 0, refSeconds = 0; // time in each source's readTile
    double meanAbs() const { return channels ? sumAbs / double(channels) : 0; }
    std::string summary() const {
        return std::to_string(tiles) + " tiles, " + std::to_string(differingTiles) + " differ, max " +
               std::to_string(maxAbs) + ", mean " + std::to_string(meanAbs()) + "; read " +
               std::to_string(int(dicomSeconds * 1e6 / double(tiles ? tiles : 1))) + " us/tile (reference " +
               std::to_string(int(refSeconds * 1e6 / double(tiles ? tiles : 1))) + ")";
    }
};

// Reads tiles of `level` (every one, or every `step`-th in each direction plus the last row and
// column) from both sources and compares the valid part of each (RGB and alpha).
bool compareLevel(iris::SlideSource& dicom, int dl, iris::SlideSource& ref, int rl, int step, TileDiff* d,
                  std::string* why) {
    const iris::LevelInfo& a = dicom.info().levels[size_t(dl)];
    const iris::LevelInfo& b = ref.info().levels[size_t(rl)];
    if (a.width != b.width || a.height != b.height) {
        *why = "level sizes differ: " + std::to_string(a.width) + "x" + std::to_string(a.height) + " vs " +
               std::to_string(b.width) + "x" + std::to_string(b.height);
        return false;
    }
    std::vector<uint8_t> ta(kTileBytes), tb(kTileBytes);
    for (int64_t ty = 0; ty < a.tilesY; ++ty) {
        if (ty % step != 0 && ty != a.tilesY - 1) continue;
        for (int64_t tx = 0; tx < a.tilesX; ++tx) {
            if (tx % step != 0 && tx != a.tilesX - 1) continue;
            const auto t0 = std::chrono::steady_clock::now();
            if (auto r = dicom.readTile(dl, tx, ty, ta.data()); !r.ok()) {
                *why = "DICOM tile (" + std::to_string(tx) + ", " + std::to_string(ty) + "): " + describe(r);
                return false;
            }
            const auto t1 = std::chrono::steady_clock::now();
            if (auto r = ref.readTile(rl, tx, ty, tb.data()); !r.ok()) {
                *why = "reference tile: " + describe(r);
                return false;
            }
            d->dicomSeconds += std::chrono::duration<double>(t1 - t0).count();
            d->refSeconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
            const int w = int(std::min<int64_t>(kTileSize, a.width - tx * kTileSize));
            const int h = int(std::min<int64_t>(kTileSize, a.height - ty * kTileSize));
            bool differs = false;
            for (int y = 0; y < h; ++y) {
                for (int x = 0; x < w * 4; ++x) {
                    const size_t i = size_t(y) * kTileSize * 4 + size_t(x);
                    const int diff = std::abs(int(ta[i]) - int(tb[i]));
                    d->maxAbs = std::max(d->maxAbs, diff);
                    d->sumAbs += diff;
                    differs = differs || diff;
                }
            }
            d->channels += uint64_t(w) * h * 4;
            d->tiles++;
            d->differingTiles += differs;
        }
    }
    return true;
}

// Every level of `dicom` against the TIFF source's level of the same size.
void expectSameLevels(iris::SlideSource& dicom, iris::SlideSource& ref, int maxLevels, int step, int tolerance,
                      double meanTolerance, const char* what) {
    const auto& di = dicom.info();
    const auto& ri = ref.info();
    QVERIFY2(!di.levels.empty(), what);
    int compared = 0;
    for (size_t dl = 0; dl < di.levels.size() && compared < maxLevels; ++dl) {
        int rl = -1;
        for (size_t k = 0; k < ri.levels.size(); ++k)
            if (ri.levels[k].width == di.levels[dl].width && ri.levels[k].height == di.levels[dl].height) rl = int(k);
        QVERIFY2(rl >= 0, qPrintable(QString("%1: DICOM level %2 (%3x%4) has no TIFF level of its size")
                                         .arg(what)
                                         .arg(dl)
                                         .arg(di.levels[dl].width)
                                         .arg(di.levels[dl].height)));
        TileDiff d;
        std::string why;
        QVERIFY2(compareLevel(dicom, int(dl), ref, rl, step, &d, &why), (std::string(what) + ": " + why).c_str());
        qInfo("%s level %zu (%lldx%lld): %s", what, dl, (long long)di.levels[dl].width, (long long)di.levels[dl].height,
              d.summary().c_str());
        QVERIFY2(d.tiles > 0, what);
        QVERIFY2(d.maxAbs <= tolerance && d.meanAbs() <= meanTolerance,
                 (std::string(what) + " level " + std::to_string(dl) + ": " + d.summary()).c_str());
        ++compared;
    }
}

std::optional<fs::path> sample() {
    auto s = sampleSlidePath();
    if (!s || !fs::exists(*s)) return std::nullopt;
    return s;
}

// Writes a copy of `from` with `edit` applied to its dataset, in transfer syntax `xfer`.
bool editCopy(const fs::path& from, const fs::path& to, const std::function<void(DcmDataset*)>& edit,
              E_TransferSyntax xfer = EXS_Unknown) {
    DcmFileFormat ff;
    if (ff.loadFile(OFFilename(from.c_str())).bad()) return false;
    edit(ff.getDataset());
    const E_TransferSyntax x = xfer == EXS_Unknown ? ff.getDataset()->getOriginalXfer() : xfer;
    return ff.saveFile(OFFilename(to.c_str()), x).good();
}

bool truncatedCopy(const fs::path& from, const fs::path& to, uintmax_t bytes) {
    std::ifstream in(from, std::ios::binary);
    std::vector<char> buf(static_cast<size_t>(bytes));
    in.read(buf.data(), std::streamsize(bytes));
    std::ofstream out(to, std::ios::binary | std::ios::trunc);
    out.write(buf.data(), in.gcount());
    return bool(out);
}

// open() fails with `status` and a message naming `name` (and holding `words` when given).
void expectOpenFails(const fs::path& p, iris::Status status, const std::string& name, const std::string& words = {}) {
    auto r = iris::openSlideSource(p.string());
    QVERIFY2(!r.ok(), ("opened " + p.string()).c_str());
    const std::string& m = r.error().message();
    qInfo("%s → %s", p.filename().c_str(), describe(r.error()).c_str());
    QVERIFY2(r.error().status() == status, ("status " + std::string(iris::statusName(r.error().status())) +
                                            ", expected " + iris::statusName(status) + ": " + m)
                                               .c_str());
    QVERIFY2(m.find(name) != std::string::npos, ("the message does not name '" + name + "': " + m).c_str());
    QVERIFY2(words.empty() || m.find(words) != std::string::npos,
             ("the message does not say '" + words + "': " + m).c_str());
}

} // namespace

class TestDicom : public QObject {
    Q_OBJECT

    std::optional<fs::path> sampleJpeg_; // the sample, JPEG frames copied, level 0 split over files
    std::optional<fs::path> noneSample_; // the sample re-encoded uncompressed, 256 px frames
    std::optional<fs::path> cmu240_;     // CMU-1-Small-Region, 240 px JPEG frames copied

private slots:
    void initTestCase() {
        if (std::system("command -v OrthancWSIDicomizer > /dev/null 2>&1") != 0) {
            QFAIL("OrthancWSIDicomizer (Debian orthanc-wsi) is not installed: scripts/install-deps.sh installs it");
        }
    }

    // The shared test data's two-file series, by folder and by either file.
    void boxes() {
        auto dir = slidesDir("unsupported/dicom-boxes");
        auto svs = slidesDir("aperio");
        if (!dir || !svs) QSKIP("no test data");
        for (const fs::path& p : {*dir, *dir / "boxes_0.dcm", *dir / "boxes_1.dcm"}) {
            std::string why;
            auto src = openOrFail(p, &why);
            QVERIFY2(src, why.c_str());
            const iris::SlideInfo& info = src->info();
            QCOMPARE(info.width, int64_t(16));
            QCOMPARE(info.height, int64_t(16));
            QCOMPARE(info.levels.size(), size_t(1));
            QCOMPARE(info.vendor, std::string("Leica Biosystems"));
            QCOMPARE(info.mppX, 0.499);
            QCOMPARE(info.mppY, 0.499);
            QCOMPARE(info.objectivePower, 20.0);
            QCOMPARE(info.iccProfile.size(), size_t(456));
            QCOMPARE(std::string(reinterpret_cast<const char*>(info.iccProfile.data()) + 36, 4), std::string("acsp"));
            QCOMPARE(info.associatedImages, std::vector<std::string>{"thumbnail"});
            const auto prop = [&](const std::string& k) {
                for (const auto& [key, value] : info.properties)
                    if (key == k) return value;
                return std::string("(absent)");
            };
            QCOMPARE(prop("dicom.Manufacturer"), std::string("Leica Biosystems"));
            QCOMPARE(prop("dicom.ImageType"), std::string("DERIVED\\PRIMARY\\VOLUME\\NONE"));
            QCOMPARE(prop("dicom.TotalPixelMatrixColumns"), std::string("16"));
            QCOMPARE(prop("dicom.ContainerIdentifier"), std::string("SLIDE_1"));
            QCOMPARE(prop("dicom.SpecimenIdentifier"), std::string("SPECIMEN_1"));
            QCOMPARE(prop("dicom.TransferSyntaxUID"), std::string("1.2.840.10008.1.2.4.50"));
            QVERIFY(std::is_sorted(info.properties.begin(), info.properties.end()));
            auto thumb = src->readAssociatedImage("thumbnail");
            QVERIFY2(thumb.ok(), describe(thumb.error()).c_str());
            QCOMPARE(thumb->width, 16u);
            QCOMPARE(thumb->height, 16u);
            QVERIFY(!src->readAssociatedImage("label").ok());
        }
        // PixelMed copied small.svs's JPEG tile (64×64, RGB components) into the frame: the
        // pixels are small.svs's, byte for byte (through the TIFF source, which libtiff decodes).
        std::string why;
        auto dicom = openOrFail(*dir, &why);
        auto ref = openOrFail(*svs / "small.svs", &why);
        QVERIFY2(dicom && ref, why.c_str());
        CHECKED(expectSameLevels(*dicom, *ref, 1, 1, 0, 0, "dicom-boxes vs small.svs"));
        // The THUMBNAIL instance is uncompressed: it holds small.svs's thumbnail directory.
        auto thumb = dicom->readAssociatedImage("thumbnail");
        auto refThumb = ref->readAssociatedImage("thumbnail");
        QVERIFY(thumb.ok() && refThumb.ok());
        QCOMPARE(thumb->width, refThumb->width);
        const DiffStats st = compareImages(*thumb, *refThumb);
        qInfo("thumbnail: %s", st.summary().c_str());
        QCOMPARE(st.differing, uint64_t(0));
    }

    // The sample slide with its JPEG tiles copied into frames (YBR_FULL_422), level 0 split
    // over several files: every tile of every level equals the TIFF's byte for byte.
    void sampleJpegCopied() {
        auto s = sample();
        if (!s) QSKIP("no sample slide (IRIS_TEST_SAMPLE)");
        std::string why;
        sampleJpeg_ = dicomize("sample-jpeg", *s, "--reencode=0 --max-size=1", &why);
        QVERIFY2(sampleJpeg_, why.c_str());
        int files = 0;
        for (const auto& e : fs::directory_iterator(*sampleJpeg_)) files += e.is_regular_file();
        auto tiff = iris::TiffTileSource::tryOpen(s->string());
        QVERIFY2(tiff.ok(), describe(tiff.error()).c_str());
        QVERIFY2(
            size_t(files) > (*tiff)->info().levels.size(),
            qPrintable(
                QString("%1 files for %2 levels: no level was split").arg(files).arg((*tiff)->info().levels.size())));
        auto dicom = openOrFail(*sampleJpeg_, &why);
        QVERIFY2(dicom, why.c_str());
        QCOMPARE(dicom->info().levels.size(), (*tiff)->info().levels.size());
        for (size_t l = 0; l < dicom->info().levels.size(); ++l)
            QCOMPARE(dicom->info().levels[l].downsample, (*tiff)->info().levels[l].downsample);
        // Orthanc writes PixelSpacing from --imaged-width/height (15 mm by default) over the matrix.
        // Pixel Spacing is (row, column) spacing: mppY is the first value. Orthanc writes it
        // through a float ("0.00374999992"), hence the tolerance.
        QVERIFY(std::abs(dicom->info().mppX - 15000.0 / 6000) < 1e-5);
        QVERIFY(std::abs(dicom->info().mppY - 15000.0 / 4000) < 1e-5);
        QVERIFY(!dicom->info().iccProfile.empty()); // Orthanc adds an sRGB profile
        CHECKED(expectSameLevels(*dicom, **tiff, 99, 1, 0, 0, "sample, JPEG copied"));
        // One file of the series opens the whole series.
        auto one = openOrFail(*sampleJpeg_ / "wsi-000002.dcm", &why);
        QVERIFY2(one, why.c_str());
        QCOMPARE(one->info().levels.size(), dicom->info().levels.size());
    }

    // TILED_FULL: Orthanc's dicomizer places frames explicitly (Plane Position (Slide)), in
    // row-major order and with Concatenation Frame Offset Number on split levels. The same files
    // with the positions removed and TILED_FULL declared are a valid TILED_FULL series whose
    // level 0 is a 4-part concatenation: frames placed by order alone give the same tiles.
    void tiledFullConcatenation() {
        if (!sampleJpeg_) QSKIP("sampleJpegCopied did not run");
        auto s = sample();
        const fs::path out = dicomOut() / "sample-tiled-full";
        fs::remove_all(out);
        fs::create_directories(out);
        const auto toTiledFull = [](DcmDataset* ds) {
            ds->findAndDeleteElement(DCM_PerFrameFunctionalGroupsSequence);
            ds->putAndInsertString(DCM_DimensionOrganizationType, "TILED_FULL");
        };
        for (const auto& e : fs::directory_iterator(*sampleJpeg_))
            QVERIFY(editCopy(e.path(), out / e.path().filename(), toTiledFull));
        std::string why;
        auto dicom = openOrFail(out, &why);
        auto tiff = iris::TiffTileSource::tryOpen(s->string());
        QVERIFY2(dicom && tiff.ok(), why.c_str());
        CHECKED(expectSameLevels(*dicom, **tiff, 99, 1, 0, 0, "sample as TILED_FULL"));

        // Without its last part, level 0 lacks frames: refused, as TILED_FULL cannot have holes.
        fs::remove(out / "wsi-000003.dcm");
        CHECKED(expectOpenFails(out, iris::Status::CorruptData, "sample-tiled-full", "frames are missing"));
    }

    // Sparse tiling: a position with no frame is background (opaque white); a frame off the
    // frame grid is refused.
    void sparseHoleAndOffGrid() {
        if (!sampleJpeg_) QSKIP("sampleJpegCopied did not run");
        auto s = sample();
        // wsi-000007.dcm: the 375×250 level, frames at columns 1 and 257 of row 1.
        const fs::path in = *sampleJpeg_ / "wsi-000007.dcm";
        const auto movedTo = [](Sint32 column) {
            return [column](DcmDataset* ds) {
                DcmItem* frame = nullptr;
                DcmItem* pos = nullptr;
                if (ds->findAndGetSequenceItem(DCM_PerFrameFunctionalGroupsSequence, frame, 1).good() &&
                    frame->findAndGetSequenceItem(DCM_PlanePositionSlideSequence, pos, 0).good()) {
                    pos->putAndInsertSint32(DCM_ColumnPositionInTotalImagePixelMatrix, column);
                }
            };
        };
        const fs::path hole = dicomOut() / "sparse-hole", offGrid = dicomOut() / "sparse-off-grid";
        for (const auto& d : {hole, offGrid}) {
            fs::remove_all(d);
            fs::create_directories(d);
        }
        QVERIFY(editCopy(in, hole / "hole.dcm", movedTo(1))); // frame 2 drawn over frame 1: (1, 0) empty
        QVERIFY(editCopy(in, offGrid / "off-grid.dcm", movedTo(100)));
        std::string why;
        auto dicom = openOrFail(hole, &why);
        auto tiff = iris::TiffTileSource::tryOpen(s->string());
        QVERIFY2(dicom && tiff.ok(), why.c_str());
        QCOMPARE(dicom->info().width, int64_t(375));
        std::vector<uint8_t> a(kTileBytes), b(kTileBytes);
        int rl = -1;
        for (size_t k = 0; k < (*tiff)->info().levels.size(); ++k)
            if ((*tiff)->info().levels[k].width == 375) rl = int(k);
        QVERIFY(rl >= 0);
        QVERIFY(dicom->readTile(0, 0, 0, a.data()).ok());
        QVERIFY((*tiff)->readTile(rl, 0, 0, b.data()).ok());
        QVERIFY2(a == b, "the tile with its frame differs from the TIFF's");
        QVERIFY(dicom->readTile(0, 1, 0, a.data()).ok());
        QVERIFY2(std::all_of(a.begin(), a.end(), [](uint8_t v) { return v == 255; }), "the hole is not opaque white");
        CHECKED(expectOpenFails(offGrid, iris::Status::CorruptData, "off-grid.dcm", "not on the 256x256 frame grid"));
    }

    // CMU-1-Small-Region: 240×240 frames (RGB photometric), copied from the SVS.
    void cmuJpegCopied240() {
        auto svs = slidesDir("aperio");
        if (!svs) QSKIP("no test data");
        std::string why;
        auto out = dicomize("cmu-240", *svs / "CMU-1-Small-Region.svs", "--reencode=0", &why);
        QVERIFY2(out, why.c_str());
        cmu240_ = out;
        auto dicom = openOrFail(*out, &why);
        auto ref = openOrFail(*svs / "CMU-1-Small-Region.svs", &why);
        QVERIFY2(dicom && ref, why.c_str());
        CHECKED(expectSameLevels(*dicom, *ref, 99, 1, 0, 0, "CMU-1-Small-Region, 240 px JPEG copied"));
    }

    // Lossless re-encodings, uncompressed: 256 and non-square 128×64 frames. The dicomizer
    // decodes the TIFF's JPEG tiles with libjpeg as libtiff does, so the pixels it encodes are
    // the TIFF source's, and lossless frames decode to them exactly.
    // Level 0 only: when it re-encodes, the dicomizer does not copy the TIFF's smaller levels
    // but builds its own from level 0 (its log: "Constructing the 4 lower levels of the
    // pyramid"), with another filter than iris-sample's, so those are not the TIFF's pixels. They
    // are checked against each other instead: the same reconstruction, stored losslessly.
    void sampleLossless_data() {
        QTest::addColumn<QString>("options");
        QTest::newRow("none") << "--compression=none";
        QTest::newRow("none-128x64") << "--compression=none --tile-width=128 --tile-height=64";
    }
    void sampleLossless() {
        QFETCH(QString, options);
        auto s = sample();
        if (!s) QSKIP("no sample slide (IRIS_TEST_SAMPLE)");
        std::string why;
        const std::string name = "sample-" + std::string(QTest::currentDataTag());
        auto out = dicomize(name, *s, options.toStdString(), &why);
        QVERIFY2(out, why.c_str());
        auto dicom = openOrFail(*out, &why);
        auto tiff = iris::TiffTileSource::tryOpen(s->string());
        QVERIFY2(dicom && tiff.ok(), why.c_str());
        // Level 0 whole.
        CHECKED(expectSameLevels(*dicom, **tiff, 1, 1, 0, 0, name.c_str()));
        // The smaller levels: equal to the uncompressed 256 px version's (the first row).
        if (std::string(QTest::currentDataTag()) == "none") {
            noneSample_ = out;
        } else if (noneSample_) {
            auto none = openOrFail(*noneSample_, &why);
            QVERIFY2(none, why.c_str());
            // The pyramid's depth depends on the frame size: compare the levels of equal size.
            int compared = 0;
            for (size_t l = 1; l < dicom->info().levels.size(); ++l) {
                for (size_t k = 1; k < none->info().levels.size(); ++k) {
                    if (none->info().levels[k].width != dicom->info().levels[l].width ||
                        none->info().levels[k].height != dicom->info().levels[l].height) {
                        continue;
                    }
                    TileDiff d;
                    QVERIFY2(compareLevel(*dicom, int(l), *none, int(k), 1, &d, &why), why.c_str());
                    qInfo("%s level %zu vs the uncompressed version: %s", name.c_str(), l, d.summary().c_str());
                    QCOMPARE(d.maxAbs, 0);
                    ++compared;
                }
            }
            QVERIFY(compared > 0);
        }
    }

    // JPEG 2000 lossless (reversible wavelet and colour transform): 240 and non-square 120×80
    // frames from CMU-1-Small-Region (the sample would do too, but encoding its 24 Mpx to JPEG
    // 2000 takes the dicomizer 20 s). Level 0 exactly, for the reason given above.
    void cmuJpeg2000_data() {
        QTest::addColumn<QString>("options");
        QTest::newRow("240") << "--compression=jpeg2000 --reencode=1";
        QTest::newRow("120x80") << "--compression=jpeg2000 --tile-width=120 --tile-height=80";
    }
    void cmuJpeg2000() {
        QFETCH(QString, options);
        auto svs = slidesDir("aperio");
        if (!svs) QSKIP("no test data");
        std::string why;
        const std::string name = "cmu-jpeg2000-" + std::string(QTest::currentDataTag());
        auto out = dicomize(name, *svs / "CMU-1-Small-Region.svs", options.toStdString(), &why);
        QVERIFY2(out, why.c_str());
        auto dicom = openOrFail(*out, &why);
        auto ref = openOrFail(*svs / "CMU-1-Small-Region.svs", &why);
        QVERIFY2(dicom && ref, why.c_str());
        CHECKED(expectSameLevels(*dicom, *ref, 1, 1, 0, 0, name.c_str()));
    }

    // 512×512 JPEG 2000 frames (and 1024 in the TIFF): from a test slide with 1024 px tiles,
    // which the dicomizer reads through OpenSlide. Level 0 only: OpenSlide 3.4.1 returns wrong
    // pixels on this file's small levels (SOURCES.md), and the dicomizer encodes what it gets.
    void large512Jp2k() {
        auto dir = slidesDir("generic-tiff");
        if (!dir) QSKIP("no test data");
        const fs::path src = *dir / "yb10kx5k.zstd.tiff";
        std::string why;
        auto out =
            dicomize("yb-512-jp2k", src,
                     "--openslide=libopenslide.so.0 --compression=jpeg2000 --tile-width=512 --tile-height=512", &why);
        QVERIFY2(out, why.c_str());
        auto dicom = openOrFail(*out, &why);
        auto ref = openOrFail(src, &why);
        QVERIFY2(dicom && ref, why.c_str());
        CHECKED(expectSameLevels(*dicom, *ref, 1, 5, 0, 0, "yb10kx5k, 512 px JPEG 2000"));
    }

    // JPEG re-encoded (120×120 frames from CMU's 240): lossy, so within a JPEG tolerance. The
    // mean error is small (under 2 at quality 95) but single channels at sharp stain edges move
    // by up to about 105: the dicomizer's encoder subsamples chroma 4:2:0, and colour bleeds
    // over a 2-pixel edge. (The frame mapping itself is exact: see the lossless 128×64 case.)
    void cmuJpegReencoded() {
        auto svs = slidesDir("aperio");
        if (!svs) QSKIP("no test data");
        std::string why;
        auto out =
            dicomize("cmu-120-jpeg", *svs / "CMU-1-Small-Region.svs",
                     "--reencode=1 --compression=jpeg --jpeg-quality=95 --tile-width=120 --tile-height=120", &why);
        QVERIFY2(out, why.c_str());
        auto dicom = openOrFail(*out, &why);
        auto ref = openOrFail(*svs / "CMU-1-Small-Region.svs", &why);
        QVERIFY2(dicom && ref, why.c_str());
        CHECKED(expectSameLevels(*dicom, *ref, 1, 1, 128, 2.5, "CMU-1-Small-Region, JPEG q95 re-encoded at 120 px"));
    }

    // iris-encode converts a DICOM series (given as its folder) like any slide: the .iris file
    // has the DICOM's levels, and its tiles are the DICOM's within JPEG re-encoding error.
    void encodeToIris() {
        auto dir = slidesDir("unsupported/dicom-boxes");
        if (!dir) QSKIP("no test data");
        const fs::path out = dicomOut() / "boxes.iris";
        fs::remove(out);
        // iris-encode beside this program (the build's bin/ folder, or a bundle copied elsewhere).
        const QString exe = QCoreApplication::applicationDirPath() + "/iris-encode";
        QVERIFY2(QFileInfo::exists(exe), qPrintable(exe + " does not exist (built with this suite)"));
        const std::string cmd = exe.toStdString() + " '" + dir->string() + "' -o '" + out.string() +
                                "' > '" + out.string() + ".log' 2>&1";
        QVERIFY2(std::system(cmd.c_str()) == 0, ("iris-encode failed: " + cmd).c_str());
        std::string why;
        auto dicom = openOrFail(*dir, &why);
        auto iris = openOrFail(out, &why);
        QVERIFY2(dicom && iris, why.c_str());
        QCOMPARE(iris->info().width, dicom->info().width);
        QCOMPARE(iris->info().levels.size(), dicom->info().levels.size());
        CHECKED(expectSameLevels(*iris, *dicom, 99, 1, 40, 3.0, "boxes.iris vs the DICOM series"));
    }

    // Label, overview and thumbnail instances are the associated images label, macro, thumbnail.
    void associatedKinds() {
        auto dir = slidesDir("unsupported/dicom-boxes");
        if (!dir) QSKIP("no test data");
        const fs::path out = dicomOut() / "associated";
        fs::remove_all(out);
        fs::create_directories(out);
        fs::copy_file(*dir / "boxes_0.dcm", out / "boxes_0.dcm");
        const auto as = [](const char* type, const char* uid) {
            return [type, uid](DcmDataset* ds) {
                ds->putAndInsertString(DCM_ImageType, type);
                ds->putAndInsertString(DCM_SOPInstanceUID, uid);
            };
        };
        QVERIFY(editCopy(*dir / "boxes_1.dcm", out / "label.dcm", as("ORIGINAL\\PRIMARY\\LABEL\\NONE", "1.2.3.4.1")));
        QVERIFY(
            editCopy(*dir / "boxes_1.dcm", out / "overview.dcm", as("ORIGINAL\\PRIMARY\\OVERVIEW\\NONE", "1.2.3.4.2")));
        std::string why;
        auto src = openOrFail(out, &why);
        QVERIFY2(src, why.c_str());
        QCOMPARE(src->info().associatedImages, (std::vector<std::string>{"label", "macro"}));
        QCOMPARE(src->info().levels.size(), size_t(1));
        for (const char* name : {"label", "macro"}) {
            auto img = src->readAssociatedImage(name);
            QVERIFY2(img.ok(), describe(img.error()).c_str());
            QCOMPARE(img->width, 16u);
        }
    }

    // Through the public Engine: the DICOM folder renders, at level 0 and at a level's
    // downsample, exactly as the TIFF it was made from.
    void engineRendersLikeTiff() {
        if (!sampleJpeg_) QSKIP("sampleJpegCopied did not run");
        auto s = sample();
        constexpr uint32_t kW = 320, kH = 240;
        // Colour management off, as every suite that compares bytes: OrthancWSIDicomizer embeds
        // an ICC profile ("uRGB") that the TIFF does not carry, and its transform to sRGB, though
        // close to the identity, moves a few pixels by one code.
        iris::EngineConfig cfg;
        cfg.color.managed = false;
        TestEngine e = createTestEngine(cfg);
        QVERIFY2(e, describe(e.error).c_str());
        QVERIFY(e->bindOffscreen(kW, kH).ok());
        e.beginTest();
        for (const double ds : {1.0, 4.0}) {
            const iris::View view = viewWithOrigin(1234, 987, ds, kW, kH);
            std::string why;
            QVERIFY2(e->open(s->string()).ok(), "the TIFF does not open");
            auto a = renderView(*e.engine, view, kW, kH, std::chrono::seconds(60), &why);
            QVERIFY2(a, why.c_str());
            const iris::Result r = e->open(sampleJpeg_->string());
            QVERIFY2(r.ok(), describe(r).c_str());
            auto b = renderView(*e.engine, view, kW, kH, std::chrono::seconds(60), &why);
            QVERIFY2(b, why.c_str());
            const DiffStats st = compareImages(b->image, a->image);
            qInfo("engine frame at downsample %.0f: %s", ds, st.summary().c_str());
            QVERIFY2(st.differing == 0, saveFailureArtefacts("dicom.engine", b->image, a->image, nullptr).c_str());
        }
        const std::string endWhy = e.endTest();
        QVERIFY2(endWhy.empty(), endWhy.c_str());
        const std::string finishWhy = e.finish();
        QVERIFY2(finishWhy.empty(), finishWhy.c_str());
    }

    // Many threads read the same tiles at once (the loader pool's pattern): the same pixels.
    // 256 px frames decode straight into the tile; 240 px frames go through the shared cache of
    // decoded frames, where threads race to decode, insert and share the same frames (a fresh
    // source, so the first reads of each frame race). The tsan preset runs this
    // (engine.dicom.threads).
    void concurrentReads_data() {
        QTest::addColumn<int>("which");
        QTest::newRow("256-direct") << 0;
        QTest::newRow("240-cached") << 1;
    }
    void concurrentReads() {
        QFETCH(int, which);
        const std::optional<fs::path>& folder = which == 0 ? sampleJpeg_ : cmu240_;
        if (!folder) QSKIP("sampleJpegCopied or cmuJpegCopied240 did not run");
        std::string why;
        auto dicom = openOrFail(*folder, &why);
        QVERIFY2(dicom, why.c_str());
        const auto& L = dicom->info().levels[0];
        const int64_t tiles = std::min<int64_t>(L.tilesX * L.tilesY, 64);
        std::vector<std::vector<uint8_t>> expected;
        {
            auto reference = openOrFail(*folder, &why); // its own cache: `dicom` starts cold
            QVERIFY2(reference, why.c_str());
            for (int64_t i = 0; i < tiles; ++i) {
                expected.emplace_back(kTileBytes);
                QVERIFY(reference->readTile(0, i % L.tilesX, i / L.tilesX, expected.back().data()).ok());
            }
        }
        std::atomic<int> bad{0};
        std::vector<std::thread> threads;
        for (int t = 0; t < 8; ++t) {
            threads.emplace_back([&, t] {
                std::vector<uint8_t> tile(kTileBytes);
                for (int k = 0; k < 100; ++k) {
                    const int64_t i = (k * 7 + t * 5) % tiles;
                    if (!dicom->readTile(0, i % L.tilesX, i / L.tilesX, tile.data()).ok() ||
                        tile != expected[size_t(i)])
                        bad.fetch_add(1, std::memory_order_relaxed); // read after join()
                }
            });
        }
        for (auto& th : threads) th.join();
        QCOMPARE(bad.load(), 0);
    }

    // Random byte corruption of a small series file (a few bytes at a time, fixed seed): open()
    // either fails with a message naming the file or succeeds, and then every tile and the
    // associated images read or fail clearly. Nothing crashes (the asan preset runs this too).
    void corruptedBytes() {
        auto dir = slidesDir("unsupported/dicom-boxes");
        if (!dir) QSKIP("no test data");
        std::ifstream in(*dir / "boxes_0.dcm", std::ios::binary);
        const std::vector<char> original((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        QVERIFY(original.size() > 1000);
        const fs::path sub = dicomOut() / "corrupted";
        fs::remove_all(sub);
        fs::create_directories(sub);
        const fs::path p = sub / "corrupt.dcm";
        std::mt19937 rng(15);
        constexpr int kRounds = 1500;
        int opened = 0, refused = 0, tileErrors = 0;
        std::vector<uint8_t> tile(kTileBytes);
        for (int round = 0; round < kRounds; ++round) {
            std::vector<char> bytes = original;
            const int n = 1 + int(rng() % 8);
            for (int k = 0; k < n; ++k) {
                // Mostly the header (where the structure is), sometimes anywhere.
                const size_t at = (rng() % 4 ? 132 + rng() % 2000 : rng() % bytes.size()) % bytes.size();
                bytes[at] = char(rng() % 4 ? rng() : (rng() % 2 ? 0xff : 0x00));
            }
            {
                std::ofstream out(p, std::ios::binary | std::ios::trunc);
                out.write(bytes.data(), std::streamsize(bytes.size()));
            }
            auto r = iris::openSlideSource(p.string());
            if (!r.ok()) {
                ++refused;
                QVERIFY2(r.error().message().find("corrupt.dcm") != std::string::npos, r.error().message().c_str());
                continue;
            }
            ++opened;
            for (size_t l = 0; l < (*r)->info().levels.size(); ++l) {
                const auto& L = (*r)->info().levels[l];
                for (int64_t ty = 0; ty < std::min<int64_t>(L.tilesY, 4); ++ty)
                    for (int64_t tx = 0; tx < std::min<int64_t>(L.tilesX, 4); ++tx) {
                        auto t = (*r)->readTile(int(l), tx, ty, tile.data());
                        if (!t.ok()) {
                            ++tileErrors;
                            QVERIFY2(!t.message().empty(), "an empty tile error");
                        }
                    }
            }
            for (const std::string& name : (*r)->info().associatedImages) (void)(*r)->readAssociatedImage(name);
        }
        qInfo("%d corrupted copies: %d refused at open, %d opened (%d tile errors)", kRounds, refused, opened,
              tileErrors);
        QVERIFY(refused > 0 && opened > 0);
    }

    void errors() {
        auto dir = slidesDir("unsupported/dicom-boxes");
        if (!dir) QSKIP("no test data");
        const fs::path out = dicomOut() / "errors";
        fs::remove_all(out);
        fs::create_directories(out);
        const fs::path boxes0 = *dir / "boxes_0.dcm", boxes1 = *dir / "boxes_1.dcm";

        // Not a whole-slide image: the SOP class of a CT image.
        fs::create_directories(out / "ct");
        QVERIFY(editCopy(boxes1, out / "ct" / "ct.dcm",
                         [](DcmDataset* ds) { ds->putAndInsertString(DCM_SOPClassUID, "1.2.840.10008.5.1.4.1.1.2"); }));
        CHECKED(expectOpenFails(out / "ct" / "ct.dcm", iris::Status::UnsupportedFormat, "ct.dcm",
                                "not a VL Whole Slide Microscopy Image"));
        CHECKED(expectOpenFails(out / "ct", iris::Status::UnsupportedFormat, "ct", "none of its 1 DICOM files"));

        // A transfer syntax this reader does not decode, named in the message.
        fs::create_directories(out / "bigendian");
        QVERIFY(editCopy(
            boxes1, out / "bigendian" / "be.dcm", [](DcmDataset*) {}, EXS_BigEndianExplicit));
        CHECKED(expectOpenFails(out / "bigendian" / "be.dcm", iris::Status::UnsupportedFormat, "be.dcm",
                                "transfer syntax 1.2.840.10008.1.2.2"));

        // Hostile values.
        const std::pair<const char*, std::function<void(DcmDataset*)>> hostile[] = {
            {"frames.dcm", [](DcmDataset* ds) { ds->putAndInsertString(DCM_NumberOfFrames, "1000"); }},
            {"noframes.dcm", [](DcmDataset* ds) { ds->putAndInsertString(DCM_NumberOfFrames, "-5"); }},
            {"matrix.dcm", [](DcmDataset* ds) { ds->putAndInsertUint32(DCM_TotalPixelMatrixColumns, 4000000000u); }},
            {"rows.dcm", [](DcmDataset* ds) { ds->putAndInsertUint16(DCM_Rows, 0); }},
            {"bits.dcm", [](DcmDataset* ds) { ds->putAndInsertUint16(DCM_BitsAllocated, 16); }},
            {"photometric.dcm",
             [](DcmDataset* ds) { ds->putAndInsertString(DCM_PhotometricInterpretation, "PALETTE COLOR"); }},
        };
        for (const auto& [name, edit] : hostile) {
            const fs::path sub = out / fs::path(name).stem();
            fs::create_directories(sub);
            QVERIFY(editCopy(boxes0, sub / name, edit));
            auto r = iris::openSlideSource((sub / name).string());
            QVERIFY2(!r.ok(), name);
            qInfo("%s → %s", name, describe(r.error()).c_str());
            QVERIFY2(r.error().status() == iris::Status::CorruptData ||
                         r.error().status() == iris::Status::UnsupportedFormat,
                     describe(r.error()).c_str());
            QVERIFY2(r.error().message().find(name) != std::string::npos, r.error().message().c_str());
        }

        // Truncated copies of a JPEG series file at many lengths: open() fails clearly (DCMTK
        // parses the pixel data's item structure, so a cut anywhere is found at open). Never a crash.
        if (sampleJpeg_) {
            const fs::path whole = *sampleJpeg_ / "wsi-000000.dcm";
            const auto size = fs::file_size(whole);
            int openedCount = 0, failedReads = 0;
            for (uintmax_t len : {uintmax_t(0), uintmax_t(100), uintmax_t(131), uintmax_t(132), uintmax_t(700),
                                  size / 50, size / 10, size / 2, size - 1000, size - 1}) {
                const fs::path sub = out / ("truncated-" + std::to_string(len));
                fs::create_directories(sub);
                const fs::path p = sub / "cut.dcm";
                QVERIFY(truncatedCopy(whole, p, len));
                auto r = iris::openSlideSource(p.string());
                if (!r.ok()) {
                    QVERIFY2(r.error().message().find("cut.dcm") != std::string::npos, r.error().message().c_str());
                    continue;
                }
                ++openedCount;
                std::vector<uint8_t> tile(kTileBytes);
                const auto& L = (*r)->info().levels[0];
                for (int64_t ty = 0; ty < L.tilesY; ++ty)
                    for (int64_t tx = 0; tx < L.tilesX; ++tx) {
                        auto t = (*r)->readTile(0, tx, ty, tile.data());
                        if (!t.ok()) {
                            ++failedReads;
                            QVERIFY2(t.message().find("cut.dcm") != std::string::npos, t.message().c_str());
                        }
                    }
            }
            qInfo("truncated copies: %d opened, %d tile reads failed with a clear error", openedCount, failedReads);
        }

        // A file truncated after open (a network share, a copy still being written): the frames
        // past the cut fail with a clear error naming the file; those before it still read.
        if (sampleJpeg_) {
            const fs::path sub = out / "truncated-after-open";
            fs::create_directories(sub);
            const fs::path p = sub / "shrinking.dcm";
            fs::copy_file(*sampleJpeg_ / "wsi-000007.dcm", p); // 375x250: 2 frames, one file
            auto r = iris::openSlideSource(p.string());
            QVERIFY2(r.ok(), describe(r.error()).c_str());
            fs::resize_file(p, fs::file_size(p) - 2000);
            std::vector<uint8_t> tile(kTileBytes);
            auto first = (*r)->readTile(0, 0, 0, tile.data());
            auto last = (*r)->readTile(0, 1, 0, tile.data());
            QVERIFY2(first.ok(), describe(first).c_str());
            QVERIFY(!last.ok());
            qInfo("after truncation: %s", describe(last).c_str());
            QVERIFY2(last.message().find("shrinking.dcm") != std::string::npos, last.message().c_str());
        }

        // A level split over several files, one of them missing.
        if (sampleJpeg_) {
            const fs::path sub = out / "missing-part";
            fs::create_directories(sub);
            int copied = 0;
            for (const auto& e : fs::directory_iterator(*sampleJpeg_)) {
                if (e.path().filename() == "wsi-000001.dcm") continue; // the second part of level 0
                fs::copy_file(e.path(), sub / e.path().filename());
                ++copied;
            }
            QVERIFY(copied > 0);
            CHECKED(expectOpenFails(sub, iris::Status::CorruptData, "missing-part", "a file is missing"));
        }

        // Two series in one folder: a file opens its own series; the folder is ambiguous.
        if (sampleJpeg_) {
            const fs::path sub = out / "two-series";
            fs::create_directories(sub);
            for (const auto& e : fs::directory_iterator(*sampleJpeg_))
                fs::copy_file(e.path(), sub / e.path().filename());
            fs::copy_file(boxes0, sub / "boxes_0.dcm");
            fs::copy_file(boxes1, sub / "boxes_1.dcm");
            std::string why;
            auto boxes = openOrFail(sub / "boxes_1.dcm", &why);
            QVERIFY2(boxes, why.c_str());
            QCOMPARE(boxes->info().width, int64_t(16));
            auto sampleSeries = openOrFail(sub / "wsi-000000.dcm", &why);
            QVERIFY2(sampleSeries, why.c_str());
            QCOMPARE(sampleSeries->info().width, int64_t(6000));
            QCOMPARE(sampleSeries->info().levels.size(), size_t(6)); // all its files, none of the boxes
            CHECKED(expectOpenFails(sub, iris::Status::UnsupportedFormat, "two-series", "2 whole-slide series"));
        }

        // A folder without DICOM files is not a slide.
        fs::create_directories(out / "empty-folder");
        { std::ofstream(out / "empty-folder" / "notes.txt") << "not DICOM"; }
        CHECKED(expectOpenFails(out / "empty-folder", iris::Status::NotAFile, "empty-folder", "without DICOM files"));
    }
};

QTEST_GUILESS_MAIN(TestDicom)
#include "tst_dicom.moc"
