// Files that change under the viewer (issue 14): a slide truncated, deleted or replaced while it
// is open, for the .iris reader (which parses and reads with pread, never through a memory map,
// so that a truncated file cannot raise SIGBUS; iris.bytes cuts a file during its parse), the
// direct TIFF reader (libtiff without its memory map: tiff_source.cpp opens with "m"), the same
// TIFF read through OpenSlide (EngineConfig::source = OpenSlide), and a DICOM series made by
// OrthancWSIDicomizer (the change hits its largest file, which holds level 0's frames).
//
//   * truncated mid-walk: the walk goes on to complete frames, the tiles past the new end are
//     drawn as the failed-tile placeholder, the engine's error names the file, and the engine
//     opens the next slide as if nothing happened;
//   * deleted or replaced mid-walk: the open file is still the one shown (POSIX keeps an open
//     file's data): every frame is as before and no error is reported.
// The frames are compared with a second engine showing an untouched copy.
#include <QtTest>

#include <filesystem>
#include <fstream>

#include "dicomizer.h"

#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

namespace {
constexpr uint32_t kW = 512, kH = 384;

// The placeholder's grey (fillFailedTilePlaceholder): 128, 128, 128.
uint64_t countPlaceholderGrey(const iris::Image& img) {
    uint64_t n = 0;
    for (uint32_t y = 0; y < img.height; ++y)
        for (uint32_t x = 0; x < img.width; ++x) {
            const uint8_t* p = pixel(img, x, y);
            n += (p[0] == 128 && p[1] == 128 && p[2] == 128) ? 1 : 0;
        }
    return n;
}
} // namespace

class TestChangingFiles : public QObject {
    Q_OBJECT
    TestEngine e_, reference_;
    TestEngine os_, osReference_; // EngineConfig::source = OpenSlide
    std::optional<fs::path> dicom_; // the sample slide as a DICOM series

    // Ten 1:1 fields along the slide's diagonal: level-0 tiles, which the fitted view before
    // the change did not load (it draws the coarse levels), so they are read after it.
    static std::vector<iris::View> walk(const iris::SlideInfo& info) {
        std::vector<iris::View> out;
        for (int k = 0; k < 10; ++k) {
            const double f = (k + 0.5) / 10;
            out.push_back(iris::View{f * double(info.width), f * double(info.height), 1.0});
        }
        return out;
    }
    static fs::path copyOf(const fs::path& from, const std::string& name) {
        const fs::path dir = testOutDir() / "changing";
        fs::create_directories(dir);
        const fs::path to = dir / name;
        fs::remove_all(to);
        if (fs::is_directory(from)) {
            fs::copy(from, to, fs::copy_options::recursive);
            for (const auto& e : fs::directory_iterator(to))
                fs::permissions(e.path(), fs::perms::owner_read | fs::perms::owner_write, fs::perm_options::add);
        } else {
            fs::copy_file(from, to);
            fs::permissions(to, fs::perms::owner_read | fs::perms::owner_write, fs::perm_options::add);
        }
        return to;
    }
    // The file a change hits: the slide itself, or a series folder's largest file.
    static fs::path target(const fs::path& slide) {
        if (!fs::is_directory(slide)) return slide;
        fs::path largest;
        uintmax_t size = 0;
        for (const auto& e : fs::directory_iterator(slide))
            if (e.is_regular_file() && e.file_size() > size) size = e.file_size(), largest = e.path();
        return largest;
    }

private slots:
    void initTestCase() {
        iris::EngineConfig cfg;
        cfg.color.managed = false;
        e_ = createTestEngine(cfg);
        QVERIFY2(e_, describe(e_.error).c_str());
        reference_ = createTestEngine(cfg);
        QVERIFY2(reference_, describe(reference_.error).c_str());
        QVERIFY(e_->bindOffscreen(kW, kH).ok());
        QVERIFY(reference_->bindOffscreen(kW, kH).ok());
        cfg.source = iris::SourcePreference::OpenSlide;
        os_ = createTestEngine(cfg);
        QVERIFY2(os_, describe(os_.error).c_str());
        osReference_ = createTestEngine(cfg);
        QVERIFY2(osReference_, describe(osReference_.error).c_str());
        QVERIFY(os_->bindOffscreen(kW, kH).ok());
        QVERIFY(osReference_->bindOffscreen(kW, kH).ok());
        if (const auto sample = sampleSlidePath(); sample && dicomizerInstalled()) {
            std::string why;
            dicom_ = dicomize(testOutDir() / "changing-dicom-source", *sample, "--reencode=0 --max-size=1", &why);
            QVERIFY2(dicom_, why.c_str());
        }
    }
    void cleanupTestCase() {
        for (TestEngine* e : {&e_, &reference_, &os_, &osReference_}) {
            if (!*e) continue;
            // Error lines were expected (the truncated reads): only validation counts here.
            const std::string why = e->endTest(TestEngine::ErrorLines::Show);
            QVERIFY2(why.empty(), why.c_str());
            (*e)->close();
            QCOMPARE((*e)->validationMessageCount(), uint64_t(0));
        }
    }

    void changedMidWalk_data() {
        QTest::addColumn<QString>("slide");
        QTest::addColumn<QString>("change");
        QTest::addColumn<QString>("reader");
        // Slides with reduced levels, so that the fitted view does not read level 0.
        const std::vector<std::pair<const char*, std::optional<fs::path>>> slides{
            {"iris", slidesDir("iris") ? std::optional(*slidesDir("iris") / "tcga-cr-7395-01a-01-ts1.v1.0.iris")
                                       : std::nullopt},
            {"tiff", sampleSlidePath()},
            {"openslide", sampleSlidePath()},
            {"dicom", dicom_},
        };
        bool any = false;
        for (const auto& [kind, path] : slides) {
            if (!path || !fs::exists(*path)) continue;
            any = true;
            for (const char* change : {"truncated", "deleted", "replaced"})
                QTest::addRow("%s %s", kind, change)
                    << QString::fromStdString(path->string()) << QString(change) << QString(kind);
        }
        if (!any) QTest::newRow("no test data") << QString() << QString() << QString();
    }
    void changedMidWalk() {
        QFETCH(QString, slide);
        QFETCH(QString, change);
        QFETCH(QString, reader);
        if (slide.isEmpty()) QSKIP("no test data (set IRIS_TESTDATA or IRIS_TESTDATA_DEFAULT)");
        TestEngine& eng = reader == "openslide" ? os_ : e_;
        TestEngine& ref = reader == "openslide" ? osReference_ : reference_;
        eng.beginTest();
        const fs::path original = slide.toStdString();
        const fs::path path = copyOf(original, "changing-" + reader.toStdString() + "-" + change.toStdString() +
                                                   original.extension().string());
        QVERIFY2(eng->open(path.string()).ok(), describe(eng->error()).c_str());
        QVERIFY(ref->open(original.string()).ok());
        const iris::SlideInfo info = *eng->slideInfo();
        const std::vector<iris::View> fields = walk(info);
        QVERIFY2(info.levels.size() > 1 && !info.levels[1].synthetic, "the slide needs stored reduced levels");
        // The fitted view drawn from the file as it was.
        std::string why;
        QVERIFY2(renderView(*eng.engine, eng->fitView(), kW, kH, 60s, &why), why.c_str());

        const fs::path hit = target(path);
        if (change == "truncated") {
            fs::resize_file(hit, fs::file_size(hit) * 35 / 100);
        } else if (change == "deleted") {
            fs::remove(hit);
        } else {
            // Another file takes the name (a scanner re-exporting the slide): the open one stays.
            // Another slide where the test data has one, else 1 MiB that is no slide at all.
            fs::path other;
            if (const auto tiffs = slidesDir("generic-tiff")) {
                other = copyOf(*tiffs / "boxes.tiff", "changing-other.tmp");
            } else {
                other = testOutDir() / "changing-other.tmp";
                std::ofstream out(other, std::ios::binary | std::ios::trunc);
                for (uint32_t i = 0; i < (1u << 20) / 4; ++i) {
                    const uint32_t w = i * 2654435761u;
                    out.write(reinterpret_cast<const char*>(&w), 4);
                }
                QVERIFY(out.good());
            }
            fs::rename(other, hit);
        }

        uint64_t placeholder = 0, differing = 0;
        for (size_t k = 0; k < fields.size(); ++k) {
            auto f = renderView(*eng.engine, fields[k], kW, kH, 60s, &why);
            QVERIFY2(f, ("field " + std::to_string(k) + ": " + why).c_str()); // complete, in time, no crash
            auto r = renderView(*ref.engine, fields[k], kW, kH, 60s, &why);
            QVERIFY2(r, why.c_str());
            const DiffStats d = compareImages(f->image, r->image);
            differing += d.differing;
            placeholder += countPlaceholderGrey(f->image);
        }
        const iris::Result err = eng->error();
        qInfo("%s: %llu px differ from the untouched copy, %llu placeholder grey; engine error: %s",
              qPrintable(change), (unsigned long long)differing, (unsigned long long)placeholder, describe(err).c_str());
        if (change == "truncated") {
            QVERIFY2(!err.ok(), "a truncated file's failed reads were not reported");
            QVERIFY2(err.message().find(path.filename().string()) != std::string::npos ||
                         err.message().find(hit.filename().string()) != std::string::npos,
                     err.message().c_str());
            QVERIFY2(placeholder > 0, "no tile past the new end shows the placeholder");
        } else {
            QVERIFY2(err.ok(), describe(err).c_str());
            QCOMPARE(differing, uint64_t(0));
        }
        // The engine goes on: the untouched slide opens and draws, and the error is gone.
        QVERIFY(eng->open(original.string()).ok());
        QVERIFY(eng->error().ok());
        QVERIFY2(renderView(*eng.engine, fields[4], kW, kH, 60s, &why), why.c_str());
        const std::string problems = eng.endTest(TestEngine::ErrorLines::Show);
        QVERIFY2(problems.empty(), problems.c_str());
    }
};

QTEST_GUILESS_MAIN(TestChangingFiles)
#include "tst_changing_files.moc"
