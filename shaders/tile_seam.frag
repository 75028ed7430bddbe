#version 450
#extension GL_GOOGLE_include_directive : require
// The seam pass's pixels: those within half a texel of a side of the tile where a neighbour is
// resident (tile_bands.glsl). The hardware sampler, clamped to the tile's own layer, would
// interpolate the tile's edge texel with itself there (a one-pixel grid along every tile
// boundary when zoomed in); here the four bilinear taps are fetched from whichever tile holds
// each, this one or a neighbour, with clamp-to-edge where a neighbour is missing (a corner).
// Only these bands run this shader: on a CPU device (lavapipe) a branch in the tile pass's
// shader costs every pixel both paths.

layout(set = 0, binding = 0) uniform sampler2DArray atlas; // 256×256 RGBA8 premultiplied, full mips

#include "color_lut.glsl"

layout(location = 0) flat in vec2 inOrigin;
layout(location = 1) flat in vec4 inTexel;   // valid w, valid h, layer, lod (0 here)
layout(location = 2) flat in float inScale;
layout(location = 3) flat in vec4 inSides;   // left, right, above, below: atlas layers, -1 none
layout(location = 4) flat in vec4 inCorners; // above-left, above-right, below-left, below-right

layout(location = 0) out vec4 outColor;

const int TILE = 256;

// Texel t of this tile's level-0 grid, t in [-1, valid]: from this tile, a neighbour, or
// clamped into this tile where the neighbour is missing.
vec4 texelAt(ivec2 t) {
    ivec2 valid = ivec2(inTexel.xy);
    ivec2 side = ivec2(t.x < 0 ? -1 : (t.x >= valid.x ? 1 : 0), t.y < 0 ? -1 : (t.y >= valid.y ? 1 : 0));
    float layer = inTexel.z;
    if (side != ivec2(0)) {
        float n;
        if (side.y == 0) n = side.x < 0 ? inSides.x : inSides.y;
        else if (side.x == 0) n = side.y < 0 ? inSides.z : inSides.w;
        else n = side.y < 0 ? (side.x < 0 ? inCorners.x : inCorners.y) : (side.x < 0 ? inCorners.z : inCorners.w);
        if (n >= 0.0) {
            layer = n;
            t -= side * TILE; // a neighbour exists only past a full 256-texel edge
        } else {
            t = clamp(t, ivec2(0), valid - 1);
        }
    }
    return texelFetch(atlas, ivec3(t, int(layer)), 0);
}

void main() {
    vec2 q = (gl_FragCoord.xy - inOrigin) * inScale - 0.5;
    ivec2 i0 = ivec2(floor(q));
    vec2 f = q - vec2(i0);
    outColor = colorManaged(mix(mix(texelAt(i0), texelAt(i0 + ivec2(1, 0)), f.x),
                                mix(texelAt(i0 + ivec2(0, 1)), texelAt(i0 + ivec2(1, 1)), f.x), f.y));
}
