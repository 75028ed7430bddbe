#include "net/frame_disk_cache.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <map>

#include "core/thread_name.h"

namespace iris::net {

namespace fs = std::filesystem;

namespace {

// "IRISFRM1", then the key's, the transfer syntax's and the frame's lengths (u32, u32, u64,
// little endian), the three themselves, and a CRC-32 of everything after the magic.
constexpr char kMagic[8] = {'I', 'R', 'I', 'S', 'F', 'R', 'M', '1'};
constexpr size_t kHeaderBytes = 8 + 4 + 4 + 8;
// Temporary files of a writer that died are removed by the next scan once this old (a live
// writer renames its file within moments).
constexpr auto kStaleTemporary = std::chrono::minutes(10);

int64_t nowNs() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
        .count();
}

void putLe(uint8_t* p, uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i) p[i] = uint8_t(v >> (8 * i));
}
uint64_t getLe(const uint8_t* p, int bytes) {
    uint64_t v = 0;
    for (int i = 0; i < bytes; ++i) v |= uint64_t(p[i]) << (8 * i);
    return v;
}

uint32_t crcOf(const uint8_t* p, size_t n, uint32_t crc = 0) {
    if (crc == 0) crc = uint32_t(crc32(0L, Z_NULL, 0));
    while (n > 0) { // zlib takes uInt lengths
        const uInt step = uInt(std::min<size_t>(n, 1u << 30));
        crc = uint32_t(crc32(crc, p, step));
        p += step;
        n -= step;
    }
    return crc;
}

bool hexName(const std::string& name, uint64_t* hash) {
    if (name.size() != 16) return false;
    uint64_t v = 0;
    for (const char c : name) {
        int d;
        if (c >= '0' && c <= '9')
            d = c - '0';
        else if (c >= 'a' && c <= 'f')
            d = c - 'a' + 10;
        else
            return false;
        v = v << 4 | uint64_t(d);
    }
    *hash = v;
    return true;
}

std::string hex16(uint64_t v) {
    static const char* digits = "0123456789abcdef";
    std::string s(16, '0');
    for (int i = 15; i >= 0; --i, v >>= 4) s[size_t(i)] = digits[v & 15];
    return s;
}

bool writeAll(int fd, const uint8_t* p, size_t n) {
    while (n > 0) {
        const ssize_t w = ::write(fd, p, n);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) return false;
        p += w;
        n -= size_t(w);
    }
    return true;
}

// Every process-wide cache by its folder (weakly: the last source to let one go closes it).
std::mutex registryMutex;
std::map<std::string, std::weak_ptr<FrameDiskCache>>& registry() {
    static std::map<std::string, std::weak_ptr<FrameDiskCache>> r;
    return r;
}

} // namespace

uint64_t frameCacheHash(std::string_view key, uint64_t seed) {
    uint64_t h = seed;
    for (const unsigned char c : key) {
        h ^= c;
        h *= 0x100000001b3ull;
    }
    return h;
}

Expected<std::shared_ptr<FrameDiskCache>> FrameDiskCache::open(const std::string& directory, uint64_t maxBytes) {
    const std::string context = "Cannot keep frames in '" + directory + "': ";
    if (directory.empty()) return Result(Status::InvalidArgument, context + "no folder given");
    std::error_code ec;
    const fs::path dir = fs::absolute(fs::path(directory), ec);
    if (ec) return Result(Status::IoError, context + ec.message());
    if (!fs::exists(dir, ec)) {
        fs::create_directories(dir, ec);
        if (ec) return Result(Status::IoError, context + ec.message());
        fs::permissions(dir, fs::perms::owner_all, fs::perm_options::replace, ec); // patient data: the user's alone
    }
    if (!fs::is_directory(dir, ec)) return Result(Status::IoError, context + "it is not a folder");
    if (::access(dir.c_str(), R_OK | W_OK | X_OK) != 0)
        return Result(Status::IoError, context + "the folder cannot be written (" + std::strerror(errno) + ")");
    const std::string name = fs::weakly_canonical(dir, ec).string();
    maxBytes = std::max<uint64_t>(maxBytes, uint64_t(1) << 20);

    std::lock_guard lock(registryMutex);
    if (auto existing = registry()[name].lock()) {
        {
            std::lock_guard l(existing->mutex_);
            existing->maxBytes_ = maxBytes;
            existing->evictLocked();
        }
        return existing;
    }
    std::shared_ptr<FrameDiskCache> cache(new FrameDiskCache(name, maxBytes));
    cache->scan();
    cache->thread_ = std::thread([c = cache.get()] { c->writer(); });
    registry()[name] = cache;
    return cache;
}

FrameDiskCache::FrameDiskCache(std::string dir, uint64_t maxBytes) : dir_(std::move(dir)), maxBytes_(maxBytes) {}

FrameDiskCache::~FrameDiskCache() {
    {
        std::lock_guard lock(mutex_);
        stopping_ = true; // the queue is written first: a frame handed over is not lost on close
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
    std::lock_guard lock(registryMutex);
    auto it = registry().find(dir_);
    if (it != registry().end() && it->second.expired()) registry().erase(it);
}

std::string FrameDiskCache::pathOf(uint64_t hash) const {
    const std::string name = hex16(hash);
    return dir_ + "/" + name.substr(0, 2) + "/" + name;
}

void FrameDiskCache::scan() {
    // Called once, before the writer starts and before anyone else sees the cache.
    std::error_code ec;
    const auto staleBefore = fs::file_time_type::clock::now() - kStaleTemporary;
    for (fs::directory_iterator sub(dir_, ec), end; !ec && sub != end; sub.increment(ec)) {
        std::error_code e;
        if (!sub->is_directory(e) || sub->path().filename().string().size() != 2) continue;
        for (fs::directory_iterator f(sub->path(), e); !e && f != end; f.increment(e)) {
            std::error_code fe;
            const std::string name = f->path().filename().string();
            uint64_t hash = 0;
            struct stat st {};
            if (::lstat(f->path().c_str(), &st) != 0 || !S_ISREG(st.st_mode)) continue; // no symbolic links
            if (!hexName(name, &hash)) {
                if (name.rfind(".tmp-", 0) == 0 && f->last_write_time(fe) < staleBefore) fs::remove(f->path(), fe);
                continue;
            }
            Entry& entry = index_[hash];
            entry.bytes = uint64_t(st.st_size);
            entry.lastUse = int64_t(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
            total_ += entry.bytes;
        }
    }
    evictLocked(); // a bound smaller than last time's
}

bool FrameDiskCache::contains(uint64_t keyHash) const {
    std::lock_guard lock(mutex_);
    return index_.count(keyHash) != 0;
}

std::optional<FrameDiskCache::Frame> FrameDiskCache::get(const std::string& key, const std::string& transferSyntax) {
    const uint64_t hash = frameCacheHash(key);
    const std::string path = pathOf(hash);
    {
        std::lock_guard lock(mutex_);
        if (!index_.count(hash)) {
            ++stats_.misses;
            return std::nullopt;
        }
    }
    // Read and check the whole file. `broken`: the file is not a frame file of ours (removed);
    // else a miss that leaves the file (another key's, or gone meanwhile).
    bool broken = false;
    std::optional<Frame> frame;
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
    const bool gone = fd < 0 && errno == ENOENT; // another error (EMFILE, …) says nothing of the file
    struct stat st {};
    if (fd >= 0) {
        const uint64_t maxFile = kHeaderBytes + kMaxKeyBytes + kMaxTransferSyntaxBytes + kMaxFrameBytes + 4;
        if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) || uint64_t(st.st_size) > maxFile ||
            uint64_t(st.st_size) < kHeaderBytes + 4) {
            broken = true;
        } else {
            std::vector<uint8_t> data(size_t(st.st_size));
            size_t got = 0;
            while (got < data.size()) {
                const ssize_t r = ::read(fd, data.data() + got, data.size() - got);
                if (r < 0 && errno == EINTR) continue;
                if (r <= 0) break;
                got += size_t(r);
            }
            const uint64_t keyLen = got >= kHeaderBytes ? getLe(&data[8], 4) : 0;
            const uint64_t tsLen = got >= kHeaderBytes ? getLe(&data[12], 4) : 0;
            const uint64_t len = got >= kHeaderBytes ? getLe(&data[16], 8) : 0;
            if (got != data.size() || std::memcmp(data.data(), kMagic, 8) != 0 || keyLen > kMaxKeyBytes ||
                tsLen > kMaxTransferSyntaxBytes || len > kMaxFrameBytes || len == 0 ||
                kHeaderBytes + keyLen + tsLen + len + 4 != data.size() ||
                getLe(&data[data.size() - 4], 4) != crcOf(data.data() + 8, data.size() - 12)) {
                broken = true;
            } else {
                const char* k = reinterpret_cast<const char*>(&data[kHeaderBytes]);
                const char* ts = k + keyLen;
                const bool anySyntax = transferSyntax.empty() && tsLen > 0;
                if (key.size() == keyLen && std::memcmp(k, key.data(), keyLen) == 0 &&
                    (anySyntax ||
                     (transferSyntax.size() == tsLen && std::memcmp(ts, transferSyntax.data(), tsLen) == 0))) {
                    const uint8_t* b = reinterpret_cast<const uint8_t*>(ts + tsLen);
                    frame = Frame{std::string(ts, tsLen), std::vector<uint8_t>(b, b + len)};
                }
            }
        }
        ::close(fd);
    }
    std::lock_guard lock(mutex_);
    const auto it = index_.find(hash);
    if (frame) {
        ++stats_.hits;
        if (it != index_.end()) it->second.lastUse = nowNs();
        // The file's mtime carries the use to the next session's eviction order.
        (void)::utimensat(AT_FDCWD, path.c_str(), nullptr, AT_SYMLINK_NOFOLLOW);
        return frame;
    }
    ++stats_.misses;
    // The writer renames files into place without the lock and indexes them under it: a file
    // that is there now, or another than the one read, is left to the index as it stands.
    struct stat now {};
    const bool present = ::lstat(path.c_str(), &now) == 0;
    const bool sameFile = present && now.st_ino == st.st_ino && now.st_dev == st.st_dev;
    if (gone && !present && it != index_.end()) { // another process evicted it: unindexed
        total_ -= std::min(total_, it->second.bytes);
        index_.erase(it);
        // Its sub-folder gone too: the folder was cleared under us (the viewer's Clear, a user's
        // rm). Every entry of a sub-folder that is gone goes now, so that the frames it held are
        // asked for in lists again rather than each missed on its own first.
        if (::access(fs::path(path).parent_path().c_str(), F_OK) != 0) unindexGoneFolders();
    } else if (broken) {
        ++stats_.broken;
        if (sameFile) {
            ::unlink(path.c_str());
            if (it != index_.end()) {
                total_ -= std::min(total_, it->second.bytes);
                index_.erase(it);
            }
        }
    }
    return std::nullopt;
}

void FrameDiskCache::put(const std::string& key, Frame frame) {
    if (key.size() > kMaxKeyBytes || frame.transferSyntax.size() > kMaxTransferSyntaxBytes || frame.bytes.empty() ||
        frame.bytes.size() > kMaxFrameBytes)
        return;
    {
        std::lock_guard lock(mutex_);
        if (stopping_) return;
        if (queuedBytes_ + frame.bytes.size() > kMaxQueuedBytes) { // the disk is behind: not kept
            ++stats_.dropped;
            return;
        }
        queuedBytes_ += frame.bytes.size();
        queue_.push_back(Pending{key, std::move(frame), ++queuedSerial_});
    }
    wake_.notify_one();
}

void FrameDiskCache::flush() {
    std::unique_lock lock(mutex_);
    const uint64_t target = queuedSerial_;
    written_.wait(lock, [&] { return doneSerial_ >= target || !thread_.joinable(); });
}

FrameDiskCache::Stats FrameDiskCache::stats() const {
    std::lock_guard lock(mutex_);
    Stats s = stats_;
    s.files = index_.size();
    s.bytes = total_;
    return s;
}

bool FrameDiskCache::write(const Pending& p, uint64_t* bytes) {
    const uint64_t hash = frameCacheHash(p.key);
    const std::string name = hex16(hash);
    const std::string sub = dir_ + "/" + name.substr(0, 2);
    const std::string path = sub + "/" + name;
    const std::string& ts = p.frame.transferSyntax;
    const std::vector<uint8_t>& b = p.frame.bytes;
    std::vector<uint8_t> head(kHeaderBytes + p.key.size() + ts.size());
    std::memcpy(head.data(), kMagic, 8);
    putLe(&head[8], p.key.size(), 4);
    putLe(&head[12], ts.size(), 4);
    putLe(&head[16], b.size(), 8);
    std::memcpy(&head[kHeaderBytes], p.key.data(), p.key.size());
    std::memcpy(&head[kHeaderBytes + p.key.size()], ts.data(), ts.size());
    uint32_t crc = crcOf(head.data() + 8, head.size() - 8);
    crc = crcOf(b.data(), b.size(), crc);
    uint8_t tail[4];
    putLe(tail, crc, 4);

    static std::atomic<uint64_t> counter{0};
    const std::string tmp =
        sub + "/.tmp-" + name + "-" + std::to_string(::getpid()) + "-" + std::to_string(counter.fetch_add(1));
    int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0600);
    if (fd < 0 && errno == ENOENT) { // the sub-folder (or the folder: removed under us) is made again
        std::error_code ec;
        if (fs::create_directories(dir_, ec))
            fs::permissions(dir_, fs::perms::owner_all, fs::perm_options::replace, ec);
        fs::create_directories(sub, ec);
        fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0600);
    }
    if (fd < 0) return false;
    const bool ok = writeAll(fd, head.data(), head.size()) && writeAll(fd, b.data(), b.size()) && writeAll(fd, tail, 4);
    if (::close(fd) != 0 || !ok || ::rename(tmp.c_str(), path.c_str()) != 0) {
        ::unlink(tmp.c_str());
        return false;
    }
    *bytes = head.size() + b.size() + 4;
    return true;
}

void FrameDiskCache::writer() {
    nameThisThread("iris-framecache");
    std::unique_lock lock(mutex_);
    for (;;) {
        wake_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
        if (queue_.empty()) break; // stopping, everything written
        Pending p = std::move(queue_.front());
        queue_.pop_front();
        lock.unlock();
        uint64_t bytes = 0;
        const bool ok = write(p, &bytes);
        lock.lock();
        queuedBytes_ -= p.frame.bytes.size();
        if (ok) {
            ++stats_.written;
            Entry& e = index_[frameCacheHash(p.key)];
            total_ = total_ - std::min(total_, e.bytes) + bytes;
            e.bytes = bytes;
            e.lastUse = nowNs();
            evictLocked();
        } else {
            ++stats_.writeErrors;
        }
        doneSerial_ = p.serial;
        written_.notify_all();
    }
    doneSerial_ = queuedSerial_;
    written_.notify_all();
}

void FrameDiskCache::unindexGoneFolders() {
    bool gone[256];
    bool seen[256] = {};
    for (auto it = index_.begin(); it != index_.end();) {
        const unsigned sub = unsigned(it->first >> 56); // the name's first two hex digits
        if (!seen[sub]) {
            seen[sub] = true;
            gone[sub] = ::access((dir_ + "/" + hex16(it->first).substr(0, 2)).c_str(), F_OK) != 0;
        }
        if (gone[sub]) {
            total_ -= std::min(total_, it->second.bytes);
            it = index_.erase(it);
        } else {
            ++it;
        }
    }
}

void FrameDiskCache::evictLocked() {
    if (total_ <= maxBytes_) return;
    // Down to 7/8 of the bound, oldest first: one sort pays for many writes.
    std::vector<std::pair<int64_t, uint64_t>> order;
    order.reserve(index_.size());
    for (const auto& [hash, e] : index_) order.emplace_back(e.lastUse, hash);
    std::sort(order.begin(), order.end());
    const uint64_t target = maxBytes_ - maxBytes_ / 8;
    for (const auto& [use, hash] : order) {
        if (total_ <= target) break;
        const auto it = index_.find(hash);
        total_ -= std::min(total_, it->second.bytes);
        index_.erase(it);
        ::unlink(pathOf(hash).c_str());
        ++stats_.evicted;
    }
}

} // namespace iris::net
