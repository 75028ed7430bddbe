#include "gpu/mip_pipeline.h"

#include "gpu/mip_kernel.h"
#include "gpu/vk_util.h"

#include <algorithm>
#include <cstdlib>
#include <string>
#include <iris_shaders/mip_reduce_comp.h>
#include <iris_shaders/mip_reduce_serial_comp.h>

namespace iris::gpu {

namespace {
// The shader's push constant block (std430 layout).
struct MipPush {
    uint32_t layers[MipPipeline::kMaxTiles];
    uint32_t enhance;
    float lambda;
};
static_assert(sizeof(MipPush) == 40);
} // namespace

MipPipeline::Schedule MipPipeline::resolve(EngineTuning::MipSchedule requested, const VkPhysicalDeviceProperties& device) {
    using Requested = EngineTuning::MipSchedule;
    if (requested == Requested::Host || (requested == Requested::Auto && device.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU))
        return Schedule::Host;
    if (requested == Requested::Serial) return Schedule::Serial;
    // 13.4 KiB of shared memory: within Vulkan's 16 KiB minimum, else the serial pass.
    return device.limits.maxComputeSharedMemorySize < kSharedBytes ? Schedule::Serial : Schedule::Wide;
}

Result MipPipeline::init(EngineTuning::MipSchedule requested) {
    VkDevice dev = device_.device();
    const VkPhysicalDeviceLimits& limits = device_.properties().limits;
    schedule_ = resolve(requested, device_.properties());
    if (schedule_ == Schedule::Host) return {}; // the buffer thread makes the levels; no pipeline
    // Scratch: the level-4 sums, then the counters at an aligned offset.
    const VkDeviceSize align = std::max<VkDeviceSize>(limits.minStorageBufferOffsetAlignment, 16);
    const VkDeviceSize slots = std::max<uint32_t>(atlas_.slotCount(), 1);
    sumsBytes_ = slots * 256 * 8;
    countersOffset_ = (sumsBytes_ + align - 1) / align * align;
    countersBytes_ = slots * 4;
    if (Result r = vk::createDeviceBuffer(device_.physical(), dev, countersOffset_ + countersBytes_,
                                          VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                          scratch_, scratchMemory_);
        !r.ok())
        return r;
    const VkShaderModuleCreateInfo smci{.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO,
                                        .pNext = nullptr,
                                        .flags = 0,
                                        .codeSize = schedule_ == Schedule::Wide ? sizeof(mip_reduce_comp_spv)
                                                                                : sizeof(mip_reduce_serial_comp_spv),
                                        .pCode = schedule_ == Schedule::Wide ? mip_reduce_comp_spv : mip_reduce_serial_comp_spv};
    IRIS_VK_TRY(vkCreateShaderModule(dev, &smci, nullptr, module_.replace(dev)));
    const VkDescriptorSetLayoutBinding bindings[4] = {
        {.binding = 0, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, .descriptorCount = 1,
         .stageFlags = VK_SHADER_STAGE_COMPUTE_BIT, .pImmutableSamplers = nullptr},
        {.binding = 1, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, .descriptorCount = kTileMipLevels - 1,
         .stageFlags = VK_SHADER_STAGE_COMPUTE_BIT, .pImmutableSamplers = nullptr},
        {.binding = 2, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, .descriptorCount = 1,
         .stageFlags = VK_SHADER_STAGE_COMPUTE_BIT, .pImmutableSamplers = nullptr},
        {.binding = 3, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, .descriptorCount = 1,
         .stageFlags = VK_SHADER_STAGE_COMPUTE_BIT, .pImmutableSamplers = nullptr},
    };
    const VkDescriptorSetLayoutCreateInfo dslci{
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO, .pNext = nullptr, .flags = 0, .bindingCount = 4, .pBindings = bindings};
    IRIS_VK_TRY(vkCreateDescriptorSetLayout(dev, &dslci, nullptr, setLayout_.replace(dev)));
    const VkDescriptorSetLayout setLayout = setLayout_.get();
    const VkPushConstantRange push{.stageFlags = VK_SHADER_STAGE_COMPUTE_BIT, .offset = 0, .size = sizeof(MipPush)};
    const VkPipelineLayoutCreateInfo plci{.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                          .pNext = nullptr,
                                          .flags = 0,
                                          .setLayoutCount = 1,
                                          .pSetLayouts = &setLayout,
                                          .pushConstantRangeCount = 1,
                                          .pPushConstantRanges = &push};
    IRIS_VK_TRY(vkCreatePipelineLayout(dev, &plci, nullptr, layout_.replace(dev)));
    Expected<VkPipeline> pipeline = vk::createComputePipeline(dev, layout_.get(), module_.get());
    if (!pipeline) return pipeline.error();
    pipeline_ = vk::Pipeline(dev, *pipeline);

    const VkDescriptorPoolSize ps[2] = {{.type = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, .descriptorCount = kTileMipLevels},
                                        {.type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, .descriptorCount = 2}};
    const VkDescriptorPoolCreateInfo dpci{
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO, .pNext = nullptr, .flags = 0, .maxSets = 1, .poolSizeCount = 2, .pPoolSizes = ps};
    IRIS_VK_TRY(vkCreateDescriptorPool(dev, &dpci, nullptr, pool_.replace(dev)));
    const VkDescriptorSetAllocateInfo dsai{.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
                                           .pNext = nullptr,
                                           .descriptorPool = pool_.get(),
                                           .descriptorSetCount = 1,
                                           .pSetLayouts = &setLayout};
    IRIS_VK_TRY(vkAllocateDescriptorSets(dev, &dsai, &set_));
    VkDescriptorImageInfo infos[kTileMipLevels];
    for (uint32_t m = 0; m < kTileMipLevels; ++m)
        infos[m] = {.sampler = VK_NULL_HANDLE, .imageView = atlas_.mipView(m), .imageLayout = VK_IMAGE_LAYOUT_GENERAL};
    const VkDescriptorBufferInfo buffers[2] = {
        {.buffer = scratch_.get(), .offset = 0, .range = sumsBytes_},
        {.buffer = scratch_.get(), .offset = countersOffset_, .range = countersBytes_}};
    const VkWriteDescriptorSet writes[4] = {
        {.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, .pNext = nullptr, .dstSet = set_, .dstBinding = 0, .dstArrayElement = 0,
         .descriptorCount = 1, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, .pImageInfo = &infos[0],
         .pBufferInfo = nullptr, .pTexelBufferView = nullptr},
        {.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, .pNext = nullptr, .dstSet = set_, .dstBinding = 1, .dstArrayElement = 0,
         .descriptorCount = kTileMipLevels - 1, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, .pImageInfo = &infos[1],
         .pBufferInfo = nullptr, .pTexelBufferView = nullptr},
        {.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, .pNext = nullptr, .dstSet = set_, .dstBinding = 2, .dstArrayElement = 0,
         .descriptorCount = 1, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, .pImageInfo = nullptr,
         .pBufferInfo = &buffers[0], .pTexelBufferView = nullptr},
        {.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, .pNext = nullptr, .dstSet = set_, .dstBinding = 3, .dstArrayElement = 0,
         .descriptorCount = 1, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, .pImageInfo = nullptr,
         .pBufferInfo = &buffers[1], .pTexelBufferView = nullptr},
    };
    vkUpdateDescriptorSets(dev, 4, writes, 0, nullptr);
    return {};
}

void MipPipeline::recordScratchBarrier(VkCommandBuffer cmd) {
    if (!countersZeroed_) {
        // The counters only ever grow by 16 per tile (the shader tests old % 16), so zeroing
        // them once, before the first dispatch, is enough.
        vkCmdFillBuffer(cmd, scratch_.get(), countersOffset_, countersBytes_, 0);
        countersZeroed_ = true;
    }
    // Order this dispatch's scratch accesses after the fill and after earlier dispatches on
    // this queue (a slot's scratch is reused when the slot is refilled).
    const VkBufferMemoryBarrier2 b{
        .sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2,
        .pNext = nullptr,
        .srcStageMask = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
        .srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
        .dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
        .dstAccessMask = VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
        .srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
        .dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
        .buffer = scratch_.get(),
        .offset = 0,
        .size = VK_WHOLE_SIZE};
    vk::pipelineBarrier(cmd, b);
}

void MipPipeline::record(VkCommandBuffer cmd, const int* layers, uint32_t count, bool enhance) {
    if (schedule_ == Schedule::Host) return; // nothing to dispatch: the levels were uploaded
    if (schedule_ == Schedule::Wide) recordScratchBarrier(cmd);
    MipPush push{};
    for (uint32_t i = 0; i < count && i < kMaxTiles; ++i) push.layers[i] = uint32_t(layers[i]);
    push.enhance = enhance ? 1u : 0u;
    push.lambda = mipkernel::kLambda;
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_.get());
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_.get(), 0, 1, &set_, 0, nullptr);
    vkCmdPushConstants(cmd, layout_.get(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
    vkCmdDispatch(cmd, schedule_ == Schedule::Wide ? kRegionsPerTile : 1, count, 1);
}

} // namespace iris::gpu
