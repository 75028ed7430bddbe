#version 450
// Mip reduction: every mip level (128×128 … 1×1) of every tile of a microtransaction in one
// dispatch, one workgroup per tile.
//
// Integration (buffer/buffer_thread.cpp, gpu/mip_pipeline.cpp): binding 0 is a storage view
// of mip 0 of the whole atlas (all layers), binding 1 an array of 8 storage views, mips 1..8.
// The push constants give each workgroup its atlas layer. The base level must be written and
// made visible to the compute stage before the dispatch.
//
// Each level is the exact area average of the 1× base level (never of a rounded level):
// thread t owns a 16×16 block of the base, sums it bottom-up in integers (exact, no float
// accumulation error), writes levels 1–4 of its block, and leaves its 16×16 sum in shared
// memory; levels 5–8 are reduced from those sums. Only the final division rounds.
// The reduction-enhancement (Laplacian-of-Gaussian) kernel will replace the plain average.

layout(local_size_x = 256) in;

layout(set = 0, binding = 0, rgba8) uniform readonly image2DArray baseLevel;
layout(set = 0, binding = 1, rgba8) uniform writeonly image2DArray mipLevel[8];

layout(push_constant) uniform Push {
    uvec4 layers[2]; // atlas layer of workgroup i: layers[i / 4][i % 4]
} pc;

shared uvec4 sums16[256]; // 16×16 grid of 16×16-block sums
shared uvec4 sums32[64];  // 8×8 grid of 32×32-block sums
shared uvec4 sums64[16];
shared uvec4 sums128[4];

uvec4 loadBase(ivec2 p, int layer) {
    return uvec4(round(imageLoad(baseLevel, ivec3(p, layer)) * 255.0));
}

vec4 average(uvec4 sum, float texels) {
    return vec4(sum) / (texels * 255.0);
}

// Constant indices only (no dynamic indexing of the image array is needed).
void store(int level, ivec2 p, int layer, vec4 v) {
    switch (level) {
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

void main() {
    const uint wg = gl_WorkGroupID.x;
    const int layer = int(pc.layers[wg / 4u][wg % 4u]);
    const uint t = gl_LocalInvocationIndex;
    const ivec2 block = ivec2(int(t % 16u), int(t / 16u)); // this thread's 16×16 block
    const ivec2 o = block * 16;

    uvec4 acc4 = uvec4(0);
    for (int q3 = 0; q3 < 4; ++q3) {
        const ivec2 o3 = o + 8 * ivec2(q3 & 1, q3 >> 1);
        uvec4 acc3 = uvec4(0);
        for (int q2 = 0; q2 < 4; ++q2) {
            const ivec2 o2 = o3 + 4 * ivec2(q2 & 1, q2 >> 1);
            uvec4 acc2 = uvec4(0);
            for (int q1 = 0; q1 < 4; ++q1) {
                const ivec2 o1 = o2 + 2 * ivec2(q1 & 1, q1 >> 1);
                const uvec4 s1 = loadBase(o1, layer) + loadBase(o1 + ivec2(1, 0), layer) +
                                 loadBase(o1 + ivec2(0, 1), layer) + loadBase(o1 + ivec2(1, 1), layer);
                store(1, o1 / 2, layer, average(s1, 4.0));
                acc2 += s1;
            }
            store(2, o2 / 4, layer, average(acc2, 16.0));
            acc3 += acc2;
        }
        store(3, o3 / 8, layer, average(acc3, 64.0));
        acc4 += acc3;
    }
    store(4, block, layer, average(acc4, 256.0));
    sums16[t] = acc4;
    barrier();

    if (t < 64u) {
        const ivec2 p = ivec2(int(t % 8u), int(t / 8u));
        const int i = p.y * 32 + p.x * 2; // top-left of the 2×2 in the 16-wide grid
        const uvec4 s = sums16[i] + sums16[i + 1] + sums16[i + 16] + sums16[i + 17];
        sums32[t] = s;
        store(5, p, layer, average(s, 1024.0));
    }
    barrier();
    if (t < 16u) {
        const ivec2 p = ivec2(int(t % 4u), int(t / 4u));
        const int i = p.y * 16 + p.x * 2;
        const uvec4 s = sums32[i] + sums32[i + 1] + sums32[i + 8] + sums32[i + 9];
        sums64[t] = s;
        store(6, p, layer, average(s, 4096.0));
    }
    barrier();
    if (t < 4u) {
        const ivec2 p = ivec2(int(t % 2u), int(t / 2u));
        const int i = p.y * 8 + p.x * 2;
        const uvec4 s = sums64[i] + sums64[i + 1] + sums64[i + 4] + sums64[i + 5];
        sums128[t] = s;
        store(7, p, layer, average(s, 16384.0));
    }
    barrier();
    if (t == 0u) {
        const uvec4 s = sums128[0] + sums128[1] + sums128[2] + sums128[3];
        store(8, ivec2(0), layer, average(s, 65536.0));
    }
}
