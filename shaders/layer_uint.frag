#version 450
#extension GL_GOOGLE_include_directive : require
// Label maps (class ids through the class table, always nearest) and RGBA maps (nearest, or
// bilinear on premultiplied values). See layer_common.glsl.
#include "layer_push.glsl"
#include "layer_common.glsl"

layout(set = 0, binding = 0) uniform usampler2D chunk; // R16_UINT ids or R8G8B8A8_UINT colours
layout(location = 0) out vec4 outColour;

void main() {
    vec2 local;
    if (!localPosition(local)) discard;
    if (pc.mode.x == 2) { // label
        const int id = int(texelFetch(chunk, nearestTexel(local), 0).r);
        if (id >= pc.mode.z) discard;
        const vec4 c = paletteEntry(id);
        if (c.a == 0.0) discard; // an invisible class
        outColour = finish(c);
        return;
    }
    if (pc.mode.y == 1) {
        outColour = finish(vec4(texelFetch(chunk, nearestTexel(local), 0)));
        return;
    }
    ivec2 t[4];
    vec2 f;
    bilinearTaps(local, t, f);
    const float w[4] = float[4]((1.0 - f.x) * (1.0 - f.y), f.x * (1.0 - f.y), (1.0 - f.x) * f.y, f.x * f.y);
    vec4 sum = vec4(0.0); // premultiplied RGB, alpha (0..1)
    for (int i = 0; i < 4; ++i) {
        const vec4 c = vec4(texelFetch(chunk, t[i], 0));
        const float a = c.a / 255.0;
        sum += vec4(w[i] * c.rgb * a, w[i] * a);
    }
    if (!(sum.a > 0.0)) discard;
    outColour = finish(vec4(sum.rgb / sum.a, 255.0 * sum.a));
}
