// The .iris reader's file access at open (issue 14): parse() reads an open file through
// ife::ByteSource (pread in blocks), never through a memory map, so a file that shrinks while
// it is being parsed gives a clear IoError where a map's pages past the new end would raise
// SIGBUS and kill the host. The truncation is made deterministic here: the size is taken, the
// file is cut, then the parse runs on the size it had.
//
//   * the same file parsed from memory and through the open file gives the same layout and
//     SlideInfo (levels, properties, ICC profile);
//   * cut at its header, in its middle and one byte short: IoError naming the file and saying
//     it was truncated while being opened; no crash (with a map each of these is SIGBUS);
//   * a read error (a descriptor that cannot read) is an IoError too.
#include <QtTest>

#include <fcntl.h>
#include <unistd.h>

#include "iris_test_util.h"
#include "slide/iris_file.h"

using namespace iris_test;

namespace {

fs::path copyTo(const fs::path& from, const char* name) {
    const fs::path to = outDir("iris-bytes") / name;
    fs::remove(to);
    fs::copy_file(from, to);
    fs::permissions(to, fs::perms::owner_read | fs::perms::owner_write, fs::perm_options::add);
    return to;
}

} // namespace

class TestIrisBytes : public QObject {
    Q_OBJECT
private slots:
    void fileAndMemoryAgree_data() {
        QTest::addColumn<QString>("name");
        for (const char* f : {"CMU-1-Small-Region.v1.1.iris", "tcga-cr-7395-01a-01-ts1.v1.0.iris", "small.v1.0.iris"})
            QTest::newRow(f) << QString(f);
    }
    void fileAndMemoryAgree() {
        QFETCH(QString, name);
        const fs::path path = fixture(name.toUtf8().constData());
        if (!fs::exists(path)) QSKIP("the shared .iris test files are not here");
        const std::vector<uint8_t> bytes = readAll(path);
        const std::string n = name.toStdString();
        const auto fromMemory = iris::ife::parse(bytes.data(), bytes.size(), n);
        QVERIFY2(fromMemory.ok(), fromMemory.ok() ? "" : fromMemory.error().message().c_str());

        const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        QVERIFY(fd >= 0);
        const auto source = iris::ife::ByteSource::file(fd, bytes.size(), n);
        const auto fromFile = iris::ife::parse(source, n);
        QVERIFY2(fromFile.ok(), fromFile.ok() ? "" : fromFile.error().message().c_str());
        const iris::SlideInfo a = iris::ife::slideInfo(bytes.data(), *fromMemory, path.string());
        const iris::SlideInfo b = iris::ife::slideInfo(source, *fromFile, path.string());
        QVERIFY(source.failure().ok());
        ::close(fd);

        QCOMPARE(fromFile->layers.size(), fromMemory->layers.size());
        for (size_t i = 0; i < fromFile->layers.size(); ++i) {
            QCOMPARE(fromFile->layers[i].xTiles, fromMemory->layers[i].xTiles);
            QCOMPARE(fromFile->layers[i].yTiles, fromMemory->layers[i].yTiles);
            QCOMPARE(fromFile->layers[i].firstTile, fromMemory->layers[i].firstTile);
        }
        QCOMPARE(fromFile->tileEntries, fromMemory->tileEntries);
        QCOMPARE(fromFile->attributes, fromMemory->attributes);
        QCOMPARE(fromFile->images.size(), fromMemory->images.size());
        QCOMPARE(b.levels.size(), a.levels.size());
        QCOMPARE(b.properties, a.properties);
        QCOMPARE(b.iccProfile, a.iccProfile);
        QCOMPARE(b.associatedImages, a.associatedImages);
    }

    void truncatedWhileParsed_data() {
        QTest::addColumn<double>("keep"); // the share of the file left, < 1
        QTest::newRow("to its header (64 bytes)") << -64.0;
        QTest::newRow("to half") << 0.5;
        QTest::newRow("one byte short") << -1.0;
    }
    void truncatedWhileParsed() {
        QFETCH(double, keep);
        const fs::path from = fixture("tcga-cr-7395-01a-01-ts1.v1.0.iris");
        if (!fs::exists(from)) QSKIP("the shared .iris test files are not here");
        const fs::path path = copyTo(from, "cut.iris");
        const uint64_t size = fs::file_size(path);
        const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        QVERIFY(fd >= 0);
        // keep < 0: that many bytes kept (−64) or cut (−1).
        const uint64_t left = keep == -64.0 ? 64 : keep == -1.0 ? size - 1 : uint64_t(double(size) * keep);
        fs::resize_file(path, left);
        // Where the file's structure lies decides whether the cut part is read at all: the
        // metadata of this encoder's files is at the end, so every cut here is read.
        const auto source = iris::ife::ByteSource::file(fd, size, "cut.iris");
        const auto layout = iris::ife::parse(source, "cut.iris");
        ::close(fd);
        QVERIFY(!layout.ok());
        QCOMPARE(layout.error().status(), iris::Status::IoError);
        const std::string m = layout.error().message();
        qInfo("%s", m.c_str());
        QVERIFY2(m.find("Cannot open 'cut.iris'") == 0, m.c_str());
        QVERIFY2(m.find("truncated or rewritten while being opened") != std::string::npos, m.c_str());
    }

    void unreadableDescriptor() {
        const fs::path from = fixture("small.v1.0.iris");
        if (!fs::exists(from)) QSKIP("the shared .iris test files are not here");
        // A descriptor open for writing only: every pread fails (EBADF).
        const fs::path path = copyTo(from, "write-only.iris");
        const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
        QVERIFY(fd >= 0);
        const auto source = iris::ife::ByteSource::file(fd, fs::file_size(path), "write-only.iris");
        const auto layout = iris::ife::parse(source, "write-only.iris");
        ::close(fd);
        QVERIFY(!layout.ok());
        QCOMPARE(layout.error().status(), iris::Status::IoError);
        QVERIFY2(layout.error().message().find("Cannot open 'write-only.iris': cannot read byte 0 of its ") == 0,
                 layout.error().message().c_str());
    }
};

QTEST_GUILESS_MAIN(TestIrisBytes)
#include "tst_iris_bytes.moc"
