// The GPU JPEG reconstruction, pass 2 of 2: chroma upsampling and colour conversion of every
// pixel of a batch of tiles, from the sample planes of shaders/jpeg_idct.comp to RGBA8 (alpha
// 255). Both are libjpeg's defaults, in its own integer arithmetic:
//   - "fancy" upsampling: a 2×1 chroma sample is weighted 3:1 with its nearer neighbour
//     (rounding +1 / +2 alternately); 2×2 is that in both directions (9:3:3:1, +8 / +7); at a
//     plane's edges the outer output takes the edge sample (the first and last columns) and
//     the row beyond the edge is the edge row itself;
//   - YCbCr → RGB with 16-bit fixed-point constants: R = Y + ⌊1.402·Cr⌉,
//     B = Y + ⌊1.772·Cb⌉, G = Y + ((−0.34414·Cb − 0.71414·Cr + ½) >> 16), clamped to 0..255.
// Dispatch: (ceil(width/16), ceil(height/16), tiles). Included by jpeg_color.comp (RGBA8 words
// into a buffer) and jpeg_color_atlas.comp (JPEG_OUTPUT_ATLAS: into the tile atlas's base level).
#include "jpeg_common.glsl"

#ifdef JPEG_OUTPUT_ATLAS
// The atlas's base level (its storage view across the layers, RGBA8).
layout(set = 0, binding = 2, rgba8) uniform writeonly image2DArray jpegAtlas;
#else
layout(std430, set = 0, binding = 2) writeonly buffer JpegOutput { uint words[]; } jpegOut;
#endif

layout(local_size_x = 16, local_size_y = 16) in;

uint tileIndex;

int samp(uint c, uint x, uint y) {
    const uint cw = JPEG_COMP_WORD(c);
    const uint word = jpegPlanes.words[jpegDesc(tileIndex, cw + 5u) + y * jpegDesc(tileIndex, cw + 6u) + (x >> 2)];
    return int((word >> ((x & 3u) * 8u)) & 255u);
}

int chroma(uint c, uint x, uint y, uint hMax, uint vMax, uint width, uint height) {
    if (hMax == 1u) return samp(c, x, y);
    const uint i = x >> 1;
    const uint last = (width + 1u) / 2u - 1u;
    if (vMax == 1u) {
        const int s = samp(c, i, y);
        if ((x & 1u) == 0u) return i == 0u ? s : (3 * s + samp(c, i - 1u, y) + 1) >> 2;
        return i == last ? s : (3 * s + samp(c, i + 1u, y) + 2) >> 2;
    }
    const uint r = y >> 1;
    const uint lastRow = (height + 1u) / 2u - 1u;
    const uint r1 = (y & 1u) == 0u ? (r == 0u ? 0u : r - 1u) : min(r + 1u, lastRow);
    const int here = 3 * samp(c, i, r) + samp(c, i, r1);
    if ((x & 1u) == 0u) {
        if (i == 0u) return (here * 4 + 8) >> 4;
        return (here * 3 + 3 * samp(c, i - 1u, r) + samp(c, i - 1u, r1) + 8) >> 4;
    }
    if (i == last) return (here * 4 + 7) >> 4;
    return (here * 3 + 3 * samp(c, i + 1u, r) + samp(c, i + 1u, r1) + 7) >> 4;
}

void main() {
    tileIndex = gl_GlobalInvocationID.z;
    if (tileIndex >= jpegPush.tileCount) return;
    const uint x = gl_GlobalInvocationID.x, y = gl_GlobalInvocationID.y;
    const uint width = jpegDesc(tileIndex, 0u), height = jpegDesc(tileIndex, 1u);
    if (x >= width || y >= height) return;
    // Beyond the valid part, the last valid column and row again.
    const uint sx = min(x, jpegDesc(tileIndex, 9u) - 1u), sy = min(y, jpegDesc(tileIndex, 10u) - 1u);
    const uint transform = jpegDesc(tileIndex, 2u);
    const int luma = samp(0u, sx, sy);
    int r = luma, g = luma, b = luma;
    if (transform != 0u) {
        const uint hMax = jpegDesc(tileIndex, 3u), vMax = jpegDesc(tileIndex, 4u);
        const int c1 = chroma(1u, sx, sy, hMax, vMax, width, height);
        const int c2 = chroma(2u, sx, sy, hMax, vMax, width, height);
        if (transform == 1u) {
            const int cb = c1 - 128, cr = c2 - 128;
            r = clamp(luma + ((91881 * cr + 32768) >> 16), 0, 255);
            g = clamp(luma + ((-22554 * cb - 46802 * cr + 32768) >> 16), 0, 255);
            b = clamp(luma + ((116130 * cb + 32768) >> 16), 0, 255);
        } else {
            g = c1;
            b = c2;
        }
    }
#ifdef JPEG_OUTPUT_ATLAS
    // n/255 stored into UNORM8 rounds back to n exactly.
    imageStore(jpegAtlas, ivec3(int(x), int(y), int(jpegDesc(tileIndex, 7u))), vec4(r, g, b, 255) / 255.0);
#else
    jpegOut.words[jpegDesc(tileIndex, 7u) + y * jpegDesc(tileIndex, 8u) + x] =
        uint(r) | (uint(g) << 8) | (uint(b) << 16) | 0xFF000000u;
#endif
}
