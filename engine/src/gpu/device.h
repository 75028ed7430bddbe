// The Vulkan instance (own, or the host's), the physical device, the logical device and its
// queues. Queue families are discovered and reported; see ARCHITECTURE.md for which work
// runs on which queue in this slice.
#pragma once

#include <atomic>
#include <functional>
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

    // Queues. Graphics draws and presents; compute generates mips; transfer uploads. Where
    // the device has separate compute / transfer families (and EngineTuning::singleQueue is off),
    // each role has its own VkQueue of its own family; otherwise roles share the graphics
    // queue. A VkQueue must be externally synchronised: every submit/present goes through
    // submit()/present(), under that queue's mutex.
    enum class Role { Graphics = 0, Compute = 1, Transfer = 2 };
    VkQueue queue(Role r = Role::Graphics) const { return queues_[queueIndex_[int(r)]]; }
    uint32_t family(Role r) const { return queueFamily_[queueIndex_[int(r)]]; }
    uint32_t queueFamily() const { return family(Role::Graphics); }
    bool separateFamilies() const { return family(Role::Compute) != family(Role::Graphics) || family(Role::Transfer) != family(Role::Graphics); }
    VkResult submit(const VkSubmitInfo2& info, VkFence fence) { return submit(Role::Graphics, info, fence); }
    VkResult submit(Role role, const VkSubmitInfo2& info, VkFence fence);
    VkResult present(const VkPresentInfoKHR& info);
    // vkDeviceWaitIdle under every queue's mutex; an error (a lost device) is returned.
    [[nodiscard]] Result waitIdle();

    uint64_t validationMessages() const { return validationMessages_.load(std::memory_order_relaxed); }

    // Device loss (docs/ARCHITECTURE.md "Device loss"). The first VK_ERROR_DEVICE_LOST that
    // submit(), present() or waitIdle() sees, or that a thread reports from a wait of its own
    // (reportLost), marks the device lost: every later submission fails at once as on a lost
    // device, and onLost (set before the engine threads start) is called once, from the thread
    // that noticed. recreate() makes a new logical device and queues on the same physical device
    // and instance; only the render thread calls it, once every object made from the old device
    // is gone (RenderThread::recover). properties(), families() and instance() never change.
    void setLostCallback(std::function<void()> onLost) { onLost_ = std::move(onLost); }
    bool lost() const { return lost_.load(std::memory_order_acquire); }
    void reportLost(const char* where);
    [[nodiscard]] Result recreate();
    // Fault injection (Engine::injectFault): the next operation of the kind named fails as the
    // driver would report it. One fault is armed at a time.
    enum class Fault { None, LostAtFrameSubmit, LostAtUploadSubmit, LostAtFrameWait, LostAtPresent, SurfaceLostAtPresent };
    void inject(Fault f) { injected_.store(f, std::memory_order_release); }
    // The render thread's fence waits: VK_ERROR_DEVICE_LOST when a LostAtFrameWait fault is
    // armed (the fence is then waited for all the same, as teardown needs it signalled).
    VkResult waitFence(VkFence fence);

private:
    static VKAPI_ATTR VkBool32 VKAPI_CALL debugCallback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                        VkDebugUtilsMessageTypeFlagsEXT types,
                                                        const VkDebugUtilsMessengerCallbackDataEXT* data, void* user);
    Result createInstance(const EngineConfig& config);
    Result pickPhysicalDevice();
    Result createDevice();
    bool takeFault(Fault f) {
        Fault expected = f;
        return injected_.compare_exchange_strong(expected, Fault::None, std::memory_order_acq_rel);
    }
    // A VK_ERROR_DEVICE_LOST result marks the device lost; any result is passed on.
    VkResult noteResult(VkResult r, const char* where) {
        if (r == VK_ERROR_DEVICE_LOST) reportLost(where);
        return r;
    }

    const Log& log_;
    EngineTuning tuning_; // the device choice and queue roles (EngineConfig::tuning)
    VkInstance instance_ = VK_NULL_HANDLE;
    bool ownsInstance_ = false;
    VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
    VkPhysicalDevice physical_ = VK_NULL_HANDLE;
    VkPhysicalDeviceProperties props_{};
    VkDevice device_ = VK_NULL_HANDLE;
    QueueFamilies families_;
    VkQueue queues_[3] = {};          // distinct VkQueues (up to one per role)
    uint32_t queueFamily_[3] = {};    // family of each distinct queue
    int queueIndex_[3] = {0, 0, 0};   // role → distinct queue
    std::mutex queueMutex_[3];
    bool hasSwapchain_ = false;
    std::string driver_;
    std::atomic<uint64_t> validationMessages_{0}; // a counter only: relaxed is enough
    std::atomic<bool> performanceAdviceLogged_{false};
    std::function<void()> onLost_;
    std::atomic<bool> lost_{false};
    std::atomic<Fault> injected_{Fault::None};
};

} // namespace iris::gpu
