#include "gpu/device.h"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "gpu/vk_util.h"

namespace iris::gpu {

namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

// A failed query counts as "not there": the caller then goes on without the layer or extension.
bool hasLayer(const char* name) {
    uint32_t n = 0;
    if (vkEnumerateInstanceLayerProperties(&n, nullptr) < 0) return false;
    std::vector<VkLayerProperties> layers(n);
    if (vkEnumerateInstanceLayerProperties(&n, layers.data()) < 0) return false;
    layers.resize(n);
    for (const auto& l : layers)
        if (std::strcmp(l.layerName, name) == 0) return true;
    return false;
}

bool hasInstanceExtension(const char* name) {
    uint32_t n = 0;
    if (vkEnumerateInstanceExtensionProperties(nullptr, &n, nullptr) < 0) return false;
    std::vector<VkExtensionProperties> exts(n);
    if (vkEnumerateInstanceExtensionProperties(nullptr, &n, exts.data()) < 0) return false;
    exts.resize(n);
    for (const auto& e : exts)
        if (std::strcmp(e.extensionName, name) == 0) return true;
    return false;
}

} // namespace

// Hand-written, not vk::Owned: that wrapper destroys a child of a VkDevice, and none of these
// is one (the device and the instance have no parent, the messenger's is the instance and its
// destroy function is looked up at run time); the instance may be the host's, which is not
// ours to destroy. The order is fixed: wait, device, messenger, instance. The engine declares
// the Device before every object made from it, so it goes last.
Device::~Device() {
    if (device_) {
        (void)vkDeviceWaitIdle(device_); // going away: a lost device is destroyed all the same
        vkDestroyDevice(device_, nullptr);
    }
    if (messenger_) {
        auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
            vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
        if (destroy) destroy(instance_, messenger_, nullptr);
    }
    if (ownsInstance_ && instance_) vkDestroyInstance(instance_, nullptr);
}

VKAPI_ATTR VkBool32 VKAPI_CALL Device::debugCallback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                     VkDebugUtilsMessageTypeFlagsEXT types,
                                                     const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
    auto* self = static_cast<Device*>(user);
    // Performance advice is logged but not counted: the tile atlas lives in
    // VK_IMAGE_LAYOUT_GENERAL on purpose (uploads into one layer never need a layout change
    // that a frame sampling other layers could trip over), and the layer flags exactly that.
    if (types == VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT) {
        // Logged once: it repeats for every upload.
        if (!self->performanceAdviceLogged_.exchange(true, std::memory_order_relaxed))
            self->log_.debug(std::string("Vulkan performance advice (shown once): ") +
                             (data && data->pMessage ? data->pMessage : "?"));
        return VK_FALSE;
    }
    if (severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
        self->validationMessages_.fetch_add(1, std::memory_order_relaxed);
        self->log_.error(std::string("Vulkan validation: ") + (data && data->pMessage ? data->pMessage : "?"));
    }
    return VK_FALSE;
}

Result Device::init(const EngineConfig& config) {
    tuning_ = config.tuning;
    if (Result r = createInstance(config); !r.ok()) return r;
    if (Result r = pickPhysicalDevice(); !r.ok()) return r;
    return createDevice();
}

Result Device::createInstance(const EngineConfig& config) {
    const bool wantDebugUtils = hasInstanceExtension(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    if (config.instance) {
        instance_ = config.instance;
        ownsInstance_ = false;
    } else {
        std::vector<const char*> layers, exts;
        if (config.validation) {
            if (hasLayer(kValidationLayer)) {
                layers.push_back(kValidationLayer);
            } else {
                log_.warn("Vulkan validation requested but VK_LAYER_KHRONOS_validation is not installed");
            }
        }
        if (wantDebugUtils && !layers.empty()) exts.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
        // Surface extensions, so that a host can bind a window surface to an engine that made
        // its own instance (the widget passes QVulkanInstance's instance instead).
        for (const char* e : {VK_KHR_SURFACE_EXTENSION_NAME, "VK_KHR_xcb_surface", "VK_KHR_xlib_surface",
                              "VK_KHR_wayland_surface"}) {
            if (hasInstanceExtension(e)) exts.push_back(e);
        }
        const VkApplicationInfo app{
            .sType = VK_STRUCTURE_TYPE_APPLICATION_INFO,
            .pNext = nullptr,
            .pApplicationName = "Iris View",
            .applicationVersion = VK_MAKE_VERSION(0, 1, 0),
            .pEngineName = "iris_engine",
            .engineVersion = VK_MAKE_VERSION(0, 1, 0),
            .apiVersion = VK_API_VERSION_1_3,
        };
        const VkInstanceCreateInfo ici{
            .sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO,
            .pNext = nullptr,
            .flags = 0,
            .pApplicationInfo = &app,
            .enabledLayerCount = uint32_t(layers.size()),
            .ppEnabledLayerNames = layers.data(),
            .enabledExtensionCount = uint32_t(exts.size()),
            .ppEnabledExtensionNames = exts.data(),
        };
        const VkResult vr = vkCreateInstance(&ici, nullptr, &instance_);
        if (vr == VK_ERROR_INCOMPATIBLE_DRIVER) {
            return Result(Status::Vulkan, "No Vulkan 1.3 driver found (install mesa-vulkan-drivers for a CPU device)");
        }
        IRIS_VK_TRY(vr);
        ownsInstance_ = true;
    }
    // A messenger on any instance that has the layer enabled; harmless (no messages) otherwise.
    if (config.validation) {
        auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
            vkGetInstanceProcAddr(instance_, "vkCreateDebugUtilsMessengerEXT"));
        if (create) {
            const VkDebugUtilsMessengerCreateInfoEXT mci{
                .sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT,
                .pNext = nullptr,
                .flags = 0,
                .messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                                   VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT,
                .messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                               VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                               VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT,
                .pfnUserCallback = &Device::debugCallback,
                .pUserData = this,
            };
            if (create(instance_, &mci, nullptr, &messenger_) != VK_SUCCESS) messenger_ = VK_NULL_HANDLE;
        }
    }
    return {};
}

Result Device::pickPhysicalDevice() {
    uint32_t n = 0;
    IRIS_VK_TRY(vkEnumeratePhysicalDevices(instance_, &n, nullptr));
    std::vector<VkPhysicalDevice> devices(n);
    IRIS_VK_TRY(vkEnumeratePhysicalDevices(instance_, &n, devices.data()));
    int bestScore = -1;
    std::string rejected;
    const std::string& forced = tuning_.deviceName; // a part of the device's name; empty: any
    for (VkPhysicalDevice pd : devices) {
        VkPhysicalDeviceProperties p;
        vkGetPhysicalDeviceProperties(pd, &p);
        VkPhysicalDeviceVulkan13Features f13{.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
        VkPhysicalDeviceVulkan12Features f12{.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES, .pNext = &f13};
        VkPhysicalDeviceFeatures2 f2{.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, .pNext = &f12};
        vkGetPhysicalDeviceFeatures2(pd, &f2);
        if (p.apiVersion < VK_API_VERSION_1_3 || !f13.synchronization2 || !f13.dynamicRendering ||
            !f12.timelineSemaphore) {
            rejected += std::string(" ") + p.deviceName + " (needs Vulkan 1.3 with synchronization2, dynamic rendering, timeline semaphores);";
            continue;
        }
        if (!forced.empty() && !std::strstr(p.deviceName, forced.c_str())) {
            rejected += std::string(" ") + p.deviceName + " (its name does not contain '" + forced + "');";
            continue;
        }
        int score = 1;
        if (p.deviceType == VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU) score = 4;
        else if (p.deviceType == VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU) score = 3;
        else if (p.deviceType == VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU) score = 2;
        if (score > bestScore) {
            bestScore = score;
            physical_ = pd;
            props_ = p;
        }
    }
    if (!physical_) {
        return Result(Status::Vulkan, "No usable Vulkan device:" + (rejected.empty() ? std::string(" none found") : rejected));
    }
    VkPhysicalDeviceDriverProperties drv{.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
    VkPhysicalDeviceProperties2 p2{.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, .pNext = &drv};
    vkGetPhysicalDeviceProperties2(physical_, &p2);
    driver_ = std::string(drv.driverName) + " " + drv.driverInfo;

    uint32_t qn = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(physical_, &qn, nullptr);
    std::vector<VkQueueFamilyProperties> qf(qn);
    vkGetPhysicalDeviceQueueFamilyProperties(physical_, &qn, qf.data());
    for (uint32_t i = 0; i < qn; ++i) {
        const VkQueueFlags f = qf[i].queueFlags;
        if ((f & VK_QUEUE_GRAPHICS_BIT) && (f & VK_QUEUE_COMPUTE_BIT) && families_.graphics == UINT32_MAX)
            families_.graphics = i;
        if ((f & VK_QUEUE_COMPUTE_BIT) && !(f & VK_QUEUE_GRAPHICS_BIT) && families_.compute == UINT32_MAX)
            families_.compute = i;
        if ((f & VK_QUEUE_TRANSFER_BIT) && !(f & (VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT)) &&
            families_.transfer == UINT32_MAX)
            families_.transfer = i;
    }
    if (families_.graphics == UINT32_MAX) return Result(Status::Vulkan, std::string(props_.deviceName) + " has no graphics+compute queue");
    if (families_.compute == UINT32_MAX) families_.compute = families_.graphics;
    if (families_.transfer == UINT32_MAX) families_.transfer = families_.graphics;
    log_.info(std::string("Vulkan device: ") + props_.deviceName + " (" + driver_ + "); queue families: graphics " +
              std::to_string(families_.graphics) + ", compute " + std::to_string(families_.compute) + ", transfer " +
              std::to_string(families_.transfer));
    return {};
}

Result Device::createDevice() {
    uint32_t n = 0;
    IRIS_VK_TRY(vkEnumerateDeviceExtensionProperties(physical_, nullptr, &n, nullptr));
    std::vector<VkExtensionProperties> exts(n);
    IRIS_VK_TRY(vkEnumerateDeviceExtensionProperties(physical_, nullptr, &n, exts.data()));
    exts.resize(n);
    std::vector<const char*> enable;
    for (const auto& e : exts) {
        if (std::strcmp(e.extensionName, VK_KHR_SWAPCHAIN_EXTENSION_NAME) == 0) {
            enable.push_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
            hasSwapchain_ = true;
        }
    }
    // One queue per distinct family among the roles; tuning.singleQueue forces the
    // single-queue path on any device (to test both paths on one machine).
    const bool single = tuning_.singleQueue;
    const uint32_t roleFamily[3] = {families_.graphics, single ? families_.graphics : families_.compute,
                                    single ? families_.graphics : families_.transfer};
    std::vector<uint32_t> distinct;
    for (int r = 0; r < 3; ++r) {
        auto it = std::find(distinct.begin(), distinct.end(), roleFamily[r]);
        if (it == distinct.end()) {
            queueIndex_[r] = int(distinct.size());
            distinct.push_back(roleFamily[r]);
        } else {
            queueIndex_[r] = int(it - distinct.begin());
        }
    }
    const float priority = 1.0f;
    std::vector<VkDeviceQueueCreateInfo> qcis;
    for (uint32_t fam : distinct) {
        qcis.push_back({.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO,
                        .pNext = nullptr,
                        .flags = 0,
                        .queueFamilyIndex = fam,
                        .queueCount = 1,
                        .pQueuePriorities = &priority});
    }
    VkPhysicalDeviceVulkan13Features f13{.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
    f13.synchronization2 = VK_TRUE;
    f13.dynamicRendering = VK_TRUE;
    VkPhysicalDeviceVulkan12Features f12{.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES, .pNext = &f13};
    f12.timelineSemaphore = VK_TRUE;
    const VkPhysicalDeviceFeatures2 f2{.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, .pNext = &f12, .features = {}};
    const VkDeviceCreateInfo dci{
        .sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO,
        .pNext = &f2,
        .flags = 0,
        .queueCreateInfoCount = uint32_t(qcis.size()),
        .pQueueCreateInfos = qcis.data(),
        .enabledLayerCount = 0,
        .ppEnabledLayerNames = nullptr,
        .enabledExtensionCount = uint32_t(enable.size()),
        .ppEnabledExtensionNames = enable.data(),
        .pEnabledFeatures = nullptr,
    };
    IRIS_VK_TRY(vkCreateDevice(physical_, &dci, nullptr, &device_));
    for (size_t i = 0; i < distinct.size(); ++i) {
        vkGetDeviceQueue(device_, distinct[i], 0, &queues_[i]);
        queueFamily_[i] = distinct[i];
    }
    log_.info("queues in use: graphics family " + std::to_string(family(Role::Graphics)) + ", compute family " +
              std::to_string(family(Role::Compute)) + ", transfer family " + std::to_string(family(Role::Transfer)) +
              (separateFamilies() ? " (separate families: ownership transfers between them)" : " (one queue)"));
    return {};
}

VkResult Device::submit(Role role, const VkSubmitInfo2& info, VkFence fence) {
    if (lost()) return VK_ERROR_DEVICE_LOST; // as a lost device answers every submission
    if (takeFault(role == Role::Graphics ? Fault::LostAtFrameSubmit : Fault::LostAtUploadSubmit)) {
        reportLost(role == Role::Graphics ? "frame submission (injected)" : "upload submission (injected)");
        return VK_ERROR_DEVICE_LOST;
    }
    const int q = queueIndex_[int(role)];
    std::lock_guard lock(queueMutex_[q]);
    return noteResult(vkQueueSubmit2(queues_[q], 1, &info, fence), "vkQueueSubmit2");
}

VkResult Device::present(const VkPresentInfoKHR& info) {
    if (lost()) return VK_ERROR_DEVICE_LOST;
    VkResult r;
    {
        const int q = queueIndex_[int(Role::Graphics)];
        std::lock_guard lock(queueMutex_[q]);
        r = vkQueuePresentKHR(queues_[q], &info);
    }
    // An injected fault lets the present happen (the image goes back to the window system, as
    // after a real fault the driver reports) and then reports the fault.
    if (r >= 0 && takeFault(Fault::SurfaceLostAtPresent)) return VK_ERROR_SURFACE_LOST_KHR;
    if (r >= 0 && takeFault(Fault::LostAtPresent)) {
        reportLost("vkQueuePresentKHR (injected)");
        return VK_ERROR_DEVICE_LOST;
    }
    return noteResult(r, "vkQueuePresentKHR");
}

VkResult Device::waitFence(VkFence fence) {
    const VkResult r = noteResult(vkWaitForFences(device_, 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
    if (r == VK_SUCCESS && takeFault(Fault::LostAtFrameWait)) {
        reportLost("frame fence wait (injected)");
        return VK_ERROR_DEVICE_LOST;
    }
    return r;
}

Result Device::waitIdle() {
    // vkDeviceWaitIdle needs every queue externally synchronised. On a device lost by an
    // injected fault the wait is real (the work submitted before it still runs), so that
    // teardown after it is safe either way; the result then reports the loss.
    VkResult r;
    {
        std::scoped_lock lock(queueMutex_[0], queueMutex_[1], queueMutex_[2]);
        r = vkDeviceWaitIdle(device_);
    }
    noteResult(r, "vkDeviceWaitIdle");
    if (r == VK_SUCCESS && lost()) r = VK_ERROR_DEVICE_LOST;
    return vk::check(r, "vkDeviceWaitIdle");
}

void Device::reportLost(const char* where) {
    if (lost_.exchange(true, std::memory_order_acq_rel)) return; // noticed already
    log_.error(std::string("Vulkan device lost (") + where + ")");
    if (onLost_) onLost_();
}

Result Device::recreate() {
    if (device_) {
        (void)vkDeviceWaitIdle(device_); // lost: returns at once; what it reports is known
        vkDestroyDevice(device_, nullptr);
        device_ = VK_NULL_HANDLE;
    }
    for (VkQueue& q : queues_) q = VK_NULL_HANDLE;
    if (Result r = createDevice(); !r.ok()) return r;
    injected_.store(Fault::None, std::memory_order_release);
    lost_.store(false, std::memory_order_release);
    return {};
}

} // namespace iris::gpu
