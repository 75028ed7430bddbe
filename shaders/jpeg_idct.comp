#version 450
// The GPU JPEG reconstruction, pass 1 of 2: dequantisation and the inverse DCT of every block
// of a batch of tiles, into per-component sample planes. The arithmetic is libjpeg's "islow"
// integer IDCT (the decode every CPU path of the engine makes, libjpeg-turbo's default, its SIMD
// versions bit-exact with its C one): 13-bit fixed-point constants, two passes with two extra
// bits between them, each result rounded by adding half before the arithmetic shift. The
// final clamp to 0..255 saturates as libjpeg-turbo's SIMD code does; its C code wraps results
// more than 384 out of range instead, which the coefficients of a real image never produce.
// Bit-exactness against libjpeg-turbo is what engine.jpeg_gpu checks.
//
// Workgroup: 8 blocks, 8 invocations each (one column in the first pass, one row in the
// second), the blocks' intermediate values in shared memory. Dispatch: (ceil(blocks/8), tiles).
#extension GL_GOOGLE_include_directive : require
#include "jpeg_common.glsl"

layout(local_size_x = 64) in;

shared int ws[8][64];

// 13-bit fixed-point constants: round(x · 2^13).
const int F_0_298631336 = 2446;
const int F_0_390180644 = 3196;
const int F_0_541196100 = 4433;
const int F_0_765366865 = 6270;
const int F_0_899976223 = 7373;
const int F_1_175875602 = 9633;
const int F_1_501321110 = 12299;
const int F_1_847759065 = 15137;
const int F_1_961570560 = 16069;
const int F_2_053119869 = 16819;
const int F_2_562915447 = 20995;
const int F_3_072711026 = 25172;

int descale(int x, int n) { return (x + (1 << (n - 1))) >> n; }

// The 1-D kernel on eight values; `shift` is the descale of its outputs.
void idct8(in int v[8], int shift, out int o[8]) {
    // Even part.
    int z2 = v[2], z3 = v[6];
    int z1 = (z2 + z3) * F_0_541196100;
    int tmp2 = z1 - z3 * F_1_847759065;
    int tmp3 = z1 + z2 * F_0_765366865;
    int tmp0 = (v[0] + v[4]) << 13;
    int tmp1 = (v[0] - v[4]) << 13;
    const int tmp10 = tmp0 + tmp3;
    const int tmp13 = tmp0 - tmp3;
    const int tmp11 = tmp1 + tmp2;
    const int tmp12 = tmp1 - tmp2;
    // Odd part.
    tmp0 = v[7];
    tmp1 = v[5];
    tmp2 = v[3];
    tmp3 = v[1];
    z1 = tmp0 + tmp3;
    z2 = tmp1 + tmp2;
    z3 = tmp0 + tmp2;
    int z4 = tmp1 + tmp3;
    const int z5 = (z3 + z4) * F_1_175875602;
    tmp0 *= F_0_298631336;
    tmp1 *= F_2_053119869;
    tmp2 *= F_3_072711026;
    tmp3 *= F_1_501321110;
    z1 *= -F_0_899976223;
    z2 *= -F_2_562915447;
    z3 = z3 * -F_1_961570560 + z5;
    z4 = z4 * -F_0_390180644 + z5;
    tmp0 += z1 + z3;
    tmp1 += z2 + z4;
    tmp2 += z2 + z3;
    tmp3 += z1 + z4;
    o[0] = descale(tmp10 + tmp3, shift);
    o[7] = descale(tmp10 - tmp3, shift);
    o[1] = descale(tmp11 + tmp2, shift);
    o[6] = descale(tmp11 - tmp2, shift);
    o[2] = descale(tmp12 + tmp1, shift);
    o[5] = descale(tmp12 - tmp1, shift);
    o[3] = descale(tmp13 + tmp0, shift);
    o[4] = descale(tmp13 - tmp0, shift);
}

uint sample8(int x) { return uint(clamp(x + 128, 0, 255)); }

void main() {
    const uint tile = gl_WorkGroupID.y;
    const uint slot = gl_LocalInvocationID.x >> 3;
    const uint lane = gl_LocalInvocationID.x & 7u;
    const uint block = gl_WorkGroupID.x * 8u + slot;
    const bool live = tile < jpegPush.tileCount && block < jpegDesc(tile, 6u);
    uint c = 0u;
    if (live) {
        const uint components = jpegDesc(tile, 5u);
        if (components == 3u && block >= jpegDesc(tile, JPEG_COMP_WORD(2u) + 2u)) c = 2u;
        else if (components == 3u && block >= jpegDesc(tile, JPEG_COMP_WORD(1u) + 2u)) c = 1u;
    }
    const uint cw = JPEG_COMP_WORD(c);
    const uint local = live ? block - jpegDesc(tile, cw + 2u) : 0u;
    const uint quantWord = live ? jpegDesc(tile, cw + 4u) : 0u;

    // Pass 1: column `lane`, dequantised.
    if (live) {
        // The block's entry in the packed table: which coefficients are non-zero, and where
        // its values start; coefficient k is value number popcount(mask below k).
        const uint entry = jpegDesc(tile, cw + 3u) + local * 3u;
        const uint maskLo = jpegIn.words[entry], maskHi = jpegIn.words[entry + 1u];
        const uint values = jpegDesc(tile, 11u) + jpegIn.words[entry + 2u];
        const uint last = jpegDesc(tile, 12u) - 1u;
        const uint countLo = bitCount(maskLo);
        int v[8];
        bool acZero = true;
        for (uint r = 0u; r < 8u; ++r) {
            const uint k = r * 8u + lane;
            const bool lo = k < 32u;
            const uint bit = lo ? k : k - 32u;
            const uint mask = lo ? maskLo : maskHi;
            int coef = 0;
            if ((mask & (1u << bit)) != 0u) {
                const uint index = (lo ? 0u : countLo) + bitCount(mask & ((1u << bit) - 1u));
                coef = bitfieldExtract(int(jpegIn.words[min(values + (index >> 1), last)]), int(index & 1u) * 16, 16);
            }
            v[r] = coef * int(jpegIn.words[quantWord + k]);
            if (r > 0u && v[r] != 0) acZero = false;
        }
        if (acZero) {
            // AC terms all zero: the column is its DC term (libjpeg's shortcut, the same values).
            for (uint r = 0u; r < 8u; ++r) ws[slot][r * 8u + lane] = v[0] << 2;
        } else {
            int o[8];
            idct8(v, 11, o); // CONST_BITS − PASS1_BITS
            for (uint r = 0u; r < 8u; ++r) ws[slot][r * 8u + lane] = o[r];
        }
    }
    barrier();
    // Pass 2: row `lane`, to eight samples.
    if (live) {
        int v[8];
        bool acZero = true;
        for (uint k = 0u; k < 8u; ++k) {
            v[k] = ws[slot][lane * 8u + k];
            if (k > 0u && v[k] != 0) acZero = false;
        }
        int o[8];
        if (acZero) {
            const int dc = descale(v[0], 5); // PASS1_BITS + 3
            for (uint k = 0u; k < 8u; ++k) o[k] = dc;
        } else {
            idct8(v, 18, o); // CONST_BITS + PASS1_BITS + 3
        }
        const uint blocksWide = jpegDesc(tile, cw);
        const uint bx = local % blocksWide;
        const uint by = local / blocksWide;
        const uint at = jpegDesc(tile, cw + 5u) + (by * 8u + lane) * jpegDesc(tile, cw + 6u) + bx * 2u;
        jpegPlanes.words[at] = sample8(o[0]) | (sample8(o[1]) << 8) | (sample8(o[2]) << 16) | (sample8(o[3]) << 24);
        jpegPlanes.words[at + 1u] = sample8(o[4]) | (sample8(o[5]) << 8) | (sample8(o[6]) << 16) | (sample8(o[7]) << 24);
    }
}
