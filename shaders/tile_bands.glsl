// Where a tile's seam bands lie, in target pixels (included by tile.vert and tile_seam.vert).
//
// Each tile is its own atlas layer, sampled with clamp-to-edge. Along a side where the tile's
// neighbour in the level is resident, the filter needs the neighbour's texels within half a
// texel of the edge, at every mip level it reads: at LOD 0 (1:1 or enlarged, bilinear) half a
// texel of mip 0; through the mips (shrunk, trilinear between mips floor(lod) and ceil(lod))
// half a texel of mip ceil(lod), the coarser one, which is 2^ceil(lod) / 2 of the tile's texels
// and at most one target pixel. The tile pass (tile.vert/tile.frag) draws the tile's interior
// without those bands, through the hardware sampler; the seam pass (tile_seam.vert/
// tile_seam.frag) draws exactly the bands, filtering by hand across the seam. Both compute the
// partition here, with the same `precise` expressions, so that it has no gap and no overlap:
// each pixel is drawn (and blended) once. The seam shader gives the right colour for any pixel
// of the tile, so a band may be wider than it needs to be (a narrow edge tile's is limited to
// half its width).
//   left and right bands: the tile's full height;
//   top and bottom bands: between the left and right bands.
// A view turned by other than a right angle (`full`) cuts every tile the same way, 3 × 3,
// whatever its neighbours: the interior, four sides and four corners, each side band and
// corner drawn by the seam pass (which clamps where a neighbour is missing, as the sampler
// would). Turned edges are no longer axis-aligned, so a vertex lying on another piece's edge (a
// T-junction: a top band's corner on a full-height left band) would round off it and leave
// single-pixel cracks; the fixed 3 × 3 cut gives neighbouring pieces, and neighbouring tiles of
// a level, whole shared edges.

// The band's width in the tile's (level-0) texels: half a texel of the coarsest mip read (the
// atlas has mips 0-8; 8 is one texel).
float bandTexels(float lod) {
    return 0.5 * exp2(min(ceil(lod), 8.0));
}

// The part of `rect` (x0, y0, x1, y1) the tile pass draws (`full`: every side has a band).
vec4 tileInterior(vec4 rect, vec4 texel, float scale, vec4 sides, bool full) {
    if (full) sides = vec4(0.0);
    precise vec4 r = rect;
    precise float b = bandTexels(texel.w);
    precise float bx = min(b, 0.5 * texel.x);
    precise float by = min(b, 0.5 * texel.y);
    if (sides.x >= 0.0) r.x = rect.x + bx / scale;
    if (sides.y >= 0.0) r.z = rect.x + (texel.x - bx) / scale;
    if (sides.z >= 0.0) r.y = rect.y + by / scale;
    if (sides.w >= 0.0) r.w = rect.y + (texel.y - by) / scale;
    return r;
}

// Band `edge` (1 left, 2 right, 3 top, 4 bottom; `full` also 5-8: the corners above-left,
// above-right, below-left, below-right) of `rect`; empty (x1 <= x0) where that side has no band.
vec4 tileBand(int edge, vec4 rect, vec4 texel, float scale, vec4 sides, bool full) {
    vec4 i = tileInterior(rect, texel, scale, sides, full);
    if (full) {
        if (edge == 1) return vec4(rect.x, i.y, i.x, i.w);
        if (edge == 2) return vec4(i.z, i.y, rect.z, i.w);
        if (edge == 3) return vec4(i.x, rect.y, i.z, i.y);
        if (edge == 4) return vec4(i.x, i.w, i.z, rect.w);
        if (edge == 5) return vec4(rect.x, rect.y, i.x, i.y);
        if (edge == 6) return vec4(i.z, rect.y, rect.z, i.y);
        if (edge == 7) return vec4(rect.x, i.w, i.x, rect.w);
        return vec4(i.z, i.w, rect.z, rect.w);
    }
    if (edge == 1) return sides.x >= 0.0 ? vec4(rect.x, rect.y, i.x, rect.w) : vec4(0.0);
    if (edge == 2) return sides.y >= 0.0 ? vec4(i.z, rect.y, rect.z, rect.w) : vec4(0.0);
    if (edge == 3) return sides.z >= 0.0 ? vec4(i.x, rect.y, i.z, i.y) : vec4(0.0);
    return sides.w >= 0.0 ? vec4(i.x, i.w, i.z, rect.w) : vec4(0.0);
}
