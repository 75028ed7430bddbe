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

// `pixels` 4-byte pixels from src into dst (disjoint), with red and blue swapped when `swap`;
// returns whether every pixel's alpha (byte 3, in either order) is 255. One pass where a copy,
// a swap and a look at the alpha would take three.
inline bool copyPixels(const uint8_t* src, uint8_t* dst, size_t pixels, bool swap) {
    static_assert(std::endian::native == std::endian::little, "the masks below take byte 0 as the lowest");
    uint32_t all = ~0u;
    for (size_t i = 0; i < pixels; ++i) {
        uint32_t p;
        std::memcpy(&p, src + 4 * i, 4);
        if (swap) p = (p & 0xFF00FF00u) | ((p & 0xFFu) << 16) | ((p >> 16) & 0xFFu);
        all &= p;
        std::memcpy(dst + 4 * i, &p, 4);
    }
    return (all >> 24) == 0xFFu;
}

} // namespace iris
