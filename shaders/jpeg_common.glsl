// The GPU JPEG reconstruction's shared declarations (shaders/jpeg_idct.comp,
// shaders/jpeg_color.comp; host side gpu/jpeg_reconstruct.h, whose constants these mirror).
//
// One batch reconstructs `tileCount` JPEG tiles. The tile table (binding 3) holds one
// descriptor of JPEG_DESC_WORDS words per tile:
//   0 width   1 height   2 transform (0 grey, 1 YCbCr, 2 RGB)   3 hMax   4 vMax
//   5 components   6 blocks (all components)
//   7 output: the first pixel's word in the output buffer (jpeg_color.comp), or the atlas
//     layer whose base level the tile fills (jpeg_color_atlas.comp)
//   8 output pitch (words from one row to the next; buffer output)
//   9, 10 the valid width and height: pixels beyond them repeat the last valid column and
//     row (a level's edge tile, as the CPU path pads it)
//   11 the word of its packed blocks' table in the input (their values count from it)
//   12 the word after its packed blocks: a value's word is clamped below it, so a table that
//     points elsewhere (never written so; not checked per tile) reads nothing outside them
//   then per component c (at 16 + 8c): blocksWide, blocksHigh, first block (of the tile's),
//   table word (its first block's entry, in the input), quantisation word (its 64 values,
//   in the input), plane word, plane pitch (words), unused.
// Coefficients, packed (slide/jpeg_coefficients.h, jpegblocks): a table of three words a block
// (the 64-bit mask of its non-zero coefficients, natural order, lower word first; the word,
// from the table's start, of its values), then the values, two int16 a word (lower half first).
// Quantisation tables: 64 words each, natural order. Planes (the scratch buffer): each
// component's samples after the inverse DCT, one byte a sample, four to a word, rows of
// blocksWide·8 samples.
#define JPEG_DESC_WORDS 40u
#define JPEG_COMP_WORD(c) (16u + 8u * (c))

layout(std430, set = 0, binding = 0) readonly buffer JpegInput { uint words[]; } jpegIn;
layout(std430, set = 0, binding = 1) buffer JpegPlanes { uint words[]; } jpegPlanes;
layout(std430, set = 0, binding = 3) readonly buffer JpegTiles { uint words[]; } jpegTiles;

layout(push_constant) uniform JpegPush {
    uint tileCount;
} jpegPush;

uint jpegDesc(uint tile, uint word) { return jpegTiles.words[tile * JPEG_DESC_WORDS + word]; }
