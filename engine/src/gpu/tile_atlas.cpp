#include "gpu/tile_atlas.h"

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

TileAtlas::~TileAtlas() {
    VkDevice dev = device_.device();
    if (!dev) return;
    if (sampler_) vkDestroySampler(dev, sampler_, nullptr);
    for (VkImageView v : mipViews_)
        if (v) vkDestroyImageView(dev, v, nullptr);
    if (view_) vkDestroyImageView(dev, view_, nullptr);
}

Result TileAtlas::init(uint64_t vramBudgetBytes) {
    VkDevice dev = device_.device();
    const auto& limits = device_.properties().limits;
    uint64_t n = vramBudgetBytes / bytesPerSlot();
    n = std::clamp<uint64_t>(n, 64, limits.maxImageArrayLayers);

    constexpr VkFormat kFormat = VK_FORMAT_R8G8B8A8_UNORM; // UNORM: bytes in, bytes out, no sRGB conversion
    VkFormatProperties fp;
    vkGetPhysicalDeviceFormatProperties(device_.physical(), kFormat, &fp);
    const VkFormatFeatureFlags need = VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT | VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT |
                                      VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT;
    if ((fp.optimalTilingFeatures & need) != need) {
        return Result(Status::Vulkan, "The device cannot sample (linear) and store RGBA8 images");
    }

    Result made(Status::OutOfMemory, "no room for a tile atlas of 64 slots");
    // Halve the slot count until the allocation succeeds (a budget larger than the device).
    for (; n >= 64; n /= 2) {
        const VkImageCreateInfo ici =
            vk::image2D(kFormat, uint32_t(kTileSize), uint32_t(kTileSize), kTileMipLevels, uint32_t(n),
                        VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_STORAGE_BIT);
        made = vk::createDeviceImage(device_.physical(), dev, ici, image_, memory_);
        if (made.ok()) break;
    }
    if (!made.ok()) return made;

    if (Result r =
            vk::createImageView(dev, image_.get(), VK_IMAGE_VIEW_TYPE_2D_ARRAY, kFormat, vk::colorRange(), view_);
        !r.ok())
        return r;
    for (uint32_t m = 0; m < kTileMipLevels; ++m) {
        if (Result r = vk::createImageView(dev, image_.get(), VK_IMAGE_VIEW_TYPE_2D_ARRAY, kFormat,
                                           vk::colorRange(m, 1), mipViews_[m]);
            !r.ok())
            return r;
    }

    const VkSamplerCreateInfo sci = vk::clampSampler(VK_FILTER_LINEAR, float(kTileMipLevels - 1));
    IRIS_VK_TRY(vkCreateSampler(dev, &sci, nullptr, &sampler_));

    // One-time transition of every layer to GENERAL, where the image stays.
    VkCommandPool pool;
    const VkCommandPoolCreateInfo pci{.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
                                      .pNext = nullptr,
                                      .flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT,
                                      .queueFamilyIndex = device_.queueFamily()};
    IRIS_VK_TRY(vkCreateCommandPool(dev, &pci, nullptr, &pool));
    VkCommandBuffer cmd;
    const VkCommandBufferAllocateInfo cai{.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
                                          .pNext = nullptr,
                                          .commandPool = pool,
                                          .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
                                          .commandBufferCount = 1};
    // Each step runs only if the one before succeeded; the first failure is reported, and the
    // fence and the pool go away on every path.
    VkResult sr = vkAllocateCommandBuffers(dev, &cai, &cmd);
    const VkCommandBufferBeginInfo bi{.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                      .pNext = nullptr,
                                      .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT,
                                      .pInheritanceInfo = nullptr};
    if (sr == VK_SUCCESS) sr = vkBeginCommandBuffer(cmd, &bi);
    const VkImageMemoryBarrier2 b =
        vk::imageBarrier(image_.get(), VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                         VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                         VK_IMAGE_LAYOUT_GENERAL, vk::colorRange());
    if (sr == VK_SUCCESS) {
        vk::pipelineBarrier(cmd, &b, 1);
        sr = vkEndCommandBuffer(cmd);
    }
    VkFence fence = VK_NULL_HANDLE;
    const VkFenceCreateInfo fci{.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO, .pNext = nullptr, .flags = 0};
    if (sr == VK_SUCCESS) sr = vkCreateFence(dev, &fci, nullptr, &fence);
    const VkCommandBufferSubmitInfo cbi = vk::commandInfo(cmd);
    const VkSubmitInfo2 si = vk::submitInfo(&cbi);
    if (sr == VK_SUCCESS) sr = device_.submit(si, fence);
    if (sr == VK_SUCCESS) sr = vkWaitForFences(dev, 1, &fence, VK_TRUE, UINT64_MAX);
    if (fence) vkDestroyFence(dev, fence, nullptr);
    vkDestroyCommandPool(dev, pool, nullptr);
    IRIS_VK_TRY(sr);

    map_ = std::make_unique<TileMap>(uint32_t(n));
    return {};
}

} // namespace iris::gpu
