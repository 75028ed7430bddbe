// The colour transform step of the tile pass (docs/COLOR.md): the slide's colours through the
// 3D lookup table that LittleCMS baked (slide profile → display profile), trilinearly
// interpolated. COLOR_MANAGED is a specialization constant: frames without a transform use
// pipelines where the step is compiled out, so their bytes are unchanged.
//
// The sampler interpolates (LUT_SAMPLED, constant 1, the default on every device: one fetch):
// its filter weights have at least 8 fractional bits (subTexelPrecisionBits), which puts a
// result at most 1/512 of one node step (about 4 codes with 65 nodes) from the exact
// interpolation, and the accuracy tests measured it equal to the float path on the H200 and
// lavapipe. EngineTuning::ColorLookup::Nodes interpolates here instead, in 32-bit float from
// the eight nodes around the colour (texelFetch), the CPU model's exact weights, at 2-3× the
// per-frame cost (docs/COLOR.md, "Cost").
//
// Tiles are premultiplied: the table applies to the unpremultiplied colour.

layout(constant_id = 0) const bool COLOR_MANAGED = false;
layout(constant_id = 1) const bool LUT_SAMPLED = false;
layout(set = 0, binding = 1) uniform sampler3D colorLut; // N³ RGBA16F; node (r, g, b) = colour (r, g, b) / (N − 1)

vec4 colorManaged(vec4 c) {
    if (!COLOR_MANAGED || c.a <= 0.0) return c;
    int n = textureSize(colorLut, 0).x;
    vec3 g = clamp(c.rgb / c.a, 0.0, 1.0) * float(n - 1);
    vec3 rgb;
    if (LUT_SAMPLED) {
        // Node i's texel centre is (i + 0.5) / n.
        rgb = textureLod(colorLut, (g + 0.5) / float(n), 0.0).rgb;
        rgb = (floor(clamp(rgb, 0.0, 1.0) * 255.0 + 0.5) + 0.25) / 255.0; // as below
        return vec4(rgb * c.a, c.a);
    }
    ivec3 i = min(ivec3(g), ivec3(n - 2)); // the cell; its far corner is i + 1
    vec3 f = g - vec3(i);
    vec3 c000 = texelFetch(colorLut, i, 0).rgb;
    vec3 c100 = texelFetch(colorLut, i + ivec3(1, 0, 0), 0).rgb;
    vec3 c010 = texelFetch(colorLut, i + ivec3(0, 1, 0), 0).rgb;
    vec3 c110 = texelFetch(colorLut, i + ivec3(1, 1, 0), 0).rgb;
    vec3 c001 = texelFetch(colorLut, i + ivec3(0, 0, 1), 0).rgb;
    vec3 c101 = texelFetch(colorLut, i + ivec3(1, 0, 1), 0).rgb;
    vec3 c011 = texelFetch(colorLut, i + ivec3(0, 1, 1), 0).rgb;
    vec3 c111 = texelFetch(colorLut, i + ivec3(1, 1, 1), 0).rgb;
    rgb = mix(mix(mix(c000, c100, f.x), mix(c010, c110, f.x), f.y),
                   mix(mix(c001, c101, f.x), mix(c011, c111, f.x), f.y), f.z);
    // Rounded to the 8-bit targets' code here (round half up), a quarter code above it: the
    // conversion to UNORM that follows is the implementation's (Vulkan allows either neighbour,
    // and blend units convert in their own way), and it keeps this code under rounding or
    // truncation alike, so every GPU shows the same bytes (the H100 differed from lavapipe in
    // 6-18 % of pixels by one code without it).
    rgb = (floor(clamp(rgb, 0.0, 1.0) * 255.0 + 0.5) + 0.25) / 255.0;
    return vec4(rgb * c.a, c.a);
}
