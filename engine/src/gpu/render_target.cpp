#include "gpu/render_target.h"

#include <algorithm>

namespace iris::gpu {

Result OffscreenTarget::init(uint32_t width, uint32_t height, bool storage) {
    VkDevice dev = device_.device();
    width_ = width;
    height_ = height;
    const VkImageCreateInfo ici =
        vk::image2D(format_, width, height, 1, 1,
                    VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT |
                        (storage ? VkImageUsageFlags(VK_IMAGE_USAGE_STORAGE_BIT) : VkImageUsageFlags(0)));
    if (Result r = vk::createDeviceImage(device_.physical(), dev, ici, image_, memory_); !r.ok()) return r;
    if (Result r = vk::createImageView(dev, image_.get(), VK_IMAGE_VIEW_TYPE_2D, format_, vk::colorRange(0, 1, 0, 1),
                                       *view_.replace(dev));
        !r.ok())
        return r;
    return vk::createMappedBuffer(device_.physical(), dev, VkDeviceSize(width) * height * 4,
                                  VK_BUFFER_USAGE_TRANSFER_DST_BIT, /*preferCached=*/true, readback_);
}

void Swapchain::destroyResources() {
    views_.clear();
    renderDone_.clear();
    images_.clear();
}

VkExtent2D Swapchain::surfaceExtent() const {
    VkSurfaceCapabilitiesKHR caps;
    if (vkGetPhysicalDeviceSurfaceCapabilitiesKHR(device_.physical(), surface_, &caps) != VK_SUCCESS) return {0, 0};
    return caps.currentExtent;
}

Result Swapchain::recreate(uint32_t width, uint32_t height) {
    VkDevice dev = device_.device();
    VkPhysicalDevice pd = device_.physical();
    VkBool32 supported = VK_FALSE;
    IRIS_VK_TRY(vkGetPhysicalDeviceSurfaceSupportKHR(pd, device_.queueFamily(), surface_, &supported));
    if (!supported) return Result(Status::Vulkan, "The engine's graphics queue cannot present to this surface");
    VkSurfaceCapabilitiesKHR caps;
    IRIS_VK_TRY(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(pd, surface_, &caps));
    VkExtent2D extent = caps.currentExtent;
    if (extent.width == UINT32_MAX) {
        extent.width = std::clamp(width, caps.minImageExtent.width, caps.maxImageExtent.width);
        extent.height = std::clamp(height, caps.minImageExtent.height, caps.maxImageExtent.height);
    }
    // The old swapchain's images may still be in use by the presentation engine: wait.
    if (Result r = device_.waitIdle(); !r.ok()) return r;
    destroyResources();
    // The old swapchain stays until the new one is made from it; it goes on every path.
    vk::SwapchainKHR old = std::move(swapchain_);
    if (extent.width == 0 || extent.height == 0) return {};
    uint32_t n = 0;
    IRIS_VK_TRY(vkGetPhysicalDeviceSurfaceFormatsKHR(pd, surface_, &n, nullptr));
    std::vector<VkSurfaceFormatKHR> formats(n);
    IRIS_VK_TRY(vkGetPhysicalDeviceSurfaceFormatsKHR(pd, surface_, &n, formats.data()));
    formats.resize(n);
    // UNORM formats: slide bytes go to the screen unchanged (no sRGB encode on write).
    VkSurfaceFormatKHR chosen{VK_FORMAT_UNDEFINED, VK_COLOR_SPACE_SRGB_NONLINEAR_KHR};
    for (VkFormat want : {VK_FORMAT_B8G8R8A8_UNORM, VK_FORMAT_R8G8B8A8_UNORM}) {
        for (const auto& f : formats) {
            if (f.format == want && f.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR && chosen.format == VK_FORMAT_UNDEFINED)
                chosen = f;
        }
    }
    if (chosen.format == VK_FORMAT_UNDEFINED) {
        if (formats.empty()) return Result(Status::Vulkan, "The surface offers no formats");
        chosen = formats[0];
    }
    format_ = chosen.format;
    transferDst_ = (caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT) != 0;
    uint32_t count = std::max(caps.minImageCount + 1, 3u);
    if (caps.maxImageCount) count = std::min(count, caps.maxImageCount);
    const VkSwapchainCreateInfoKHR sci{
        .sType = VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR,
        .pNext = nullptr,
        .flags = 0,
        .surface = surface_,
        .minImageCount = count,
        .imageFormat = chosen.format,
        .imageColorSpace = chosen.colorSpace,
        .imageExtent = extent,
        .imageArrayLayers = 1,
        .imageUsage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT |
                      (caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT),
        .imageSharingMode = VK_SHARING_MODE_EXCLUSIVE,
        .queueFamilyIndexCount = 0,
        .pQueueFamilyIndices = nullptr,
        .preTransform = (caps.supportedTransforms & VK_SURFACE_TRANSFORM_IDENTITY_BIT_KHR)
                            ? VK_SURFACE_TRANSFORM_IDENTITY_BIT_KHR
                            : caps.currentTransform,
        .compositeAlpha =
            (caps.supportedCompositeAlpha & VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR)
                ? VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR
                : VkCompositeAlphaFlagBitsKHR(caps.supportedCompositeAlpha & -caps.supportedCompositeAlpha),
        .presentMode = VK_PRESENT_MODE_FIFO_KHR, // vsync: the monitor's rate, no tearing, always supported
        .clipped = VK_TRUE,
        .oldSwapchain = old.get(),
    };
    const VkResult vr = vkCreateSwapchainKHR(dev, &sci, nullptr, swapchain_.replace(dev));
    old.reset(); // retired by the new one (or by the failure)
    IRIS_VK_TRY(vr);
    extent_ = extent;
    IRIS_VK_TRY(vkGetSwapchainImagesKHR(dev, swapchain_.get(), &n, nullptr));
    images_.resize(n);
    IRIS_VK_TRY(vkGetSwapchainImagesKHR(dev, swapchain_.get(), &n, images_.data()));
    views_.resize(n);
    renderDone_.resize(n);
    const VkSemaphoreCreateInfo semci{.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO, .pNext = nullptr, .flags = 0};
    for (uint32_t i = 0; i < n; ++i) {
        if (Result r = vk::createImageView(dev, images_[i], VK_IMAGE_VIEW_TYPE_2D, format_, vk::colorRange(0, 1, 0, 1),
                                           *views_[i].replace(dev));
            !r.ok())
            return r;
        IRIS_VK_TRY(vkCreateSemaphore(dev, &semci, nullptr, renderDone_[i].replace(dev)));
    }
    return {};
}

} // namespace iris::gpu
