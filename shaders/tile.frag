#version 450
#extension GL_GOOGLE_include_directive : require
// Samples one tile. The texel is computed from the fragment's own pixel centre rather than
// from interpolated UVs, so that at 1:1 with integer alignment every fragment lands exactly
// on a texel centre and reproduces the source bytes (linear filtering with weight 0).
// Along a side where a neighbour is resident, a tile leaves a band (half a texel of the
// coarsest mip it reads) to the seam pass (tile_bands.glsl, tile_seam.frag), which filters
// across the seam.
// A level drawn exactly (EXACT; render/draw_list.h, drawsExact: 1:1, every pixel centre on a
// texel centre) fetches its texels instead: the same bytes, since the filter's weights are 0
// there, without the filtering's cost (most of a frame's on lavapipe). It has no seam bands.

layout(set = 0, binding = 0) uniform sampler2DArray atlas; // 256×256 RGBA8 premultiplied, full mips

#include "color_lut.glsl"
#include "tile_turn.glsl"

layout(location = 0) flat in vec2 inOrigin;
layout(location = 1) flat in vec4 inTexel;  // valid w, valid h, layer, lod
layout(location = 2) flat in float inScale;
layout(location = 5) flat in vec4 inTurn;   // the view's turn and its centre (tile_turn.glsl)
layout(location = 6) flat in vec2 inCentre;

layout(location = 0) out vec4 outColor;

layout(constant_id = 2) const bool EXACT = false; // (0 and 1: color_lut.glsl)

const float TILE = 256.0;

void main() {
    vec2 texel = (turnFromTarget(gl_FragCoord.xy, inTurn, inCentre) - inOrigin) * inScale;
    if (EXACT) {
        ivec2 i = clamp(ivec2(floor(texel)), ivec2(0), ivec2(inTexel.xy) - 1);
        outColor = colorManaged(texelFetch(atlas, ivec3(i, int(inTexel.z)), 0));
        return;
    }
    // Clamp into the tile's valid area so edge tiles never sample their padding at level 0.
    texel = clamp(texel, vec2(0.5), inTexel.xy - vec2(0.5));
    outColor = colorManaged(textureLod(atlas, vec3(texel / TILE, inTexel.z), inTexel.w));
}
