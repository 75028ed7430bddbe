#include "gpu/overlay_pipeline.h"

#include <cstddef>

#include <iris_shaders/overlay_frag.h>
#include <iris_shaders/overlay_vert.h>

namespace iris::gpu {

Result OverlayPipeline::init(uint32_t atlasSize) {
    VkDevice dev = device_.device();
    if (Result r = vk::createShaderModule(dev, overlay_vert_spv, sizeof(overlay_vert_spv), *vert_.replace(dev));
        !r.ok())
        return r;
    if (Result r = vk::createShaderModule(dev, overlay_frag_spv, sizeof(overlay_frag_spv), *frag_.replace(dev));
        !r.ok())
        return r;

    constexpr VkFormat kFormat = VK_FORMAT_R8_UNORM; // sampled R8 is mandatory in Vulkan
    const VkImageCreateInfo ici =
        vk::image2D(kFormat, atlasSize, atlasSize, 1, 1, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT);
    if (Result r = vk::createDeviceImage(device_.physical(), dev, ici, atlas_, atlasMemory_); !r.ok()) return r;
    if (Result r = vk::createImageView(dev, atlas_.get(), VK_IMAGE_VIEW_TYPE_2D, kFormat, vk::colorRange(0, 1, 0, 1),
                                       *atlasView_.replace(dev));
        !r.ok())
        return r;
    // The shader uses texelFetch; a sampler is still part of a combined image sampler.
    const VkSamplerCreateInfo sci = vk::clampSampler(VK_FILTER_NEAREST, 0);
    IRIS_VK_TRY(vkCreateSampler(dev, &sci, nullptr, sampler_.replace(dev)));

    return vk::createSampledImageSet(dev, sizeof(OverlayPush), sampler_.get(), atlasView_.get(),
                                     VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, *setLayout_.replace(dev),
                                     *layout_.replace(dev), *pool_.replace(dev), set_);
}

Expected<VkPipeline> OverlayPipeline::pipelineFor(VkFormat format) {
    if (auto it = pipelines_.find(int(format)); it != pipelines_.end()) return it->second.get();
    const VkVertexInputAttributeDescription attrs[3] = {
        {.location = 0, .binding = 0, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .offset = offsetof(OverlayInstance, rect)},
        {.location = 1, .binding = 0, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .offset = offsetof(OverlayInstance, colour)},
        {.location = 2, .binding = 0, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .offset = offsetof(OverlayInstance, glyph)},
    };
    Expected<VkPipeline> p = vk::createInstancedQuadPipeline(device_.device(), layout_.get(), vert_.get(), frag_.get(),
                                                             sizeof(OverlayInstance), attrs, 3, format);
    if (p) pipelines_.emplace(int(format), vk::Pipeline(device_.device(), *p));
    return p;
}

void OverlayPipeline::recordUploads(VkCommandBuffer cmd, VkBuffer staging, const VkBufferImageCopy* regions,
                                    uint32_t count) {
    if (atlasReady_ && count == 0) return;
    const VkImageSubresourceRange range = vk::colorRange(0, 1, 0, 1);
    // Earlier frames sample the atlas in their fragment shaders: an execution dependency is
    // enough before overwriting (write-after-read). The first time its contents are undefined.
    const VkImageMemoryBarrier2 toDst =
        vk::imageBarrier(atlas_.get(), VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_NONE,
                         VK_PIPELINE_STAGE_2_CLEAR_BIT | VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                         atlasReady_ ? VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL : VK_IMAGE_LAYOUT_UNDEFINED,
                         VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, range);
    vk::pipelineBarrier(cmd, &toDst, 1);
    if (!atlasReady_) {
        const VkClearColorValue zero{};
        vkCmdClearColorImage(cmd, atlas_.get(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &zero, 1, &range);
        if (count > 0) {
            const VkImageMemoryBarrier2 clearToCopy =
                vk::imageBarrier(atlas_.get(), VK_PIPELINE_STAGE_2_CLEAR_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                 VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                 VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, range);
            vk::pipelineBarrier(cmd, &clearToCopy, 1);
        }
    }
    if (count > 0)
        vkCmdCopyBufferToImage(cmd, staging, atlas_.get(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, count, regions);
    const VkImageMemoryBarrier2 toRead = vk::imageBarrier(
        atlas_.get(), VK_PIPELINE_STAGE_2_CLEAR_BIT | VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
        VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
        VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, range);
    vk::pipelineBarrier(cmd, &toRead, 1);
    atlasReady_ = true;
}

} // namespace iris::gpu
