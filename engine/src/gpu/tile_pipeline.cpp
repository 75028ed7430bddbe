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

    if (Result r = vk::createSampledImageSet(dev, sizeof(TilePush), atlas_.sampler(), atlas_.view(), VK_IMAGE_LAYOUT_GENERAL,
                                             setLayout_, layout_, pool_, set_);
        !r.ok())
        return r;
    return {};
}

Expected<VkPipeline> TilePipeline::pipelineFor(VkFormat format) {
    if (auto it = pipelines_.find(int(format)); it != pipelines_.end()) return it->second;
    const VkVertexInputAttributeDescription attrs[5] = {
        {.location = 0, .binding = 0, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .offset = offsetof(TileInstance, rect)},
        {.location = 1, .binding = 0, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .offset = offsetof(TileInstance, texel)},
        {.location = 2, .binding = 0, .format = VK_FORMAT_R32_SFLOAT, .offset = offsetof(TileInstance, scale)},
        {.location = 3, .binding = 0, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .offset = offsetof(TileInstance, sides)},
        {.location = 4, .binding = 0, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .offset = offsetof(TileInstance, corners)},
    };
    // Premultiplied "over": tiles are premultiplied RGBA; the target stays opaque.
    Expected<VkPipeline> p = vk::createInstancedQuadPipeline(device_.device(), layout_, vert_, frag_, sizeof(TileInstance),
                                                             attrs, 5, format);
    if (p) pipelines_[int(format)] = *p;
    return p;
}

} // namespace iris::gpu
