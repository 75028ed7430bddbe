#version 450
// Instanced tile quads. One instance = one tile of one pyramid level, already placed in
// target pixels by the render thread (render/render_thread.cpp, TileInstance).
// Vertices are generated from gl_VertexIndex (a 4-vertex triangle strip); no vertex buffer.

layout(location = 0) in vec4 inRect;   // x0, y0, x1, y1: the tile's valid area in target pixels
layout(location = 1) in vec4 inTexel;  // valid width, valid height (texels), atlas layer, mip LOD
layout(location = 2) in float inScale; // texels per target pixel

layout(push_constant) uniform Push {
    vec2 targetSize; // pixels
} pc;

layout(location = 0) flat out vec2 outOrigin;
layout(location = 1) flat out vec4 outTexel;
layout(location = 2) flat out float outScale;

void main() {
    vec2 corner = vec2(gl_VertexIndex & 1, (gl_VertexIndex >> 1) & 1);
    vec2 p = mix(inRect.xy, inRect.zw, corner);
    gl_Position = vec4(p / pc.targetSize * 2.0 - 1.0, 0.0, 1.0);
    outOrigin = inRect.xy;
    outTexel = inTexel;
    outScale = inScale;
}
