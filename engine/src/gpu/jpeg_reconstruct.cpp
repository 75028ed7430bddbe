#include "gpu/jpeg_reconstruct.h"

#include <algorithm>
#include <cstring>

#include "gpu/vk_util.h"
#include <iris_shaders/jpeg_color_atlas_comp.h>
#include <iris_shaders/jpeg_color_comp.h>
#include <iris_shaders/jpeg_idct_comp.h>

namespace iris::gpu {

namespace {
constexpr uint32_t kCompWord = 16; // JPEG_COMP_WORD(0)
constexpr uint32_t kCompStride = 8;
static_assert(kCompWord + 3 * kCompStride == JpegReconstruct::kDescriptorWords);

// A component's sample plane: rows of blocksWide·8 samples, four a word.
uint64_t planePitch(const JpegCoefficients::Component& c) { return uint64_t(c.blocksWide) * 2; }
uint64_t componentPlaneWords(const JpegCoefficients::Component& c) { return planePitch(c) * c.blocksHigh * 8; }
} // namespace

uint64_t JpegReconstruct::blockWords(const JpegCoefficients& t) {
    return t.blocks.empty() ? t.packedWords : jpegblocks::packedWords(t.blocks.data(), t.blockCount());
}

uint64_t JpegReconstruct::planeWords(const JpegCoefficients& t) {
    uint64_t words = 0;
    for (uint32_t c = 0; c < t.components; ++c) words += componentPlaneWords(t.comp[c]);
    return words;
}

JpegReconstruct::Sizes JpegReconstruct::measure(std::span<const JpegCoefficients* const> tiles) {
    Sizes s;
    s.tiles = uint32_t(tiles.size());
    s.inputWords = uint64_t(tiles.size()) * kDescriptorWords;
    for (const JpegCoefficients* t : tiles) {
        s.inputWords += quantWords(*t) + blockWords(*t);
        s.planeWords += planeWords(*t);
        s.maxBlocks = std::max(s.maxBlocks, t->blockCount());
        s.maxWidth = std::max(s.maxWidth, t->width);
        s.maxHeight = std::max(s.maxHeight, t->height);
    }
    return s;
}

void JpegReconstruct::writeQuant(const JpegCoefficients& t, uint32_t* dst) {
    for (uint32_t c = 0; c < t.components; ++c)
        for (int q = 0; q < 64; ++q) dst[c * 64 + q] = t.comp[c].quant[q];
}

void JpegReconstruct::describe(const JpegCoefficients& t, const Placement& placement, uint32_t index, uint64_t quantWord,
                               uint64_t blocksWord, uint64_t planeWord, uint32_t* table) {
    uint32_t* d = table + uint64_t(index) * kDescriptorWords;
    std::memset(d, 0, kDescriptorWords * 4);
    d[0] = t.width;
    d[1] = t.height;
    d[2] = uint32_t(t.transform);
    d[3] = t.hMax;
    d[4] = t.vMax;
    d[5] = t.components;
    d[6] = t.blockCount();
    d[7] = placement.outputWord;
    d[8] = placement.outputPitch;
    d[9] = placement.validWidth ? std::min(placement.validWidth, t.width) : t.width;
    d[10] = placement.validHeight ? std::min(placement.validHeight, t.height) : t.height;
    d[11] = uint32_t(blocksWord); // the packed blocks' table: their values' words count from it
    d[12] = uint32_t(blocksWord + blockWords(t)); // the word after them: no value is read from there on
    uint64_t plane = planeWord;
    for (uint32_t c = 0; c < t.components; ++c) {
        const JpegCoefficients::Component& k = t.comp[c];
        uint32_t* cd = d + kCompWord + kCompStride * c;
        cd[0] = k.blocksWide;
        cd[1] = k.blocksHigh;
        cd[2] = k.firstBlock;
        cd[3] = uint32_t(blocksWord + uint64_t(k.firstBlock) * jpegblocks::kTableWords);
        cd[4] = uint32_t(quantWord + uint64_t(c) * 64);
        cd[5] = uint32_t(plane);
        cd[6] = uint32_t(planePitch(k));
        plane += componentPlaneWords(k);
    }
}

void JpegReconstruct::pack(std::span<const JpegCoefficients* const> tiles, std::span<const Placement> placements,
                           uint32_t* dst) {
    uint64_t next = uint64_t(tiles.size()) * kDescriptorWords; // the first word after the descriptors
    uint64_t plane = 0;
    for (size_t i = 0; i < tiles.size(); ++i) {
        const JpegCoefficients& t = *tiles[i];
        const uint64_t blocks = next + quantWords(t);
        describe(t, placements[i], uint32_t(i), next, blocks, plane, dst);
        writeQuant(t, dst + next);
        const uint64_t words = blockWords(t);
        jpegblocks::pack(t.blocks.data(), t.blockCount(), dst + blocks, words);
        next = blocks + words;
        plane += planeWords(t);
    }
}

Result JpegReconstruct::init(uint32_t maxSets) {
    VkDevice dev = device_.device();
    if (Result r = vk::createShaderModule(dev, jpeg_idct_comp_spv, sizeof(jpeg_idct_comp_spv), *idctModule_.replace(dev));
        !r.ok())
        return r;
    const bool atlas = output_ == Output::Atlas;
    if (Result r = atlas ? vk::createShaderModule(dev, jpeg_color_atlas_comp_spv, sizeof(jpeg_color_atlas_comp_spv),
                                                  *colorModule_.replace(dev))
                         : vk::createShaderModule(dev, jpeg_color_comp_spv, sizeof(jpeg_color_comp_spv), *colorModule_.replace(dev));
        !r.ok())
        return r;
    VkDescriptorSetLayoutBinding bindings[4];
    for (uint32_t b = 0; b < 4; ++b)
        bindings[b] = {.binding = b,
                       .descriptorType = b == 2 && atlas ? VK_DESCRIPTOR_TYPE_STORAGE_IMAGE : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                       .descriptorCount = 1,
                       .stageFlags = VK_SHADER_STAGE_COMPUTE_BIT,
                       .pImmutableSamplers = nullptr};
    const VkDescriptorSetLayoutCreateInfo dslci{
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO, .pNext = nullptr, .flags = 0, .bindingCount = 4, .pBindings = bindings};
    IRIS_VK_TRY(vkCreateDescriptorSetLayout(dev, &dslci, nullptr, setLayout_.replace(dev)));
    const VkDescriptorSetLayout setLayout = setLayout_.get();
    const VkPushConstantRange push{.stageFlags = VK_SHADER_STAGE_COMPUTE_BIT, .offset = 0, .size = sizeof(uint32_t)};
    const VkPipelineLayoutCreateInfo plci{.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                          .pNext = nullptr,
                                          .flags = 0,
                                          .setLayoutCount = 1,
                                          .pSetLayouts = &setLayout,
                                          .pushConstantRangeCount = 1,
                                          .pPushConstantRanges = &push};
    IRIS_VK_TRY(vkCreatePipelineLayout(dev, &plci, nullptr, layout_.replace(dev)));
    Expected<VkPipeline> idct = vk::createComputePipeline(dev, layout_.get(), idctModule_.get());
    if (!idct) return idct.error();
    idct_ = vk::Pipeline(dev, *idct);
    Expected<VkPipeline> color = vk::createComputePipeline(dev, layout_.get(), colorModule_.get());
    if (!color) return color.error();
    color_ = vk::Pipeline(dev, *color);
    const VkDescriptorPoolSize ps[2] = {{.type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, .descriptorCount = 4 * maxSets},
                                        {.type = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, .descriptorCount = maxSets}};
    const VkDescriptorPoolCreateInfo dpci{.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
                                          .pNext = nullptr,
                                          .flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT,
                                          .maxSets = maxSets,
                                          .poolSizeCount = 2,
                                          .pPoolSizes = ps};
    IRIS_VK_TRY(vkCreateDescriptorPool(dev, &dpci, nullptr, pool_.replace(dev)));
    return {};
}

namespace {
Expected<VkDescriptorSet> allocateSet(VkDevice dev, VkDescriptorPool pool, VkDescriptorSetLayout layout) {
    const VkDescriptorSetAllocateInfo dsai{.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
                                           .pNext = nullptr,
                                           .descriptorPool = pool,
                                           .descriptorSetCount = 1,
                                           .pSetLayouts = &layout};
    VkDescriptorSet set = VK_NULL_HANDLE;
    if (Result r = vk::check(vkAllocateDescriptorSets(dev, &dsai, &set), "vkAllocateDescriptorSets"); !r.ok()) return r;
    return set;
}

VkWriteDescriptorSet bufferWrite(VkDescriptorSet set, uint32_t binding, const VkDescriptorBufferInfo* info) {
    return {.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, .pNext = nullptr, .dstSet = set, .dstBinding = binding,
            .dstArrayElement = 0, .descriptorCount = 1, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
            .pImageInfo = nullptr, .pBufferInfo = info, .pTexelBufferView = nullptr};
}
} // namespace

Expected<VkDescriptorSet> JpegReconstruct::makeSet(VkBuffer input, VkDeviceSize inputOffset, VkDeviceSize inputBytes,
                                                   VkBuffer planes, VkDeviceSize planeBytes, VkBuffer output,
                                                   VkDeviceSize outputOffset, VkDeviceSize outputBytes) {
    if (output_ != Output::Buffer) return Result(Status::InvalidArgument, "makeSet: this pipeline writes the atlas");
    VkDevice dev = device_.device();
    Expected<VkDescriptorSet> set = allocateSet(dev, pool_.get(), setLayout_.get());
    if (!set) return set;
    const VkDescriptorBufferInfo infos[4] = {{.buffer = input, .offset = inputOffset, .range = inputBytes},
                                             {.buffer = planes, .offset = 0, .range = planeBytes},
                                             {.buffer = output, .offset = outputOffset, .range = outputBytes},
                                             {.buffer = input, .offset = inputOffset, .range = inputBytes}};
    VkWriteDescriptorSet writes[4];
    for (uint32_t b = 0; b < 4; ++b) writes[b] = bufferWrite(*set, b, &infos[b]);
    vkUpdateDescriptorSets(dev, 4, writes, 0, nullptr);
    return set;
}

Expected<VkDescriptorSet> JpegReconstruct::makeAtlasSet(VkBuffer input, VkDeviceSize inputBytes, VkBuffer planes,
                                                        VkDeviceSize planeOffset, VkDeviceSize planeBytes, VkImageView atlasBase,
                                                        VkBuffer table, VkDeviceSize tableOffset, VkDeviceSize tableBytes) {
    if (output_ != Output::Atlas) return Result(Status::InvalidArgument, "makeAtlasSet: this pipeline writes a buffer");
    VkDevice dev = device_.device();
    Expected<VkDescriptorSet> set = allocateSet(dev, pool_.get(), setLayout_.get());
    if (!set) return set;
    const VkDescriptorBufferInfo infos[3] = {{.buffer = input, .offset = 0, .range = inputBytes},
                                             {.buffer = planes, .offset = planeOffset, .range = planeBytes},
                                             {.buffer = table, .offset = tableOffset, .range = tableBytes}};
    const VkDescriptorImageInfo image{.sampler = VK_NULL_HANDLE, .imageView = atlasBase, .imageLayout = VK_IMAGE_LAYOUT_GENERAL};
    const VkWriteDescriptorSet writes[4] = {
        bufferWrite(*set, 0, &infos[0]), bufferWrite(*set, 1, &infos[1]), bufferWrite(*set, 3, &infos[2]),
        {.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, .pNext = nullptr, .dstSet = *set, .dstBinding = 2,
         .dstArrayElement = 0, .descriptorCount = 1, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
         .pImageInfo = &image, .pBufferInfo = nullptr, .pTexelBufferView = nullptr}};
    vkUpdateDescriptorSets(dev, 4, writes, 0, nullptr);
    return set;
}

void JpegReconstruct::freeSet(VkDescriptorSet set) {
    if (set != VK_NULL_HANDLE) vkFreeDescriptorSets(device_.device(), pool_.get(), 1, &set);
}

void JpegReconstruct::record(VkCommandBuffer cmd, VkDescriptorSet set, const Sizes& sizes) {
    if (sizes.tiles == 0) return;
    const uint32_t tiles = sizes.tiles;
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_.get(), 0, 1, &set, 0, nullptr);
    vkCmdPushConstants(cmd, layout_.get(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof tiles, &tiles);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, idct_.get());
    vkCmdDispatch(cmd, (sizes.maxBlocks + 7) / 8, tiles, 1);
    // The planes written by the first pass, read by the second.
    vk::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                      VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, color_.get());
    vkCmdDispatch(cmd, (sizes.maxWidth + 15) / 16, (sizes.maxHeight + 15) / 16, tiles);
}

} // namespace iris::gpu
