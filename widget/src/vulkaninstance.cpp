#include "vulkaninstance_p.h"

#include <atomic>
#include <mutex>

#include <QtCore/QByteArrayList>
#include <QtCore/QVersionNumber>
#include <QtGui/QVulkanInstance>

#include "logging_p.h"

namespace IrisWidget {

namespace {
constexpr auto kValidationLayer = "VK_LAYER_KHRONOS_validation";
constexpr auto kDebugUtils = "VK_EXT_debug_utils";
} // namespace

namespace {
std::atomic<bool> g_validation{false};
} // namespace

void setValidationRequested(bool on)
{
    g_validation.store(on, std::memory_order_relaxed);
}

bool validationRequested()
{
    return g_validation.load(std::memory_order_relaxed);
}

std::shared_ptr<QVulkanInstance> acquireVulkanInstance(QString *error)
{
    // Only the GUI thread creates widgets, but the lock keeps this honest.
    static std::mutex mutex;
    static std::weak_ptr<QVulkanInstance> shared;
    std::lock_guard lock(mutex);
    if (auto existing = shared.lock())
        return existing;

    auto instance = std::make_shared<QVulkanInstance>();
    instance->setApiVersion(QVersionNumber(1, 3));
    // The engine logs and counts validation messages itself; Qt's own redirect would
    // report them twice.
    instance->setFlags(QVulkanInstance::NoDebugOutputRedirect);
    if (validationRequested()) {
        if (instance->supportedLayers().contains(kValidationLayer)) {
            instance->setLayers({kValidationLayer});
            qCInfo(lcIrisWidget) << "Vulkan validation layer enabled";
        } else {
            qCWarning(lcIrisWidget) << "validation requested but" << kValidationLayer << "is not installed";
        }
        if (instance->supportedExtensions().contains(kDebugUtils))
            instance->setExtensions({kDebugUtils});
    }
    if (!instance->create()) {
        const QString reason = instance->errorCode() == 0
            ? QStringLiteral("this platform has no Vulkan support")
            : QStringLiteral("vkCreateInstance failed (VkResult %1)").arg(instance->errorCode());
        if (error)
            *error = QStringLiteral("Vulkan is not available: %1.").arg(reason);
        qCWarning(lcIrisWidget).noquote() << "cannot create the Vulkan instance:" << reason;
        return nullptr;
    }
    qCDebug(lcIrisWidget) << "Vulkan instance created, API" << instance->apiVersion();
    shared = instance;
    return instance;
}

} // namespace IrisWidget
