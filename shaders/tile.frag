#version 450
// Samples one tile. The texel is computed from the fragment's own pixel centre rather than
// from interpolated UVs, so that at 1:1 with integer alignment every fragment lands exactly
// on a texel centre and reproduces the source bytes (linear filtering with weight 0).
//
// Seams. Each tile is its own atlas layer, sampled with clamp-to-edge, so within half a texel
// of its edge the hardware filter would interpolate the tile's edge texel with itself: zoomed
// in, a one-pixel grid along every tile boundary. At LOD 0 (the tile is drawn at 1:1 or
// enlarged) the fragments in that band filter by hand instead: the four bilinear taps are
// fetched from whichever tile holds them, this one or a neighbour the draw list names, with
// the hardware's clamp-to-edge where there is no neighbour (the slide's edge, a tile not
// resident). Inside the band nothing changes, so interior pixels and 1:1 frames stay
// byte-identical. Tiles drawn shrunk (LOD > 0) sample their mips as before.

layout(set = 0, binding = 0) uniform sampler2DArray atlas; // 256×256 RGBA8 premultiplied, full mips

layout(location = 0) flat in vec2 inOrigin;
layout(location = 1) flat in vec4 inTexel;   // valid w, valid h, layer, lod
layout(location = 2) flat in float inScale;
layout(location = 3) flat in vec4 inSides;   // left, right, above, below: atlas layers, -1 none
layout(location = 4) flat in vec4 inCorners; // above-left, above-right, below-left, below-right

layout(location = 0) out vec4 outColor;

const float TILE = 256.0;

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
            t -= side * int(TILE); // a neighbour exists only past a full 256-texel edge
        } else {
            t = clamp(t, ivec2(0), valid - 1);
        }
    }
    return texelFetch(atlas, ivec3(t, int(layer)), 0);
}

void main() {
    vec2 texel = (gl_FragCoord.xy - inOrigin) * inScale;
    if (inTexel.w == 0.0 && (any(lessThan(texel, vec2(0.5))) || any(greaterThan(texel, inTexel.xy - vec2(0.5))))) {
        vec2 q = texel - 0.5;
        ivec2 i0 = ivec2(floor(q));
        vec2 f = q - vec2(i0);
        outColor = mix(mix(texelAt(i0), texelAt(i0 + ivec2(1, 0)), f.x),
                       mix(texelAt(i0 + ivec2(0, 1)), texelAt(i0 + ivec2(1, 1)), f.x), f.y);
        return;
    }
    // Clamp into the tile's valid area so edge tiles never sample their padding at level 0.
    texel = clamp(texel, vec2(0.5), inTexel.xy - vec2(0.5));
    outColor = textureLod(atlas, vec3(texel / TILE, inTexel.z), inTexel.w);
}
