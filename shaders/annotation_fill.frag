#version 450
// Annotation fills: one colour a triangle, premultiplied for the "over" blend. The triangles of
// one object do not overlap (a constrained Delaunay triangulation), so each pixel of a fill is
// covered once; the outline drawn over it hides the aliased edge.

layout(location = 0) flat in vec4 inColour;
layout(location = 0) out vec4 outColour;

void main() {
    outColour = vec4(inColour.rgb * inColour.a, inColour.a);
}
