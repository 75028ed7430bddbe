// Render targets owned by the render thread: an offscreen RGBA8 image with a host-visible
// readback buffer, or a swapchain on a host's VkSurfaceKHR. Both can be copied into (the
// exact copy of levels at their own scale; a swapchain where its surface allows it).
#pragma once

#include <vector>

#include "gpu/device.h"
#include "gpu/vk_handle.h"
#include "gpu/vk_util.h"

namespace iris::gpu {

class OffscreenTarget {
public:
    // format: RGBA8, or BGRA8 (the atlas's where it is swapped, so that tiles copy into it; the
    // read-back is swapped back to RGBA by the render thread).
    explicit OffscreenTarget(Device& device, VkFormat format = VK_FORMAT_R8G8B8A8_UNORM)
        : device_(device), format_(format) {}
    // storage: the image can also be written by a compute shader (the per-pixel resolve).
    Result init(uint32_t width, uint32_t height, bool storage = false);
    VkFormat format() const { return format_; }
    VkImage image() const { return image_.get(); }
    VkImageView view() const { return view_.get(); }
    const vk::MappedBuffer& readback() const { return readback_; }
    VkExtent2D extent() const { return {width_, height_}; }

private:
    Device& device_;
    VkFormat format_;
    vk::MappedBuffer readback_;
    vk::Memory memory_;
    vk::Image image_;
    vk::ImageView view_;
    uint32_t width_ = 0, height_ = 0;
};

class Swapchain {
public:
    Swapchain(Device& device, VkSurfaceKHR surface) : device_(device), surface_(surface) {}
    // (Re)creates the swapchain at the surface's current extent (or width×height when the
    // surface leaves it to the application). A zero extent (minimised) yields ok() with
    // valid() false: nothing is rendered until the next resize.
    Result recreate(uint32_t width, uint32_t height);
    bool valid() const { return bool(swapchain_); }
    VkSwapchainKHR handle() const { return swapchain_.get(); }
    VkFormat format() const { return format_; }
    // Its images can be copied into (the surface allows VK_IMAGE_USAGE_TRANSFER_DST_BIT).
    bool transferDst() const { return transferDst_; }
    VkExtent2D extent() const { return extent_; }
    // The surface's current extent as the window system reports it now ({UINT32_MAX,
    // UINT32_MAX}: the application chooses; {0, 0} on an error).
    VkExtent2D surfaceExtent() const;
    VkImage image(uint32_t i) const { return images_[i]; }
    VkImageView view(uint32_t i) const { return views_[i].get(); }
    VkSemaphore renderDone(uint32_t i) const { return renderDone_[i].get(); }

private:
    void destroyResources();
    Device& device_;
    VkSurfaceKHR surface_;
    vk::SwapchainKHR swapchain_; // declared first: it goes after its images' views and semaphores
    VkFormat format_ = VK_FORMAT_UNDEFINED;
    bool transferDst_ = false;
    VkExtent2D extent_{};
    std::vector<VkImage> images_;           // the swapchain's own
    std::vector<vk::Semaphore> renderDone_; // one per image: present waits on it
    std::vector<vk::ImageView> views_;
};

} // namespace iris::gpu
