// Where a tile's seam bands lie, in target pixels (included by tile.vert and tile_seam.vert).
//
// A tile drawn at LOD 0 (1:1 or enlarged) whose neighbour on a side is resident has, along that
// side, a band half a texel wide in which bilinear filtering needs the neighbour's texels. The
// tile pass (tile.vert/tile.frag) draws the tile's interior without those bands, through the
// hardware sampler; the seam pass (tile_seam.vert/tile_seam.frag) draws exactly the bands,
// filtering by hand across the seam. Both compute the partition here, with the same `precise`
// expressions, so that it has no gap and no overlap: each pixel is drawn (and blended) once.
//   left and right bands: the tile's full height;
//   top and bottom bands: between the left and right bands.

// The part of `rect` (x0, y0, x1, y1) the tile pass draws.
vec4 tileInterior(vec4 rect, vec4 texel, float scale, vec4 sides) {
    precise vec4 r = rect;
    if (texel.w != 0.0) return r; // drawn through its mips: no bands
    precise float band = 0.5 / scale;
    if (sides.x >= 0.0) r.x = rect.x + band;
    if (sides.y >= 0.0) r.z = rect.x + (texel.x - 0.5) / scale;
    if (sides.z >= 0.0) r.y = rect.y + band;
    if (sides.w >= 0.0) r.w = rect.y + (texel.y - 0.5) / scale;
    return r;
}

// Band `edge` (1 left, 2 right, 3 top, 4 bottom) of `rect`; empty (x1 <= x0) where that side
// has no band.
vec4 tileBand(int edge, vec4 rect, vec4 texel, float scale, vec4 sides) {
    vec4 i = tileInterior(rect, texel, scale, sides);
    if (edge == 1) return sides.x >= 0.0 && texel.w == 0.0 ? vec4(rect.x, rect.y, i.x, rect.w) : vec4(0.0);
    if (edge == 2) return sides.y >= 0.0 && texel.w == 0.0 ? vec4(i.z, rect.y, rect.z, rect.w) : vec4(0.0);
    if (edge == 3) return sides.z >= 0.0 && texel.w == 0.0 ? vec4(i.x, rect.y, i.z, i.y) : vec4(0.0);
    return sides.w >= 0.0 && texel.w == 0.0 ? vec4(i.x, i.w, i.z, rect.w) : vec4(0.0);
}
