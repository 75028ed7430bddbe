// The GPU half of a JPEG decode: from the quantised coefficients the CPU's entropy decode
// reads (slide/jpeg_coefficients.h) to RGBA8 pixels, for a batch of tiles in two dispatches
// (shaders/jpeg_idct.comp: dequantisation and islow inverse DCT into sample planes;
// shaders/jpeg_color.comp: fancy chroma upsampling and YCbCr → RGB). The bytes are
// libjpeg-turbo's default decode's (engine.jpeg_gpu compares every pixel of the test slides'
// tiles and of synthetic JPEGs of each layout taken).
//
// Why: on a GPU machine the loaders' JPEG decode is what a new field waits for, and half of
// each tile's decode is this part (docs/BENCHMARKS.md, "How much of a decode that would
// move"): iris-bench times it per field beside the decode floor.
//
// The caller owns the three buffers (input: pack()'s words, read-only; planes: scratch of
// Sizes::planeWords words; output: Sizes::outputWords words of RGBA8, tile i at the output
// word and pitch given to pack()), and orders its own transfers around record(): the input's
// writes before it, its reads of the output after (compute-shader writes).
// Threading: one thread records at a time (the descriptor pool is not synchronised); pack()
// and measure() are pure functions.
#pragma once

#include <cstdint>
#include <span>

#include "gpu/device.h"
#include "gpu/vk_handle.h"
#include "slide/jpeg_coefficients.h"

namespace iris::gpu {

class JpegReconstruct {
public:
    static constexpr uint32_t kDescriptorWords = 40; // JPEG_DESC_WORDS in shaders/jpeg_common.glsl
    struct Sizes {
        uint32_t tiles = 0;
        uint64_t inputWords = 0;  // descriptors, quantisation tables, coefficients
        uint64_t planeWords = 0;  // the scratch planes
        uint32_t maxBlocks = 0;   // of one tile: the first dispatch's width
        uint32_t maxWidth = 0;    // of one tile: the second dispatch's extent
        uint32_t maxHeight = 0;
    };
    struct Placement {
        uint32_t outputWord = 0;  // the tile's first pixel in the output buffer
        uint32_t outputPitch = 0; // words from one of its rows to the next (≥ its width)
    };

    explicit JpegReconstruct(Device& device) : device_(device) {}
    // `maxSets`: descriptor sets that may exist at once (makeSet).
    Result init(uint32_t maxSets = 4);

    static Sizes measure(std::span<const JpegCoefficients* const> tiles);
    // Writes measure(tiles).inputWords words to `dst`: the descriptors, then each tile's
    // tables and blocks.
    static void pack(std::span<const JpegCoefficients* const> tiles, std::span<const Placement> placements, uint32_t* dst);

    // The pieces of pack() for a caller that lays the input out itself (fixed room per tile,
    // filled by several threads at once): words of one tile's quantisation tables, of its
    // blocks, and of its planes (a 256×256 tile's most: 3·64, 3072·32 and 3·64·256).
    static uint32_t quantWords(const JpegCoefficients& t) { return t.components * 64; }
    static uint64_t coefficientWords(const JpegCoefficients& t) { return uint64_t(t.blockCount()) * 32; }
    static uint64_t planeWords(const JpegCoefficients& t);
    // Writes tile `index`'s descriptor at dst[index · kDescriptorWords] and its quantisation
    // tables at dst[quantWord]; its blocks must be at dst[coefficientWord] (readJpegCoefficients
    // into the caller's memory puts them there) and its planes go at planeWord.
    static void describe(const JpegCoefficients& t, const Placement& placement, uint32_t index, uint64_t quantWord,
                         uint64_t coefficientWord, uint64_t planeWord, uint32_t* dst);

    // A descriptor set over the three buffers (whole ranges from the offsets given); freed by
    // freeSet or with the pipeline.
    Expected<VkDescriptorSet> makeSet(VkBuffer input, VkDeviceSize inputOffset, VkDeviceSize inputBytes, VkBuffer planes,
                                      VkDeviceSize planeBytes, VkBuffer output, VkDeviceSize outputOffset,
                                      VkDeviceSize outputBytes);
    void freeSet(VkDescriptorSet set);
    // The two dispatches and the barrier between them.
    void record(VkCommandBuffer cmd, VkDescriptorSet set, const Sizes& sizes);

private:
    Device& device_;
    vk::ShaderModule idctModule_;
    vk::ShaderModule colorModule_;
    vk::DescriptorSetLayout setLayout_;
    vk::PipelineLayout layout_;
    vk::DescriptorPool pool_;
    vk::Pipeline idct_;
    vk::Pipeline color_;
};

} // namespace iris::gpu
