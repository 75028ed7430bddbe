#version 450
#extension GL_GOOGLE_include_directive : require
// Instanced tile quads. One instance = one tile of one pyramid level, already placed in
// target pixels by the draw list (render/draw_list.cpp, gpu::TileInstance).
// Vertices are generated from gl_VertexIndex (a 4-vertex triangle strip); no vertex buffer.
// A tile with seam bands (tile_bands.glsl) is drawn without them; the seam pass draws them.

layout(location = 0) in vec4 inRect;   // x0, y0, x1, y1: the tile's valid area in target pixels
layout(location = 1) in vec4 inTexel;  // valid width, valid height (texels), atlas layer, mip LOD
layout(location = 2) in float inScale; // texels per target pixel
layout(location = 3) in vec4 inSides;  // neighbours' atlas layers: left, right, above, below (-1: none)

layout(push_constant) uniform Push {
    vec2 targetSize; // pixels
    int edge;        // the seam pass's band; unused here
    float fullBands; // 1: a turned view's fixed 3 × 3 cut (tile_bands.glsl)
    vec4 turn;       // the view's turn (tile_turn.glsl)
    vec2 centre;     // its centre, target pixels
} pc;

layout(location = 0) flat out vec2 outOrigin;
layout(location = 1) flat out vec4 outTexel;
layout(location = 2) flat out float outScale;
layout(location = 5) flat out vec4 outTurn;
layout(location = 6) flat out vec2 outCentre;

#include "tile_bands.glsl"
#include "tile_turn.glsl"

void main() {
    vec2 corner = vec2(gl_VertexIndex & 1, (gl_VertexIndex >> 1) & 1);
    vec4 r = tileInterior(inRect, inTexel, inScale, inSides, pc.fullBands > 0.5);
    vec2 p = turnToTarget(mix(r.xy, r.zw, corner), pc.turn, pc.centre);
    gl_Position = vec4(p / pc.targetSize * 2.0 - 1.0, 0.0, 1.0);
    outOrigin = inRect.xy;
    outTexel = inTexel;
    outScale = inScale;
    outTurn = pc.turn;
    outCentre = pc.centre;
}
