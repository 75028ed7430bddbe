// One tile quad as the tile pipeline draws it: the per-instance vertex data, without Vulkan
// (the draw-list builder produces them and is tested without a device).
#pragma once

namespace iris::gpu {

// Per-instance data; the layout matches shaders/tile.vert.
struct TileInstance {
    float rect[4];  // x0, y0, x1, y1 in target pixels
    float texel[4]; // valid width, valid height, atlas layer, mip LOD
    float scale;    // texels per target pixel
    // The atlas layers of the tile's neighbours in the same level, so that pixels along its
    // edges filter across the seam (shaders/tile_seam.frag); -1 where there is none (the
    // slide's edge, a tile not resident, an overview thumbnail's tile).
    float sides[4] = {-1, -1, -1, -1};   // left, right, above, below
    float corners[4] = {-1, -1, -1, -1}; // above-left, above-right, below-left, below-right
};

} // namespace iris::gpu
