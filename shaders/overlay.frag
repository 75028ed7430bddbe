#version 450
// A solid quad, or a glyph: the coverage texel is fetched for the fragment's own pixel
// (glyph quads sit on whole target pixels and are exactly the bitmap's size), so glyphs are
// drawn texel for pixel, as FreeType rasterised them at the device pixel size. Output is
// premultiplied, blended "over" what is below.

layout(set = 0, binding = 0) uniform sampler2D glyphs; // R8 coverage atlas

layout(location = 0) flat in vec2 inOrigin;
layout(location = 1) flat in vec4 inColour;
layout(location = 2) flat in vec4 inGlyph;

layout(location = 0) out vec4 outColour;

void main() {
    float a = inColour.a;
    if (inGlyph.z > 0.5) {
        ivec2 texel = ivec2(inGlyph.xy) + ivec2(floor(gl_FragCoord.xy - inOrigin));
        a *= texelFetch(glyphs, texel, 0).r;
    }
    outColour = vec4(inColour.rgb * a, a);
}
