#include "gpu/tile_pipeline.h"

#include <cstddef>

#include "gpu/vk_util.h"
#include <iris_shaders/tile_frag.h>
#include <iris_shaders/tile_seam_frag.h>
#include <iris_shaders/tile_seam_vert.h>
#include <iris_shaders/tile_vert.h>

namespace iris::gpu {

Result TilePipeline::init(uint32_t frameSlots, EngineTuning::ColorLookup lookup) {
    VkDevice dev = device_.device();
    lutSampled_ = lookup != EngineTuning::ColorLookup::Nodes;
    const auto module = [&](const uint32_t* code, size_t bytes, vk::ShaderModule& out) {
        return vk::createShaderModule(dev, code, bytes, *out.replace(dev));
    };
    if (Result r = module(tile_vert_spv, sizeof(tile_vert_spv), vert_); !r.ok()) return r;
    if (Result r = module(tile_frag_spv, sizeof(tile_frag_spv), frag_); !r.ok()) return r;
    if (Result r = module(tile_seam_vert_spv, sizeof(tile_seam_vert_spv), seamVert_); !r.ok()) return r;
    if (Result r = module(tile_seam_frag_spv, sizeof(tile_seam_frag_spv), seamFrag_); !r.ok()) return r;

    if (Result r = colorLut_.init(frameSlots); !r.ok()) return r;
    const vk::SampledImage images[2] = {{atlas_.sampler(), atlas_.view(), VK_IMAGE_LAYOUT_GENERAL},
                                        {colorLut_.sampler(), colorLut_.view(), ColorLutTexture::kLayout}};
    return vk::createSampledImageSet(dev, sizeof(TilePush), images, *setLayout_.replace(dev), *layout_.replace(dev),
                                     *pool_.replace(dev), set_);
}

namespace {

// The tile shaders' specialization: the colour step's two constants (ColorSpecialization) and
// tile.frag's EXACT (constant 2; the seam shader has none, and ignores it).
struct TileSpecialization {
    VkBool32 values[3];
    VkSpecializationMapEntry entries[3] = {{.constantID = 0, .offset = 0, .size = sizeof(VkBool32)},
                                           {.constantID = 1, .offset = sizeof(VkBool32), .size = sizeof(VkBool32)},
                                           {.constantID = 2, .offset = 2 * sizeof(VkBool32), .size = sizeof(VkBool32)}};
    VkSpecializationInfo info;
    TileSpecialization(const ColorSpecialization& color, bool exact)
        : values{color.values[0], color.values[1], exact ? VK_TRUE : VK_FALSE},
          info{.mapEntryCount = 3, .pMapEntries = entries, .dataSize = sizeof(values), .pData = values} {}
    TileSpecialization(const TileSpecialization&) = delete; // `info` points into the object
    TileSpecialization& operator=(const TileSpecialization&) = delete;
};

} // namespace

Expected<VkPipeline> TilePipeline::pipelineFor(VkFormat format, bool colorManaged, bool exact) {
    return create(format, false, colorManaged, exact);
}

Expected<VkPipeline> TilePipeline::seamPipelineFor(VkFormat format, bool colorManaged) {
    return create(format, true, colorManaged, false);
}

Expected<VkPipeline> TilePipeline::create(VkFormat format, bool seams, bool colorManaged, bool exact) {
    const uint64_t key = uint64_t(format) * 8 + (exact ? 4 : 0) + (seams ? 2 : 0) + (colorManaged ? 1 : 0);
    if (auto it = pipelines_.find(key); it != pipelines_.end()) return it->second.get();
    // The tile pass reads the sides (to leave the seam bands out); the seam pass also the corners.
    const VkVertexInputAttributeDescription attrs[5] = {
        {.location = 0, .binding = 0, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .offset = offsetof(TileInstance, rect)},
        {.location = 1, .binding = 0, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .offset = offsetof(TileInstance, texel)},
        {.location = 2, .binding = 0, .format = VK_FORMAT_R32_SFLOAT, .offset = offsetof(TileInstance, scale)},
        {.location = 3, .binding = 0, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .offset = offsetof(TileInstance, sides)},
        {.location = 4, .binding = 0, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .offset = offsetof(TileInstance, corners)},
    };
    // Premultiplied "over": tiles are premultiplied RGBA; the target stays opaque.
    const TileSpecialization spec(ColorSpecialization(colorManaged, lutSampled_), exact);
    Expected<VkPipeline> p = vk::createInstancedQuadPipeline(
        device_.device(), layout_.get(), (seams ? seamVert_ : vert_).get(), (seams ? seamFrag_ : frag_).get(),
        sizeof(TileInstance), attrs, seams ? 5 : 4, format, &spec.info);
    if (p) pipelines_.emplace(key, vk::Pipeline(device_.device(), *p));
    return p;
}

} // namespace iris::gpu
