// The helpers every SlideSource shares (declared in slide_source.h), apart from the format
// table in slide_source.cpp so that one reader can be built on its own (tests/fuzz).
#include <cstring>

#include <fcntl.h>
#include <unistd.h>

#include "slide/slide_source.h"

namespace iris {

void fillTileGrid(LevelInfo& level) {
    level.tilesX = (level.width + kTileSize - 1) / kTileSize;
    level.tilesY = (level.height + kTileSize - 1) / kTileSize;
}

void fillLevelPhysics(SlideInfo& info) {
    for (LevelInfo& l : info.levels) {
        l.mppX = info.mppX > 0 ? info.mppX * l.downsample : 0;
        l.mppY = info.mppY > 0 ? info.mppY * l.downsample : 0;
        l.magnification = info.objectivePower > 0 ? info.objectivePower / l.downsample : 0;
    }
}

void fillFailedTilePlaceholder(uint8_t* rgba) {
    for (int y = 0; y < kTileSize; ++y) {
        for (int x = 0; x < kTileSize; ++x) {
            uint8_t* p = rgba + (size_t(y) * kTileSize + size_t(x)) * 4;
            const bool stripe = ((x + y) / 8) % 4 == 0;
            p[0] = stripe ? 200 : 128;
            p[1] = stripe ? 40 : 128;
            p[2] = stripe ? 40 : 128;
            p[3] = 255;
        }
    }
}

void padTileEdges(uint8_t* rgba, int validWidth, int validHeight) {
    if (validWidth <= 0 || validHeight <= 0) {
        std::memset(rgba, 0, kTileBytes);
        return;
    }
    const size_t stride = size_t(kTileSize) * 4;
    if (validWidth < kTileSize) {
        for (int y = 0; y < validHeight; ++y) {
            uint8_t* row = rgba + y * stride;
            uint32_t last;
            std::memcpy(&last, row + (validWidth - 1) * 4, 4);
            for (int x = validWidth; x < kTileSize; ++x) std::memcpy(row + x * 4, &last, 4);
        }
    }
    for (int y = validHeight; y < kTileSize; ++y)
        std::memcpy(rgba + y * stride, rgba + (validHeight - 1) * stride, stride);
}

PinnedFile::PinnedFile(const std::string& path) : name_(path) {
    fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd_ < 0) return; // the library's own open will say why
    unsigned char head[4] = {0, 0, 0, 0};
    if (::pread(fd_, head, 4, 0) == 4)
        tiff_ = (head[0] == 'I' && head[1] == 'I' && (head[2] == 42 || head[2] == 43) && head[3] == 0) ||
                (head[0] == 'M' && head[1] == 'M' && head[2] == 0 && (head[3] == 42 || head[3] == 43));
    const std::string proc = "/proc/self/fd/" + std::to_string(fd_);
    if (::access(proc.c_str(), R_OK) == 0) name_ = proc;
}

PinnedFile::~PinnedFile() {
    if (fd_ >= 0) ::close(fd_);
}

} // namespace iris
