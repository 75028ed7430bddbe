// The GPU JPEG reconstruction's shared declarations (shaders/jpeg_idct.comp,
// shaders/jpeg_color.comp; host side gpu/jpeg_reconstruct.h, whose constants these mirror).
//
// One batch reconstructs up to `tileCount` JPEG tiles. The input buffer starts with one
// descriptor of JPEG_DESC_WORDS words per tile:
//   0 width   1 height   2 transform (0 grey, 1 YCbCr, 2 RGB)   3 hMax   4 vMax
//   5 components   6 blocks (all components)   7 output word (first pixel's, RGBA8 words)
//   8 output pitch (words from one row to the next)
//   then per component c (at 16 + 8c): blocksWide, blocksHigh, first block (of the tile's),
//   coefficient word (of its first block), quantisation word (its 64 values), plane word,
//   plane pitch (words), unused.
// Coefficients: 32 words a block, two int16 a word (the lower half first), natural order.
// Quantisation tables: 64 words each, natural order. Planes (the scratch buffer): each
// component's samples after the inverse DCT, one byte a sample, four to a word, rows of
// blocksWide·8 samples.
#define JPEG_DESC_WORDS 40u
#define JPEG_COMP_WORD(c) (16u + 8u * (c))

layout(std430, set = 0, binding = 0) readonly buffer JpegInput { uint words[]; } jpegIn;
layout(std430, set = 0, binding = 1) buffer JpegPlanes { uint words[]; } jpegPlanes;
layout(std430, set = 0, binding = 2) writeonly buffer JpegOutput { uint words[]; } jpegOut;

layout(push_constant) uniform JpegPush {
    uint tileCount;
} jpegPush;

uint jpegDesc(uint tile, uint word) { return jpegIn.words[tile * JPEG_DESC_WORDS + word]; }
