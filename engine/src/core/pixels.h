// Pixel byte orders. Tiles are RGBA8 in RAM (SlideSource::readTile); the atlas and offscreen
// targets of CPU devices are BGRA8, the order of X11's swapchains, so that the exact copy can
// go straight into them (gpu/tile_atlas.h).
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace iris {

// Red and blue of `pixels` 4-byte pixels swapped from src into dst (the same buffer or disjoint
// ones): RGBA ↔ BGRA. Word-wise, which compilers vectorise.
inline void swapRedBlue(const uint8_t* src, uint8_t* dst, size_t pixels) {
    static_assert(std::endian::native == std::endian::little, "the masks below take byte 0 as the lowest");
    for (size_t i = 0; i < pixels; ++i) {
        uint32_t p;
        std::memcpy(&p, src + 4 * i, 4);
        p = (p & 0xFF00FF00u) | ((p & 0xFFu) << 16) | ((p >> 16) & 0xFFu);
        std::memcpy(dst + 4 * i, &p, 4);
    }
}

} // namespace iris
