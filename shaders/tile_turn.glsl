// The view's turn (rotation and flips, ViewTransform in iris/types.h), included by the tile
// shaders. The draw list places tiles in the view's unturned frame; the vertex shaders turn
// the corners about the target's centre (M), and the fragment shaders map their pixel back
// (Mᵀ, M being orthonormal) to sample. An unturned view (M the identity) maps every pixel
// centre onto itself exactly; so does a multiple of 90° (entries 0 and ±1, and half-integer
// coordinates), which keeps such views byte-exact.

// Target position of unturned position u.
vec2 turnToTarget(vec2 u, vec4 m, vec2 c) {
    if (m == vec4(1.0, 0.0, 0.0, 1.0)) return u; // the common case, bit for bit
    vec2 d = u - c;
    return c + vec2(m.x * d.x + m.y * d.y, m.z * d.x + m.w * d.y);
}

// Unturned position of target position p.
vec2 turnFromTarget(vec2 p, vec4 m, vec2 c) {
    vec2 d = p - c;
    return c + vec2(m.x * d.x + m.z * d.y, m.y * d.x + m.w * d.y);
}
