// Iris View widget — not API. The process's QVulkanInstance, shared by every IrisSlideView.
#pragma once

#include <memory>

#include <QtCore/QString>

QT_BEGIN_NAMESPACE
class QVulkanInstance;
QT_END_NAMESPACE

namespace IrisWidget {

// IrisSlideView::setVulkanValidation: when on, an instance created afterwards gets the Khronos
// validation layer (and VK_EXT_debug_utils, so that the engine can count the layer's
// messages), and so do engines. Any thread.
void setValidationRequested(bool on);
bool validationRequested();

// Returns the shared instance (Vulkan 1.3), creating it on first use. It lives as long as
// any holder does; engines and surfaces made on it must be destroyed before the last
// holder lets go. On failure returns null and sets *error to a sentence a user can read.
std::shared_ptr<QVulkanInstance> acquireVulkanInstance(QString *error);

} // namespace IrisWidget
