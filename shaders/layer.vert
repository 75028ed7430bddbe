#version 450
#extension GL_GOOGLE_include_directive : require
// Raster layers (render/layer_pass.cpp): the quad of one chunk's core, grown by a margin so that
// every target pixel whose centre lies in the core is covered; the fragment shader decides which
// pixels belong to the chunk (half-open, in local coordinates), so neighbouring chunks neither
// overlap nor leave a gap.
#include "layer_push.glsl"


void main() {
    const float m = pc.toLocalX.w;
    const vec2 corner = vec2((gl_VertexIndex & 1) != 0 ? float(pc.core.x) + m : -m,
                             (gl_VertexIndex & 2) != 0 ? float(pc.core.y) + m : -m);
    const vec2 target = vec2(dot(pc.toScreenX.xyz, vec3(corner, 1.0)), dot(pc.toScreenY.xyz, vec3(corner, 1.0)));
    gl_Position = vec4(target / vec2(pc.toScreenX.w, pc.toScreenY.w) * 2.0 - 1.0, 0.0, 1.0);
}
