// One tile quad as the tile pipeline draws it: the per-instance vertex data, without Vulkan
// (the draw-list builder produces them and is tested without a device).
#pragma once

namespace iris::gpu {

// Per-instance data; the layout matches shaders/tile.vert.
struct TileInstance {
    float rect[4];  // x0, y0, x1, y1 in target pixels
    float texel[4]; // valid width, valid height, atlas layer, mip LOD
    float scale;    // texels per target pixel
};

} // namespace iris::gpu
