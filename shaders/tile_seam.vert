#version 450
#extension GL_GOOGLE_include_directive : require
// The seam pass: for each tile instance of a level, the band along one side
// (push constant `edge`) that the tile pass left out because a neighbour is resident there
// (tile_bands.glsl). A side without a band gives an empty quad.

layout(location = 0) in vec4 inRect;
layout(location = 1) in vec4 inTexel;
layout(location = 2) in float inScale;
layout(location = 3) in vec4 inSides;   // left, right, above, below: atlas layers, -1 none
layout(location = 4) in vec4 inCorners; // above-left, above-right, below-left, below-right

layout(push_constant) uniform Push {
    vec2 targetSize; // pixels
    int edge;        // 1 left, 2 right, 3 top, 4 bottom; 5-8 the corners (fullBands)
    float fullBands; // 1: a turned view's fixed 3 × 3 cut (tile_bands.glsl)
    vec4 turn;       // the view's turn (tile_turn.glsl)
    vec2 centre;     // its centre, target pixels
} pc;

layout(location = 0) flat out vec2 outOrigin;
layout(location = 1) flat out vec4 outTexel;
layout(location = 2) flat out float outScale;
layout(location = 5) flat out vec4 outTurn;
layout(location = 6) flat out vec2 outCentre;
layout(location = 3) flat out vec4 outSides;
layout(location = 4) flat out vec4 outCorners;

#include "tile_bands.glsl"
#include "tile_turn.glsl"

void main() {
    vec2 corner = vec2(gl_VertexIndex & 1, (gl_VertexIndex >> 1) & 1);
    vec4 r = tileBand(pc.edge, inRect, inTexel, inScale, inSides, pc.fullBands > 0.5);
    vec2 p = turnToTarget(mix(r.xy, r.zw, corner), pc.turn, pc.centre);
    gl_Position = vec4(p / pc.targetSize * 2.0 - 1.0, 0.0, 1.0);
    outOrigin = inRect.xy;
    outTexel = inTexel;
    outScale = inScale;
    outTurn = pc.turn;
    outCentre = pc.centre;
    outSides = inSides;
    outCorners = inCorners;
}
