#include "gpu/tile_pipeline.h"

#include <cstddef>

#include "gpu/vk_util.h"
#include <iris_shaders/tile_frag.h>
#include <iris_shaders/tile_seam_frag.h>
#include <iris_shaders/tile_seam_vert.h>
#include <iris_shaders/tile_vert.h>

namespace iris::gpu {

TilePipeline::~TilePipeline() {
    VkDevice dev = device_.device();
    if (!dev) return;
    for (auto& [f, p] : pipelines_) vkDestroyPipeline(dev, p, nullptr);
    for (auto& [f, p] : seamPipelines_) vkDestroyPipeline(dev, p, nullptr);
    if (pool_) vkDestroyDescriptorPool(dev, pool_, nullptr);
    if (layout_) vkDestroyPipelineLayout(dev, layout_, nullptr);
    if (setLayout_) vkDestroyDescriptorSetLayout(dev, setLayout_, nullptr);
    if (vert_) vkDestroyShaderModule(dev, vert_, nullptr);
    if (frag_) vkDestroyShaderModule(dev, frag_, nullptr);
    if (seamVert_) vkDestroyShaderModule(dev, seamVert_, nullptr);
    if (seamFrag_) vkDestroyShaderModule(dev, seamFrag_, nullptr);
}

Result TilePipeline::init() {
    VkDevice dev = device_.device();
    if (Result r = vk::createShaderModule(dev, tile_vert_spv, sizeof(tile_vert_spv), vert_); !r.ok()) return r;
    if (Result r = vk::createShaderModule(dev, tile_frag_spv, sizeof(tile_frag_spv), frag_); !r.ok()) return r;
    if (Result r = vk::createShaderModule(dev, tile_seam_vert_spv, sizeof(tile_seam_vert_spv), seamVert_); !r.ok())
        return r;
    if (Result r = vk::createShaderModule(dev, tile_seam_frag_spv, sizeof(tile_seam_frag_spv), seamFrag_); !r.ok())
        return r;

    if (Result r = vk::createSampledImageSet(dev, sizeof(TilePush), atlas_.sampler(), atlas_.view(), VK_IMAGE_LAYOUT_GENERAL,
                                             setLayout_, layout_, pool_, set_);
        !r.ok())
        return r;
    return {};
}

Expected<VkPipeline> TilePipeline::pipelineFor(VkFormat format) {
    return pipelineFor(format, false);
}

Expected<VkPipeline> TilePipeline::seamPipelineFor(VkFormat format) {
    return pipelineFor(format, true);
}

Expected<VkPipeline> TilePipeline::pipelineFor(VkFormat format, bool seams) {
    auto& cache = seams ? seamPipelines_ : pipelines_;
    if (auto it = cache.find(int(format)); it != cache.end()) return it->second;
    // The tile pass reads the sides (to leave the seam bands out); the seam pass also the corners.
    const VkVertexInputAttributeDescription attrs[5] = {
        {.location = 0, .binding = 0, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .offset = offsetof(TileInstance, rect)},
        {.location = 1, .binding = 0, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .offset = offsetof(TileInstance, texel)},
        {.location = 2, .binding = 0, .format = VK_FORMAT_R32_SFLOAT, .offset = offsetof(TileInstance, scale)},
        {.location = 3, .binding = 0, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .offset = offsetof(TileInstance, sides)},
        {.location = 4, .binding = 0, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .offset = offsetof(TileInstance, corners)},
    };
    // Premultiplied "over": tiles are premultiplied RGBA; the target stays opaque.
    Expected<VkPipeline> p = vk::createInstancedQuadPipeline(device_.device(), layout_, seams ? seamVert_ : vert_,
                                                             seams ? seamFrag_ : frag_, sizeof(TileInstance), attrs,
                                                             seams ? 5 : 4, format);
    if (p) cache[int(format)] = *p;
    return p;
}

} // namespace iris::gpu
