// Render targets owned by the render thread: an offscreen RGBA8 image with a host-visible
// readback buffer, or a swapchain on a host's VkSurfaceKHR.
#pragma once

#include <vector>

#include "gpu/device.h"
#include "gpu/vk_util.h"

namespace iris::gpu {

class OffscreenTarget {
public:
    OffscreenTarget(Device& device) : device_(device) {}
    ~OffscreenTarget();
    // storage: the image can also be written by a compute shader (the per-pixel resolve).
    Result init(uint32_t width, uint32_t height, bool storage = false);
    static constexpr VkFormat kFormat = VK_FORMAT_R8G8B8A8_UNORM;
    VkImage image() const { return image_.get(); }
    VkImageView view() const { return view_; }
    const vk::MappedBuffer& readback() const { return readback_; }
    VkExtent2D extent() const { return {width_, height_}; }

private:
    Device& device_;
    vk::Memory memory_;
    vk::Image image_;
    VkImageView view_ = VK_NULL_HANDLE;
    vk::MappedBuffer readback_;
    uint32_t width_ = 0, height_ = 0;
};

class Swapchain {
public:
    Swapchain(Device& device, VkSurfaceKHR surface) : device_(device), surface_(surface) {}
    ~Swapchain();
    // (Re)creates the swapchain at the surface's current extent (or width×height when the
    // surface leaves it to the application). A zero extent (minimised) yields ok() with
    // valid() false: nothing is rendered until the next resize.
    Result recreate(uint32_t width, uint32_t height);
    bool valid() const { return swapchain_ != VK_NULL_HANDLE; }
    VkSwapchainKHR handle() const { return swapchain_; }
    VkFormat format() const { return format_; }
    VkExtent2D extent() const { return extent_; }
    // The surface's current extent as the window system reports it now ({UINT32_MAX,
    // UINT32_MAX}: the application chooses; {0, 0} on an error).
    VkExtent2D surfaceExtent() const;
    VkImage image(uint32_t i) const { return images_[i]; }
    VkImageView view(uint32_t i) const { return views_[i]; }
    VkSemaphore renderDone(uint32_t i) const { return renderDone_[i]; }

private:
    void destroyResources();
    Device& device_;
    VkSurfaceKHR surface_;
    VkSwapchainKHR swapchain_ = VK_NULL_HANDLE;
    VkFormat format_ = VK_FORMAT_UNDEFINED;
    VkExtent2D extent_{};
    std::vector<VkImage> images_;
    std::vector<VkImageView> views_;
    std::vector<VkSemaphore> renderDone_; // one per image: present waits on it
};

} // namespace iris::gpu
