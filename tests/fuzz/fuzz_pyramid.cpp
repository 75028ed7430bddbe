// libFuzzer target for the synthetic-level builder (engine/src/slide/pyramid_source.cpp), see
// README.md.
//
// The input describes a broken slide: a FakeSource whose stored levels have the sizes it
// says (1 to 2^36 pixels a side, beyond what any reader opens), whose stored tiles fail with
// the statuses it says (CorruptData, IoError, Cancelled) at the places it says, and which may
// let go of the slide (abandon) in the middle of a read. PyramidSource::complete wraps it, and
// a bounded number of tiles of the computed levels are read (as many as 16 stored tiles'
// worth per input), edge tiles and input-chosen ones.
//
// Besides the sanitizers it checks the decorator's promises:
//   * complete() returns the source itself when its coarsest level is small enough, otherwise
//     the stored levels unchanged and then levels at 2×, 4×, … the coarsest downsample, each
//     the ceiling of the coarsest level's size over 2^k, marked synthetic, until one fits
//     kMaxResidentBaseTiles (or the 64 levels a TileKey can name are used up);
//   * a stored level's reads go to the source unchanged; a computed tile reads only stored
//     tiles of the coarsest stored level that lie inside its grid, each at most once;
//   * a computed tile is the exact rounded area average of the stored pixels under it, with a
//     failed stored tile counted as the failed-tile placeholder (computed here independently,
//     pixel by pixel), and the edge rule of readTile past the level's edge;
//   * a failure is reported: the first stored tile's error with its status and message and
//     the count of unreadable tiles; Cancelled from the source, or an abandon() during the
//     read, stops it with Cancelled; requests outside the grid are InvalidArgument.
#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "fuzz_support.h"
#include "slide/pyramid_source.h"
#include "view/view_model.h"

namespace {

using namespace iris;

// 2^36: a level of 2^28 × 2^28 tiles still counts them in an int64_t (no reader opens a level
// anywhere near it: OpenSlide's are at most 2^29 a side, DICOM's 2^24).
constexpr int64_t kMaxSide = int64_t(1) << 36;
constexpr int64_t kStoredTileBudget = 16; // stored tiles read per input (each a 256² tile, twice)

// A stored pixel: a function of its position, so that the expected average needs no tile.
inline void storedPixel(uint32_t seed, int64_t x, int64_t y, uint8_t out[4]) {
    const uint64_t h = (uint64_t(x) * 0x9E3779B97F4A7C15ull) ^ (uint64_t(y) * 0xC2B2AE3D27D4EB4Full) ^ seed;
    out[0] = uint8_t(h >> 13);
    out[1] = uint8_t(h >> 29);
    out[2] = uint8_t(h >> 41);
    out[3] = uint8_t(h >> 53);
}

// The failed-tile placeholder's pixel (x, y) of a tile, read back from the engine's own fill so
// that the check does not copy its pattern.
const std::vector<uint8_t>& placeholder() {
    static const std::vector<uint8_t> p = [] {
        std::vector<uint8_t> v(kTileBytes);
        fillFailedTilePlaceholder(v.data());
        return v;
    }();
    return p;
}

struct Failure {
    Status status = Status::Ok;
    uint32_t modulus = 0; // tiles where (tx * 31 + ty * 17 + salt) % modulus == 0 fail
    uint32_t salt = 0;
};

class FakeSource final : public SlideSource {
public:
    FakeSource(SlideInfo info, uint32_t seed, std::vector<Failure> failures, int64_t abandonAfter, bool partial)
        : info_(std::move(info)), seed_(seed), failures_(std::move(failures)), abandonAfter_(abandonAfter),
          partial_(partial) {}

    const SlideInfo& info() const override { return info_; }
    bool keepsPartialTiles(int) const override { return partial_; }
    Expected<Image> readAssociatedImage(const std::string& name) override {
        return Result(Status::InvalidArgument, "no associated image '" + name + "'");
    }
    void abandon() override { abandoned = true; }

    // The status stored tile (tx, ty) of the coarsest level fails with (Ok: it reads).
    Status failureAt(int64_t tx, int64_t ty) const {
        for (const Failure& f : failures_)
            if (f.modulus && uint64_t(tx * 31 + ty * 17 + f.salt) % f.modulus == 0) return f.status;
        return Status::Ok;
    }

    Result readTile(int level, int64_t tx, int64_t ty, uint8_t* dst) override {
        // A computed tile asks only for tiles of the source's own grid; a request for a stored
        // level is passed on as it came, and refused here as a reader refuses it.
        const bool inGrid = level >= 0 && size_t(level) < info_.levels.size() && tx >= 0 && ty >= 0 &&
                            tx < info_.levels[size_t(level)].tilesX && ty < info_.levels[size_t(level)].tilesY;
        if (computing) PROMISE(inGrid && level == int(info_.levels.size()) - 1);
        if (!inGrid) return Result(Status::InvalidArgument, "no such tile");
        const LevelInfo& li = info_.levels[size_t(level)];
        ++reads;
        if (computing) PROMISE(readSet.insert({tx, ty}).second);            // each stored tile once a computed tile
        if (computing && outer && reads == abandonAfter_) outer->abandon(); // the engine lets go meanwhile
        if (const Status s = level == int(info_.levels.size()) - 1 ? failureAt(tx, ty) : Status::Ok; s != Status::Ok) {
            std::memset(dst, 0x3C, kTileBytes); // garbage left behind, as a failed decoder may
            return Result(s, "stored tile " + std::to_string(tx) + "," + std::to_string(ty) + " is broken");
        }
        const int w = fuzz::validWidth(li, tx), h = fuzz::validHeight(li, ty);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                storedPixel(seed_ + uint32_t(level), tx * kTileSize + x, ty * kTileSize + y,
                            dst + (size_t(y) * kTileSize + size_t(x)) * 4);
        padTileEdges(dst, w, h);
        return {};
    }

    SlideSource* outer = nullptr; // abandoned after abandonAfter reads of a computed tile
    bool computing = false;       // reads are for a computed tile
    int64_t reads = 0;
    bool abandoned = false;
    std::set<std::pair<int64_t, int64_t>> readSet;

private:
    SlideInfo info_;
    uint32_t seed_;
    std::vector<Failure> failures_;
    int64_t abandonAfter_;
    bool partial_;
};

// The stored tiles under computed tile (tx, ty) of `out`, k levels above the coarsest stored
// level `src`: columns [x0, x1], rows [y0, y1].
struct StoredSpan {
    int64_t x0, x1, y0, y1;
    int64_t count() const { return (x1 - x0 + 1) * (y1 - y0 + 1); }
};
StoredSpan storedTilesUnder(const LevelInfo& out, const LevelInfo& src, int k, int64_t tx, int64_t ty) {
    const int64_t f = int64_t(1) << k;
    const int64_t sx1 = std::min(src.width, (tx * kTileSize + fuzz::validWidth(out, tx)) * f);
    const int64_t sy1 = std::min(src.height, (ty * kTileSize + fuzz::validHeight(out, ty)) * f);
    return {tx * f, (sx1 - 1) / kTileSize, ty * f, (sy1 - 1) / kTileSize};
}

// The expected computed tile, pixel by pixel from the stored pixels (or the placeholder where a
// stored tile fails).
void expectedTile(const FakeSource& fake, uint32_t seed, const LevelInfo& src, int k, const LevelInfo& out, int64_t tx,
                  int64_t ty, const StoredSpan& span, std::vector<uint8_t>& dst) {
    const int64_t f = int64_t(1) << k;
    const int w = fuzz::validWidth(out, tx), h = fuzz::validHeight(out, ty);
    // Whether each stored tile under the tile reads (looked up once, not once a pixel).
    const int64_t spanW = span.x1 - span.x0 + 1;
    std::vector<uint8_t> fails(size_t(span.count()));
    for (int64_t y = span.y0; y <= span.y1; ++y)
        for (int64_t x = span.x0; x <= span.x1; ++x)
            fails[size_t((y - span.y0) * spanW + (x - span.x0))] = fake.failureAt(x, y) != Status::Ok;
    dst.assign(kTileBytes, 0);
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            uint64_t sum[4] = {0, 0, 0, 0}, n = 0;
            const int64_t bx = (tx * kTileSize + x) * f, by = (ty * kTileSize + y) * f;
            for (int64_t sy = by; sy < std::min(by + f, src.height); ++sy) {
                for (int64_t sx = bx; sx < std::min(bx + f, src.width); ++sx) {
                    uint8_t p[4];
                    const int64_t stx = sx / kTileSize, sty = sy / kTileSize;
                    PROMISE(stx >= span.x0 && stx <= span.x1 && sty >= span.y0 && sty <= span.y1);
                    if (fails[size_t((sty - span.y0) * spanW + (stx - span.x0))]) {
                        std::memcpy(
                            p, placeholder().data() + (size_t(sy % kTileSize) * kTileSize + size_t(sx % kTileSize)) * 4,
                            4);
                    } else {
                        storedPixel(seed, sx, sy, p);
                    }
                    for (int c = 0; c < 4; ++c) sum[c] += p[c];
                    ++n;
                }
            }
            PROMISE(n > 0);
            for (int c = 0; c < 4; ++c)
                dst[(size_t(y) * kTileSize + size_t(x)) * 4 + size_t(c)] = uint8_t((sum[c] + n / 2) / n);
        }
    }
    padTileEdges(dst.data(), w, h);
}

// complete()'s promises about the levels.
void checkLevels(const SlideInfo& stored, const SlideInfo& info) {
    const LevelInfo& coarsest = stored.levels.back();
    PROMISE(info.levels.size() > stored.levels.size());
    PROMISE(info.levels.size() <= size_t(1) << TileKey::kLevelBits);
    for (size_t l = 0; l < stored.levels.size(); ++l) {
        PROMISE(info.levels[l].width == stored.levels[l].width && info.levels[l].height == stored.levels[l].height);
        PROMISE(info.levels[l].downsample == stored.levels[l].downsample && !info.levels[l].synthetic);
    }
    for (size_t l = stored.levels.size(); l < info.levels.size(); ++l) {
        const LevelInfo& li = info.levels[l];
        const int k = int(l - stored.levels.size() + 1);
        const int64_t f = int64_t(1) << k;
        PROMISE(li.synthetic);
        PROMISE(li.width == (coarsest.width + f - 1) / f && li.height == (coarsest.height + f - 1) / f);
        PROMISE(li.downsample == coarsest.downsample * double(f));
        PROMISE(li.tilesX == (li.width + kTileSize - 1) / kTileSize &&
                li.tilesY == (li.height + kTileSize - 1) / kTileSize);
        const bool last = l + 1 == info.levels.size();
        const bool fits = li.tilesX * li.tilesY <= kMaxResidentBaseTiles;
        PROMISE(fits == last || (last && info.levels.size() == size_t(1) << TileKey::kLevelBits));
        if (stored.mppX > 0) PROMISE(li.mppX == stored.mppX * li.downsample);
    }
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    FuzzedDataProvider in(data, size);
    // The coarsest stored level, then up to three finer ones (each about twice its size).
    SlideInfo stored;
    stored.vendor = "fuzz";
    stored.mppX = stored.mppY = in.ConsumeBool() ? 0.25 : 0;
    const int storedLevels = in.ConsumeIntegralInRange(1, 4);
    const int64_t cw =
        std::max<int64_t>(1, in.ConsumeIntegralInRange<int64_t>(1, kMaxSide) >> in.ConsumeIntegralInRange(0, 36));
    const int64_t ch =
        std::max<int64_t>(1, in.ConsumeIntegralInRange<int64_t>(1, kMaxSide) >> in.ConsumeIntegralInRange(0, 36));
    const double coarsestDownsample =
        double(int64_t(1) << (storedLevels - 1)) * in.ConsumeFloatingPointInRange(1.0, 1.01);
    for (int l = 0; l < storedLevels; ++l) {
        LevelInfo li;
        const int shift = storedLevels - 1 - l;
        li.width = std::min(kMaxSide, cw << shift);
        li.height = std::min(kMaxSide, ch << shift);
        li.downsample = l + 1 == storedLevels ? coarsestDownsample : double(int64_t(1) << l);
        fillTileGrid(li);
        stored.levels.push_back(li);
    }
    stored.width = stored.levels[0].width;
    stored.height = stored.levels[0].height;
    fillLevelPhysics(stored);

    std::vector<Failure> failures;
    const int nFailures = in.ConsumeIntegralInRange(0, 3);
    for (int i = 0; i < nFailures; ++i) {
        static constexpr Status kStatuses[] = {Status::CorruptData, Status::IoError, Status::Cancelled,
                                               Status::CorruptData};
        Failure f;
        f.status = kStatuses[in.ConsumeIntegralInRange(0, 3)];
        f.modulus = in.ConsumeIntegralInRange<uint32_t>(1, 64);
        f.salt = in.ConsumeIntegral<uint32_t>();
        failures.push_back(f);
    }
    const uint32_t seed = in.ConsumeIntegral<uint32_t>();
    const int64_t abandonAfter = in.ConsumeBool() ? in.ConsumeIntegralInRange<int64_t>(1, 8) : -1;
    const bool partial = in.ConsumeBool();

    auto fakeOwned = std::make_unique<FakeSource>(stored, seed, failures, abandonAfter, partial);
    FakeSource& fake = *fakeOwned;
    SlideSource* const innerAddress = fakeOwned.get();
    std::unique_ptr<SlideSource> src = PyramidSource::complete(std::move(fakeOwned));
    const LevelInfo& coarsest = stored.levels.back();
    if (coarsest.tilesX * coarsest.tilesY <= kMaxResidentBaseTiles) {
        PROMISE(src.get() == innerAddress); // nothing to add: the source itself
        return 0;
    }
    PROMISE(src.get() != innerAddress);
    fake.outer = src.get();
    fake.computing = false;
    const SlideInfo& info = src->info();
    checkLevels(stored, info);

    fuzz::TileBuffer tile;
    std::vector<uint8_t> expected;
    const int srcLevel = storedLevels - 1;
    // A stored level's tile is the source's, unchanged (its error too).
    {
        const int level = in.ConsumeIntegralInRange(0, srcLevel);
        PROMISE(src->keepsPartialTiles(level) == partial);
        const int64_t tx = in.ConsumeIntegralInRange<int64_t>(0, info.levels[size_t(level)].tilesX - 1);
        const Status want = level == srcLevel ? fake.failureAt(tx, 0) : Status::Ok;
        fake.reads = 0;
        const Result r = src->readTile(level, tx, 0, tile.data());
        PROMISE(r.status() == want && fake.reads == 1);
        if (r.ok()) {
            expected.resize(kTileBytes);
            PROMISE(fake.readTile(level, tx, 0, expected.data()).ok());
            PROMISE(std::memcmp(tile.data(), expected.data(), kTileBytes) == 0);
        }
    }

    // Computed tiles: of each level, coarsest first, the bottom-right edge tile, the top-left
    // one and one the input picks, while the budget of stored tiles lasts.
    int64_t budget = kStoredTileBudget;
    for (int level = int(info.levels.size()) - 1; level > srcLevel && budget > 0 && !fake.abandoned; --level) {
        const LevelInfo& out = info.levels[size_t(level)];
        const int k = level - srcLevel;
        PROMISE(src->keepsPartialTiles(level));
        const std::pair<int64_t, int64_t> picks[] = {{out.tilesX - 1, out.tilesY - 1},
                                                     {0, 0},
                                                     {in.ConsumeIntegralInRange<int64_t>(0, out.tilesX - 1),
                                                      in.ConsumeIntegralInRange<int64_t>(0, out.tilesY - 1)}};
        for (const auto& [tx, ty] : picks) {
            const StoredSpan span = storedTilesUnder(out, coarsest, k, tx, ty);
            const int64_t cost = span.count();
            if (cost > budget || fake.abandoned) continue;
            budget -= cost;
            fake.reads = 0;
            fake.readSet.clear();
            tile.reset();
            fake.computing = true;
            const Result r = src->readTile(level, tx, ty, tile.data());
            fake.computing = false;
            PROMISE(tile.guardIntact());
            if (fuzz::verbose()) fuzz::note("computed tile", r);
            if (fake.abandoned) {
                // Let go of during the read: it stops before its next stored tile.
                PROMISE(r.status() == Status::Cancelled || fake.reads == cost);
                fake.computing = true;
                PROMISE(src->readTile(level, tx, ty, tile.data()).status() == Status::Cancelled);
                fake.computing = false;
                break;
            }
            // Every stored tile under it is read once, in rows, unless one says Cancelled; the
            // first failure is the one reported.
            int64_t broken = 0;
            Status first = Status::Ok;
            bool cancelled = false;
            for (int64_t sty = span.y0; sty <= span.y1 && !cancelled; ++sty) {
                for (int64_t stx = span.x0; stx <= span.x1 && !cancelled; ++stx) {
                    const Status s = fake.failureAt(stx, sty);
                    cancelled = s == Status::Cancelled;
                    if (s != Status::Ok && !cancelled && broken++ == 0) first = s;
                }
            }
            if (cancelled) {
                PROMISE(r.status() == Status::Cancelled);
                PROMISE(fake.reads <= cost);
                continue;
            }
            PROMISE(fake.reads == cost);
            if (broken == 0) {
                PROMISE(r.ok());
            } else {
                PROMISE(r.status() == first);
                PROMISE(fuzz::contains(r.message(), " is broken (computed level " + std::to_string(level)));
                PROMISE(fuzz::contains(r.message(), "shows " + std::to_string(broken) + " of its " +
                                                        std::to_string(cost) + " stored tiles as unreadable"));
            }
            expectedTile(fake, seed + uint32_t(srcLevel), coarsest, k, out, tx, ty, span, expected);
            PROMISE(std::memcmp(tile.data(), expected.data(), kTileBytes) == 0);
        }
    }
    if (!fake.abandoned) {
        fuzz::checkOutOfGrid(*src, tile.data());
        const int last = int(info.levels.size()) - 1;
        PROMISE(src->readTile(last, info.levels.back().tilesX, 0, tile.data()).status() == Status::InvalidArgument);
        PROMISE(src->readTile(last, 0, -1, tile.data()).status() == Status::InvalidArgument);
    }
    return 0;
}
