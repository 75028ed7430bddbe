// Owned Vulkan handles: move-only, destroyed with their device when the owner goes away, so a
// class that makes Vulkan objects needs no hand-written destroy list and a failed init leaves
// nothing behind. New code uses these (gpu/color_lut_texture, gpu/tile_pipeline); the older
// classes (render_target, tile_atlas, overlay and mip pipelines, the render and buffer
// threads' frame resources) still keep destroy lists and move over as they are touched.
//
//   vk::Owned<VkImage, vkDestroyImage> image;
//   IRIS_VK_TRY(vkCreateImage(dev, &info, nullptr, image.replace(dev)));
#pragma once

#include <utility>

#include <vulkan/vulkan.h>

namespace iris::vk {

template <class H, void(VKAPI_PTR* Destroy)(VkDevice, H, const VkAllocationCallbacks*)>
class Owned {
public:
    Owned() = default;
    Owned(VkDevice dev, H handle) : dev_(dev), handle_(handle) {}
    ~Owned() { reset(); }
    Owned(Owned&& o) noexcept
        : dev_(std::exchange(o.dev_, VK_NULL_HANDLE)), handle_(std::exchange(o.handle_, VK_NULL_HANDLE)) {}
    Owned& operator=(Owned&& o) noexcept {
        if (this != &o) {
            reset();
            dev_ = std::exchange(o.dev_, VK_NULL_HANDLE);
            handle_ = std::exchange(o.handle_, VK_NULL_HANDLE);
        }
        return *this;
    }
    Owned(const Owned&) = delete;
    Owned& operator=(const Owned&) = delete;

    H get() const { return handle_; }
    explicit operator bool() const { return handle_ != VK_NULL_HANDLE; }
    // Destroys the handle held (if any) and returns where a vkCreate* call writes the new one.
    H* replace(VkDevice dev) {
        reset();
        dev_ = dev;
        return &handle_;
    }
    void reset() {
        if (handle_ != VK_NULL_HANDLE) Destroy(dev_, handle_, nullptr);
        handle_ = VK_NULL_HANDLE;
    }

private:
    VkDevice dev_ = VK_NULL_HANDLE;
    H handle_ = VK_NULL_HANDLE;
};

using Image = Owned<VkImage, vkDestroyImage>;
using ImageView = Owned<VkImageView, vkDestroyImageView>;
using Sampler = Owned<VkSampler, vkDestroySampler>;
using Memory = Owned<VkDeviceMemory, vkFreeMemory>;
using Buffer = Owned<VkBuffer, vkDestroyBuffer>;
using ShaderModule = Owned<VkShaderModule, vkDestroyShaderModule>;
using Pipeline = Owned<VkPipeline, vkDestroyPipeline>;
using PipelineLayout = Owned<VkPipelineLayout, vkDestroyPipelineLayout>;
using DescriptorSetLayout = Owned<VkDescriptorSetLayout, vkDestroyDescriptorSetLayout>;
using DescriptorPool = Owned<VkDescriptorPool, vkDestroyDescriptorPool>;
using CommandPool = Owned<VkCommandPool, vkDestroyCommandPool>; // its command buffers go with it
using Fence = Owned<VkFence, vkDestroyFence>;
using Semaphore = Owned<VkSemaphore, vkDestroySemaphore>;
using QueryPool = Owned<VkQueryPool, vkDestroyQueryPool>;
using SwapchainKHR = Owned<VkSwapchainKHR, vkDestroySwapchainKHR>; // its images go with it

} // namespace iris::vk
