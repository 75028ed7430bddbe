#version 450
#extension GL_GOOGLE_include_directive : require
// The seam pass's pixels: those in a band along a side of the tile where a neighbour is
// resident (tile_bands.glsl). The hardware sampler, clamped to the tile's own layer, would
// filter the tile's edge texels with themselves there (a one-pixel grid along every tile
// boundary, zoomed in or between levels); here every bilinear tap, at each mip level the
// trilinear filter reads, is fetched from whichever tile holds it, this one or a neighbour,
// with clamp-to-edge where a neighbour is missing (a corner), as the hardware would. Only these
// bands run this shader: on a CPU device (lavapipe) a branch in the tile pass's shader costs
// every pixel both paths.

layout(set = 0, binding = 0) uniform sampler2DArray atlas; // 256×256 RGBA8 premultiplied, full mips

#include "color_lut.glsl"
#include "tile_turn.glsl"

layout(location = 0) flat in vec2 inOrigin;
layout(location = 1) flat in vec4 inTexel;   // valid w, valid h, layer, lod
layout(location = 2) flat in float inScale;
layout(location = 5) flat in vec4 inTurn;   // the view's turn and its centre (tile_turn.glsl)
layout(location = 6) flat in vec2 inCentre;
layout(location = 3) flat in vec4 inSides;   // left, right, above, below: atlas layers, -1 none
layout(location = 4) flat in vec4 inCorners; // above-left, above-right, below-left, below-right

layout(location = 0) out vec4 outColor;

const int TILE = 256;
const int MAX_MIP = 8; // the atlas's mips: 256² down to 1²

// Texel t of mip m of this tile's grid, one texel past its edge at most: from this tile, a
// neighbour, or clamped into this tile where the neighbour is missing. `size` is the tile's
// extent at mip m: its valid texels at mip 0 (an edge tile's padding is never read there, as
// tile.frag's clamp ensures), the whole layer through the mips (as the hardware reads it).
vec4 texelAt(ivec2 t, int m, ivec2 size) {
    ivec2 side = ivec2(t.x < 0 ? -1 : (t.x >= size.x ? 1 : 0), t.y < 0 ? -1 : (t.y >= size.y ? 1 : 0));
    float layer = inTexel.z;
    if (side != ivec2(0)) {
        float n;
        if (side.y == 0) n = side.x < 0 ? inSides.x : inSides.y;
        else if (side.x == 0) n = side.y < 0 ? inSides.z : inSides.w;
        else n = side.y < 0 ? (side.x < 0 ? inCorners.x : inCorners.y) : (side.x < 0 ? inCorners.z : inCorners.w);
        if (n >= 0.0) {
            layer = n;
            t -= side * (TILE >> m); // a neighbour exists only past a full 256-texel edge
        } else {
            t = clamp(t, ivec2(0), size - 1);
        }
    }
    return texelFetch(atlas, ivec3(t, int(layer)), m);
}

// Bilinear filtering of mip m at p (the tile's level-0 texel units; texel centres at i + 0.5).
vec4 bilinear(vec2 p, int m) {
    float k = float(1 << m);
    ivec2 size = m == 0 ? ivec2(inTexel.xy) : ivec2(TILE >> m);
    vec2 q = p / k - 0.5;
    ivec2 i0 = ivec2(floor(q));
    vec2 f = q - vec2(i0);
    return mix(mix(texelAt(i0, m, size), texelAt(i0 + ivec2(1, 0), m, size), f.x),
               mix(texelAt(i0 + ivec2(0, 1), m, size), texelAt(i0 + ivec2(1, 1), m, size), f.x), f.y);
}

void main() {
    vec2 p = (turnFromTarget(gl_FragCoord.xy, inTurn, inCentre) - inOrigin) * inScale;
    // tile.frag's clamp into the valid area, on the sides without a neighbour (across a seam
    // the position runs on into the neighbour).
    vec2 lo = vec2(inSides.x >= 0.0 ? -1e9 : 0.5, inSides.z >= 0.0 ? -1e9 : 0.5);
    vec2 hi = vec2(inSides.y >= 0.0 ? 1e9 : inTexel.x - 0.5, inSides.w >= 0.0 ? 1e9 : inTexel.y - 0.5);
    p = clamp(p, lo, hi);
    float lod = min(inTexel.w, float(MAX_MIP));
    int m0 = int(floor(lod));
    vec4 c = bilinear(p, m0);
    float f = lod - float(m0);
    if (f > 0.0) c = mix(c, bilinear(p, m0 + 1), f);
    outColor = colorManaged(c);
}
