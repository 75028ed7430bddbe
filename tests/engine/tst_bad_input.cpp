// Bad input (issue 2, "Tests"; DESIGN.md "Errors"): every broken, unsupported or missing
// path gives a clear error from open() — a specific Status and a message naming the file —
// and never a crash or a hang; the same engine then opens a good slide and renders it
// exactly. Calls made in any order without a slide or a target do not crash, and those
// that return a Result say NoSlide / NotBound.
#include <QtTest>

#include <cmath>
#include <fstream>
#include <limits>

#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;

namespace {

constexpr uint32_t kW = 160, kH = 120;

std::optional<std::filesystem::path> goodSlide() {
    auto d = slidesDir("aperio");
    if (!d) return std::nullopt;
    return *d / "CMU-1-Small-Region.svs";
}

// Writes the first `bytes` bytes of `from` to `to`.
bool truncatedCopy(const std::filesystem::path& from, const std::filesystem::path& to, std::size_t bytes) {
    std::ifstream in(from, std::ios::binary);
    std::vector<char> buf(bytes);
    in.read(buf.data(), std::streamsize(bytes));
    if (std::size_t(in.gcount()) != bytes) return false;
    std::ofstream out(to, std::ios::binary | std::ios::trunc);
    out.write(buf.data(), std::streamsize(bytes));
    return bool(out);
}

// Runs a helper that asserts, and stops the test function when it failed.
#define CHECKED(call)                                                                               \
    do {                                                                                            \
        call;                                                                                       \
        if (QTest::currentTestFailed()) return;                                                     \
    } while (0)

constexpr double kInf = std::numeric_limits<double>::infinity();

QString statusText(iris::Status s) {
    return QString::fromLatin1(iris::statusName(s));
}

} // namespace

class TestBadInput : public QObject {
    Q_OBJECT

    TestEngine e_;

    // The engine must still work: open the good slide (the built-in sample where the test data
    // is absent) and render a small 1:1 area that equals read_region byte for byte.
    void checkStillUsable() {
        auto good = goodSlide();
        if (!good) good = sampleSlidePath();
        QVERIFY2(good.has_value(), "neither the test data nor the built-in sample slide");
        const iris::Result r = e_->open(good->string());
        QVERIFY2(r.ok(), ("the good slide no longer opens: " + describe(r)).c_str());
        QVERIFY2(e_->error().ok(), ("error() not cleared by a successful open(): " + describe(e_->error())).c_str());
        std::string err;
        const int64_t x0 = 1003, y0 = 1517; // inside the 2220×2967 slide and the 6000×4000 sample, across tile seams
        auto frame = renderView(*e_.engine, viewWithOrigin(double(x0), double(y0), 1.0, kW, kH), kW, kH, 30s, &err);
        QVERIFY2(frame.has_value(), err.c_str());
        auto os = OpenSlideRef::open(*good, &err);
        QVERIFY2(os, err.c_str());
        auto ref = os->readLevel0(x0, y0, kW, kH, &err);
        QVERIFY2(ref.has_value(), err.c_str());
        const DiffStats st = compareImages(frame->image, *ref);
        if (st.differing) {
            QFAIL(("after a bad file, the good slide renders wrongly: " + st.summary() + "; " +
                   saveFailureArtefacts("bad_input.recovery", frame->image, *ref, nullptr))
                      .c_str());
        }
    }

    // open() must fail with one of `allowed`, a message that names the file, fast.
    void expectOpenFails(const std::filesystem::path& path, std::initializer_list<iris::Status> allowed) {
        const auto t0 = std::chrono::steady_clock::now();
        const iris::Result r = e_->open(path.string());
        const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        QVERIFY2(!r.ok(), ("open() accepted " + path.string()).c_str());
        QStringList names;
        bool ok = false;
        for (iris::Status s : allowed) {
            names << statusText(s);
            ok = ok || r.status() == s;
        }
        QVERIFY2(ok, qPrintable(QString("status %1 (\"%2\"), expected %3")
                                    .arg(statusText(r.status()), QString::fromStdString(r.message()),
                                         names.join(" or "))));
        QVERIFY2(!r.message().empty(), "empty error message");
        const std::string name = path.filename().string();
        QVERIFY2(r.message().find(name) != std::string::npos,
                 ("the message does not name the file '" + name + "': \"" + r.message() + "\"").c_str());
        QVERIFY2(secs < 10.0, ("open() took " + std::to_string(secs) + " s to fail").c_str());
        qInfo("%s → %s", name.c_str(), describe(r).c_str());
        // No slide now: the engine says so.
        QVERIFY(!e_->slideInfo().has_value());
        const iris::Result w = e_->waitForFrame(100ms);
        QCOMPARE(statusText(w.status()), statusText(iris::Status::NoSlide));
    }

private slots:
    void initTestCase() {
        e_ = createTestEngine();
        QVERIFY2(e_, describe(e_.error).c_str());
        QVERIFY2(e_->bindOffscreen(kW, kH).ok(), "bindOffscreen failed");
    }

    void init() { e_.beginTest(); }

    void cleanup() {
        // Error lines are expected here (bad files); they are shown, not counted.
        const std::string why = e_.endTest(TestEngine::ErrorLines::Show);
        QVERIFY2(why.empty(), why.c_str());
    }

    void cleanupTestCase() {
        const std::string why = e_.finish();
        QVERIFY2(why.empty(), why.c_str());
    }

    // Every file under testdata/slides/bad/ (but unreadable.svs, see below) and under
    // testdata/slides/unsupported/ (but dicom-boxes/, a DICOM series Iris View reads since
    // issue 15: dicomBoxesOpen below).
    void badFiles_data() {
        QTest::addColumn<QString>("path");
        auto bad = slidesDir("bad");
        auto unsupported = slidesDir("unsupported");
        if (!bad || !unsupported || !goodSlide()) {
            QTest::newRow("no test data") << QString();
            return;
        }
        for (const auto& dir : {*bad, *unsupported}) {
            for (const auto& f : filesUnder(dir, true)) {
                if (f.filename() == "unreadable.svs") continue;
                if (f.parent_path().filename() == "dicom-boxes") continue;
                const std::string row = std::filesystem::relative(f, dir.parent_path()).string();
                QTest::newRow(row.c_str()) << QString::fromStdString(f.string());
            }
        }
    }
    void badFiles() {
        QFETCH(QString, path);
        if (path.isEmpty()) QSKIP("no test data (set IRIS_TESTDATA or IRIS_TESTDATA_DEFAULT)");
        CHECKED(expectOpenFails(path.toStdString(), {iris::Status::UnsupportedFormat, iris::Status::CorruptData}));
        CHECKED(checkStillUsable());
    }

    // The DICOM series that once was "unsupported" opens as a folder and as either of its files,
    // and its 16×16 pixels (small.svs's JPEG tile, copied into a DICOM frame) render as
    // small.svs's read_region does.
    void dicomBoxesOpen() {
        auto dir = slidesDir("unsupported/dicom-boxes");
        auto svs = slidesDir("aperio");
        if (!dir || !svs) QSKIP("no test data");
        std::string err;
        auto os = OpenSlideRef::open(*svs / "small.svs", &err);
        QVERIFY2(os, err.c_str());
        auto ref = os->readLevel0(0, 0, 16, 16, &err);
        QVERIFY2(ref.has_value(), err.c_str());
        for (const auto& p : {*dir, *dir / "boxes_0.dcm", *dir / "boxes_1.dcm"}) {
            const iris::Result r = e_->open(p.string());
            QVERIFY2(r.ok(), (p.string() + ": " + describe(r)).c_str());
            auto info = e_->slideInfo();
            QVERIFY(info.has_value());
            QCOMPARE(info->width, int64_t(16));
            QCOMPARE(info->height, int64_t(16));
            auto frame = renderView(*e_.engine, viewWithOrigin(0, 0, 1.0, kW, kH), kW, kH, 30s, &err);
            QVERIFY2(frame.has_value(), err.c_str());
            iris::Image crop = makeImage(16, 16);
            for (uint32_t y = 0; y < 16; ++y)
                std::memcpy(pixel(crop, 0, y), pixel(frame->image, 0, y), 16 * 4);
            const DiffStats st = compareImages(crop, *ref);
            QVERIFY2(st.differing == 0, (p.string() + ": " + st.summary()).c_str());
        }
        e_->close();
        CHECKED(checkStillUsable());
    }

    // TIFFs that crash OpenSlide 3.4.1 while it opens them (tests/fuzz/README.md): a SIGFPE,
    // GLib aborts on a 16 GiB tile buffer and on tile byte counts of gigabytes. They are
    // refused before OpenSlide sees them, by the format table and by an engine that reads with
    // OpenSlide alone, with a clear error; each engine then still renders the good slide.
    void hostileTiffs_data() {
        QTest::addColumn<QString>("file");
        QTest::addColumn<bool>("openSlideOnly");
        for (const char* f : {"openslide-aperio-empty-tile-divides-by-zero.fuzz", "openslide-jp2k-tile-16gib-at-open.fuzz",
                              "openslide-tile-bytecount-3gb.fuzz", "openslide-absurd-malloc-at-open.fuzz"}) {
            QTest::newRow((std::string(f) + " (auto)").c_str()) << QString(f) << false;
            QTest::newRow((std::string(f) + " (OpenSlide)").c_str()) << QString(f) << true;
        }
    }
    void hostileTiffs() {
        QFETCH(QString, file);
        QFETCH(bool, openSlideOnly);
        const std::filesystem::path in = std::filesystem::path(IRIS_TIFF_REGRESSIONS) / file.toStdString();
        QVERIFY2(std::filesystem::exists(in), in.c_str());
        // Copied under a slide's extension: OpenSlide finds TIFF vendors by their contents.
        const auto out = testOutDir() / (in.stem().string() + ".svs");
        std::filesystem::copy_file(in, out, std::filesystem::copy_options::overwrite_existing);
        if (!openSlideOnly) {
            CHECKED(expectOpenFails(out, {iris::Status::UnsupportedFormat, iris::Status::CorruptData}));
            CHECKED(checkStillUsable());
            return;
        }
        iris::EngineConfig cfg;
        cfg.source = iris::SourcePreference::OpenSlide;
        TestEngine os = createTestEngine(cfg);
        QVERIFY2(os, describe(os.error).c_str());
        QVERIFY(os->bindOffscreen(kW, kH).ok());
        const iris::Result r = os->open(out.string());
        QVERIFY2(!r.ok(), "OpenSlide's reader accepted it");
        QVERIFY2(r.status() == iris::Status::UnsupportedFormat || r.status() == iris::Status::CorruptData,
                 describe(r).c_str());
        QVERIFY2(r.message().find(out.filename().string()) != std::string::npos, describe(r).c_str());
        qInfo("%s (OpenSlide) → %s", out.filename().string().c_str(), describe(r).c_str());
        auto good = goodSlide();
        if (!good) good = sampleSlidePath();
        QVERIFY(good.has_value());
        const iris::Result g = os->open(good->string());
        QVERIFY2(g.ok(), describe(g).c_str());
        std::string err;
        QVERIFY2(renderView(*os.engine, viewWithOrigin(0, 0, 1.0, kW, kH), kW, kH, 30s, &err).has_value(),
                 err.c_str());
        const std::string why = os.finish();
        QVERIFY2(why.empty(), why.c_str());
    }

    // TIFFs of the vendors only OpenSlide reads, on which OpenSlide 3.4.1 dies while it opens
    // or reads them (openslide_guard.h): the format table refuses each with a clear error
    // before OpenSlide sees it, and the engine still renders the good slide. The same files
    // made well ("…-ok") open, and draw a complete frame, through OpenSlide: the checks refuse
    // nothing a valid slide has.
    void hostileVendorFiles_data() {
        QTest::addColumn<QString>("file");
        QTest::addColumn<bool>("valid");
        for (const char* f : {"ventana-ok", "ventana-huge-tile-count", "ventana-tile-count-wraps", "ventana-negative-mag",
                              "leica-ok", "leica-no-objective", "leica-no-z0-dimension", "ndpi-ok", "ndpi-zero-width",
                              "ndpi-zero-height", "ndpi-tile-count-overflow", "ndpi-strip-shorter-than-header"}) {
            QTest::newRow(f) << QString(f) << QString(f).endsWith("-ok");
        }
    }
    void hostileVendorFiles() {
        QFETCH(QString, file);
        QFETCH(bool, valid);
        const std::string f = file.toStdString();
        const auto out = testOutDir() / ("bad-input-" + f + ".tif");
        std::string err;
        if (f.rfind("ndpi", 0) == 0) {
            // Hamamatsu NDPI, written byte by byte (tests/engine/hostile/README.md).
            std::filesystem::copy_file(std::filesystem::path(IRIS_HOSTILE_FILES) / (f + ".bin"), out,
                                       std::filesystem::copy_options::overwrite_existing);
        } else if (f.rfind("ventana", 0) == 0) {
            // A Ventana BIF: the label's XMLPacket says iScan; level 0's holds the scan areas
            // (EncodeInfo); each level's ImageDescription names its level and magnification.
            const std::string iscan = "<?xml version=\"1.0\"?><iScan Magnification=\"40\" ScanRes=\"0.25\"/>";
            std::string cols = "2", rows = "2", mag0 = "40", mag1 = "10";
            if (f == "ventana-huge-tile-count") cols = rows = "2147483648";
            if (f == "ventana-tile-count-wraps") cols = "119537721", rows = "154317347858"; // product 2^64 + 2
            if (f == "ventana-negative-mag") mag0 = "-1", mag1 = "-2";
            const std::string encode =
                "<?xml version=\"1.0\"?><EncodeInfo Ver=\"2\"><SlideStitchInfo><ImageInfo AOIScanned=\"1\" AOIIndex=\"0\" "
                "Width=\"256\" Height=\"256\" NumRows=\"" + rows + "\" NumCols=\"" + cols + "\" Pos-X=\"0\" Pos-Y=\"0\">"
                "<TileJointInfo FlagJoined=\"1\" Confidence=\"100\" Direction=\"RIGHT\" Tile1=\"1\" Tile2=\"2\" OverlapX=\"2\" OverlapY=\"0\"/>"
                "<TileJointInfo FlagJoined=\"1\" Confidence=\"100\" Direction=\"UP\" Tile1=\"1\" Tile2=\"4\" OverlapX=\"0\" OverlapY=\"2\"/>"
                "</ImageInfo></SlideStitchInfo><AoiOrigin><AOI0 OriginX=\"0\" OriginY=\"0\"/></AoiOrigin></EncodeInfo>";
            const bool negative = f == "ventana-negative-mag"; // level 1 wider than level 0
            QVERIFY2(writeTiffPyramid(out, 512, 512,
                                      {{16, "Label Image", iscan},
                                       {negative ? 2u : 1u, "level=0 mag=" + mag0 + " quality=90", encode},
                                       {negative ? 1u : 4u, "level=1 mag=" + mag1 + " quality=90", {}}},
                                      &err),
                     err.c_str());
        } else {
            // A Leica SCN: the collection's XML in the first ImageDescription; one brightfield
            // main image whose z-plane-0 dimension is directory 0.
            const std::string z = f == "leica-no-z0-dimension" ? " z=\"1\"" : "";
            const std::string objective =
                f == "leica-no-objective" ? "" : "<objectiveSettings><objective>20</objective></objectiveSettings>";
            const std::string xml =
                "<?xml version=\"1.0\"?><scn xmlns=\"http://www.leica-microsystems.com/scn/2010/10/01\">"
                "<collection sizeX=\"32000\" sizeY=\"32000\"><image><creationDate>2012</creationDate>"
                "<device model=\"SCN400\" version=\"1.0\"/><pixels sizeX=\"512\" sizeY=\"512\">"
                "<dimension sizeX=\"512\" sizeY=\"512\" r=\"0\" ifd=\"0\"" + z + "/></pixels>"
                "<view sizeX=\"30000\" sizeY=\"30000\" offsetX=\"1000\" offsetY=\"1000\"/><scanSettings>" + objective +
                "<illuminationSettings><numericalAperture>0.7</numericalAperture>"
                "<illuminationSource>brightfield</illuminationSource></illuminationSettings></scanSettings>"
                "</image></collection></scn>";
            QVERIFY2(writeTiffPyramid(out, 512, 512, {{1, xml, {}}}, &err), err.c_str());
        }
        if (!valid) {
            CHECKED(expectOpenFails(out, {iris::Status::CorruptData}));
            CHECKED(checkStillUsable());
            return;
        }
        const iris::Result r = e_->open(out.string());
        QVERIFY2(r.ok(), describe(r).c_str());
        auto info = e_->slideInfo();
        QVERIFY(info.has_value());
        QCOMPARE(QString::fromStdString(info->vendor), file.startsWith("ndpi") ? QString("hamamatsu") : file.section('-', 0, 0));
        QVERIFY2(renderView(*e_.engine, viewWithOrigin(0, 0, 1.0, kW, kH), kW, kH, 30s, &err).has_value(), err.c_str());
        e_->close();
    }

    void truncatedCopy() {
        auto good = goodSlide();
        if (!good) QSKIP("no test data");
        const auto out = testOutDir() / "CMU-1-Small-Region.truncated-200KiB.svs";
        QVERIFY(::truncatedCopy(*good, out, 200 * 1024));
        CHECKED(expectOpenFails(out, {iris::Status::UnsupportedFormat, iris::Status::CorruptData}));
        CHECKED(checkStillUsable());
    }

    void emptyFile() {
        if (!goodSlide()) QSKIP("no test data");
        const auto out = testOutDir() / "empty.svs";
        { std::ofstream(out, std::ios::binary | std::ios::trunc); }
        QCOMPARE(std::filesystem::file_size(out), std::uintmax_t(0));
        CHECKED(expectOpenFails(out, {iris::Status::UnsupportedFormat, iris::Status::CorruptData}));
        CHECKED(checkStillUsable());
    }

    void directory() {
        if (!goodSlide()) QSKIP("no test data");
        const auto dir = testOutDir() / "a-directory.svs";
        std::filesystem::create_directories(dir);
        CHECKED(expectOpenFails(dir, {iris::Status::NotAFile}));
        CHECKED(checkStillUsable());
    }

    void missingPath() {
        if (!goodSlide()) QSKIP("no test data");
        CHECKED(expectOpenFails(testOutDir() / "no-such-slide.svs", {iris::Status::NotFound}));
        CHECKED(checkStillUsable());
        CHECKED(expectOpenFails(testOutDir() / "no-such-folder" / "slide.svs", {iris::Status::NotFound}));
        CHECKED(checkStillUsable());
    }

    void missingNonAsciiPath() {
        if (!goodSlide()) QSKIP("no test data");
        // UTF-8: "préparation-组织-ščř.svs"
        const std::filesystem::path p =
            testOutDir() / std::filesystem::u8path(u8"pr\u00e9paration-\u7ec4\u7ec7-\u0161\u010d\u0159.svs");
        std::filesystem::remove(p);
        CHECKED(expectOpenFails(p, {iris::Status::NotFound}));
        CHECKED(checkStillUsable());
    }

    // A good slide under a non-ASCII name opens like any other.
    void nonAsciiPathThatExists() {
        auto good = goodSlide();
        if (!good) QSKIP("no test data");
        const std::filesystem::path p = testOutDir() / std::filesystem::u8path(u8"CMU-\u00e9chantillon-\u7ec4\u7ec7.svs");
        std::filesystem::copy_file(*good, p, std::filesystem::copy_options::overwrite_existing);
        const iris::Result r = e_->open(p.string());
        QVERIFY2(r.ok(), describe(r).c_str());
        std::string err;
        auto frame = renderView(*e_.engine, viewWithOrigin(0, 0, 1.0, kW, kH), kW, kH, 30s, &err);
        QVERIFY2(frame.has_value(), err.c_str());
        e_->close();
    }

    // bad/unreadable.svs opens in OpenSlide but none of its tiles decode. The engine may
    // refuse it at open() with CorruptData, or open it and then report the failure through
    // error() while drawing a visible placeholder; either way waitForFrame() returns (with
    // the error, not by timing out) and nothing crashes.
    void unreadableTiles() {
        auto bad = slidesDir("bad");
        if (!bad || !goodSlide()) QSKIP("no test data");
        const auto path = *bad / "unreadable.svs";
        e_->clearError();
        const iris::Result r = e_->open(path.string());
        if (!r.ok()) {
            qInfo("refused at open: %s", describe(r).c_str());
            QCOMPARE(statusText(r.status()), statusText(iris::Status::CorruptData));
            QVERIFY2(r.message().find("unreadable.svs") != std::string::npos, r.message().c_str());
        } else {
            qInfo("opened; rendering its tiles must fail visibly");
            auto info = e_->slideInfo();
            QVERIFY(info.has_value());
            QCOMPARE(info->width, int64_t(16));
            QCOMPARE(info->height, int64_t(16));
            // 16×16 level-0 pixels at 8 screen pixels each, in the middle of the target.
            const iris::View view{8.0, 8.0, 0.125};
            e_->setView(view);
            const auto t0 = std::chrono::steady_clock::now();
            const iris::Result w = e_->waitForFrame(10s);
            const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            qInfo("waitForFrame → %s after %.2f s", describe(w).c_str(), secs);
            QVERIFY2(secs < 12.0, "waitForFrame overran its timeout");
            QVERIFY2(w.status() != iris::Status::Timeout,
                     "waitForFrame timed out: the engine waits for tiles that can never arrive (a hang to the user)");
            // The failure is reported through error(): a loader records a tile's error before
            // it publishes the tile's placeholder, and the complete frame waited for above drew
            // that placeholder, so the error is there by now.
            const iris::Result e = e_->error();
            QVERIFY2(!e.ok(), "error() is Ok although no tile of the slide can be decoded");
            QVERIFY2(e.status() == iris::Status::CorruptData || e.status() == iris::Status::IoError,
                     describe(e).c_str());
            QVERIFY2(!e.message().empty(), "empty error message");
            // And the slide's area of the frame shows something: not the background colour.
            auto frame = e_->readFrame();
            QVERIFY2(frame.ok(), describe(frame.error()).c_str());
            const iris::Image& img = frame->image;
            QCOMPARE(img.width, kW);
            QCOMPARE(img.height, kH);
            // The slide covers target pixels [16, 144) × [-4, 124) → rows 0..119, columns 16..143.
            Mask slideArea(std::size_t(kW) * kH, 0);
            for (uint32_t y = 4; y < kH - 4; ++y) {
                for (uint32_t x = 20; x < 140; ++x) slideArea[std::size_t(y) * kW + x] = 1;
            }
            const uint64_t notBackground = countNotColour(img, backgroundBytes(), &slideArea);
            if (notBackground == 0) {
                qWarning("%s", saveFailureArtefacts("bad_input.unreadable", img, img, &slideArea).c_str());
            }
            QVERIFY2(notBackground > 0, "tiles that failed to decode are not drawn as a visible placeholder");
            e_->close();
        }
        e_->clearError();
        QVERIFY(e_->error().ok());
        CHECKED(checkStillUsable());
    }

    // Calls in any order with no slide open.
    void callsWithoutSlide() {
        e_->close();
        e_->close();
        QVERIFY(!e_->slideInfo().has_value());
        e_->translate(10, -5);
        e_->zoom(2.0, 3, 4);
        e_->zoom(0.25, -100, 1e9);
        e_->setView(iris::View{100, 200, 3});
        (void)e_->view();
        (void)e_->fitView();
        QCOMPARE(statusText(e_->waitForFrame(50ms).status()), statusText(iris::Status::NoSlide));
        auto frame = e_->readFrame();
        if (frame.ok()) {
            // Allowed: the last frame (of the background); it still has the target's size.
            QCOMPARE(frame->image.width, kW);
            QCOMPARE(frame->image.height, kH);
        } else {
            QCOMPARE(statusText(frame.error().status()), statusText(iris::Status::NoSlide));
        }
        auto assoc = e_->readAssociatedImage("label");
        QVERIFY(!assoc.ok());
        QCOMPARE(statusText(assoc.error().status()), statusText(iris::Status::NoSlide));
        e_->setBackground(0.1f, 0.2f, 0.3f);
        e_->setBackground(kBackground[0], kBackground[1], kBackground[2]);
        e_->close();
        // Nonsense arguments are refused or ignored, never taken.
        QCOMPARE(statusText(e_->bindOffscreen(0, 100).status()), statusText(iris::Status::InvalidArgument));
        QVERIFY2(e_->bindOffscreen(kW, kH).ok(), "rebinding the valid size failed");
        e_->setView(iris::View{std::nan(""), kInf, -1});
        e_->zoom(std::nan(""), 0, 0);
        e_->translate(std::nan(""), kInf);
        const iris::View v = e_->view();
        QVERIFY2(std::isfinite(v.centerX) && std::isfinite(v.centerY) && std::isfinite(v.downsample) && v.downsample > 0,
                 "a NaN/infinite/negative view was taken as the engine's view");
        CHECKED(checkStillUsable());
        // The same nonsense with a slide open leaves a view that still renders.
        e_->setView(iris::View{std::nan(""), 0, 0});
        e_->zoom(0.0, 0, 0);
        const iris::View v2 = e_->view();
        QVERIFY(std::isfinite(v2.centerX) && std::isfinite(v2.centerY) && std::isfinite(v2.downsample) &&
                v2.downsample > 0);
        QVERIFY2(e_->waitForFrame(30s).ok(), "no frame after nonsense view calls");
        e_->close();
    }

    // An engine with no target: calls that need one say NotBound (or NoSlide first).
    void callsWithoutTarget() {
        TestEngine fresh = createTestEngine();
        QVERIFY2(fresh, describe(fresh.error).c_str());
        const auto noTarget = {iris::Status::NotBound, iris::Status::NoSlide};
        auto isOneOf = [](iris::Status s, std::initializer_list<iris::Status> l) {
            return std::find(l.begin(), l.end(), s) != l.end();
        };
        const iris::Result w = fresh->waitForFrame(50ms);
        QVERIFY2(isOneOf(w.status(), noTarget), describe(w).c_str());
        auto f = fresh->readFrame();
        QVERIFY(!f.ok());
        QVERIFY2(isOneOf(f.error().status(), noTarget), describe(f.error()).c_str());
        fresh->translate(1, 1);
        fresh->zoom(2, 0, 0);
        fresh->resize(64, 64);
        fresh->setVisible(false);
        fresh->setVisible(true);
        fresh->unbindSurface();
        if (auto good = goodSlide()) {
            const iris::Result r = fresh->open(good->string());
            QVERIFY2(r.ok(), describe(r).c_str());
            QVERIFY(fresh->slideInfo().has_value());
            const iris::Result w2 = fresh->waitForFrame(50ms);
            QCOMPARE(statusText(w2.status()), statusText(iris::Status::NotBound));
            auto f2 = fresh->readFrame();
            QVERIFY(!f2.ok());
            QCOMPARE(statusText(f2.error().status()), statusText(iris::Status::NotBound));
            fresh->close();
            fresh->close();
        }
        QCOMPARE(fresh->validationMessageCount(), uint64_t(0));
    }
};

QTEST_GUILESS_MAIN(TestBadInput)
#include "tst_bad_input.moc"
