#version 450
#extension GL_GOOGLE_include_directive : require
// Mip reduction, the wide schedule (GPUs): every mip level (128×128 … 1×1) of every tile of a
// microtransaction in one dispatch of 16 × tiles workgroups, each level computed from the 1×
// base level only. The kernel, the common bindings and push constants: mip_common.glsl.
// Bindings 2 and 3 are the per-slot scratch (level-4 sums and arrival counters, zeroed once by
// gpu/mip_pipeline.cpp).
//
// Work split (the dispatch is 16 × tiles workgroups of 256 threads):
//   - Workgroup (x, y) handles region x (a 64×64 quarter-of-a-quarter of tile y). It loads the
//     region plus a 16-texel halo (one level-4 texel; none without enhance) once, builds the
//     integer block sums of levels 1–4 over that window in shared memory, and writes its part
//     of levels 1–4: each blur only needs one texel of halo at its own level.
//   - Levels 5–8 need the whole tile. Each region writes its 4×4 level-4 sums to the slot's
//     scratch, then counts itself in with an atomic add on the slot's counter; the workgroup
//     that arrives 16th (old value ≡ 15 mod 16, so the counter never needs resetting) reads
//     all 256 sums back and writes levels 5–8. This is the single-pass pattern of AMD's
//     FidelityFX SPD: no second dispatch, no workgroup ever waits for another.
// Every sum fits 16 bits per channel up to level 4 (255 · 256 = 65280), so levels 1–4 are
// stored RG|BA-packed in two uints.

#include "mip_common.glsl"

layout(set = 0, binding = 2, std430) coherent buffer Level4Sums { uvec2 level4[]; }; // 256 per slot
layout(set = 0, binding = 3, std430) coherent buffer Arrivals { uint arrivals[]; };  // one per slot

const int kHalo = 16; // base texels around a region: one level-4 texel

// Windows (region + halo) of level k, side (64 + 2·16) >> k, origin (regionOrigin − 16) >> k.
shared uvec2 s1[48 * 48];
shared uvec2 s2[24 * 24];
shared uvec2 s3[12 * 12];
shared uvec2 s4[6 * 6];
// The last region's whole-tile grids: level 4 (packed), 5, 6, 7.
shared uvec2 t16[256];
shared uvec4 t32[64];
shared uvec4 t64[16];
shared uvec4 t128[4];
shared bool lastRegion;

ivec2 origin;  // the region's top-left base texel
bool plain;

// Window accessors: level-k texel q (tile coordinates, inside the window) → its block sum.
uvec4 w1(ivec2 q) { const ivec2 c = q - ((origin - kHalo) >> 1); return unpack16(s1[c.y * 48 + c.x]); }
uvec4 w2(ivec2 q) { const ivec2 c = q - ((origin - kHalo) >> 2); return unpack16(s2[c.y * 24 + c.x]); }
uvec4 w3(ivec2 q) { const ivec2 c = q - ((origin - kHalo) >> 3); return unpack16(s3[c.y * 12 + c.x]); }
uvec4 w4(ivec2 q) { const ivec2 c = q - ((origin - kHalo) >> 4); return unpack16(s4[c.y * 6 + c.x]); }
uvec4 g16(ivec2 q) { return unpack16(t16[q.y * 16 + q.x]); }
uvec4 g32(ivec2 q) { return t32[q.y * 8 + q.x]; }
uvec4 g64(ivec2 q) { return t64[q.y * 4 + q.x]; }
uvec4 g128(ivec2 q) { return t128[q.y * 2 + q.x]; }

BLUR_FN(blur1, w1, 128)
BLUR_FN(blur2, w2, 64)
BLUR_FN(blur3, w3, 32)
BLUR_FN(blur4, w4, 16)
BLUR_FN(blur5, g32, 8)
BLUR_FN(blur6, g64, 4)
BLUR_FN(blur7, g128, 2)

// Whether window cell c of level k (side 96 >> k) is needed: inside the tile, and inside the
// region itself unless the blur needs the halo.
bool needed(int k, ivec2 c, out ivec2 q) {
    const int halo = kHalo >> k;
    q = ((origin - kHalo) >> k) + c;
    const int n = 256 >> k;
    if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, ivec2(n)))) return false;
    return !plain || (all(greaterThanEqual(c, ivec2(halo))) && all(lessThan(c, ivec2(halo + (64 >> k)))));
}

// Writes the region's part of level k from its window (s: the texel's sum, blurred from the window).
#define OUTPUT_FN(NAME, K, GET, BLUR)                                                \
    void NAME(uint t) {                                                              \
        const int side = 64 >> K;                                                    \
        for (int i = int(t); i < side * side; i += 256) {                            \
            const ivec2 q = (origin >> K) + ivec2(i % side, i / side);               \
            store(K, q, level(GET(q), plain ? uvec4(0) : BLUR(q), float(1 << (2 * K)))); \
        }                                                                            \
    }
OUTPUT_FN(output1, 1, w1, blur1)
OUTPUT_FN(output2, 2, w2, blur2)
OUTPUT_FN(output3, 3, w3, blur3)
OUTPUT_FN(output4, 4, w4, blur4)

void main() {
    const uint tile = gl_WorkGroupID.y;
    layer = int(pc.layers[tile / 4u][tile % 4u]);
    const uint region = gl_WorkGroupID.x; // 0..15, row-major 4×4
    origin = 64 * ivec2(int(region % 4u), int(region / 4u));
    plain = pc.enhance == 0u;
    const uint t = gl_LocalInvocationIndex;
    ivec2 q;

    // Level 1 over the window, straight from the base level: 9 cells per thread.
    for (int i = int(t); i < 48 * 48; i += 256) {
        const ivec2 c = ivec2(i % 48, i / 48);
        if (!needed(1, c, q)) continue;
        const ivec2 b = 2 * q;
        s1[i] = pack16(loadBase(b) + loadBase(b + ivec2(1, 0)) + loadBase(b + ivec2(0, 1)) + loadBase(b + ivec2(1, 1)));
    }
    barrier();
    // Levels 2–4 over their windows, each from the one below (a cell's children are 2c + {0,1}²).
    for (int i = int(t); i < 24 * 24; i += 256) {
        const ivec2 c = ivec2(i % 24, i / 24);
        if (!needed(2, c, q)) continue;
        const int j = 2 * c.y * 48 + 2 * c.x;
        s2[i] = pack16(unpack16(s1[j]) + unpack16(s1[j + 1]) + unpack16(s1[j + 48]) + unpack16(s1[j + 49]));
    }
    barrier();
    if (t < 12u * 12u) {
        const ivec2 c = ivec2(int(t % 12u), int(t / 12u));
        if (needed(3, c, q)) {
            const int j = 2 * c.y * 24 + 2 * c.x;
            s3[t] = pack16(unpack16(s2[j]) + unpack16(s2[j + 1]) + unpack16(s2[j + 24]) + unpack16(s2[j + 25]));
        }
    }
    barrier();
    if (t < 6u * 6u) {
        const ivec2 c = ivec2(int(t % 6u), int(t / 6u));
        if (needed(4, c, q)) {
            const int j = 2 * c.y * 12 + 2 * c.x;
            s4[t] = pack16(unpack16(s3[j]) + unpack16(s3[j + 1]) + unpack16(s3[j + 12]) + unpack16(s3[j + 13]));
        }
    }
    barrier();

    output1(t);
    output2(t);
    output3(t);
    output4(t);

    // Hand the region's level-4 sums to whichever region of this tile finishes last.
    if (t < 16u) {
        const ivec2 p = (origin >> 4) + ivec2(int(t % 4u), int(t / 4u));
        level4[uint(layer) * 256u + uint(p.y * 16 + p.x)] = pack16(w4(p));
    }
    memoryBarrierBuffer();
    barrier();
    if (t == 0u) lastRegion = (atomicAdd(arrivals[layer], 1u) % 16u) == 15u;
    barrier();
    if (!lastRegion) return; // uniform across the workgroup
    memoryBarrierBuffer();

    t16[t] = level4[uint(layer) * 256u + t];
    barrier();
    if (t < 64u) {
        const ivec2 p = ivec2(int(t % 8u), int(t / 8u));
        const ivec2 b = 2 * p;
        t32[t] = g16(b) + g16(b + ivec2(1, 0)) + g16(b + ivec2(0, 1)) + g16(b + ivec2(1, 1));
    }
    barrier();
    if (t < 64u) {
        const ivec2 p = ivec2(int(t % 8u), int(t / 8u));
        store(5, p, level(t32[t], plain ? uvec4(0) : blur5(p), 1024.0));
    }
    if (t < 16u) {
        const ivec2 p = ivec2(int(t % 4u), int(t / 4u));
        const int i = p.y * 16 + p.x * 2;
        t64[t] = t32[i] + t32[i + 1] + t32[i + 8] + t32[i + 9];
    }
    barrier();
    if (t < 16u) {
        const ivec2 p = ivec2(int(t % 4u), int(t / 4u));
        store(6, p, level(t64[t], plain ? uvec4(0) : blur6(p), 4096.0));
    }
    if (t < 4u) {
        const ivec2 p = ivec2(int(t % 2u), int(t / 2u));
        const int i = p.y * 8 + p.x * 2;
        t128[t] = t64[i] + t64[i + 1] + t64[i + 4] + t64[i + 5];
    }
    barrier();
    if (t < 4u) {
        const ivec2 p = ivec2(int(t % 2u), int(t / 2u));
        store(7, p, level(t128[t], plain ? uvec4(0) : blur7(p), 16384.0));
    }
    if (t == 0u) {
        const uvec4 s = t128[0] + t128[1] + t128[2] + t128[3];
        store(8, ivec2(0), level(s, 16u * s, 65536.0)); // a 1×1 grid: G = A
    }
}
