// Push constants of the layer pass (render/layer_pass.cpp, gpu::LayerPush): one draw per chunk
// of a raster layer's level. "Local" coordinates are the level's pixel coordinates minus the
// chunk's origin (small, so float keeps them precise); the CPU composes the view's transform,
// the placement's inverse and the level's scale into toLocal, and its inverse into toScreen.
layout(push_constant) uniform Push {
    vec4 toLocalX;  // local x = dot(xyz, (target x, target y, 1)); w: the quad's margin, local pixels
    vec4 toLocalY;  // local y; w unused
    vec4 toScreenX; // target x = dot(xyz, (local x, local y, 1)); w: the target's width
    vec4 toScreenY; // target y; w: the target's height
    ivec4 core;     // the chunk's core: width, height (local [0, w) × [0, h)), origin x, y in the level
    ivec4 level;    // the level's width, height; the level pixel of the chunk texture's texel (0, 0)
    vec4 params;    // opacity, threshold, window low, window high
    ivec4 mode;     // kind (0 scalar, 1 rgba, 2 label), sampling (0 bilinear, 1 nearest), palette entries, 0
} pc;
