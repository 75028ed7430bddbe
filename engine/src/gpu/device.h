// The Vulkan instance (own, or the host's), the physical device, the logical device and its
// queues. Queue families are discovered and reported; see ARCHITECTURE.md for which work
// runs on which queue in this slice.
#pragma once

#include <atomic>
#include <mutex>
#include <string>

#include <vulkan/vulkan.h>

#include "core/log.h"
#include "iris/engine.h"

namespace iris::gpu {

struct QueueFamilies {
    uint32_t graphics = UINT32_MAX; // graphics + compute (+ transfer, implied)
    uint32_t compute = UINT32_MAX;  // a compute family without graphics where one exists
    uint32_t transfer = UINT32_MAX; // a transfer-only family where one exists
};

class Device {
public:
    Device(const Log& log) : log_(log) {}
    ~Device();
    Device(const Device&) = delete;
    Device& operator=(const Device&) = delete;

    Result init(const EngineConfig& config);

    VkInstance instance() const { return instance_; }
    VkPhysicalDevice physical() const { return physical_; }
    VkDevice device() const { return device_; }
    const QueueFamilies& families() const { return families_; }
    const VkPhysicalDeviceProperties& properties() const { return props_; }
    bool hasSwapchain() const { return hasSwapchain_; }
    const std::string& driverName() const { return driver_; }

    // The single queue of this slice (graphics family). VkQueue access must be externally
    // synchronised: every submit/present goes through submit()/present() under queueMutex_.
    VkQueue queue() const { return queue_; }
    uint32_t queueFamily() const { return families_.graphics; }
    VkResult submit(const VkSubmitInfo2& info, VkFence fence);
    VkResult present(const VkPresentInfoKHR& info);
    void waitIdle();

    uint64_t validationMessages() const { return validationMessages_.load(std::memory_order_relaxed); }

private:
    static VKAPI_ATTR VkBool32 VKAPI_CALL debugCallback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                        VkDebugUtilsMessageTypeFlagsEXT types,
                                                        const VkDebugUtilsMessengerCallbackDataEXT* data, void* user);
    Result createInstance(const EngineConfig& config);
    Result pickPhysicalDevice();
    Result createDevice();

    const Log& log_;
    VkInstance instance_ = VK_NULL_HANDLE;
    bool ownsInstance_ = false;
    VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
    VkPhysicalDevice physical_ = VK_NULL_HANDLE;
    VkPhysicalDeviceProperties props_{};
    VkDevice device_ = VK_NULL_HANDLE;
    QueueFamilies families_;
    VkQueue queue_ = VK_NULL_HANDLE;
    std::mutex queueMutex_;
    bool hasSwapchain_ = false;
    std::string driver_;
    std::atomic<uint64_t> validationMessages_{0}; // a counter only: relaxed is enough
};

} // namespace iris::gpu
