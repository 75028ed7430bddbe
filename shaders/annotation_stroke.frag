#version 450
// Annotation strokes: coverage from the pixel centre's distance to the shape (the segment for
// a capsule, the centre in the max-norm for a square), a one-pixel ramp at its edge, so
// outlines keep the same crisp width at every zoom. Premultiplied for the "over" blend.

layout(location = 0) flat in vec4 inSegment;
layout(location = 1) flat in float inHalfWidth;
layout(location = 2) flat in vec4 inColour;
layout(location = 0) out vec4 outColour;

void main() {
    vec2 p = gl_FragCoord.xy;
    vec2 p0 = inSegment.xy, p1 = inSegment.zw;
    float coverage;
    if (inHalfWidth < 0.0) {
        vec2 q = abs(p - p0);
        coverage = clamp(-inHalfWidth + 0.5 - max(q.x, q.y), 0.0, 1.0);
    } else {
        vec2 pa = p - p0, ba = p1 - p0;
        float t = clamp(dot(pa, ba) / max(dot(ba, ba), 1e-12), 0.0, 1.0);
        coverage = clamp(inHalfWidth + 0.5 - length(pa - ba * t), 0.0, 1.0);
    }
    if (coverage <= 0.0) discard;
    float a = inColour.a * coverage;
    outColour = vec4(inColour.rgb * a, a);
}
