// The colour transform step of the tile pass (docs/COLOR.md): the slide's colours through the
// 3D lookup table that LittleCMS baked (slide profile → display profile), trilinearly
// interpolated by the sampler. COLOR_MANAGED is a specialization constant: frames without a
// transform use pipelines where the step is compiled out, so their bytes are unchanged.
//
// Tiles are premultiplied: the table applies to the unpremultiplied colour.

layout(constant_id = 0) const bool COLOR_MANAGED = false;
layout(set = 0, binding = 1) uniform sampler3D colorLut; // N³ RGBA16F, entry i at (i + 0.5) / N

vec4 colorManaged(vec4 c) {
    if (!COLOR_MANAGED || c.a <= 0.0) return c;
    float n = float(textureSize(colorLut, 0).x);
    vec3 rgb = clamp(c.rgb / c.a, 0.0, 1.0);
    // Source value v lies at grid position v·(N − 1), whose texel centre is (v·(N − 1) + 0.5) / N.
    vec3 coord = (rgb * (n - 1.0) + 0.5) / n;
    return vec4(textureLod(colorLut, coord, 0.0).rgb * c.a, c.a);
}
