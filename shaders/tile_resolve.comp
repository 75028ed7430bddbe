#version 450
#extension GL_GOOGLE_include_directive : require
// The per-pixel resolve (EngineTuning::TileResolve::Compute; render/resolve_pass.h): every
// target pixel finds its slide position, then the finest of the frame's layers (HR, LR, base)
// whose tile there is resident, through a page table the render thread writes each frame from
// the draw list (atlas layer per tile of each layer's visible range, -1 where absent). It
// filters by hand from texels fetched through the page table — bilinearly at LOD 0 (a layer
// drawn at or past 1:1), trilinearly between two mips when shrunk — so a tile boundary is
// filtered like its interior (no seam pass); where a tap's tile is absent it samples the
// pixel's own tile through the hardware sampler, as that tile's quad would show it. Then the
// colour step, and "over" the background. One invocation per pixel, 16×16 per workgroup.

layout(local_size_x = 16, local_size_y = 16) in;

layout(set = 0, binding = 0) uniform sampler2DArray atlas;
#include "color_lut.glsl"
#include "tile_turn.glsl"
layout(set = 0, binding = 2, rgba8) uniform writeonly image2D target;

struct Layer {
    ivec4 range;   // x0, y0, x1, y1: the tiles the table lists (inclusive); x1 < x0: none
    vec4 geometry; // level-pixel position of the target's (0, 0) corner (x, y), level px per target px, LOD
    ivec4 extent;  // level width, level height, first entry in `tiles`, unused
};

layout(std430, set = 0, binding = 3) readonly buffer PageTable {
    vec4 background;
    ivec4 info;     // target width, target height, layer count, unused
    vec4 turn;      // the view's turn (tile_turn.glsl): the layers' geometry is unturned
    vec4 centre;    // xy: its centre, target pixels
    Layer layers[3]; // finest first
    int tiles[];
} table;

const int TILE = 256;

// The atlas layer of tile (tx, ty) of layer l, or -1.
int entry(int l, ivec2 t) {
    ivec4 r = table.layers[l].range;
    if (t.x < r.x || t.y < r.y || t.x > r.z || t.y > r.w) return -1;
    return table.tiles[table.layers[l].extent.z + (t.y - r.y) * (r.z - r.x + 1) + (t.x - r.x)];
}

// Texel p (level pixels, integer) of layer l, clamped into the level; `ok` false when the tile
// holding it is absent.
vec4 texelOf(int l, ivec2 p, inout bool ok) {
    ivec2 e = table.layers[l].extent.xy;
    p = clamp(p, ivec2(0), e - 1);
    ivec2 t = p / TILE;
    int layer = entry(l, t);
    if (layer < 0) {
        ok = false;
        return vec4(0.0);
    }
    return texelFetch(atlas, ivec3(p - t * TILE, layer), 0);
}

// Texel p of mip m (in the level's mip-m texels) of layer l, from the tile that holds it; past
// the level's last tile the edge tile's own texel (clamp-to-edge, as its quad reads its
// padding through the mips); `ok` false when that tile is absent.
vec4 mipTexelOf(int l, ivec2 p, int m, inout bool ok) {
    int size = TILE >> m;
    ivec2 tiles = (table.layers[l].extent.xy + TILE - 1) / TILE;
    p = clamp(p, ivec2(0), tiles * size - 1);
    ivec2 t = p / size;
    int layer = entry(l, t);
    if (layer < 0) {
        ok = false;
        return vec4(0.0);
    }
    return texelFetch(atlas, ivec3(p - t * size, layer), m);
}

// Bilinear filtering of mip m of layer l at level position q.
vec4 bilinearMip(int l, vec2 q, int m, inout bool ok) {
    vec2 f0 = q / float(1 << m) - 0.5;
    ivec2 i0 = ivec2(floor(f0));
    vec2 f = f0 - vec2(i0);
    vec4 a = mipTexelOf(l, i0, m, ok), b = mipTexelOf(l, i0 + ivec2(1, 0), m, ok);
    vec4 c = mipTexelOf(l, i0 + ivec2(0, 1), m, ok), d = mipTexelOf(l, i0 + ivec2(1, 1), m, ok);
    return mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
}

// Layer l's colour at level position q (texel centres at i + 0.5), or ok = false.
vec4 sampleLayer(int l, vec2 q, inout bool ok) {
    Layer L = table.layers[l];
    if (L.range.z < L.range.x) {
        ok = false;
        return vec4(0.0);
    }
    ivec2 e = L.extent.xy;
    if (q.x < 0.0 || q.y < 0.0 || q.x >= float(e.x) || q.y >= float(e.y)) {
        ok = false;
        return vec4(0.0);
    }
    if (L.geometry.w <= 0.0) {
        // LOD 0: bilinear across tiles, each tap from the tile that holds it.
        vec2 f0 = q - 0.5;
        ivec2 i0 = ivec2(floor(f0));
        vec2 f = f0 - vec2(i0);
        bool whole = true;
        vec4 a = texelOf(l, i0, whole), b = texelOf(l, i0 + ivec2(1, 0), whole);
        vec4 c = texelOf(l, i0 + ivec2(0, 1), whole), d = texelOf(l, i0 + ivec2(1, 1), whole);
        if (whole) return mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
        // A neighbour is absent: the tile's own texels, clamped (what its quad would show).
    } else {
        // Through the mips: trilinear by hand, between mips floor(lod) and floor(lod) + 1, at
        // the position clamped into the level's valid texels (as tile.frag clamps it).
        vec2 qc = clamp(q, vec2(0.5), vec2(e) - 0.5);
        float lod = min(L.geometry.w, 8.0);
        int m0 = int(floor(lod));
        bool whole = true;
        vec4 c = bilinearMip(l, qc, m0, whole);
        float f = lod - float(m0);
        if (f > 0.0) c = mix(c, bilinearMip(l, qc, m0 + 1, whole), f);
        if (whole) return c;
    }
    ivec2 t = ivec2(floor(q)) / TILE;
    int layer = entry(l, t);
    if (layer < 0) {
        ok = false;
        return vec4(0.0);
    }
    vec2 valid = vec2(min(ivec2(TILE), e - t * TILE));
    vec2 texel = clamp(q - vec2(t * TILE), vec2(0.5), valid - vec2(0.5));
    return textureLod(atlas, vec3(texel / float(TILE), float(layer)), L.geometry.w);
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (px.x >= table.info.x || px.y >= table.info.y) return;
    vec4 color = table.background;
    vec2 u = turnFromTarget(vec2(px) + 0.5, table.turn, table.centre.xy);
    for (int l = 0; l < table.info.z; ++l) {
        Layer L = table.layers[l];
        vec2 q = L.geometry.xy + u * L.geometry.z;
        bool ok = true;
        vec4 s = sampleLayer(l, q, ok);
        if (ok) {
            s = colorManaged(s);
            color = s + color * (1.0 - s.a);
            break;
        }
    }
    imageStore(target, px, color);
}
