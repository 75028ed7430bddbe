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
// Two outputs: RGBA8 words into a buffer (Output::Buffer: iris-bench, engine.jpeg_gpu), or the
// tile atlas's base level (Output::Atlas: the buffer thread, EngineTuning::gpuDecode), each tile
// into the layer its descriptor names. The caller owns the buffers (input: the tables and
// blocks; the tile table: a descriptor per tile, which pack() puts at the input's start; planes:
// scratch of Sizes::planeWords words; a buffer output: tile i at the word and pitch of its
// Placement), and orders its own work around record(): the input's writes before it, the
// output's readers after it (compute-shader writes).
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
        uint32_t outputWord = 0;  // the tile's first pixel in the output buffer; its atlas layer (Output::Atlas)
        uint32_t outputPitch = 0; // words from one of its rows to the next (≥ its width)
        // Pixels at or beyond these repeat the last valid column and row (padTileEdges); 0: the
        // tile's own width and height.
        uint32_t validWidth = 0, validHeight = 0;
    };
    enum class Output { Buffer, Atlas };

    explicit JpegReconstruct(Device& device, Output output = Output::Buffer) : device_(device), output_(output) {}
    // `maxSets`: descriptor sets that may exist at once (makeSet).
    Result init(uint32_t maxSets = 4);

    static Sizes measure(std::span<const JpegCoefficients* const> tiles);
    // Writes measure(tiles).inputWords words to `dst`: the descriptors, then each tile's
    // tables and packed blocks (the tiles' dense blocks, packed here).
    static void pack(std::span<const JpegCoefficients* const> tiles, std::span<const Placement> placements, uint32_t* dst);

    // The pieces of pack() for a caller that lays the input out itself (fixed room per tile,
    // filled by several threads at once): words of one tile's quantisation tables, of its
    // packed blocks (slide/jpeg_coefficients.h, jpegblocks; counted from its dense blocks, or
    // packedWords when they were read packed), and of its planes (a 256×256 tile's most: 3·64
    // and 3·64·256).
    static uint32_t quantWords(const JpegCoefficients& t) { return t.components * 64; }
    static uint64_t blockWords(const JpegCoefficients& t);
    static uint64_t planeWords(const JpegCoefficients& t);
    // Writes tile `index`'s descriptor at table[index · kDescriptorWords], for tables at
    // quantWord and packed blocks at blocksWord in the input (readJpegCoefficients into the
    // caller's memory puts them there; writeQuant the tables) and planes from planeWord.
    static void describe(const JpegCoefficients& t, const Placement& placement, uint32_t index, uint64_t quantWord,
                         uint64_t blocksWord, uint64_t planeWord, uint32_t* table);
    // Its quantisation tables, 64 words each, at dst.
    static void writeQuant(const JpegCoefficients& t, uint32_t* dst);

    // Output::Buffer: a descriptor set over the input (its start the tile table), the planes
    // and the output buffer; freed by freeSet or with the pipeline.
    Expected<VkDescriptorSet> makeSet(VkBuffer input, VkDeviceSize inputOffset, VkDeviceSize inputBytes, VkBuffer planes,
                                      VkDeviceSize planeBytes, VkBuffer output, VkDeviceSize outputOffset,
                                      VkDeviceSize outputBytes);
    // Output::Atlas: the input, the planes (from planeOffset), the atlas's base-level storage
    // view (GENERAL layout) and a tile table of its own.
    Expected<VkDescriptorSet> makeAtlasSet(VkBuffer input, VkDeviceSize inputBytes, VkBuffer planes, VkDeviceSize planeOffset,
                                           VkDeviceSize planeBytes, VkImageView atlasBase, VkBuffer table,
                                           VkDeviceSize tableOffset, VkDeviceSize tableBytes);
    void freeSet(VkDescriptorSet set);
    // The two dispatches and the barrier between them.
    void record(VkCommandBuffer cmd, VkDescriptorSet set, const Sizes& sizes);

private:
    Device& device_;
    const Output output_;
    vk::ShaderModule idctModule_;
    vk::ShaderModule colorModule_;
    vk::DescriptorSetLayout setLayout_;
    vk::PipelineLayout layout_;
    vk::DescriptorPool pool_;
    vk::Pipeline idct_;
    vk::Pipeline color_;
};

} // namespace iris::gpu
