// What the file-reading fuzz targets share: the broken-promise abort, a scratch folder for
// readers that open paths, and a tile buffer with a guard band. Header-only: each target is
// one translation unit plus the engine sources it needs (CMakeLists.txt).
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "fuzz_signals.h"
#include "iris/types.h"
#include "slide/slide_source.h"

// A malloc the system cannot satisfy returns NULL, as glibc's does, instead of ending the run,
// and any single allocation over 2 GiB counts as one the system cannot satisfy: libtiff,
// OpenSlide (up to 12 GiB while opening a hostile TIFF, for a tag count it believes), OpenJPEG
// and LittleCMS ask for absurd sizes that a hostile file states and handle the NULL. Granting
// them would only make ASan poison gigabytes of shadow memory. operator new still reports such
// a size (ASan's new never returns NULL), so the engine's own allocations of sizes a file
// states stay checked, as does the -rss_limit_mb. One definition per target: each includes this
// header from its one source file.
extern "C" const char* __asan_default_options() { return "allocator_may_return_null=1:max_allocation_size_mb=2048"; }

namespace fuzz {

inline bool verbose() {
    static const bool v = std::getenv("IRIS_FUZZ_VERBOSE") != nullptr;
    return v;
}

[[noreturn]] inline void broken(const char* file, int line, const char* what) {
    std::fprintf(stderr, "%s:%d: broken promise: %s\n", file, line, what);
    std::abort();
}

// A promise the code under test makes; a broken one aborts, so libFuzzer keeps the input.
#define PROMISE(cond)                                                                                                  \
    do {                                                                                                               \
        if (!(cond)) ::fuzz::broken(__FILE__, __LINE__, #cond);                                                        \
    } while (0)

// Known bugs: a promise broken by code outside tests/fuzz's reach that is not fixed yet
// (README.md, "Known bugs", names each with its reproducer in known/<target>/). Fuzzing goes on
// past them: the input is dropped with a note (once per bug and process) instead of aborting,
// so that one open bug does not stop every run at the same place. With IRIS_FUZZ_STRICT set
// (the fuzz.<target>.known tests) the promise is checked and a broken one aborts as any other.
inline bool strict() {
    static const bool s = std::getenv("IRIS_FUZZ_STRICT") != nullptr;
    return s;
}
struct KnownBug {};
// Notes that an input shows known bug `name` (once per bug and process).
inline void noteKnownBug(const char* name) {
    static std::vector<std::string> seen;
    if (std::find(seen.begin(), seen.end(), name) == seen.end()) {
        seen.emplace_back(name);
        std::fprintf(stderr, "known bug '%s' (tests/fuzz/README.md): not checked; IRIS_FUZZ_STRICT=1 checks it\n",
                     name);
    }
}
// Notes it and drops the input (the target's LLVMFuzzerTestOneInput catches KnownBug), where
// going on would run into the bug.
[[noreturn]] inline void knownBug(const char* name) {
    noteKnownBug(name);
    throw KnownBug{};
}

// Prints why a promise about a Result is about to break (or, verbose, every error).
inline void note(const char* what, const iris::Result& r) {
    if (!r.ok()) std::fprintf(stderr, "  %s: %s: %s\n", what, iris::statusName(r.status()), r.message().c_str());
}

// A private folder for readers that take a path: in /dev/shm where there is one (writing a
// file per input there costs no disk), else $TMPDIR or /tmp. Removed at exit. A run that
// crashes (every reproducer of a known bug does) cannot remove it, so each new one first
// removes the folders of processes that are gone: their names carry the process id.
class ScratchDir {
public:
    ScratchDir() {
        std::string base = "/dev/shm";
        if (access(base.c_str(), W_OK) != 0) base = std::getenv("TMPDIR") ? std::getenv("TMPDIR") : "/tmp";
        removeStale(base);
        std::string templ = base + "/iris-fuzz-" + std::to_string(getpid()) + "-XXXXXX";
        if (!mkdtemp(templ.data())) {
            std::perror("mkdtemp");
            std::abort();
        }
        path_ = templ;
    }
    ~ScratchDir() {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }
    ScratchDir(const ScratchDir&) = delete;
    ScratchDir& operator=(const ScratchDir&) = delete;
    const std::string& path() const { return path_; }

    // Removes every file in the folder.
    void clear() const {
        std::error_code ec;
        for (const auto& e : std::filesystem::directory_iterator(path_, ec)) std::filesystem::remove_all(e.path(), ec);
    }

    // Writes `size` bytes to `name` inside the folder (replacing what was there) and returns
    // its path.
    std::string write(const std::string& name, const uint8_t* data, size_t size) const {
        const std::string p = path_ + "/" + name;
        const int fd = ::open(p.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
        if (fd < 0) {
            std::perror(p.c_str());
            std::abort();
        }
        size_t done = 0;
        while (done < size) {
            const ssize_t n = ::write(fd, data + done, size - done);
            if (n <= 0) {
                std::perror(p.c_str());
                std::abort();
            }
            done += size_t(n);
        }
        ::close(fd);
        return p;
    }

private:
    static void removeStale(const std::string& base) {
        std::error_code ec;
        for (const auto& e : std::filesystem::directory_iterator(base, ec)) {
            const std::string name = e.path().filename().string();
            if (name.rfind("iris-fuzz-", 0) != 0) continue;
            const long pid = std::strtol(name.c_str() + 10, nullptr, 10);
            if (pid > 0 && kill(pid_t(pid), 0) != 0 && errno == ESRCH) std::filesystem::remove_all(e.path(), ec);
        }
    }
    std::string path_;
};

// One engine tile and a guard band behind it, pre-filled with a pattern: the decoders are the
// system's uninstrumented libraries, so ASan would not see them write past the tile, and a
// reader that leaves part of a tile unwritten shows the pattern.
class TileBuffer {
public:
    static constexpr size_t kGuard = 4096;
    static constexpr uint8_t kFill = 0xA5;
    TileBuffer() : bytes_(iris::kTileBytes + kGuard, kFill) {}
    uint8_t* data() { return bytes_.data(); }
    void reset() { std::fill(bytes_.begin(), bytes_.end(), kFill); }
    bool guardIntact() const {
        return std::all_of(bytes_.begin() + iris::kTileBytes, bytes_.end(), [](uint8_t b) { return b == kFill; });
    }
    // Every pixel opaque: what a reader of opaque formats promises for a tile it returns.
    bool opaque() const {
        for (size_t i = 3; i < size_t(iris::kTileBytes); i += 4)
            if (bytes_[i] != 255) return false;
        return true;
    }
    // SlideSource::readTile's edge rule: past the level's edge, the last valid column and row
    // are repeated.
    bool paddedFrom(int validW, int validH) const {
        const auto px = [&](int x, int y) { return bytes_.data() + (size_t(y) * iris::kTileSize + size_t(x)) * 4; };
        const auto same = [](const uint8_t* a, const uint8_t* b) { return std::equal(a, a + 4, b); };
        for (int y = 0; y < iris::kTileSize; ++y) {
            for (int x = 0; x < iris::kTileSize; ++x) {
                if (x < validW && y < validH) continue;
                if (!same(px(x, y), px(std::min(x, validW - 1), std::min(y, validH - 1)))) return false;
            }
        }
        return true;
    }

private:
    std::vector<uint8_t> bytes_;
};

// The part of tile (tx, ty) inside `level`.
inline int validWidth(const iris::LevelInfo& l, int64_t tx) {
    return int(std::min<int64_t>(iris::kTileSize, l.width - tx * iris::kTileSize));
}
inline int validHeight(const iris::LevelInfo& l, int64_t ty) {
    return int(std::min<int64_t>(iris::kTileSize, l.height - ty * iris::kTileSize));
}

// Each level's downsample is larger than the one before (the engine picks levels by it).
inline bool levelsGetCoarser(const iris::SlideInfo& info) {
    for (size_t l = 1; l < info.levels.size(); ++l)
        if (!(info.levels[l].downsample > info.levels[l - 1].downsample)) return false;
    return true;
}

// What every reader's open promises about the SlideInfo it returns. `coarser`: the levels'
// downsamples grow (false only while a known bug says otherwise).
inline void checkSlideInfo(const iris::SlideInfo& info, bool coarser = true) {
    PROMISE(!info.levels.empty());
    PROMISE(info.width == info.levels.front().width && info.height == info.levels.front().height);
    for (size_t l = 0; l < info.levels.size(); ++l) {
        const iris::LevelInfo& li = info.levels[l];
        PROMISE(li.width > 0 && li.height > 0);
        PROMISE(li.tilesX == (li.width + iris::kTileSize - 1) / iris::kTileSize);
        PROMISE(li.tilesY == (li.height + iris::kTileSize - 1) / iris::kTileSize);
        PROMISE(std::isfinite(li.downsample) && li.downsample >= 1.0 - 1e-9);
        PROMISE(!li.synthetic);
    }
    if (coarser) PROMISE(levelsGetCoarser(info));
    for (size_t i = 1; i < info.properties.size(); ++i) {
        PROMISE(info.properties[i - 1].first < info.properties[i].first); // sorted, unique
    }
}

// Tiles a bounded walk reads from `info`: of each level, coarsest first, the first tile, the
// last (bottom-right, the partial edge tile) and the one in the middle, until `budget` is spent.
struct TileRef {
    int level;
    int64_t tx, ty;
};
inline std::vector<TileRef> tilesToRead(const iris::SlideInfo& info, size_t budget) {
    std::vector<TileRef> out;
    for (int level = int(info.levels.size()) - 1; level >= 0 && out.size() < budget; --level) {
        const iris::LevelInfo& li = info.levels[size_t(level)];
        const TileRef picks[] = {
            {level, 0, 0}, {level, li.tilesX - 1, li.tilesY - 1}, {level, li.tilesX / 2, li.tilesY / 2}};
        for (const TileRef& t : picks) {
            if (out.size() >= budget) break;
            const bool dup = std::any_of(out.begin(), out.end(), [&](const TileRef& o) {
                return o.level == t.level && o.tx == t.tx && o.ty == t.ty;
            });
            if (!dup) out.push_back(t);
        }
    }
    return out;
}

// Requests outside the grid are refused (InvalidArgument) before anything is read.
inline void checkOutOfGrid(iris::SlideSource& src, uint8_t* tile) {
    const iris::SlideInfo& info = src.info();
    const int levels = int(info.levels.size());
    const iris::LevelInfo& finest = info.levels.front();
    using iris::Status;
    PROMISE(src.readTile(-1, 0, 0, tile).status() == Status::InvalidArgument);
    PROMISE(src.readTile(levels, 0, 0, tile).status() == Status::InvalidArgument);
    PROMISE(src.readTile(0, finest.tilesX, 0, tile).status() == Status::InvalidArgument);
    PROMISE(src.readTile(0, 0, finest.tilesY, tile).status() == Status::InvalidArgument);
    PROMISE(src.readTile(0, -1, 0, tile).status() == Status::InvalidArgument);
    PROMISE(src.readTile(0, 0, -1, tile).status() == Status::InvalidArgument);
}

inline bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// Reads up to `maxReads` tiles (tilesToRead) and checks each: nothing written past the tile; a
// tile that reads is opaque, edge-padded from its valid area and the same when read again (a
// reader's caches); a failure satisfies `acceptable` (its kind, and that it names the file).
// Then requests outside the grid.
template <class Acceptable>
void readTileSample(iris::SlideSource& src, size_t maxReads, Acceptable&& acceptable) {
    const iris::SlideInfo& info = src.info();
    TileBuffer buf, again;
    for (const TileRef& t : tilesToRead(info, maxReads)) {
        buf.reset();
        const iris::Result r = src.readTile(t.level, t.tx, t.ty, buf.data());
        PROMISE(buf.guardIntact());
        if (verbose()) note("tile", r);
        if (!r.ok()) {
            if (!acceptable(r)) note("tile", r);
            PROMISE(acceptable(r));
            continue;
        }
        const iris::LevelInfo& li = info.levels[size_t(t.level)];
        PROMISE(buf.opaque());
        PROMISE(buf.paddedFrom(validWidth(li, t.tx), validHeight(li, t.ty)));
        again.reset();
        PROMISE(src.readTile(t.level, t.tx, t.ty, again.data()).ok());
        PROMISE(std::memcmp(buf.data(), again.data(), iris::kTileBytes) == 0);
    }
    checkOutOfGrid(src, buf.data());
    PROMISE(buf.guardIntact());
}

} // namespace fuzz
