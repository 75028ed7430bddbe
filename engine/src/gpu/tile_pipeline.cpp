#include "gpu/tile_pipeline.h"

#include <cstddef>

#include "gpu/vk_util.h"
#include <iris_shaders/tile_frag.h>
#include <iris_shaders/tile_vert.h>

namespace iris::gpu {

TilePipeline::~TilePipeline() {
    VkDevice dev = device_.device();
    if (!dev) return;
    for (auto& [f, p] : pipelines_) vkDestroyPipeline(dev, p, nullptr);
    if (pool_) vkDestroyDescriptorPool(dev, pool_, nullptr);
    if (layout_) vkDestroyPipelineLayout(dev, layout_, nullptr);
    if (setLayout_) vkDestroyDescriptorSetLayout(dev, setLayout_, nullptr);
    if (vert_) vkDestroyShaderModule(dev, vert_, nullptr);
    if (frag_) vkDestroyShaderModule(dev, frag_, nullptr);
}

Result TilePipeline::init() {
    VkDevice dev = device_.device();
    if (Result r = vk::createShaderModule(dev, tile_vert_spv, sizeof(tile_vert_spv), vert_); !r.ok()) return r;
    if (Result r = vk::createShaderModule(dev, tile_frag_spv, sizeof(tile_frag_spv), frag_); !r.ok()) return r;

    const VkDescriptorSetLayoutBinding binding{
        .binding = 0,
        .descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
        .descriptorCount = 1,
        .stageFlags = VK_SHADER_STAGE_FRAGMENT_BIT,
        .pImmutableSamplers = nullptr,
    };
    const VkDescriptorSetLayoutCreateInfo dslci{
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO, .pNext = nullptr, .flags = 0, .bindingCount = 1, .pBindings = &binding};
    IRIS_VK_TRY(vkCreateDescriptorSetLayout(dev, &dslci, nullptr, &setLayout_));
    const VkPushConstantRange push{.stageFlags = VK_SHADER_STAGE_VERTEX_BIT, .offset = 0, .size = sizeof(TilePush)};
    const VkPipelineLayoutCreateInfo plci{
        .sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
        .pNext = nullptr,
        .flags = 0,
        .setLayoutCount = 1,
        .pSetLayouts = &setLayout_,
        .pushConstantRangeCount = 1,
        .pPushConstantRanges = &push,
    };
    IRIS_VK_TRY(vkCreatePipelineLayout(dev, &plci, nullptr, &layout_));

    const VkDescriptorPoolSize ps{.type = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, .descriptorCount = 1};
    const VkDescriptorPoolCreateInfo dpci{
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO, .pNext = nullptr, .flags = 0, .maxSets = 1, .poolSizeCount = 1, .pPoolSizes = &ps};
    IRIS_VK_TRY(vkCreateDescriptorPool(dev, &dpci, nullptr, &pool_));
    const VkDescriptorSetAllocateInfo dsai{
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO, .pNext = nullptr, .descriptorPool = pool_, .descriptorSetCount = 1, .pSetLayouts = &setLayout_};
    IRIS_VK_TRY(vkAllocateDescriptorSets(dev, &dsai, &set_));
    const VkDescriptorImageInfo ii{.sampler = atlas_.sampler(), .imageView = atlas_.view(), .imageLayout = VK_IMAGE_LAYOUT_GENERAL};
    const VkWriteDescriptorSet w{
        .sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
        .pNext = nullptr,
        .dstSet = set_,
        .dstBinding = 0,
        .dstArrayElement = 0,
        .descriptorCount = 1,
        .descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
        .pImageInfo = &ii,
        .pBufferInfo = nullptr,
        .pTexelBufferView = nullptr,
    };
    vkUpdateDescriptorSets(dev, 1, &w, 0, nullptr);
    return {};
}

Expected<VkPipeline> TilePipeline::pipelineFor(VkFormat format) {
    if (auto it = pipelines_.find(int(format)); it != pipelines_.end()) return it->second;
    const VkVertexInputAttributeDescription attrs[3] = {
        {.location = 0, .binding = 0, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .offset = offsetof(TileInstance, rect)},
        {.location = 1, .binding = 0, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .offset = offsetof(TileInstance, texel)},
        {.location = 2, .binding = 0, .format = VK_FORMAT_R32_SFLOAT, .offset = offsetof(TileInstance, scale)},
    };
    // Premultiplied "over": tiles are premultiplied RGBA; the target stays opaque.
    Expected<VkPipeline> p = vk::createInstancedQuadPipeline(device_.device(), layout_, vert_, frag_, sizeof(TileInstance),
                                                             attrs, 3, format);
    if (p) pipelines_[int(format)] = *p;
    return p;
}

} // namespace iris::gpu
