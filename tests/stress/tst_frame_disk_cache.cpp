// The on-disk frame cache of DICOMweb sources (net/frame_disk_cache): a frame put is read back
// whole (bytes and transfer syntax), here and after the cache is closed and opened again; one
// cache a folder in the process; every kind of damaged file (short, long, corrupt, garbage,
// empty) is a miss that is counted and removed, while another key's file (a hash collision) is a
// miss left in place; the least recently used files go first, down to 7/8 of the bound, and a
// smaller bound given later applies at once; a folder that cannot be used is refused by name, a
// folder made by the cache is the user's alone (0700, files 0600), a folder removed under the
// cache is made again; absurd frames are not kept; and readers racing writers and eviction only
// ever read a frame whole (run under ASan and TSan too). Every test has its own folder and waits
// on flush(), never on time.
#include <QtTest>

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <thread>
#include <vector>

#include "net/frame_disk_cache.h"

namespace fs = std::filesystem;
using iris::net::FrameDiskCache;

namespace {

constexpr uint64_t kMiB = uint64_t(1) << 20;
const std::string kSyntax = "1.2.840.10008.1.2.1"; // explicit VR little endian
const std::string kOtherSyntax = "1.2.840.10008.1.2.4.50";
constexpr size_t kHeaderBytes = 8 + 4 + 4 + 8; // magic, key length, syntax length, frame length
constexpr size_t kCrcBytes = 4;

// A frame's bytes, every one of them a function of the key: a read can be checked exactly.
std::vector<uint8_t> payloadOf(const std::string& key, size_t n) {
    uint64_t x = iris::net::frameCacheHash(key) | 1;
    std::vector<uint8_t> b(n);
    for (auto& v : b) {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        v = uint8_t(x >> 32);
    }
    return b;
}

std::string keyOf(int i) {
    char s[32];
    std::snprintf(s, sizeof s, "frame-%03d", i);
    return s;
}

// What a file holding `key` in kSyntax with `n` bytes weighs on disk.
uint64_t fileBytes(const std::string& key, size_t n) {
    return kHeaderBytes + key.size() + kSyntax.size() + n + kCrcBytes;
}

// <dir>/<hh>/<16 lowercase hex digits of the key's hash>.
std::string fileOf(const std::string& dir, const std::string& key) {
    char name[17];
    std::snprintf(name, sizeof name, "%016llx", static_cast<unsigned long long>(iris::net::frameCacheHash(key)));
    return dir + "/" + std::string(name, 2) + "/" + name;
}

// The cache files (16 hex digits) on disk under `dir`.
size_t filesOnDisk(const std::string& dir) {
    size_t n = 0;
    std::error_code ec;
    for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (it->is_regular_file() && name.size() == 16 &&
            name.find_first_not_of("0123456789abcdef") == std::string::npos)
            ++n;
    }
    return n;
}

std::shared_ptr<FrameDiskCache> openCache(const std::string& dir, uint64_t maxBytes) {
    auto r = FrameDiskCache::open(dir, maxBytes);
    if (!r) {
        qWarning("open(%s) failed: %s", dir.c_str(), r.error().message().c_str());
        return nullptr;
    }
    return std::move(r).value();
}

void putFrame(FrameDiskCache& cache, const std::string& key, size_t n, const std::string& syntax = kSyntax) {
    cache.put(key, FrameDiskCache::Frame{syntax, payloadOf(key, n)});
}

// Whether `key` is read back whole: its syntax and exactly its bytes.
bool holds(FrameDiskCache& cache, const std::string& key, size_t n) {
    const auto f = cache.get(key, kSyntax);
    return f && f->transferSyntax == kSyntax && f->bytes == payloadOf(key, n);
}

std::vector<uint8_t> readFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}
void writeFile(const std::string& path, const std::vector<uint8_t>& data) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data.data()), std::streamsize(data.size()));
}

// The cache's eviction, modelled: files in order of last use (oldest first); past the bound the
// oldest go until the total is at most 7/8 of it.
struct LruModel {
    uint64_t bound = 0, total = 0, evicted = 0;
    std::deque<std::pair<int, uint64_t>> order; // frame number, bytes
    void use(int i) {
        const auto it = std::find_if(order.begin(), order.end(), [&](const auto& e) { return e.first == i; });
        if (it == order.end()) return;
        const auto e = *it;
        order.erase(it);
        order.push_back(e);
    }
    void put(int i, uint64_t bytes) {
        order.emplace_back(i, bytes);
        total += bytes;
        if (total <= bound) return;
        const uint64_t target = bound - bound / 8;
        while (total > target) {
            total -= order.front().second;
            order.pop_front();
            ++evicted;
        }
    }
    bool has(int i) const {
        return std::any_of(order.begin(), order.end(), [&](const auto& e) { return e.first == i; });
    }
};

} // namespace

class TestFrameDiskCache : public QObject {
    Q_OBJECT
private slots:
    void roundTrip() {
        QTemporaryDir tmp;
        QVERIFY(tmp.isValid());
        auto cache = openCache(tmp.path().toStdString(), 16 * kMiB);
        QVERIFY(cache);
        const std::string key = "https://pacs.example/dicomweb/studies/1/series/2/instances/3/frames/4";
        QVERIFY(!cache->contains(key));
        QVERIFY(!cache->get(key, kSyntax));
        putFrame(*cache, key, 12345);
        cache->flush();
        QVERIFY(cache->contains(key));
        QVERIFY(fs::is_regular_file(fileOf(cache->directory(), key)));
        QCOMPARE(fs::file_size(fileOf(cache->directory(), key)), fileBytes(key, 12345));
        auto s = cache->stats();
        QCOMPARE(s.written, uint64_t(1));
        QCOMPARE(s.files, uint64_t(1));
        QCOMPARE(s.bytes, fileBytes(key, 12345));
        QCOMPARE(s.writeErrors, uint64_t(0));

        const auto f = cache->get(key, kSyntax);
        QVERIFY(f);
        QCOMPARE(f->transferSyntax, kSyntax);
        QVERIFY(f->bytes == payloadOf(key, 12345));
        // Any syntax: the one kept.
        const auto any = cache->get(key, "");
        QVERIFY(any);
        QCOMPARE(any->transferSyntax, kSyntax);
        QVERIFY(any->bytes == payloadOf(key, 12345));
        // Another syntax: a miss that leaves the file.
        QVERIFY(!cache->get(key, kOtherSyntax));
        QVERIFY(cache->contains(key));
        QVERIFY(fs::exists(fileOf(cache->directory(), key)));
        QVERIFY(holds(*cache, key, 12345));
        s = cache->stats();
        QCOMPARE(s.hits, uint64_t(3));
        QCOMPARE(s.misses, uint64_t(2));
        QCOMPARE(s.broken, uint64_t(0));

        // A second put of the key replaces its file (other syntax, other size), counted once.
        cache->put(key, FrameDiskCache::Frame{kOtherSyntax, payloadOf(key, 777)});
        cache->flush();
        QVERIFY(!cache->get(key, kSyntax));
        const auto g = cache->get(key, kOtherSyntax);
        QVERIFY(g);
        QVERIFY(g->bytes == payloadOf(key, 777));
        s = cache->stats();
        QCOMPARE(s.files, uint64_t(1));
        QCOMPARE(s.bytes, uint64_t(kHeaderBytes + key.size() + kOtherSyntax.size() + 777 + kCrcBytes));
        QCOMPARE(filesOnDisk(cache->directory()), size_t(1));
    }

    void survivesReopen() {
        QTemporaryDir tmp;
        QVERIFY(tmp.isValid());
        const std::string dir = tmp.path().toStdString();
        std::weak_ptr<FrameDiskCache> weak;
        {
            auto cache = openCache(dir, 16 * kMiB);
            QVERIFY(cache);
            weak = cache;
            putFrame(*cache, "flushed", 5000);
            cache->flush();
        }
        QVERIFY(weak.expired()); // closed: the registry holds it weakly
        {
            auto cache = openCache(dir, 16 * kMiB);
            QVERIFY(cache);
            QVERIFY(cache->contains("flushed")); // the scan read the folder
            QCOMPARE(cache->stats().files, uint64_t(1));
            QCOMPARE(cache->stats().bytes, uint64_t(kHeaderBytes + 7 + kSyntax.size() + 5000 + kCrcBytes));
            QVERIFY(holds(*cache, "flushed", 5000));
            weak = cache;
            // Not flushed: closing writes what is queued.
            for (int i = 0; i < 20; ++i) putFrame(*cache, keyOf(i), 3000 + size_t(i));
        }
        QVERIFY(weak.expired());
        auto cache = openCache(dir, 16 * kMiB);
        QVERIFY(cache);
        QCOMPARE(cache->stats().files, uint64_t(21));
        QVERIFY(holds(*cache, "flushed", 5000));
        for (int i = 0; i < 20; ++i) {
            QVERIFY(cache->contains(keyOf(i)));
            QVERIFY(holds(*cache, keyOf(i), 3000 + size_t(i)));
        }
        QCOMPARE(cache->stats().broken, uint64_t(0));
    }

    void sharedPerFolder() {
        QTemporaryDir tmp, other;
        QVERIFY(tmp.isValid() && other.isValid());
        const std::string dir = tmp.path().toStdString();
        auto a = openCache(dir, 4 * kMiB);
        QVERIFY(a);
        auto b = openCache(dir, 4 * kMiB);
        QVERIFY(b);
        QCOMPARE(a.get(), b.get());
        auto c = openCache(dir + "/", 4 * kMiB);
        QVERIFY(c);
        QCOMPARE(a.get(), c.get());
        const fs::path p(dir);
        auto d = openCache(p.parent_path().string() + "/./" + p.filename().string(), 4 * kMiB);
        QVERIFY(d);
        QCOMPARE(a.get(), d.get());
        fs::create_directory(dir + "/sub");
        auto e = openCache(dir + "/sub/..", 4 * kMiB);
        QVERIFY(e);
        QCOMPARE(a.get(), e.get());
        const std::string link = other.path().toStdString() + "/link";
        fs::create_directory_symlink(dir, link);
        auto f = openCache(link, 4 * kMiB);
        QVERIFY(f);
        QCOMPARE(a.get(), f.get());
        // What one puts the others read.
        putFrame(*b, "shared", 100);
        a->flush();
        QVERIFY(holds(*f, "shared", 100));

        auto g = openCache(other.path().toStdString(), 4 * kMiB);
        QVERIFY(g);
        QVERIFY(g.get() != a.get());
        QVERIFY(!g->contains("shared"));
    }

    void corruptFilesAreMisses_data() {
        QTest::addColumn<int>("damage");
        QTest::newRow("truncated by one byte") << 0;
        QTest::newRow("one byte appended") << 1;
        QTest::newRow("payload byte flipped") << 2;
        QTest::newRow("key byte flipped") << 3;
        QTest::newRow("syntax byte flipped") << 4;
        QTest::newRow("magic byte flipped") << 5;
        QTest::newRow("crc byte flipped") << 6;
        QTest::newRow("length field changed") << 7;
        QTest::newRow("garbage") << 8;
        QTest::newRow("short garbage") << 9;
        QTest::newRow("empty") << 10;
    }
    void corruptFilesAreMisses() {
        QFETCH(int, damage);
        QTemporaryDir tmp;
        QVERIFY(tmp.isValid());
        auto cache = openCache(tmp.path().toStdString(), 16 * kMiB);
        QVERIFY(cache);
        const std::string key = "https://pacs.example/frames/" + std::to_string(damage);
        const std::string other = "https://pacs.example/frames/intact";
        constexpr size_t n = 4096;
        putFrame(*cache, key, n);
        putFrame(*cache, other, n);
        cache->flush();
        const std::string path = fileOf(cache->directory(), key);
        std::vector<uint8_t> data = readFile(path);
        QCOMPARE(uint64_t(data.size()), fileBytes(key, n));
        const size_t keyAt = kHeaderBytes, syntaxAt = keyAt + key.size(), payloadAt = syntaxAt + kSyntax.size();
        switch (damage) {
        case 0: data.pop_back(); break;
        case 1: data.push_back(0); break;
        case 2: data[payloadAt + n / 2] ^= 0x01; break;
        case 3: data[keyAt + 3] ^= 0x20; break;
        case 4: data[syntaxAt + 2] ^= 0x01; break;
        case 5: data[0] ^= 0x01; break;
        case 6: data[data.size() - 1] ^= 0x80; break;
        case 7: data[16] ^= 0x01; break; // the frame's length: the sizes no longer add up
        case 8: std::fill(data.begin(), data.end(), uint8_t(0xA5)); break;
        case 9: data.assign({'I', 'R', 'I', 'S'}); break;
        case 10: data.clear(); break;
        }
        writeFile(path, data);
        QCOMPARE(uint64_t(fs::file_size(path)), uint64_t(data.size()));
        QVERIFY(cache->contains(key));
        const auto before = cache->stats();
        QVERIFY(!cache->get(key, kSyntax));
        const auto after = cache->stats();
        QCOMPARE(after.broken, before.broken + 1);
        QCOMPARE(after.misses, before.misses + 1);
        QCOMPARE(after.files, before.files - 1);
        QCOMPARE(after.bytes, fileBytes(other, n)); // the broken file no longer counts
        QVERIFY(!fs::exists(path));
        QVERIFY(!cache->contains(key));
        QVERIFY(!cache->get(key, "")); // now a plain miss
        QCOMPARE(cache->stats().broken, after.broken);
        QVERIFY(holds(*cache, other, n)); // the intact neighbour is untouched
        // Put again, it is read again.
        putFrame(*cache, key, n);
        cache->flush();
        QVERIFY(holds(*cache, key, n));
    }

    void hashCollisionIsAMiss() {
        QTemporaryDir tmp;
        QVERIFY(tmp.isValid());
        const std::string dir = fs::canonical(tmp.path().toStdString()).string();
        const std::string a = "key-a", b = "key-b", c = "key-c";
        {
            auto cache = openCache(dir, 16 * kMiB);
            QVERIFY(cache);
            putFrame(*cache, a, 2000);
            putFrame(*cache, b, 3000);
            cache->flush();
            // B's file now holds A's frame (as if the two hashed alike): B misses, its file stays.
            QVERIFY(fs::copy_file(fileOf(cache->directory(), a), fileOf(cache->directory(), b),
                                  fs::copy_options::overwrite_existing));
            QVERIFY(!cache->get(b, kSyntax));
            QVERIFY(!cache->get(b, ""));
            auto s = cache->stats();
            QCOMPARE(s.broken, uint64_t(0));
            QCOMPARE(s.misses, uint64_t(2));
            QVERIFY(cache->contains(b));
            QVERIFY(fs::exists(fileOf(cache->directory(), b)));
            QVERIFY(holds(*cache, a, 2000));
        }
        // A file found by the scan under C's name but holding A's frame: C misses, nothing broken.
        fs::create_directories(fs::path(fileOf(dir, c)).parent_path());
        QVERIFY(fs::copy_file(fileOf(dir, a), fileOf(dir, c), fs::copy_options::overwrite_existing));
        fs::permissions(fileOf(dir, c), fs::perms::owner_read | fs::perms::owner_write, fs::perm_options::replace);
        auto cache = openCache(dir, 16 * kMiB);
        QVERIFY(cache);
        QVERIFY(cache->contains(c));
        QVERIFY(!cache->get(c, kSyntax));
        QCOMPARE(cache->stats().broken, uint64_t(0));
        QVERIFY(fs::exists(fileOf(dir, c)));
        QVERIFY(holds(*cache, a, 2000));
    }

    void evictsLeastRecentlyUsed() {
        QTemporaryDir tmp;
        QVERIFY(tmp.isValid());
        auto cache = openCache(tmp.path().toStdString(), kMiB);
        QVERIFY(cache);
        constexpr size_t n = 40000;
        const uint64_t size = fileBytes(keyOf(0), n); // every key is as long
        LruModel model;
        model.bound = kMiB;
        const auto check = [&](int upTo) {
            for (int i = 0; i < upTo; ++i)
                if (cache->contains(keyOf(i)) != model.has(i)) return false;
            const auto s = cache->stats();
            return s.files == model.order.size() && s.bytes == model.total && s.evicted == model.evicted &&
                   s.bytes <= kMiB && filesOnDisk(cache->directory()) == model.order.size();
        };
        int next = 0;
        for (; next < 40; ++next) {
            putFrame(*cache, keyOf(next), n);
            cache->flush();
            model.put(next, size);
            QVERIFY2(check(next + 1), qPrintable(QString("after frame %1").arg(next)));
        }
        auto s = cache->stats();
        QVERIFY(s.evicted > 0);
        QVERIFY(s.bytes <= kMiB);
        QVERIFY(s.bytes > kMiB / 2);
        QVERIFY(cache->contains(keyOf(39)));
        QVERIFY(holds(*cache, keyOf(39), n)); // the newest is kept (and now used)
        model.use(39);
        QVERIFY(!cache->contains(keyOf(0)));
        QVERIFY(!fs::exists(fileOf(cache->directory(), keyOf(0))));
        QVERIFY(!cache->get(keyOf(0), kSyntax));
        QCOMPARE(cache->stats().broken, uint64_t(0));

        // The three oldest left: the middle one is read, then frames are put until eviction runs
        // again. The one read outlives its neighbours, written just before and just after it.
        const int oldest = model.order.front().first;
        const int k = oldest + 1;
        QVERIFY(cache->contains(keyOf(oldest)) && cache->contains(keyOf(k)) && cache->contains(keyOf(k + 1)));
        QVERIFY(holds(*cache, keyOf(k), n));
        model.use(k);
        const uint64_t evictedBefore = cache->stats().evicted;
        while (cache->stats().evicted == evictedBefore) {
            QVERIFY(next < 200);
            putFrame(*cache, keyOf(next), n);
            cache->flush();
            model.put(next, size);
            ++next;
            QVERIFY2(check(next), qPrintable(QString("after frame %1").arg(next - 1)));
        }
        QVERIFY(cache->contains(keyOf(k)));
        QVERIFY(holds(*cache, keyOf(k), n));
        QVERIFY(!cache->contains(keyOf(k - 1)));
        QVERIFY(!cache->contains(keyOf(k + 1)));
        QVERIFY(!fs::exists(fileOf(cache->directory(), keyOf(k - 1))));
        QVERIFY(!fs::exists(fileOf(cache->directory(), keyOf(k + 1))));
        QVERIFY(cache->stats().bytes <= kMiB);
        QVERIFY(cache->stats().bytes <= kMiB - kMiB / 8); // just evicted: down to 7/8
    }

    void boundShrinksOnReopen() {
        constexpr size_t n = 40000;
        constexpr int frames = 75; // about 3 MiB
        const uint64_t size = fileBytes(keyOf(0), n);
        QTemporaryDir tmp;
        QVERIFY(tmp.isValid());
        {
            // The cache still open: the smaller bound applies to it at once.
            auto cache = openCache(tmp.path().toStdString(), 4 * kMiB);
            QVERIFY(cache);
            for (int i = 0; i < frames; ++i) putFrame(*cache, keyOf(i), n);
            cache->flush();
            QCOMPARE(cache->stats().evicted, uint64_t(0));
            QCOMPARE(cache->stats().bytes, size * frames);
            QVERIFY(cache->stats().bytes > 2 * kMiB);
            auto smaller = openCache(tmp.path().toStdString(), kMiB);
            QVERIFY(smaller);
            QCOMPARE(smaller.get(), cache.get());
            const auto s = cache->stats();
            QVERIFY(s.bytes <= kMiB);
            QVERIFY(s.evicted > 0);
            QCOMPARE(s.files + s.evicted, uint64_t(frames));
            QCOMPARE(filesOnDisk(cache->directory()), size_t(s.files));
            QVERIFY(!cache->contains(keyOf(0)));
            QVERIFY(holds(*cache, keyOf(frames - 1), n));
            // The bound holds for what comes next.
            for (int i = frames; i < frames + 10; ++i) putFrame(*cache, keyOf(i), n);
            cache->flush();
            QVERIFY(cache->stats().bytes <= kMiB);
        }
        QTemporaryDir tmp2;
        QVERIFY(tmp2.isValid());
        {
            auto cache = openCache(tmp2.path().toStdString(), 4 * kMiB);
            QVERIFY(cache);
            for (int i = 0; i < frames; ++i) putFrame(*cache, keyOf(i), n);
        } // closed: written on the way out
        {
            // Opened again with a smaller bound: the scan's files are evicted down to it.
            auto cache = openCache(tmp2.path().toStdString(), kMiB);
            QVERIFY(cache);
            const auto s = cache->stats();
            QVERIFY(s.bytes <= kMiB);
            QVERIFY(s.files > 0);
            QCOMPARE(s.evicted, uint64_t(frames) - s.files);
            QCOMPARE(s.bytes, size * s.files);
            QCOMPARE(filesOnDisk(cache->directory()), size_t(s.files));
        }
    }

    void unusableFolder() {
        QTemporaryDir tmp;
        QVERIFY(tmp.isValid());
        const std::string base = tmp.path().toStdString();

        // A regular file.
        const std::string file = base + "/a-file";
        writeFile(file, {1, 2, 3});
        auto r = FrameDiskCache::open(file, kMiB);
        QVERIFY(!r);
        QVERIFY2(r.error().message().find(file) != std::string::npos, r.error().message().c_str());
        // Under a regular file: the folder cannot be made.
        r = FrameDiskCache::open(file + "/cache", kMiB);
        QVERIFY(!r);
        QVERIFY2(r.error().message().find(file + "/cache") != std::string::npos, r.error().message().c_str());
        // No folder at all.
        r = FrameDiskCache::open("", kMiB);
        QVERIFY(!r);

        // A folder the user may not write. Root ignores permissions (access() grants it), so
        // this part means nothing there and is left out.
        if (::geteuid() != 0) {
            const std::string locked = base + "/locked";
            fs::create_directory(locked);
            fs::permissions(locked, fs::perms::owner_read | fs::perms::owner_exec, fs::perm_options::replace);
            r = FrameDiskCache::open(locked, kMiB);
            fs::permissions(locked, fs::perms::owner_all, fs::perm_options::replace);
            QVERIFY(!r);
            QVERIFY2(r.error().message().find(locked) != std::string::npos, r.error().message().c_str());
        }

        // A folder the cache makes is the user's alone, and so are its files.
        const std::string made = base + "/made/cache";
        auto cache = openCache(made, kMiB);
        QVERIFY(cache);
        struct stat st {};
        QCOMPARE(::stat(made.c_str(), &st), 0);
        QVERIFY(S_ISDIR(st.st_mode));
        QCOMPARE(int(st.st_mode & 07777), 0700);
        putFrame(*cache, "private", 1000);
        cache->flush();
        const std::string path = fileOf(cache->directory(), "private");
        QCOMPARE(::stat(path.c_str(), &st), 0);
        QVERIFY(S_ISREG(st.st_mode));
        QCOMPARE(int(st.st_mode & 07777), 0600);
        QVERIFY(holds(*cache, "private", 1000));
    }

    void folderRemovedUnderIt() {
        QTemporaryDir tmp;
        QVERIFY(tmp.isValid());
        const std::string dir = tmp.path().toStdString() + "/cache";
        auto cache = openCache(dir, 16 * kMiB);
        QVERIFY(cache);
        putFrame(*cache, "first", 2000);
        cache->flush();
        QVERIFY(holds(*cache, "first", 2000));
        QVERIFY(fs::remove_all(dir) > 0);
        QVERIFY(!fs::exists(dir));
        putFrame(*cache, "second", 3000);
        cache->flush();
        auto s = cache->stats();
        QCOMPARE(s.writeErrors, uint64_t(0));
        QCOMPARE(s.written, uint64_t(2));
        QVERIFY(fs::exists(fileOf(cache->directory(), "second")));
        QVERIFY(holds(*cache, "second", 3000));
        // The first is gone: a miss, no longer indexed nor counted.
        QVERIFY(cache->contains("first"));
        QVERIFY(!cache->get("first", kSyntax));
        QVERIFY(!cache->contains("first"));
        s = cache->stats();
        QCOMPARE(s.broken, uint64_t(0));
        QCOMPARE(s.files, uint64_t(1));
        QCOMPARE(s.bytes, uint64_t(kHeaderBytes + 6 + kSyntax.size() + 3000 + kCrcBytes));

        // Many frames over many sub-folders, the folder cleared: the first miss unindexes them
        // all (so that they are fetched in lists again, not each missed on its own first).
        for (int i = 0; i < 64; ++i) putFrame(*cache, "many-" + std::to_string(i), 500);
        cache->flush();
        QCOMPARE(cache->stats().files, uint64_t(65));
        QVERIFY(fs::remove_all(dir) > 0);
        QVERIFY(!cache->get("many-7", kSyntax));
        s = cache->stats();
        QCOMPARE(s.files, uint64_t(0));
        QCOMPARE(s.bytes, uint64_t(0));
        for (int i = 0; i < 64; ++i) QVERIFY(!cache->contains("many-" + std::to_string(i)));
        QVERIFY(!cache->contains("second"));
    }

    void rejectsAbsurdInput() {
        QTemporaryDir tmp;
        QVERIFY(tmp.isValid());
        auto cache = openCache(tmp.path().toStdString(), 16 * kMiB);
        QVERIFY(cache);
        cache->put("empty", FrameDiskCache::Frame{kSyntax, {}});
        const std::string longKey(FrameDiskCache::kMaxKeyBytes + 1, 'k');
        putFrame(*cache, longKey, 100);
        const std::string longSyntax(FrameDiskCache::kMaxTransferSyntaxBytes + 1, '1');
        putFrame(*cache, "long-syntax", 100, longSyntax);
        cache->flush();
        auto s = cache->stats();
        QCOMPARE(s.written, uint64_t(0));
        QCOMPARE(s.files, uint64_t(0));
        QCOMPARE(s.bytes, uint64_t(0));
        QCOMPARE(s.writeErrors, uint64_t(0));
        QCOMPARE(filesOnDisk(cache->directory()), size_t(0));
        QVERIFY(!cache->contains("empty"));
        QVERIFY(!cache->contains(longKey));
        QVERIFY(!cache->contains("long-syntax"));

        // At the limits they are kept.
        const std::string maxKey(FrameDiskCache::kMaxKeyBytes, 'k');
        const std::string maxSyntax(FrameDiskCache::kMaxTransferSyntaxBytes, '1');
        cache->put(maxKey, FrameDiskCache::Frame{maxSyntax, payloadOf(maxKey, 1)});
        cache->flush();
        s = cache->stats();
        QCOMPARE(s.written, uint64_t(1));
        const auto f = cache->get(maxKey, maxSyntax);
        QVERIFY(f);
        QVERIFY(f->bytes == payloadOf(maxKey, 1));
        QCOMPARE(cache->stats().broken, uint64_t(0));
    }

    void concurrentReadersAndWriters() {
        QTemporaryDir tmp;
        QVERIFY(tmp.isValid());
        auto cache = openCache(tmp.path().toStdString(), kMiB); // a tight bound: eviction runs throughout
        QVERIFY(cache);
        constexpr int kKeys = 64, kIterations = 500; // a thread: 2000 in all
        const auto keyAt = [](int i) { return "https://pacs.example/series/7/frames/" + std::to_string(i); };
        const auto sizeOf = [&](int i) { return size_t(8000 + iris::net::frameCacheHash(keyAt(i)) % 40000); };
        std::vector<std::vector<uint8_t>> expected(kKeys);
        for (int i = 0; i < kKeys; ++i) expected[size_t(i)] = payloadOf(keyAt(i), sizeOf(i));

        // The keys the writers put (fixed seeds): together they outweigh the bound.
        std::set<int> written;
        uint64_t writtenBytes = 0;
        for (int w = 0; w < 2; ++w) {
            std::mt19937 rng(uint32_t(100 + w));
            for (int it = 0; it < kIterations; ++it) written.insert(int(rng() % kKeys));
        }
        for (const int i : written) writtenBytes += fileBytes(keyAt(i), sizeOf(i));
        QVERIFY(writtenBytes > kMiB);

        std::atomic<uint64_t> hits{0}, wrong{0}, wrongSyntaxHits{0};
        std::vector<std::thread> threads;
        for (int w = 0; w < 2; ++w)
            threads.emplace_back([&, w] {
                std::mt19937 rng(uint32_t(100 + w));
                for (int it = 0; it < kIterations; ++it) {
                    const int i = int(rng() % kKeys);
                    cache->put(keyAt(i), FrameDiskCache::Frame{kSyntax, expected[size_t(i)]});
                    if (it % 64 == 63) cache->flush();
                }
            });
        for (int r = 0; r < 2; ++r)
            threads.emplace_back([&, r] {
                std::mt19937 rng(uint32_t(200 + r));
                for (int it = 0; it < kIterations; ++it) {
                    const int i = int(rng() % kKeys);
                    const int mode = int(rng() % 4);
                    const std::string syntax = mode == 0 ? std::string() : mode == 1 ? kOtherSyntax : kSyntax;
                    (void)cache->contains(keyAt(i));
                    const auto f = cache->get(keyAt(i), syntax);
                    if (!f) continue;
                    hits.fetch_add(1);
                    if (mode == 1) wrongSyntaxHits.fetch_add(1);
                    if (f->transferSyntax != kSyntax || f->bytes != expected[size_t(i)]) wrong.fetch_add(1);
                    if (it % 50 == 0) (void)cache->stats();
                }
            });
        for (auto& t : threads) t.join();
        cache->flush();
        QCOMPARE(wrong.load(), uint64_t(0));
        QCOMPARE(wrongSyntaxHits.load(), uint64_t(0));
        const auto s = cache->stats();
        QCOMPARE(s.broken, uint64_t(0));
        QCOMPARE(s.writeErrors, uint64_t(0));
        QCOMPARE(s.dropped, uint64_t(0)); // 1000 frames of 48 KB at most never fill the queue
        QCOMPARE(s.written, uint64_t(2 * kIterations));
        QVERIFY(s.evicted > 0);
        QVERIFY(s.bytes <= kMiB);
        QCOMPARE(s.hits + s.misses, uint64_t(2 * kIterations));
        QCOMPARE(s.hits, hits.load());
        // At rest, every key indexed is read whole.
        int indexed = 0;
        for (int i = 0; i < kKeys; ++i) {
            if (!cache->contains(keyAt(i))) continue;
            ++indexed;
            const auto f = cache->get(keyAt(i), kSyntax);
            QVERIFY2(f, qPrintable(QString("key %1").arg(i)));
            QVERIFY(f->bytes == expected[size_t(i)]);
        }
        QVERIFY(indexed > 0);
        QCOMPARE(uint64_t(indexed), cache->stats().files);
    }
};

QTEST_GUILESS_MAIN(TestFrameDiskCache)
#include "tst_frame_disk_cache.moc"
