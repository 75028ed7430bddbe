#include "gpu/tile_atlas.h"

#include <string>

#include <algorithm>

#include "gpu/vk_util.h"
#include "slide/slide_source.h"

namespace iris::gpu {

uint64_t TileAtlas::bytesPerSlot() {
    uint64_t bytes = 0;
    for (uint32_t m = 0; m < kTileMipLevels; ++m) {
        const uint64_t s = uint64_t(kTileSize) >> m;
        bytes += s * s * 4;
    }
    return bytes;
}

namespace {
// Takes every layer and mip of `image` from UNDEFINED to GENERAL, where it stays, and waits
// for that. The command pool and the fence are this function's: they go on every path.
Result transitionToGeneral(Device& device, VkImage image) {
    VkDevice dev = device.device();
    const VkCommandPoolCreateInfo pci{.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
                                      .pNext = nullptr,
                                      .flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT,
                                      .queueFamilyIndex = device.queueFamily()};
    vk::CommandPool pool;
    IRIS_VK_TRY(vkCreateCommandPool(dev, &pci, nullptr, pool.replace(dev)));
    VkCommandBuffer cmd = VK_NULL_HANDLE; // freed with the pool
    const VkCommandBufferAllocateInfo cai{.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
                                          .pNext = nullptr,
                                          .commandPool = pool.get(),
                                          .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
                                          .commandBufferCount = 1};
    IRIS_VK_TRY(vkAllocateCommandBuffers(dev, &cai, &cmd));
    const VkCommandBufferBeginInfo bi{.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                      .pNext = nullptr,
                                      .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT,
                                      .pInheritanceInfo = nullptr};
    IRIS_VK_TRY(vkBeginCommandBuffer(cmd, &bi));
    const VkImageMemoryBarrier2 b =
        vk::imageBarrier(image, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                         VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                         VK_IMAGE_LAYOUT_GENERAL, vk::colorRange());
    vk::pipelineBarrier(cmd, &b, 1);
    IRIS_VK_TRY(vkEndCommandBuffer(cmd));
    const VkFenceCreateInfo fci{.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO, .pNext = nullptr, .flags = 0};
    vk::Fence fence;
    IRIS_VK_TRY(vkCreateFence(dev, &fci, nullptr, fence.replace(dev)));
    const VkCommandBufferSubmitInfo cbi = vk::commandInfo(cmd);
    const VkSubmitInfo2 si = vk::submitInfo(&cbi);
    IRIS_VK_TRY(device.submit(si, fence.get()));
    const VkFence f = fence.get();
    IRIS_VK_TRY(vkWaitForFences(dev, 1, &f, VK_TRUE, UINT64_MAX));
    return {};
}
} // namespace

Result TileAtlas::create(uint32_t n, bool host) {
    VkDevice dev = device_.device();
    image_.reset();
    memory_.reset(); // a mapping goes with its memory
    mapped_ = nullptr;
    VkImageCreateInfo ici = vk::image2D(format_, uint32_t(kTileSize), uint32_t(kTileSize), kTileMipLevels, n,
                                        VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT |
                                            VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_STORAGE_BIT);
    if (!host) return vk::createDeviceImage(device_.physical(), dev, ici, image_, memory_);
    ici.tiling = VK_IMAGE_TILING_LINEAR;
    vk::Image img;
    vk::Memory mem;
    IRIS_VK_TRY(vkCreateImage(dev, &ici, nullptr, img.replace(dev)));
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(dev, img.get(), &req);
    constexpr VkMemoryPropertyFlags kHost = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    const uint32_t type =
        vk::findMemoryType(device_.physical(), req.memoryTypeBits, kHost, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    if (type == UINT32_MAX) return Result(Status::Vulkan, "no host-visible, coherent memory type holds a linear image");
    const VkMemoryAllocateInfo mai{.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO,
                                   .pNext = nullptr,
                                   .allocationSize = req.size,
                                   .memoryTypeIndex = type};
    IRIS_VK_TRY(vkAllocateMemory(dev, &mai, nullptr, mem.replace(dev)));
    IRIS_VK_TRY(vkBindImageMemory(dev, img.get(), mem.get(), 0));
    void* p = nullptr;
    IRIS_VK_TRY(vkMapMemory(dev, mem.get(), 0, VK_WHOLE_SIZE, 0, &p));
    for (uint32_t m = 0; m < kTileMipLevels; ++m) {
        const VkImageSubresource sub{.aspectMask = VK_IMAGE_ASPECT_COLOR_BIT, .mipLevel = m, .arrayLayer = 0};
        VkSubresourceLayout l;
        vkGetImageSubresourceLayout(dev, img.get(), &sub, &l);
        const VkDeviceSize side = VkDeviceSize(kTileSize) >> m;
        if (l.rowPitch < side * 4 || (n > 1 && l.arrayPitch < l.rowPitch * side))
            return Result(Status::Vulkan, "the linear atlas's layout has rows or layers shorter than a tile's");
        levels_[m] = {l.offset, l.rowPitch, l.arrayPitch};
    }
    mapped_ = static_cast<uint8_t*>(p);
    memory_ = std::move(mem);
    image_ = std::move(img);
    return {};
}

Result TileAtlas::init(uint64_t vramBudgetBytes, uint64_t allocationLimit, VkFormat format, bool hostWritten) {
    VkDevice dev = device_.device();
    format_ = format;
    hostFallback_.clear();
    const auto& limits = device_.properties().limits;
    uint64_t n = vramBudgetBytes / bytesPerSlot();
    n = std::clamp<uint64_t>(n, 64, limits.maxImageArrayLayers);
    requested_ = uint32_t(n);

    VkFormatProperties fp;
    vkGetPhysicalDeviceFormatProperties(device_.physical(), format_, &fp);
    const VkFormatFeatureFlags need = VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT | VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT |
                                      VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT;
    if ((fp.optimalTilingFeatures & need) != need) {
        return Result(Status::Vulkan, std::string("The device cannot sample (linear) and store ") +
                                          (swapped() ? "BGRA8" : "RGBA8") + " images");
    }
    bool host = hostWritten;
    if (host) {
        // Sampled with filtering, copied from (the exact copy) and bound as storage (the mip
        // pipeline's descriptors), like the optimal atlas; and of this many levels and layers.
        const VkFormatFeatureFlags linearNeed =
            need | VK_FORMAT_FEATURE_TRANSFER_SRC_BIT | VK_FORMAT_FEATURE_TRANSFER_DST_BIT;
        VkImageFormatProperties ip{};
        const VkResult r = vkGetPhysicalDeviceImageFormatProperties(
            device_.physical(), format_, VK_IMAGE_TYPE_2D, VK_IMAGE_TILING_LINEAR,
            VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT |
                VK_IMAGE_USAGE_STORAGE_BIT,
            0, &ip);
        if ((fp.linearTilingFeatures & linearNeed) != linearNeed) {
            hostFallback_ = "the device cannot sample, store and copy linear images of this format";
        } else if (r != VK_SUCCESS || ip.maxMipLevels < kTileMipLevels || ip.maxArrayLayers < 64) {
            hostFallback_ = "the device allows no linear image of 9 levels and 64 layers";
        } else {
            n = std::min<uint64_t>(n, ip.maxArrayLayers);
        }
        host = hostFallback_.empty();
    }

    Result made(Status::OutOfMemory, "no room for a tile atlas of 64 slots");
    // Halve the slot count until the allocation succeeds (a budget larger than the device).
    for (const uint64_t first = n; n >= 64; n /= 2) {
        if (allocationLimit > 0 && n * bytesPerSlot() > allocationLimit) {
            made = Result(Status::OutOfMemory, "VK_ERROR_OUT_OF_DEVICE_MEMORY (the allocation limit set for tests)");
            continue;
        }
        made = create(uint32_t(n), host);
        if (made.ok()) break;
        if (host && made.status() != Status::OutOfMemory) {
            // Not a question of size: the usual atlas instead, from the first size again.
            hostFallback_ = made.message();
            host = false;
            n = first * 2;
        }
    }
    if (!made.ok()) return made;

    if (Result r = vk::createImageView(dev, image_.get(), VK_IMAGE_VIEW_TYPE_2D_ARRAY, format_, vk::colorRange(),
                                       *view_.replace(dev));
        !r.ok())
        return r;
    for (uint32_t m = 0; m < kTileMipLevels; ++m) {
        if (Result r = vk::createImageView(dev, image_.get(), VK_IMAGE_VIEW_TYPE_2D_ARRAY, format_,
                                           vk::colorRange(m, 1), *mipViews_[m].replace(dev));
            !r.ok())
            return r;
    }

    const VkSamplerCreateInfo sci = vk::clampSampler(VK_FILTER_LINEAR, float(kTileMipLevels - 1));
    IRIS_VK_TRY(vkCreateSampler(dev, &sci, nullptr, sampler_.replace(dev)));

    // One-time transition of every layer to GENERAL, where the image stays.
    if (Result r = transitionToGeneral(device_, image_.get()); !r.ok()) return r;

    map_ = std::make_unique<TileMap>(uint32_t(n));
    return {};
}

} // namespace iris::gpu
