#version 450
// Mip reduction: every mip level (128×128 … 1×1) of every tile of a microtransaction in one
// dispatch, one workgroup per tile, each level computed from the 1× base level only.
//
// Integration (buffer/buffer_thread.cpp, gpu/mip_pipeline.cpp): binding 0 is a storage view
// of mip 0 of the whole atlas (all layers), binding 1 an array of 8 storage views, mips 1..8.
// The push constants give each workgroup its atlas layer, the enhance switch and the gain λ.
// The base level must be written and made visible to the compute stage before the dispatch.
//
// Kernel (docs/ENHANCEMENT.md; CPU reference engine/src/gpu/mip_kernel.cpp), per channel, for
// level k (r = 2^k, n = 256/r): S = integer sum of the r×r base block (exact), A = S/(r²·255),
// G = (1 2 1)ᵀ(1 2 1)/16 blur of A on the level's grid with indices clamped to the tile, and
//   enhance = 0: A (the exact area average)
//   enhance = 1: clamp(A + λ·(A − G), 0, 1), A − G from the exact integer 16·S − Σ w·S.
// Only tile texels are read, so a tile's mips do not depend on its neighbours.
//
// Thread t owns a 16×16 block of the base: it sums it bottom-up in integers; levels 1–2 of
// its block are stored from those sums (plain) or from block sums over a one-texel halo
// (enhanced); the 8×8-block sums (level 3) and the 16×16-block sums go to shared memory, and
// levels 3–8 are computed from shared grids after a barrier.

layout(local_size_x = 256) in;

layout(set = 0, binding = 0, rgba8) uniform readonly image2DArray baseLevel;
layout(set = 0, binding = 1, rgba8) uniform writeonly image2DArray mipLevel[8];

layout(push_constant) uniform Push {
    uvec4 layers[2]; // atlas layer of workgroup i: layers[i / 4][i % 4]
    uint enhance;    // 0: area average; 1: sharpened
    float lambda;    // sharpening gain λ (mipkernel::kLambda)
} pc;

shared uvec2 sums8[1024]; // 32×32 grid of 8×8-block sums, RG and BA packed 16+16 bits (≤ 16320)
shared uvec4 sums16[256]; // 16×16 grid of 16×16-block sums
shared uvec4 sums32[64];  // 8×8 grid of 32×32-block sums
shared uvec4 sums64[16];
shared uvec4 sums128[4];

int layer;

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

uvec4 get8(int i) { const uvec2 v = sums8[i]; return uvec4(v.x & 0xFFFFu, v.x >> 16, v.y & 0xFFFFu, v.y >> 16); }
uvec4 get16(int i) { return sums16[i]; }
uvec4 get32(int i) { return sums32[i]; }
uvec4 get64(int i) { return sums64[i]; }
uvec4 get128(int i) { return sums128[i]; }

#define BLUR_FN(NAME, GET, N)                                                        \
    uvec4 NAME(ivec2 p) {                                                            \
        uvec4 g = uvec4(0);                                                          \
        for (int j = -1; j <= 1; ++j)                                                \
            for (int i = -1; i <= 1; ++i) {                                          \
                const ivec2 q = clamp(p + ivec2(i, j), ivec2(0), ivec2(N - 1));      \
                g += uint((2 - abs(i)) * (2 - abs(j))) * GET(q.y * N + q.x);         \
            }                                                                        \
        return g;                                                                    \
    }
BLUR_FN(blur8, get8, 32)
BLUR_FN(blur16, get16, 16)
BLUR_FN(blur32, get32, 8)
BLUR_FN(blur64, get64, 4)
BLUR_FN(blur128, get128, 2)

// Sum of the r×r base block of level-k texel q.
uvec4 blockSum(ivec2 q, int r) {
    uvec4 s = uvec4(0);
    for (int y = 0; y < r; ++y)
        for (int x = 0; x < r; ++x) s += loadBase(q * r + ivec2(x, y));
    return s;
}

// Enhanced level 1 (r = 2, m = 8) or 2 (r = 4, m = 4) of this thread's block, from block sums
// over a one-texel halo clamped to the tile.
void enhancedSmallLevel(int lvl, ivec2 block) {
    const int r = 1 << lvl, m = 16 >> lvl, n = 256 >> lvl;
    uvec4 h[100]; // (m + 2)² ≤ 10 × 10
    const int w = m + 2;
    for (int j = 0; j < w; ++j)
        for (int i = 0; i < w; ++i) {
            const ivec2 q = clamp(block * m + ivec2(i - 1, j - 1), ivec2(0), ivec2(n - 1));
            h[j * w + i] = blockSum(q, r);
        }
    for (int y = 0; y < m; ++y)
        for (int x = 0; x < m; ++x) {
            uvec4 g = uvec4(0);
            for (int j = 0; j < 3; ++j)
                for (int i = 0; i < 3; ++i)
                    g += uint((2 - abs(i - 1)) * (2 - abs(j - 1))) * h[(y + j) * w + x + i];
            store(lvl, block * m + ivec2(x, y), level(h[(y + 1) * w + x + 1], g, float(r * r)));
        }
}

void main() {
    const uint wg = gl_WorkGroupID.x;
    layer = int(pc.layers[wg / 4u][wg % 4u]);
    const uint t = gl_LocalInvocationIndex;
    const ivec2 block = ivec2(int(t % 16u), int(t / 16u)); // this thread's 16×16 block
    const ivec2 o = block * 16;
    const bool plain = pc.enhance == 0u;

    uvec4 acc4 = uvec4(0);
    for (int q3 = 0; q3 < 4; ++q3) {
        const ivec2 o3 = o + 8 * ivec2(q3 & 1, q3 >> 1);
        uvec4 acc3 = uvec4(0);
        for (int q2 = 0; q2 < 4; ++q2) {
            const ivec2 o2 = o3 + 4 * ivec2(q2 & 1, q2 >> 1);
            uvec4 acc2 = uvec4(0);
            for (int q1 = 0; q1 < 4; ++q1) {
                const ivec2 o1 = o2 + 2 * ivec2(q1 & 1, q1 >> 1);
                const uvec4 s1 = loadBase(o1) + loadBase(o1 + ivec2(1, 0)) + loadBase(o1 + ivec2(0, 1)) +
                                 loadBase(o1 + ivec2(1, 1));
                if (plain) store(1, o1 / 2, average(s1, 4.0));
                acc2 += s1;
            }
            if (plain) store(2, o2 / 4, average(acc2, 16.0));
            acc3 += acc2;
        }
        const ivec2 p3 = o3 / 8;
        sums8[p3.y * 32 + p3.x] = uvec2(acc3.x | (acc3.y << 16), acc3.z | (acc3.w << 16));
        acc4 += acc3;
    }
    sums16[t] = acc4;
    if (!plain) {
        enhancedSmallLevel(1, block);
        enhancedSmallLevel(2, block);
    }
    barrier();

    for (int q = 0; q < 4; ++q) {
        const ivec2 p3 = block * 2 + ivec2(q & 1, q >> 1);
        store(3, p3, level(get8(p3.y * 32 + p3.x), plain ? uvec4(0) : blur8(p3), 64.0));
    }
    store(4, block, level(acc4, plain ? uvec4(0) : blur16(block), 256.0));

    if (t < 64u) {
        const ivec2 p = ivec2(int(t % 8u), int(t / 8u));
        const int i = p.y * 32 + p.x * 2; // top-left of the 2×2 in the 16-wide grid
        sums32[t] = sums16[i] + sums16[i + 1] + sums16[i + 16] + sums16[i + 17];
    }
    barrier();
    if (t < 64u) {
        const ivec2 p = ivec2(int(t % 8u), int(t / 8u));
        store(5, p, level(sums32[t], plain ? uvec4(0) : blur32(p), 1024.0));
    }
    if (t < 16u) {
        const ivec2 p = ivec2(int(t % 4u), int(t / 4u));
        const int i = p.y * 16 + p.x * 2;
        sums64[t] = sums32[i] + sums32[i + 1] + sums32[i + 8] + sums32[i + 9];
    }
    barrier();
    if (t < 16u) {
        const ivec2 p = ivec2(int(t % 4u), int(t / 4u));
        store(6, p, level(sums64[t], plain ? uvec4(0) : blur64(p), 4096.0));
    }
    if (t < 4u) {
        const ivec2 p = ivec2(int(t % 2u), int(t / 2u));
        const int i = p.y * 8 + p.x * 2;
        sums128[t] = sums64[i] + sums64[i + 1] + sums64[i + 4] + sums64[i + 5];
    }
    barrier();
    if (t < 4u) {
        const ivec2 p = ivec2(int(t % 2u), int(t / 2u));
        store(7, p, level(sums128[t], plain ? uvec4(0) : blur128(p), 16384.0));
    }
    if (t == 0u) {
        const uvec4 s = sums128[0] + sums128[1] + sums128[2] + sums128[3];
        store(8, ivec2(0), level(s, 16u * s, 65536.0)); // a 1×1 grid: G = A
    }
}
