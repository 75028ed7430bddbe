#version 450
#extension GL_GOOGLE_include_directive : require
// Scalar raster layers (probability maps): the value sampled (nearest, or bilinear on values),
// no data (NaN in any tap used) and values under the threshold left out, the window, the colour
// map interpolated between its two nearest entries, the opacity. See layer_common.glsl.
#include "layer_push.glsl"
#include "layer_common.glsl"

layout(set = 0, binding = 0) uniform sampler2D chunk; // R32_SFLOAT values of the level
layout(location = 0) out vec4 outColour;

void main() {
    vec2 local;
    if (!localPosition(local)) discard;
    float value;
    if (pc.mode.y == 1) {
        value = texelFetch(chunk, nearestTexel(local), 0).r;
        if (isnan(value)) discard;
    } else {
        ivec2 t[4];
        vec2 f;
        bilinearTaps(local, t, f);
        const float v00 = texelFetch(chunk, t[0], 0).r, v10 = texelFetch(chunk, t[1], 0).r;
        const float v01 = texelFetch(chunk, t[2], 0).r, v11 = texelFetch(chunk, t[3], 0).r;
        if (isnan(v00) || isnan(v10) || isnan(v01) || isnan(v11)) discard;
        value = (1.0 - f.y) * ((1.0 - f.x) * v00 + f.x * v10) + f.y * ((1.0 - f.x) * v01 + f.x * v11);
    }
    if (value < pc.params.y) discard;
    const float low = pc.params.z, high = pc.params.w;
    const float t = high > low ? clamp((value - low) / (high - low), 0.0, 1.0) : (value >= high ? 1.0 : 0.0);
    const float p = 255.0 * t;
    const int i0 = int(floor(p));
    const int i1 = min(i0 + 1, 255);
    const float w = p - float(i0);
    outColour = finish(mix(paletteEntry(i0), paletteEntry(i1), w));
}
