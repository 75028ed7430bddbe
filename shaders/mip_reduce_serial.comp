#version 450
#extension GL_GOOGLE_include_directive : require
// Mip reduction, the serial schedule (chosen by IRIS_MIP_SCHEDULE=serial; CPU devices make
// their mips on the host by default, gpu/mip_pipeline.h): every mip level of every
// tile of a microtransaction in one dispatch of one 256-thread workgroup per tile, each level
// computed from the 1× base level only. The kernel, bindings and push constants:
// mip_common.glsl. A CPU device runs a workgroup on one core, and llvmpipe's cost per workgroup
// made the wide schedule (mip_reduce.comp) 4–5× slower per tile there (docs/ENHANCEMENT.md).
//
// Thread t owns a 16×16 block of the base: it sums it bottom-up in integers; levels 1–2 of
// its block are stored from those sums (plain) or from block sums over a one-texel halo
// (enhanced); the 8×8-block sums (level 3) and the 16×16-block sums go to shared memory, and
// levels 3–8 are computed from shared grids after a barrier.

#include "mip_common.glsl"

shared uvec2 sums8[1024]; // 32×32 grid of 8×8-block sums, RG and BA packed 16+16 bits (≤ 16320)
shared uvec4 sums16[256]; // 16×16 grid of 16×16-block sums
shared uvec4 sums32[64];  // 8×8 grid of 32×32-block sums
shared uvec4 sums64[16];
shared uvec4 sums128[4];

uvec4 get8(ivec2 q) { return unpack16(sums8[q.y * 32 + q.x]); }
uvec4 get16(ivec2 q) { return sums16[q.y * 16 + q.x]; }
uvec4 get32(ivec2 q) { return sums32[q.y * 8 + q.x]; }
uvec4 get64(ivec2 q) { return sums64[q.y * 4 + q.x]; }
uvec4 get128(ivec2 q) { return sums128[q.y * 2 + q.x]; }

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
    const uint tile = gl_WorkGroupID.y;
    layer = int(pc.layers[tile / 4u][tile % 4u]);
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
        sums8[p3.y * 32 + p3.x] = pack16(acc3);
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
        store(3, p3, level(get8(p3), plain ? uvec4(0) : blur8(p3), 64.0));
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
