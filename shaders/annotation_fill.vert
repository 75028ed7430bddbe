#version 450
// Annotation fills (render/annotation_pass.cpp): triangles of the objects' fills, already in
// target pixels (the pass maps level-0 coordinates through the view's transform, rotation and
// mirroring included), in straight RGBA with the fill opacity in alpha.

layout(location = 0) in vec2 inPos;    // target pixels
layout(location = 1) in vec4 inColour; // straight RGBA

layout(push_constant) uniform Push {
    vec2 targetSize; // pixels
} pc;

layout(location = 0) flat out vec4 outColour;

void main() {
    gl_Position = vec4(inPos / pc.targetSize * 2.0 - 1.0, 0.0, 1.0);
    outColour = inColour;
}
