// Shared by the two schedules of the mip pass (mip_reduce.comp: 16 workgroups per tile, for
// GPUs; mip_reduce_serial.comp: one workgroup per tile; CPU devices make the same levels on the
// host instead, mipkernel::reduceChain8).
// Both compute exactly the same kernel (docs/ENHANCEMENT.md; CPU reference
// engine/src/gpu/mip_kernel.cpp), per channel, for level k (r = 2^k, n = 256/r):
// S = integer sum of the r×r base block (exact), A = S/(r²·255),
// G = (1 2 1)ᵀ(1 2 1)/16 blur of A on the level's grid with indices clamped to the tile, and
//   enhance = 0: A (the exact area average)
//   enhance = 1: clamp(A + λ·(A − G), 0, 1), A − G from the exact integer 16·S − Σ w·S.
// Only tile texels are read, so a tile's mips do not depend on its neighbours.
//
// Bindings (gpu/mip_pipeline.cpp): 0 a storage view of mip 0 of the whole atlas (all layers),
// 1 an array of 8 storage views, mips 1..8. The base level must be written and made visible
// to the compute stage before the dispatch. Tile i of the batch is workgroup row
// gl_WorkGroupID.y = i.

layout(local_size_x = 256) in;

layout(set = 0, binding = 0, rgba8) uniform readonly image2DArray baseLevel;
layout(set = 0, binding = 1, rgba8) uniform writeonly image2DArray mipLevel[8];

layout(push_constant) uniform Push {
    uvec4 layers[2]; // atlas layer of tile i: layers[i / 4][i % 4]
    uint enhance;    // 0: area average; 1: sharpened
    float lambda;    // sharpening gain λ (mipkernel::kLambda)
} pc;

int layer; // this workgroup's atlas layer (set first thing in main)

uvec4 loadBase(ivec2 p) {
    return uvec4(round(imageLoad(baseLevel, ivec3(p, layer)) * 255.0));
}

vec4 average(uvec4 sum, float texels) {
    return vec4(sum) / (texels * 255.0);
}

// s: the texel's block sum; g: Σ b_i b_j S over its clamped 3×3 neighbourhood (weights sum 16).
vec4 level(uvec4 s, uvec4 g, float texels) {
    const vec4 a = average(s, texels);
    if (pc.enhance == 0u) return a;
    const ivec4 d = ivec4(16u * s) - ivec4(g);
    return clamp(a + pc.lambda * (vec4(d) / (16.0 * texels * 255.0)), 0.0, 1.0);
}

// Constant indices only (no dynamic indexing of the image array is needed).
void store(int lvl, ivec2 p, vec4 v) {
    switch (lvl) {
    case 1: imageStore(mipLevel[0], ivec3(p, layer), v); break;
    case 2: imageStore(mipLevel[1], ivec3(p, layer), v); break;
    case 3: imageStore(mipLevel[2], ivec3(p, layer), v); break;
    case 4: imageStore(mipLevel[3], ivec3(p, layer), v); break;
    case 5: imageStore(mipLevel[4], ivec3(p, layer), v); break;
    case 6: imageStore(mipLevel[5], ivec3(p, layer), v); break;
    case 7: imageStore(mipLevel[6], ivec3(p, layer), v); break;
    case 8: imageStore(mipLevel[7], ivec3(p, layer), v); break;
    }
}

// 16-bit-per-channel packing of block sums up to 16×16 texels (255 · 256 = 65280).
uvec2 pack16(uvec4 v) { return uvec2(v.x | (v.y << 16), v.z | (v.w << 16)); }
uvec4 unpack16(uvec2 v) { return uvec4(v.x & 0xFFFFu, v.x >> 16, v.y & 0xFFFFu, v.y >> 16); }

// NAME(p) = Σ b_i b_j · GET(q) over the 3×3 neighbourhood of p on an N×N level grid, indices
// clamped to the tile; GET takes the grid coordinate.
#define BLUR_FN(NAME, GET, N)                                                        \
    uvec4 NAME(ivec2 p) {                                                            \
        uvec4 g = uvec4(0);                                                          \
        for (int j = -1; j <= 1; ++j)                                                \
            for (int i = -1; i <= 1; ++i) {                                          \
                const ivec2 q = clamp(p + ivec2(i, j), ivec2(0), ivec2(N - 1));      \
                g += uint((2 - abs(i)) * (2 - abs(j))) * GET(q);                     \
            }                                                                        \
        return g;                                                                    \
    }
