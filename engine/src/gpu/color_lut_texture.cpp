#include "gpu/color_lut_texture.h"

#include <algorithm>
#include <cstring>

namespace iris::gpu {

namespace {
constexpr uint32_t kSize = color::kLutSize;
constexpr size_t kTexels = size_t(kSize) * kSize * kSize;
constexpr size_t kBytes = kTexels * 4 * sizeof(uint16_t);

// IEEE half floats of 0 and 1.
constexpr uint16_t kHalfZero = 0x0000, kHalfOne = 0x3C00;
// The table the image holds before the first real one: opaque black. Frames without a
// transform never sample it (their pipelines leave the step out); it only gives the image a
// defined content and layout, which the descriptor set requires.
void writePlaceholder(uint16_t* out) {
    for (size_t i = 0; i < kTexels; ++i) {
        out[4 * i + 0] = out[4 * i + 1] = out[4 * i + 2] = kHalfZero;
        out[4 * i + 3] = kHalfOne;
    }
}
} // namespace

Result ColorLutTexture::init(uint32_t frameSlots) {
    VkDevice dev = device_.device();
    VkImageCreateInfo ici =
        vk::image2D(kFormat, kSize, kSize, 1, 1, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT);
    ici.imageType = VK_IMAGE_TYPE_3D;
    ici.extent.depth = kSize;
    if (Result r = vk::createDeviceImage(device_.physical(), dev, ici, image_, memory_); !r.ok()) return r;
    if (Result r = vk::createImageView(dev, image_.get(), VK_IMAGE_VIEW_TYPE_3D, kFormat, vk::colorRange(0, 1, 0, 1),
                                       *view_.replace(dev));
        !r.ok())
        return r;
    const VkSamplerCreateInfo sci = vk::clampSampler(VK_FILTER_LINEAR, 0);
    IRIS_VK_TRY(vkCreateSampler(dev, &sci, nullptr, sampler_.replace(dev)));
    staging_.resize(frameSlots);
    pending_.assign(frameSlots, false);
    for (vk::MappedBuffer& b : staging_)
        if (Result r =
                vk::createMappedBuffer(device_.physical(), dev, kBytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, false, b);
            !r.ok())
            return r;
    return {};
}

Result ColorLutTexture::prepare(uint32_t slot, std::shared_ptr<const color::Lut3D> lut) {
    if (lut && (lut->size != kSize || lut->rgba.size() != kTexels * 4))
        return Result(Status::InvalidArgument, "a colour table of " + std::to_string(lut->size) +
                                                   "³ entries; the engine's is " + std::to_string(kSize) + "³");
    const bool identity = !lut;
    if (defined_ || std::any_of(pending_.begin(), pending_.end(), [](bool p) { return p; })) {
        if (identity ? currentIsIdentity_ : lut == current_) return {}; // the image holds (or will hold) it
    }
    if (identity && defined_) { // the identity is never sampled: keep whatever table the image has
        current_.reset();
        currentIsIdentity_ = true;
        return {};
    }
    vk::MappedBuffer& b = staging_[slot];
    auto* out = static_cast<uint16_t*>(b.mapped);
    if (identity)
        writePlaceholder(out);
    else
        std::memcpy(out, lut->rgba.data(), kBytes);
    if (Result r = vk::flush(device_.device(), b); !r.ok()) return r;
    std::fill(pending_.begin(), pending_.end(), false); // an older staged table is superseded
    pending_[slot] = true;
    current_ = std::move(lut);
    currentIsIdentity_ = identity;
    return {};
}

void ColorLutTexture::recordUpload(VkCommandBuffer cmd, uint32_t slot) {
    if (!pending_[slot]) return;
    pending_[slot] = false;
    // Earlier frames may still sample the old table: wait for their fragment shading.
    const VkImageMemoryBarrier2 toCopy =
        vk::imageBarrier(image_.get(), VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_NONE,
                         VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                         VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, vk::colorRange(0, 1, 0, 1));
    vk::pipelineBarrier(cmd, &toCopy, 1);
    const VkBufferImageCopy region = vk::wholeImageCopy({kSize, kSize, kSize});
    vkCmdCopyBufferToImage(cmd, staging_[slot].buffer, image_.get(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    const VkImageMemoryBarrier2 toRead =
        vk::imageBarrier(image_.get(), VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                         VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
                         VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, kLayout, vk::colorRange(0, 1, 0, 1));
    vk::pipelineBarrier(cmd, &toRead, 1);
    defined_ = true;
}

} // namespace iris::gpu
