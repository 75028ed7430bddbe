#version 450
// Overlay quads (render/overlay_renderer.cpp, OverlayInstance): plates, bars, outlines and
// glyphs, each already placed in target pixels. Vertices come from gl_VertexIndex (a
// 4-vertex triangle strip), like the tile quads.

layout(location = 0) in vec4 inRect;   // x0, y0, x1, y1 in target pixels
layout(location = 1) in vec4 inColour; // straight RGBA
layout(location = 2) in vec4 inGlyph;  // glyph atlas texel of the rect's top-left corner (xy), glyph flag (z)

layout(push_constant) uniform Push {
    vec2 targetSize; // pixels
} pc;

layout(location = 0) flat out vec2 outOrigin;
layout(location = 1) flat out vec4 outColour;
layout(location = 2) flat out vec4 outGlyph;

void main() {
    vec2 corner = vec2(gl_VertexIndex & 1, (gl_VertexIndex >> 1) & 1);
    vec2 p = mix(inRect.xy, inRect.zw, corner);
    gl_Position = vec4(p / pc.targetSize * 2.0 - 1.0, 0.0, 1.0);
    outOrigin = inRect.xy;
    outColour = inColour;
    outGlyph = inGlyph;
}
