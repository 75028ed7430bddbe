// Small Vulkan helpers: VkResult → Result, synchronization2 barrier builders, memory types.
#pragma once

#include <array>

#include <span>
#include <string>
#include <utility>

#include <vulkan/vulkan.h>

#include "gpu/vk_handle.h"
#include "iris/types.h"

namespace iris::vk {

const char* resultName(VkResult r);

// VkResult < 0 is an error (DeviceLost gets its own status); ≥ 0 is success, including
// VK_SUBOPTIMAL_KHR, which the swapchain code handles itself.
Result check(VkResult r, const char* what);

#define IRIS_VK_TRY(expr)                                                   \
    do {                                                                    \
        if (::iris::Result iris_r_ = ::iris::vk::check((expr), #expr); !iris_r_.ok()) \
            return iris_r_;                                                 \
    } while (0)

uint32_t findMemoryType(VkPhysicalDevice pd, uint32_t typeBits, VkMemoryPropertyFlags required,
                        VkMemoryPropertyFlags preferred = 0);

inline VkImageSubresourceRange colorRange(uint32_t baseMip = 0, uint32_t mipCount = VK_REMAINING_MIP_LEVELS,
                                          uint32_t baseLayer = 0, uint32_t layerCount = VK_REMAINING_ARRAY_LAYERS) {
    return {VK_IMAGE_ASPECT_COLOR_BIT, baseMip, mipCount, baseLayer, layerCount};
}

// A copy between a buffer of tightly packed texels and the whole of mip 0, layer 0 of an image.
inline VkBufferImageCopy wholeImageCopy(VkExtent3D extent) {
    return {.bufferOffset = 0,
            .bufferRowLength = 0,
            .bufferImageHeight = 0,
            .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
            .imageOffset = {0, 0, 0},
            .imageExtent = extent};
}

inline VkImageMemoryBarrier2 imageBarrier(VkImage image, VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                                          VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess,
                                          VkImageLayout oldLayout, VkImageLayout newLayout,
                                          VkImageSubresourceRange range) {
    return VkImageMemoryBarrier2{
        .sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2,
        .pNext = nullptr,
        .srcStageMask = srcStage,
        .srcAccessMask = srcAccess,
        .dstStageMask = dstStage,
        .dstAccessMask = dstAccess,
        .oldLayout = oldLayout,
        .newLayout = newLayout,
        .srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
        .dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
        .image = image,
        .subresourceRange = range,
    };
}

// One vkCmdPipelineBarrier2 over image and buffer barriers.
inline void pipelineBarrier(VkCommandBuffer cmd, const VkImageMemoryBarrier2* images, uint32_t imageCount,
                            const VkBufferMemoryBarrier2* buffers = nullptr, uint32_t bufferCount = 0) {
    const VkDependencyInfo dep{
        .sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO,
        .pNext = nullptr,
        .dependencyFlags = 0,
        .memoryBarrierCount = 0,
        .pMemoryBarriers = nullptr,
        .bufferMemoryBarrierCount = bufferCount,
        .pBufferMemoryBarriers = buffers,
        .imageMemoryBarrierCount = imageCount,
        .pImageMemoryBarriers = images,
    };
    vkCmdPipelineBarrier2(cmd, &dep);
}

// A 2D optimal-tiling, exclusive image starting UNDEFINED.
inline VkImageCreateInfo image2D(VkFormat format, uint32_t width, uint32_t height, uint32_t mipLevels, uint32_t layers,
                                 VkImageUsageFlags usage) {
    return VkImageCreateInfo{
        .sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO,
        .pNext = nullptr,
        .flags = 0,
        .imageType = VK_IMAGE_TYPE_2D,
        .format = format,
        .extent = {width, height, 1},
        .mipLevels = mipLevels,
        .arrayLayers = layers,
        .samples = VK_SAMPLE_COUNT_1_BIT,
        .tiling = VK_IMAGE_TILING_OPTIMAL,
        .usage = usage,
        .sharingMode = VK_SHARING_MODE_EXCLUSIVE,
        .queueFamilyIndexCount = 0,
        .pQueueFamilyIndices = nullptr,
        .initialLayout = VK_IMAGE_LAYOUT_UNDEFINED,
    };
}

// A clamp-to-edge sampler of `filter` (also between mips) over mips [0, maxLod].
inline VkSamplerCreateInfo clampSampler(VkFilter filter, float maxLod) {
    return VkSamplerCreateInfo{
        .sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO,
        .pNext = nullptr,
        .flags = 0,
        .magFilter = filter,
        .minFilter = filter,
        .mipmapMode = filter == VK_FILTER_LINEAR ? VK_SAMPLER_MIPMAP_MODE_LINEAR : VK_SAMPLER_MIPMAP_MODE_NEAREST,
        .addressModeU = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE,
        .addressModeV = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE,
        .addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE,
        .mipLodBias = 0,
        .anisotropyEnable = VK_FALSE,
        .maxAnisotropy = 1,
        .compareEnable = VK_FALSE,
        .compareOp = VK_COMPARE_OP_ALWAYS,
        .minLod = 0,
        .maxLod = maxLod,
        .borderColor = VK_BORDER_COLOR_FLOAT_TRANSPARENT_BLACK,
        .unnormalizedCoordinates = VK_FALSE,
    };
}

// Creates an image bound to its own device-local allocation into `image` and `memory`
// (replacing what they held). On failure both are left empty and the result names the step
// that failed (Status::OutOfMemory also when no memory type fits).
Result createDeviceImage(VkPhysicalDevice pd, VkDevice dev, const VkImageCreateInfo& info, Image& image,
                         Memory& memory);

// A buffer bound to its own device-local allocation; same contract as createDeviceImage.
Result createDeviceBuffer(VkPhysicalDevice pd, VkDevice dev, VkDeviceSize size, VkBufferUsageFlags usage,
                          Buffer& buffer, Memory& memory);

// A timestamp query pool of `count` queries for work on `family`, and the nanoseconds per
// tick. `pool` stays null (and the result ok) when that family has no timestamps.
Result createTimestampPool(VkPhysicalDevice pd, VkDevice dev, uint32_t family, uint32_t count, VkQueryPool& pool,
                           double& periodNs);

// Submission builders (synchronization2). The returned structs point at what they were given:
// keep those alive until the submit call.
inline VkCommandBufferSubmitInfo commandInfo(VkCommandBuffer cmd) {
    return VkCommandBufferSubmitInfo{
        .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO, .pNext = nullptr, .commandBuffer = cmd, .deviceMask = 0};
}
inline VkSemaphoreSubmitInfo semaphoreInfo(VkSemaphore sem, uint64_t value, VkPipelineStageFlags2 stage) {
    return VkSemaphoreSubmitInfo{.sType = VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO,
                                 .pNext = nullptr,
                                 .semaphore = sem,
                                 .value = value,
                                 .stageMask = stage,
                                 .deviceIndex = 0};
}
inline VkSubmitInfo2 submitInfo(const VkCommandBufferSubmitInfo* cmd, const VkSemaphoreSubmitInfo* waits = nullptr,
                                uint32_t waitCount = 0, const VkSemaphoreSubmitInfo* signals = nullptr,
                                uint32_t signalCount = 0) {
    return VkSubmitInfo2{.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO_2,
                         .pNext = nullptr,
                         .flags = 0,
                         .waitSemaphoreInfoCount = waitCount,
                         .pWaitSemaphoreInfos = waits,
                         .commandBufferInfoCount = 1,
                         .pCommandBufferInfos = cmd,
                         .signalSemaphoreInfoCount = signalCount,
                         .pSignalSemaphoreInfos = signals};
}

inline void pipelineBarrier(VkCommandBuffer cmd, const VkBufferMemoryBarrier2& barrier) {
    pipelineBarrier(cmd, nullptr, 0, &barrier, 1);
}

// One vkCmdPipelineBarrier2 over a global memory barrier (src → dst) and image barriers.
inline void memoryBarrier(VkCommandBuffer cmd, VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                          VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess,
                          const VkImageMemoryBarrier2* images = nullptr, uint32_t imageCount = 0) {
    const VkMemoryBarrier2 memory{.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                  .pNext = nullptr,
                                  .srcStageMask = srcStage,
                                  .srcAccessMask = srcAccess,
                                  .dstStageMask = dstStage,
                                  .dstAccessMask = dstAccess};
    const VkDependencyInfo dep{
        .sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO,
        .pNext = nullptr,
        .dependencyFlags = 0,
        .memoryBarrierCount = 1,
        .pMemoryBarriers = &memory,
        .bufferMemoryBarrierCount = 0,
        .pBufferMemoryBarriers = nullptr,
        .imageMemoryBarrierCount = imageCount,
        .pImageMemoryBarriers = images,
    };
    vkCmdPipelineBarrier2(cmd, &dep);
}

// A colour view of `range` of an image.
Result createImageView(VkDevice dev, VkImage image, VkImageViewType type, VkFormat format,
                       VkImageSubresourceRange range, VkImageView& out);

// A shader module from SPIR-V words (the generated iris_shaders headers).
Result createShaderModule(VkDevice dev, const uint32_t* code, size_t bytes, VkShaderModule& out);

// One image a fragment shader samples (a combined image sampler binding).
struct SampledImage {
    VkSampler sampler = VK_NULL_HANDLE;
    VkImageView view = VK_NULL_HANDLE;
    VkImageLayout layout = VK_IMAGE_LAYOUT_UNDEFINED;
};

// The descriptor state of a pipeline that samples `images` in its fragment shader (bindings 0,
// 1, … in that order, combined image samplers) and takes `pushBytes` of vertex push constants:
// the set layout, the pipeline layout, a pool of one set and that set, written with the images.
// On failure what was made stays in the out-parameters for the caller's destructor.
Result createSampledImageSet(VkDevice dev, uint32_t pushBytes, std::span<const SampledImage> images,
                             VkDescriptorSetLayout& setLayout, VkPipelineLayout& pipelineLayout, VkDescriptorPool& pool,
                             VkDescriptorSet& set);
inline Result createSampledImageSet(VkDevice dev, uint32_t pushBytes, VkSampler sampler, VkImageView view,
                                    VkImageLayout imageLayout, VkDescriptorSetLayout& setLayout,
                                    VkPipelineLayout& pipelineLayout, VkDescriptorPool& pool, VkDescriptorSet& set) {
    const SampledImage image{sampler, view, imageLayout};
    return createSampledImageSet(dev, pushBytes, std::span(&image, 1), setLayout, pipelineLayout, pool, set);
}

// A graphics pipeline that draws one quad per instance (a 4-vertex triangle strip whose
// corners the vertex shader makes from gl_VertexIndex) into one colour attachment of
// `format` (dynamic rendering), blending premultiplied "over" (ONE, ONE_MINUS_SRC_ALPHA).
// Viewport and scissor are dynamic. The per-instance attributes are at binding 0.
Expected<VkPipeline> createInstancedQuadPipeline(VkDevice dev, VkPipelineLayout layout, VkShaderModule vert,
                                                 VkShaderModule frag, uint32_t instanceStride,
                                                 const VkVertexInputAttributeDescription* attributes,
                                                 uint32_t attributeCount, VkFormat format,
                                                 const VkSpecializationInfo* fragSpecialization = nullptr);
// The same blending and dynamic state for any vertex input rate and topology (the annotation
// pass's fill triangles are a per-vertex triangle list). A stride of 0 declares no vertex
// binding: the vertex shader makes everything from gl_VertexIndex (the layer pass).
Expected<VkPipeline> createBlendedPipeline(VkDevice dev, VkPipelineLayout layout, VkShaderModule vert,
                                           VkShaderModule frag, uint32_t stride, VkVertexInputRate inputRate,
                                           VkPrimitiveTopology topology,
                                           const VkVertexInputAttributeDescription* attributes,
                                           uint32_t attributeCount, VkFormat format,
                                           const VkSpecializationInfo* fragSpecialization = nullptr);

// A compute pipeline of `module`'s "main" with `layout` and, optionally, specialization
// constants.
Expected<VkPipeline> createComputePipeline(VkDevice dev, VkPipelineLayout layout, VkShaderModule module,
                                           const VkSpecializationInfo* specialization = nullptr);

// A host-visible buffer, persistently mapped, that owns its buffer and memory: they go with it
// (freeing the memory unmaps it). Move-only. `buffer` and `mapped` show what it owns, as plain
// fields because recording code takes the handle's address (vkCmdBindVertexBuffers): read
// them, never assign them.
class MappedBuffer {
public:
    MappedBuffer() = default;
    MappedBuffer(MappedBuffer&& o) noexcept { *this = std::move(o); }
    MappedBuffer& operator=(MappedBuffer&& o) noexcept {
        if (this != &o) {
            buffer_ = std::move(o.buffer_); // the old buffer goes before its memory
            memory_ = std::move(o.memory_);
            buffer = std::exchange(o.buffer, VK_NULL_HANDLE);
            mapped = std::exchange(o.mapped, nullptr);
            size = std::exchange(o.size, 0);
            coherent = std::exchange(o.coherent, true);
        }
        return *this;
    }
    MappedBuffer(const MappedBuffer&) = delete;
    MappedBuffer& operator=(const MappedBuffer&) = delete;

    VkBuffer buffer = VK_NULL_HANDLE; // buffer_'s handle
    void* mapped = nullptr;           // memory_, mapped whole
    VkDeviceSize size = 0;
    bool coherent = true;
    VkDeviceMemory memory() const { return memory_.get(); }

private:
    friend Result createMappedBuffer(VkPhysicalDevice, VkDevice, VkDeviceSize, VkBufferUsageFlags, bool, MappedBuffer&,
                                     std::array<uint32_t, 2>);
    Memory memory_;
    Buffer buffer_; // destroyed before the memory it is bound to
};
// Replaces `out` with a new buffer of `size` bytes; on failure `out` is left empty. With two
// distinct `concurrentFamilies`, the buffer is shared by both without ownership transfers
// (VK_SHARING_MODE_CONCURRENT).
Result createMappedBuffer(VkPhysicalDevice pd, VkDevice dev, VkDeviceSize size, VkBufferUsageFlags usage,
                          bool preferCached, MappedBuffer& out, std::array<uint32_t, 2> concurrentFamilies = {0, 0});
// Makes device writes visible to the host for non-coherent memory.
[[nodiscard]] Result invalidate(VkDevice dev, const MappedBuffer& b);
// Makes host writes visible to the device for non-coherent memory.
[[nodiscard]] Result flush(VkDevice dev, const MappedBuffer& b);

} // namespace iris::vk
