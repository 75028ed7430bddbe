// An on-disk cache of the frames a DICOMweb source fetched (NetworkOptions::frameCacheDirectory),
// so that a series opened again — in this session or the next, by this viewer or another on the
// same account — draws the frames it already fetched without asking the server for them.
//
// Why by hand: no Debian library keeps a bounded, self-checking folder of blobs that several
// processes may share (libcurl caches nothing; a DBM would need its own locking across
// processes and cannot hold up against a file truncated or corrupted under it). The parts are
// small: one file a frame, written whole and renamed into place, checked whole (zlib's CRC-32)
// each time it is read.
//
//   * Layout: <directory>/<hh>/<16 hex digits>, the digits a 64-bit FNV-1a hash of the frame's key
//     (its WADO-RS URL: server, series, instance, frame), <hh> their first two. A file holds a
//     magic number, the key itself, the frame's transfer syntax, its bytes and a CRC-32 of all of
//     that. A read checks every part: a file that is short, long, corrupt, of another key (a hash
//     collision) or of another transfer syntax is a miss (and a broken file is removed), never a
//     frame drawn wrong.
//   * The folder is the user's alone (created 0700, files 0600): frames are patient data. The
//     cache holds pixels only; a series is opened (its metadata read) from the server each time,
//     so a user the server refuses cannot reach its frames through the engine.
//   * Bounded: an index in memory (the file names and sizes, read from the folder when the cache
//     is first opened in this process, and the time each was last used) evicts the least recently
//     used files once the folder holds more than `maxBytes`, down to 7/8 of it. Other processes'
//     files count once this process has read the folder; several processes sharing the folder may
//     each hold it to its bound.
//   * Writes are queued (at most kMaxQueuedBytes; beyond that a frame is not kept, which costs
//     only a later fetch) and done by the cache's own thread, so that the network thread that
//     hands them over never waits on the disk. Each is written to a temporary file and renamed:
//     a reader, here or in another process, sees a whole file or none.
//   * Failures of the disk (full, read-only, the folder removed) cost the cache, not the slide:
//     a failed write is dropped and counted, a failed read is a miss.
//
// Threading: every member from any thread. `mutex_` guards the index and the queue; file I/O is
// done without it.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <unordered_map>
#include <vector>

#include "iris/types.h"

namespace iris::net {

// The key's 64-bit FNV-1a hash (the file's name). FNV-1a continues: the hash of a + b is
// frameCacheHash(b, frameCacheHash(a)).
inline constexpr uint64_t kFrameCacheHashSeed = 0xcbf29ce484222325ull;
uint64_t frameCacheHash(std::string_view key, uint64_t seed = kFrameCacheHashSeed);

class FrameDiskCache {
public:
    static constexpr uint64_t kMaxQueuedBytes = uint64_t(64) << 20;
    static constexpr uint64_t kMaxFrameBytes = uint64_t(256) << 20;
    static constexpr size_t kMaxKeyBytes = 4096;
    static constexpr size_t kMaxTransferSyntaxBytes = 64;

    // The cache kept in `directory` (created when missing), shared by every caller of this
    // process that names the same folder; `maxBytes` (at least 1 MiB) replaces the bound the
    // folder had. Fails when the folder cannot be made, read or written.
    static Expected<std::shared_ptr<FrameDiskCache>> open(const std::string& directory, uint64_t maxBytes);
    ~FrameDiskCache();
    FrameDiskCache(const FrameDiskCache&) = delete;
    FrameDiskCache& operator=(const FrameDiskCache&) = delete;

    struct Frame {
        std::string transferSyntax;
        std::vector<uint8_t> bytes;
    };
    // Whether a file for `key` is indexed (a look at the index, no I/O: get() may still miss).
    bool contains(const std::string& key) const { return contains(frameCacheHash(key)); }
    // The same by the key's hash (frameCacheHash), for a caller that continues a prefix's hash
    // rather than building each key.
    bool contains(uint64_t keyHash) const;
    // The frame kept for `key` in `transferSyntax` (empty: in whichever it was kept), read and
    // checked; nullopt when there is none or its file does not hold exactly that frame (removed
    // when broken).
    std::optional<Frame> get(const std::string& key, const std::string& transferSyntax);
    // Keeps `frame` for `key`: queued, written by the cache's thread (replacing any older file).
    void put(const std::string& key, Frame frame);
    // Returns once every frame queued before the call is written or dropped.
    void flush();

    struct Stats {
        uint64_t files = 0, bytes = 0; // indexed
        uint64_t hits = 0, misses = 0; // get()
        uint64_t written = 0, dropped = 0, writeErrors = 0, broken = 0, evicted = 0;
    };
    Stats stats() const;
    const std::string& directory() const { return dir_; }

private:
    struct Entry {
        uint64_t bytes = 0;
        int64_t lastUse = 0; // ns since the epoch: the file's mtime, or when this process last used it
    };
    struct Pending {
        std::string key;
        Frame frame;
        uint64_t serial = 0;
    };

    FrameDiskCache(std::string dir, uint64_t maxBytes);
    void scan();
    void writer();
    bool write(const Pending& p, uint64_t* bytes);
    void unindexGoneFolders(); // with mutex_ held: entries of sub-folders no longer there
    void evictLocked(); // with mutex_ held (it unlinks the files it evicts under the lock: they are few)
    std::string pathOf(uint64_t hash) const;

    const std::string dir_;
    mutable std::mutex mutex_;
    std::condition_variable wake_;    // the writer: something queued, or stopping
    std::condition_variable written_; // flush(): the writer finished a frame
    std::unordered_map<uint64_t, Entry> index_;
    uint64_t total_ = 0;
    uint64_t maxBytes_ = 0;
    std::deque<Pending> queue_;
    uint64_t queuedBytes_ = 0;
    uint64_t queuedSerial_ = 0, doneSerial_ = 0;
    bool stopping_ = false;
    Stats stats_;
    std::thread thread_;
};

} // namespace iris::net
