#version 450
// Instanced tile quads. One instance = one tile of one pyramid level, already placed in
// target pixels by the draw list (render/draw_list.cpp, gpu::TileInstance).
// Vertices are generated from gl_VertexIndex (a 4-vertex triangle strip); no vertex buffer.

layout(location = 0) in vec4 inRect;    // x0, y0, x1, y1: the tile's valid area in target pixels
layout(location = 1) in vec4 inTexel;   // valid width, valid height (texels), atlas layer, mip LOD
layout(location = 2) in float inScale;  // texels per target pixel
layout(location = 3) in vec4 inSides;   // neighbours' atlas layers: left, right, above, below (-1: none)
layout(location = 4) in vec4 inCorners; // above-left, above-right, below-left, below-right

layout(push_constant) uniform Push {
    vec2 targetSize; // pixels
} pc;

layout(location = 0) flat out vec2 outOrigin;
layout(location = 1) flat out vec4 outTexel;
layout(location = 2) flat out float outScale;
layout(location = 3) flat out vec4 outSides;
layout(location = 4) flat out vec4 outCorners;

void main() {
    vec2 corner = vec2(gl_VertexIndex & 1, (gl_VertexIndex >> 1) & 1);
    vec2 p = mix(inRect.xy, inRect.zw, corner);
    gl_Position = vec4(p / pc.targetSize * 2.0 - 1.0, 0.0, 1.0);
    outOrigin = inRect.xy;
    outTexel = inTexel;
    outScale = inScale;
    outSides = inSides;
    outCorners = inCorners;
}
