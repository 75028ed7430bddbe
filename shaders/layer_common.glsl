// The shading of a raster layer's pixel, as iris::shadeLayerAt (engine/src/layers/shading.cpp)
// writes it down, in float. Included by layer_float.frag (scalar maps) and layer_uint.frag
// (label and RGBA maps), which define fetch functions over their own texture type.
layout(set = 1, binding = 0) uniform usampler2D palette; // RGBA8 entries, 256 a row

// The local position of this pixel's centre; false when it is not in the chunk's core.
bool localPosition(out vec2 local) {
    local = vec2(dot(pc.toLocalX.xyz, vec3(gl_FragCoord.xy, 1.0)), dot(pc.toLocalY.xyz, vec3(gl_FragCoord.xy, 1.0)));
    return local.x >= 0.0 && local.y >= 0.0 && local.x < float(pc.core.x) && local.y < float(pc.core.y);
}

// The texel of level column/row `l` (clamped into the level), in the chunk texture.
ivec2 texelOf(ivec2 l) {
    return clamp(l, ivec2(0), pc.level.xy - 1) - pc.level.zw;
}

// Nearest: the level pixel under `local`.
ivec2 nearestTexel(vec2 local) {
    return texelOf(pc.core.zw + ivec2(floor(local)));
}

// Bilinear: the four taps' texels (x0 y0, x1 y0, x0 y1, x1 y1) and the second column's and row's weights.
void bilinearTaps(vec2 local, out ivec2 t[4], out vec2 f) {
    const vec2 s = local - 0.5;
    const vec2 i = floor(s);
    f = s - i;
    const ivec2 base = pc.core.zw + ivec2(i);
    t[0] = texelOf(base);
    t[1] = texelOf(base + ivec2(1, 0));
    t[2] = texelOf(base + ivec2(0, 1));
    t[3] = texelOf(base + ivec2(1, 1));
}

vec4 paletteEntry(int i) {
    return vec4(texelFetch(palette, ivec2(i & 255, i >> 8), 0));
}

// Straight colour (codes 0..255) with alpha code → the rounded result, premultiplied for the
// "over" blend: out = src·A + dst·(1 − A) in the target's 0..1 units.
vec4 finish(vec4 colour) {
    const vec3 rgb = clamp(floor(colour.rgb + 0.5), 0.0, 255.0);
    const float alpha = clamp(pc.params.x, 0.0, 1.0) * colour.a / 255.0;
    const float a = clamp(floor(255.0 * alpha + 0.5), 0.0, 255.0) / 255.0;
    return vec4(rgb / 255.0 * a, a);
}
