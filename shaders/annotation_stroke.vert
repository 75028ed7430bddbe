#version 450
// Annotation strokes (render/annotation_pass.cpp, gpu::AnnotationStroke): each instance is a
// capsule — the segment p0–p1 widened by halfWidth on every side, round caps — or, with a
// negative halfWidth, a square handle centred on p0. The quad covers the shape plus one pixel
// for the fragment shader's anti-aliasing; corners come from gl_VertexIndex (a 4-vertex strip).

layout(location = 0) in vec4 inSegment; // p0.xy, p1.xy in target pixels
layout(location = 1) in float inHalfWidth;
layout(location = 2) in vec4 inColour;  // straight RGBA

layout(push_constant) uniform Push {
    vec2 targetSize; // pixels
} pc;

layout(location = 0) flat out vec4 outSegment;
layout(location = 1) flat out float outHalfWidth;
layout(location = 2) flat out vec4 outColour;

void main() {
    vec2 p0 = inSegment.xy, p1 = inSegment.zw;
    float reach = abs(inHalfWidth) + 1.0;
    vec2 d = p1 - p0;
    float len = length(d);
    vec2 u = len > 1e-6 ? d / len : vec2(1.0, 0.0);
    vec2 n = vec2(-u.y, u.x);
    vec2 corner = vec2(gl_VertexIndex & 1, (gl_VertexIndex >> 1) & 1);
    vec2 p = (corner.x < 0.5 ? p0 - u * reach : p1 + u * reach) + n * (corner.y < 0.5 ? -reach : reach);
    gl_Position = vec4(p / pc.targetSize * 2.0 - 1.0, 0.0, 1.0);
    outSegment = inSegment;
    outHalfWidth = inHalfWidth;
    outColour = inColour;
}
