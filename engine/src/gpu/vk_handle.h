// Owned Vulkan handles: move-only, destroyed with their device when the owner goes away, so a
// class that makes Vulkan objects needs no hand-written destroy list and a failed init leaves
// nothing behind. Every engine object is held this way (a persistently mapped buffer by
// vk::MappedBuffer, gpu/vk_util.h, which owns its buffer and memory); only gpu/device.cpp
// destroys by hand: the instance, the device and the debug messenger, which outlive the rest.
//
// Members go in reverse declaration order: declare a handle after what it depends on (the
// memory before the image bound to it, an image before its views). Where the GPU may still
// use an object, the owner's destructor body waits first (device idle, the upload timeline),
// since it runs before the members go. Command buffers and descriptor sets go with their
// pools and stay plain handles.
//
// Creation: a vkCreate* call writes into replace(dev) inside IRIS_VK_TRY, in a function that
// returns Result; a helper that makes one object either takes its out-parameter (pass
// *x.replace(dev)) and returns Result, or returns Expected<H> for the caller to adopt
// (vk::Pipeline(dev, *p)).
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
