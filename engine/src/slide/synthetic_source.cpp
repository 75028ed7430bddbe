#include "slide/synthetic_source.h"

#include <algorithm>
#include <cstdio>

namespace iris {

namespace {
constexpr const char* kPrefix = "synthetic:";
constexpr int64_t kMaxSide = int64_t(1) << 28;
} // namespace

bool SyntheticSource::detect(const std::string& path) { return path.rfind(kPrefix, 0) == 0; }

Expected<std::unique_ptr<SlideSource>> SyntheticSource::open(const std::string& path) {
    long long w = 0, h = 0, maxLevels = 0;
    int used = -1, usedWithLevels = -1;
    const char* spec = path.c_str() + 10;
    const size_t specLength = path.size() - 10;
    bool ok = std::sscanf(spec, "%lldx%lld%n", &w, &h, &used) == 2 && used >= 0 && size_t(used) == specLength;
    if (!ok) {
        ok = std::sscanf(spec, "%lldx%lld:%lld%n", &w, &h, &maxLevels, &usedWithLevels) == 3 &&
             usedWithLevels >= 0 && size_t(usedWithLevels) == specLength && maxLevels >= 1;
    }
    if (!ok || w < 1 || h < 1 || w > kMaxSide || h > kMaxSide) {
        return Result(Status::InvalidArgument, "'" + path + "': a synthetic slide is 'synthetic:WIDTHxHEIGHT[:LEVELS]' with sides "
                                                   "from 1 to " + std::to_string(kMaxSide) + " and at least one level");
    }
    SlideInfo info;
    info.path = path;
    info.vendor = "synthetic";
    info.width = w;
    info.height = h;
    info.mppX = info.mppY = 0.25;
    info.objectivePower = 40;
    for (int k = 0;; ++k) {
        LevelInfo l;
        l.width = std::max<int64_t>(1, (w + (int64_t(1) << k) - 1) >> k);
        l.height = std::max<int64_t>(1, (h + (int64_t(1) << k) - 1) >> k);
        l.downsample = double(int64_t(1) << k);
        fillTileGrid(l);
        info.levels.push_back(l);
        if (std::max(l.width, l.height) <= 512 || k >= 40 || (maxLevels > 0 && k + 1 >= maxLevels)) break;
    }
    info.properties = {{"openslide.vendor", "synthetic"}, {"synthetic.size", std::to_string(w) + "x" + std::to_string(h)}};
    fillLevelPhysics(info);
    return std::unique_ptr<SlideSource>(new SyntheticSource(std::move(info)));
}

void SyntheticSource::pixel(int64_t x, int64_t y, uint8_t* p) {
    const bool checker = ((x >> 8) + (y >> 8)) & 1;
    p[0] = uint8_t((x * 255) / 4096 % 256);
    p[1] = uint8_t((y * 255) / 4096 % 256);
    p[2] = uint8_t(checker ? 200 : 60) ^ uint8_t(((x + y) & 7) << 2);
    p[3] = 255;
}

Result SyntheticSource::readTile(int level, int64_t tx, int64_t ty, uint8_t* dst) {
    if (level < 0 || size_t(level) >= info_.levels.size()) return Result(Status::InvalidArgument, "no such level");
    const LevelInfo& l = info_.levels[size_t(level)];
    if (tx < 0 || ty < 0 || tx >= l.tilesX || ty >= l.tilesY) return Result(Status::InvalidArgument, "no such tile");
    const int w = int(std::min<int64_t>(kTileSize, l.width - tx * kTileSize));
    const int h = int(std::min<int64_t>(kTileSize, l.height - ty * kTileSize));
    const int64_t step = int64_t(l.downsample);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            pixel((tx * kTileSize + x) * step, (ty * kTileSize + y) * step, dst + (size_t(y) * kTileSize + size_t(x)) * 4);
    padTileEdges(dst, w, h);
    return {};
}

Expected<Image> SyntheticSource::readAssociatedImage(const std::string& name) {
    return Result(Status::InvalidArgument, "A synthetic slide has no associated image '" + name + "'");
}

} // namespace iris
