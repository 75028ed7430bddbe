#include "slide/pyramid_source.h"

#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

#include "view/view_model.h"

namespace iris {

std::unique_ptr<SlideSource> PyramidSource::complete(std::unique_ptr<SlideSource> inner) {
    const SlideInfo& stored = inner->info();
    if (stored.levels.empty()) return inner;
    const LevelInfo coarsest = stored.levels.back();
    if (coarsest.tilesX * coarsest.tilesY <= kMaxResidentBaseTiles) return inner;

    SlideInfo info = stored;
    const int storedCount = int(info.levels.size());
    // TileKey keeps 6 bits of level; a 2^21-tile-wide level fits long before that runs out.
    constexpr int kMaxLevels = 1 << TileKey::kLevelBits;
    for (int k = 1; int(info.levels.size()) < kMaxLevels; ++k) {
        const int64_t f = int64_t(1) << k;
        LevelInfo l;
        l.width = (coarsest.width + f - 1) / f;
        l.height = (coarsest.height + f - 1) / f;
        l.downsample = coarsest.downsample * double(f);
        l.synthetic = true;
        fillTileGrid(l);
        info.levels.push_back(l);
        if (l.tilesX * l.tilesY <= kMaxResidentBaseTiles) break;
    }
    fillLevelPhysics(info);
    return std::unique_ptr<SlideSource>(new PyramidSource(std::move(inner), std::move(info), storedCount));
}

Result PyramidSource::readTile(int level, int64_t tx, int64_t ty, uint8_t* dst) {
    if (level < stored_) return inner_->readTile(level, tx, ty, dst);
    if (size_t(level) >= info_.levels.size()) return Result(Status::InvalidArgument, "no such level");
    const LevelInfo& out = info_.levels[size_t(level)];
    if (tx < 0 || ty < 0 || tx >= out.tilesX || ty >= out.tilesY) return Result(Status::InvalidArgument, "no such tile");
    const int srcLevel = stored_ - 1;
    const LevelInfo& src = info_.levels[size_t(srcLevel)];
    const int k = level - srcLevel; // each pixel here is a 2^k × 2^k block of the stored level
    const int64_t f = int64_t(1) << k;

    const int validW = int(std::min<int64_t>(kTileSize, out.width - tx * kTileSize));
    const int validH = int(std::min<int64_t>(kTileSize, out.height - ty * kTileSize));
    // The stored pixels under this tile, and the stored tiles that hold them.
    const int64_t sx0 = tx * kTileSize * f, sy0 = ty * kTileSize * f;
    const int64_t sx1 = std::min(src.width, (tx * kTileSize + validW) * f);
    const int64_t sy1 = std::min(src.height, (ty * kTileSize + validH) * f);

    // 64-bit sums: a block of 2^k × 2^k pixels of 255 overflows 32 bits from k = 12.
    thread_local std::vector<uint64_t> sums;
    thread_local std::unique_ptr<uint8_t[]> stored;
    sums.assign(size_t(kTileSize) * kTileSize * 4, 0);
    if (!stored) stored = std::make_unique<uint8_t[]>(kTileBytes);

    Result firstError;
    int64_t broken = 0;
    for (int64_t sty = sy0 / kTileSize; sty <= (sy1 - 1) / kTileSize; ++sty) {
        for (int64_t stx = sx0 / kTileSize; stx <= (sx1 - 1) / kTileSize; ++stx) {
            if (abandoned_.load(std::memory_order_relaxed)) {
                return Result(Status::Cancelled, "the slide was closed while its level " + std::to_string(level) +
                                                     " tile was being computed");
            }
            if (Result r = inner_->readTile(srcLevel, stx, sty, stored.get()); !r.ok()) {
                if (r.status() == Status::Cancelled) return r;
                // A broken stored tile costs this tile only its own area, drawn as the placeholder.
                if (broken++ == 0) firstError = std::move(r);
                fillFailedTilePlaceholder(stored.get());
            }
            const int tw = int(std::min<int64_t>(kTileSize, src.width - stx * kTileSize));
            const int th = int(std::min<int64_t>(kTileSize, src.height - sty * kTileSize));
            for (int y = 0; y < th; ++y) {
                const int64_t oy = ((sty * kTileSize + y) >> k) - ty * kTileSize;
                const uint8_t* row = stored.get() + size_t(y) * kTileSize * 4;
                uint64_t* sumRow = sums.data() + size_t(oy) * kTileSize * 4;
                for (int x = 0; x < tw; ++x) {
                    const int64_t ox = ((stx * kTileSize + x) >> k) - tx * kTileSize;
                    uint64_t* s = sumRow + size_t(ox) * 4;
                    const uint8_t* p = row + size_t(x) * 4;
                    s[0] += p[0];
                    s[1] += p[1];
                    s[2] += p[2];
                    s[3] += p[3];
                }
            }
        }
    }
    // Each output pixel averages the stored pixels of its block that lie inside the level
    // (fewer along the level's right and bottom edges).
    const auto blockSide = [f](int64_t first, int64_t limit) { return uint64_t(std::min(f, limit - first)); };
    for (int y = 0; y < validH; ++y) {
        const uint64_t bh = blockSide((ty * kTileSize + y) * f, src.height);
        for (int x = 0; x < validW; ++x) {
            const uint64_t n = bh * blockSide((tx * kTileSize + x) * f, src.width);
            const uint64_t* s = sums.data() + (size_t(y) * kTileSize + size_t(x)) * 4;
            uint8_t* d = dst + (size_t(y) * kTileSize + size_t(x)) * 4;
            for (int c = 0; c < 4; ++c) d[c] = uint8_t((s[c] + n / 2) / n);
        }
    }
    padTileEdges(dst, validW, validH);
    if (broken == 0) return {};
    const int64_t storedTiles = ((sx1 - 1) / kTileSize - sx0 / kTileSize + 1) * ((sy1 - 1) / kTileSize - sy0 / kTileSize + 1);
    return Result(firstError.status(), firstError.message() + " (computed level " + std::to_string(level) + " tile " +
                                           std::to_string(tx) + "," + std::to_string(ty) + " shows " +
                                           std::to_string(broken) + " of its " + std::to_string(storedTiles) +
                                           " stored tiles as unreadable)");
}

void PyramidSource::prefetch(const std::vector<TileAddress>& tiles, std::function<void()> arrived) {
    std::vector<TileAddress> stored;
    stored.reserve(tiles.size());
    for (const TileAddress& t : tiles)
        if (t.level < stored_) stored.push_back(t);
    inner_->prefetch(stored, std::move(arrived));
}

} // namespace iris
