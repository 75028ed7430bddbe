#include "gpu/vk_util.h"

#include <vector>

namespace iris::vk {

const char* resultName(VkResult r) {
    switch (r) {
#define X(n) case n: return #n;
        X(VK_SUCCESS) X(VK_NOT_READY) X(VK_TIMEOUT) X(VK_EVENT_SET) X(VK_EVENT_RESET) X(VK_INCOMPLETE)
        X(VK_ERROR_OUT_OF_HOST_MEMORY) X(VK_ERROR_OUT_OF_DEVICE_MEMORY) X(VK_ERROR_INITIALIZATION_FAILED)
        X(VK_ERROR_DEVICE_LOST) X(VK_ERROR_MEMORY_MAP_FAILED) X(VK_ERROR_LAYER_NOT_PRESENT)
        X(VK_ERROR_EXTENSION_NOT_PRESENT) X(VK_ERROR_FEATURE_NOT_PRESENT) X(VK_ERROR_INCOMPATIBLE_DRIVER)
        X(VK_ERROR_TOO_MANY_OBJECTS) X(VK_ERROR_FORMAT_NOT_SUPPORTED) X(VK_ERROR_FRAGMENTED_POOL)
        X(VK_ERROR_UNKNOWN) X(VK_ERROR_OUT_OF_POOL_MEMORY) X(VK_ERROR_SURFACE_LOST_KHR)
        X(VK_ERROR_NATIVE_WINDOW_IN_USE_KHR) X(VK_SUBOPTIMAL_KHR) X(VK_ERROR_OUT_OF_DATE_KHR)
#undef X
    default: return "VkResult(other)";
    }
}

Result check(VkResult r, const char* what) {
    if (r >= 0) return {};
    const Status s = r == VK_ERROR_DEVICE_LOST ? Status::DeviceLost
                     : (r == VK_ERROR_OUT_OF_HOST_MEMORY || r == VK_ERROR_OUT_OF_DEVICE_MEMORY) ? Status::OutOfMemory
                                                                                                 : Status::Vulkan;
    return Result(s, std::string(what) + " failed: " + resultName(r));
}

uint32_t findMemoryType(VkPhysicalDevice pd, uint32_t typeBits, VkMemoryPropertyFlags required,
                        VkMemoryPropertyFlags preferred) {
    VkPhysicalDeviceMemoryProperties props;
    vkGetPhysicalDeviceMemoryProperties(pd, &props);
    uint32_t fallback = UINT32_MAX;
    for (uint32_t i = 0; i < props.memoryTypeCount; ++i) {
        if (!(typeBits & (1u << i))) continue;
        const VkMemoryPropertyFlags f = props.memoryTypes[i].propertyFlags;
        if ((f & required) != required) continue;
        if ((f & (required | preferred)) == (required | preferred)) return i;
        if (fallback == UINT32_MAX) fallback = i;
    }
    return fallback;
}

namespace {
Result allocateDeviceLocal(VkPhysicalDevice pd, VkDevice dev, const VkMemoryRequirements& req, Memory& memory) {
    const uint32_t type = findMemoryType(pd, req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    if (type == UINT32_MAX) return Result(Status::OutOfMemory, "no device-local memory type fits");
    const VkMemoryAllocateInfo mai{
        .sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO, .pNext = nullptr, .allocationSize = req.size, .memoryTypeIndex = type};
    IRIS_VK_TRY(vkAllocateMemory(dev, &mai, nullptr, memory.replace(dev)));
    return {};
}
} // namespace

Result createDeviceImage(VkPhysicalDevice pd, VkDevice dev, const VkImageCreateInfo& info, Image& image,
                         Memory& memory) {
    image.reset();
    memory.reset();
    // Made into locals, handed over only when bound: a failure leaves nothing behind.
    Image img;
    Memory mem;
    IRIS_VK_TRY(vkCreateImage(dev, &info, nullptr, img.replace(dev)));
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(dev, img.get(), &req);
    if (Result r = allocateDeviceLocal(pd, dev, req, mem); !r.ok()) return r;
    IRIS_VK_TRY(vkBindImageMemory(dev, img.get(), mem.get(), 0));
    memory = std::move(mem);
    image = std::move(img);
    return {};
}

Result createDeviceBuffer(VkPhysicalDevice pd, VkDevice dev, VkDeviceSize size, VkBufferUsageFlags usage,
                          Buffer& buffer, Memory& memory) {
    buffer.reset();
    memory.reset();
    const VkBufferCreateInfo bci{.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO,
                                 .pNext = nullptr,
                                 .flags = 0,
                                 .size = size,
                                 .usage = usage,
                                 .sharingMode = VK_SHARING_MODE_EXCLUSIVE,
                                 .queueFamilyIndexCount = 0,
                                 .pQueueFamilyIndices = nullptr};
    Buffer buf;
    Memory mem;
    IRIS_VK_TRY(vkCreateBuffer(dev, &bci, nullptr, buf.replace(dev)));
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(dev, buf.get(), &req);
    if (Result r = allocateDeviceLocal(pd, dev, req, mem); !r.ok()) return r;
    IRIS_VK_TRY(vkBindBufferMemory(dev, buf.get(), mem.get(), 0));
    memory = std::move(mem);
    buffer = std::move(buf);
    return {};
}

Result createImageView(VkDevice dev, VkImage image, VkImageViewType type, VkFormat format,
                       VkImageSubresourceRange range, VkImageView& out) {
    const VkImageViewCreateInfo vci{
        .sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO,
        .pNext = nullptr,
        .flags = 0,
        .image = image,
        .viewType = type,
        .format = format,
        .components = {},
        .subresourceRange = range,
    };
    IRIS_VK_TRY(vkCreateImageView(dev, &vci, nullptr, &out));
    return {};
}

Result createTimestampPool(VkPhysicalDevice pd, VkDevice dev, uint32_t family, uint32_t count, VkQueryPool& pool,
                           double& periodNs) {
    pool = VK_NULL_HANDLE;
    uint32_t n = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(pd, &n, nullptr);
    std::vector<VkQueueFamilyProperties> qf(n);
    vkGetPhysicalDeviceQueueFamilyProperties(pd, &n, qf.data());
    VkPhysicalDeviceProperties props;
    vkGetPhysicalDeviceProperties(pd, &props);
    if (family >= n || qf[family].timestampValidBits == 0 || !(props.limits.timestampPeriod > 0)) return {};
    const VkQueryPoolCreateInfo qci{.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO,
                                    .pNext = nullptr,
                                    .flags = 0,
                                    .queryType = VK_QUERY_TYPE_TIMESTAMP,
                                    .queryCount = count,
                                    .pipelineStatistics = 0};
    IRIS_VK_TRY(vkCreateQueryPool(dev, &qci, nullptr, &pool));
    periodNs = props.limits.timestampPeriod;
    return {};
}

Result createMappedBuffer(VkPhysicalDevice pd, VkDevice dev, VkDeviceSize size, VkBufferUsageFlags usage,
                          bool preferCached, MappedBuffer& out, std::array<uint32_t, 2> concurrentFamilies) {
    out = MappedBuffer{};
    MappedBuffer b; // what is made so far goes away with it on failure
    const bool concurrent = concurrentFamilies[0] != concurrentFamilies[1];
    const VkBufferCreateInfo bci{
        .sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO,
        .pNext = nullptr,
        .flags = 0,
        .size = size,
        .usage = usage,
        .sharingMode = concurrent ? VK_SHARING_MODE_CONCURRENT : VK_SHARING_MODE_EXCLUSIVE,
        .queueFamilyIndexCount = concurrent ? 2u : 0u,
        .pQueueFamilyIndices = concurrent ? concurrentFamilies.data() : nullptr,
    };
    IRIS_VK_TRY(vkCreateBuffer(dev, &bci, nullptr, b.buffer_.replace(dev)));
    b.buffer = b.buffer_.get();
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(dev, b.buffer, &req);
    const uint32_t type = findMemoryType(pd, req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT,
                                         preferCached ? VK_MEMORY_PROPERTY_HOST_CACHED_BIT
                                                      : VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
    if (type == UINT32_MAX) return Result(Status::Vulkan, "no host-visible memory type for a staging buffer");
    VkPhysicalDeviceMemoryProperties props;
    vkGetPhysicalDeviceMemoryProperties(pd, &props);
    b.coherent = props.memoryTypes[type].propertyFlags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    const VkMemoryAllocateInfo mai{
        .sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO, .pNext = nullptr, .allocationSize = req.size, .memoryTypeIndex = type};
    IRIS_VK_TRY(vkAllocateMemory(dev, &mai, nullptr, b.memory_.replace(dev)));
    IRIS_VK_TRY(vkBindBufferMemory(dev, b.buffer, b.memory(), 0));
    IRIS_VK_TRY(vkMapMemory(dev, b.memory(), 0, VK_WHOLE_SIZE, 0, &b.mapped));
    b.size = size;
    out = std::move(b);
    return {};
}

Result invalidate(VkDevice dev, const MappedBuffer& b) {
    if (b.coherent) return {};
    const VkMappedMemoryRange range{.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE,
                                    .pNext = nullptr,
                                    .memory = b.memory(),
                                    .offset = 0,
                                    .size = VK_WHOLE_SIZE};
    return check(vkInvalidateMappedMemoryRanges(dev, 1, &range), "vkInvalidateMappedMemoryRanges");
}

Result flush(VkDevice dev, const MappedBuffer& b) {
    if (b.coherent) return {};
    const VkMappedMemoryRange range{.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE,
                                    .pNext = nullptr,
                                    .memory = b.memory(),
                                    .offset = 0,
                                    .size = VK_WHOLE_SIZE};
    return check(vkFlushMappedMemoryRanges(dev, 1, &range), "vkFlushMappedMemoryRanges");
}

Result createShaderModule(VkDevice dev, const uint32_t* code, size_t bytes, VkShaderModule& out) {
    const VkShaderModuleCreateInfo ci{
        .sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO, .pNext = nullptr, .flags = 0, .codeSize = bytes, .pCode = code};
    IRIS_VK_TRY(vkCreateShaderModule(dev, &ci, nullptr, &out));
    return {};
}

Expected<VkPipeline> createComputePipeline(VkDevice dev, VkPipelineLayout layout, VkShaderModule module,
                                           const VkSpecializationInfo* specialization) {
    const VkComputePipelineCreateInfo cpci{
        .sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO,
        .pNext = nullptr,
        .flags = 0,
        .stage = {.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
                  .pNext = nullptr,
                  .flags = 0,
                  .stage = VK_SHADER_STAGE_COMPUTE_BIT,
                  .module = module,
                  .pName = "main",
                  .pSpecializationInfo = specialization},
        .layout = layout,
        .basePipelineHandle = VK_NULL_HANDLE,
        .basePipelineIndex = -1,
    };
    VkPipeline pipeline = VK_NULL_HANDLE;
    IRIS_VK_TRY(vkCreateComputePipelines(dev, VK_NULL_HANDLE, 1, &cpci, nullptr, &pipeline));
    return pipeline;
}

Expected<VkPipeline> createInstancedQuadPipeline(VkDevice dev, VkPipelineLayout layout, VkShaderModule vert,
                                                 VkShaderModule frag, uint32_t instanceStride,
                                                 const VkVertexInputAttributeDescription* attributes,
                                                 uint32_t attributeCount, VkFormat format,
                                                 const VkSpecializationInfo* fragSpecialization) {
    return createBlendedPipeline(dev, layout, vert, frag, instanceStride, VK_VERTEX_INPUT_RATE_INSTANCE,
                                 VK_PRIMITIVE_TOPOLOGY_TRIANGLE_STRIP, attributes, attributeCount, format,
                                 fragSpecialization);
}

Expected<VkPipeline> createBlendedPipeline(VkDevice dev, VkPipelineLayout layout, VkShaderModule vert,
                                           VkShaderModule frag, uint32_t stride, VkVertexInputRate inputRate,
                                           VkPrimitiveTopology topology,
                                           const VkVertexInputAttributeDescription* attributes,
                                           uint32_t attributeCount, VkFormat format,
                                           const VkSpecializationInfo* fragSpecialization) {
    const VkPipelineShaderStageCreateInfo stages[2] = {
        {.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, .pNext = nullptr, .flags = 0,
         .stage = VK_SHADER_STAGE_VERTEX_BIT, .module = vert, .pName = "main", .pSpecializationInfo = nullptr},
        {.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, .pNext = nullptr, .flags = 0,
         .stage = VK_SHADER_STAGE_FRAGMENT_BIT, .module = frag, .pName = "main", .pSpecializationInfo = fragSpecialization},
    };
    const VkVertexInputBindingDescription vib{.binding = 0, .stride = stride, .inputRate = inputRate};
    const VkPipelineVertexInputStateCreateInfo vi{
        .sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO, .pNext = nullptr, .flags = 0,
        .vertexBindingDescriptionCount = stride ? 1u : 0u, .pVertexBindingDescriptions = stride ? &vib : nullptr,
        .vertexAttributeDescriptionCount = attributeCount, .pVertexAttributeDescriptions = attributes};
    const VkPipelineInputAssemblyStateCreateInfo ia{
        .sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO, .pNext = nullptr, .flags = 0,
        .topology = topology, .primitiveRestartEnable = VK_FALSE};
    const VkPipelineViewportStateCreateInfo vp{
        .sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO, .pNext = nullptr, .flags = 0,
        .viewportCount = 1, .pViewports = nullptr, .scissorCount = 1, .pScissors = nullptr};
    const VkPipelineRasterizationStateCreateInfo rs{
        .sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO, .pNext = nullptr, .flags = 0,
        .depthClampEnable = VK_FALSE, .rasterizerDiscardEnable = VK_FALSE, .polygonMode = VK_POLYGON_MODE_FILL,
        .cullMode = VK_CULL_MODE_NONE, .frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE, .depthBiasEnable = VK_FALSE,
        .depthBiasConstantFactor = 0, .depthBiasClamp = 0, .depthBiasSlopeFactor = 0, .lineWidth = 1};
    const VkPipelineMultisampleStateCreateInfo ms{
        .sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO, .pNext = nullptr, .flags = 0,
        .rasterizationSamples = VK_SAMPLE_COUNT_1_BIT, .sampleShadingEnable = VK_FALSE, .minSampleShading = 0,
        .pSampleMask = nullptr, .alphaToCoverageEnable = VK_FALSE, .alphaToOneEnable = VK_FALSE};
    // Premultiplied "over": what is drawn is premultiplied RGBA; the target stays opaque.
    const VkPipelineColorBlendAttachmentState blend{
        .blendEnable = VK_TRUE,
        .srcColorBlendFactor = VK_BLEND_FACTOR_ONE,
        .dstColorBlendFactor = VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA,
        .colorBlendOp = VK_BLEND_OP_ADD,
        .srcAlphaBlendFactor = VK_BLEND_FACTOR_ONE,
        .dstAlphaBlendFactor = VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA,
        .alphaBlendOp = VK_BLEND_OP_ADD,
        .colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT,
    };
    const VkPipelineColorBlendStateCreateInfo cb{
        .sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO, .pNext = nullptr, .flags = 0,
        .logicOpEnable = VK_FALSE, .logicOp = VK_LOGIC_OP_COPY, .attachmentCount = 1, .pAttachments = &blend,
        .blendConstants = {0, 0, 0, 0}};
    const VkDynamicState dyn[2] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
    const VkPipelineDynamicStateCreateInfo ds{
        .sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO, .pNext = nullptr, .flags = 0, .dynamicStateCount = 2, .pDynamicStates = dyn};
    const VkPipelineRenderingCreateInfo rci{
        .sType = VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO, .pNext = nullptr, .viewMask = 0,
        .colorAttachmentCount = 1, .pColorAttachmentFormats = &format,
        .depthAttachmentFormat = VK_FORMAT_UNDEFINED, .stencilAttachmentFormat = VK_FORMAT_UNDEFINED};
    const VkGraphicsPipelineCreateInfo gci{
        .sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO,
        .pNext = &rci,
        .flags = 0,
        .stageCount = 2,
        .pStages = stages,
        .pVertexInputState = &vi,
        .pInputAssemblyState = &ia,
        .pTessellationState = nullptr,
        .pViewportState = &vp,
        .pRasterizationState = &rs,
        .pMultisampleState = &ms,
        .pDepthStencilState = nullptr,
        .pColorBlendState = &cb,
        .pDynamicState = &ds,
        .layout = layout,
        .renderPass = VK_NULL_HANDLE,
        .subpass = 0,
        .basePipelineHandle = VK_NULL_HANDLE,
        .basePipelineIndex = -1,
    };
    VkPipeline p = VK_NULL_HANDLE;
    IRIS_VK_TRY(vkCreateGraphicsPipelines(dev, VK_NULL_HANDLE, 1, &gci, nullptr, &p));
    return p;
}

Result createSampledImageSet(VkDevice dev, uint32_t pushBytes, std::span<const SampledImage> images,
                             VkDescriptorSetLayout& setLayout, VkPipelineLayout& pipelineLayout, VkDescriptorPool& pool,
                             VkDescriptorSet& set) {
    const uint32_t n = uint32_t(images.size());
    std::vector<VkDescriptorSetLayoutBinding> bindings(n);
    std::vector<VkDescriptorImageInfo> infos(n);
    std::vector<VkWriteDescriptorSet> writes(n);
    for (uint32_t i = 0; i < n; ++i) {
        bindings[i] = VkDescriptorSetLayoutBinding{
            .binding = i,
            .descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
            .descriptorCount = 1,
            .stageFlags = VK_SHADER_STAGE_FRAGMENT_BIT,
            .pImmutableSamplers = nullptr,
        };
        infos[i] = VkDescriptorImageInfo{.sampler = images[i].sampler, .imageView = images[i].view, .imageLayout = images[i].layout};
    }
    const VkDescriptorSetLayoutCreateInfo dslci{
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO, .pNext = nullptr, .flags = 0, .bindingCount = n, .pBindings = bindings.data()};
    IRIS_VK_TRY(vkCreateDescriptorSetLayout(dev, &dslci, nullptr, &setLayout));
    const VkPushConstantRange push{.stageFlags = VK_SHADER_STAGE_VERTEX_BIT, .offset = 0, .size = pushBytes};
    const VkPipelineLayoutCreateInfo plci{
        .sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
        .pNext = nullptr,
        .flags = 0,
        .setLayoutCount = 1,
        .pSetLayouts = &setLayout,
        .pushConstantRangeCount = 1,
        .pPushConstantRanges = &push,
    };
    IRIS_VK_TRY(vkCreatePipelineLayout(dev, &plci, nullptr, &pipelineLayout));
    const VkDescriptorPoolSize ps{.type = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, .descriptorCount = n};
    const VkDescriptorPoolCreateInfo dpci{
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO, .pNext = nullptr, .flags = 0, .maxSets = 1, .poolSizeCount = 1, .pPoolSizes = &ps};
    IRIS_VK_TRY(vkCreateDescriptorPool(dev, &dpci, nullptr, &pool));
    const VkDescriptorSetAllocateInfo dsai{
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO, .pNext = nullptr, .descriptorPool = pool, .descriptorSetCount = 1, .pSetLayouts = &setLayout};
    IRIS_VK_TRY(vkAllocateDescriptorSets(dev, &dsai, &set));
    for (uint32_t i = 0; i < n; ++i) {
        writes[i] = VkWriteDescriptorSet{
            .sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
            .pNext = nullptr,
            .dstSet = set,
            .dstBinding = i,
            .dstArrayElement = 0,
            .descriptorCount = 1,
            .descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
            .pImageInfo = &infos[i],
            .pBufferInfo = nullptr,
            .pTexelBufferView = nullptr,
        };
    }
    vkUpdateDescriptorSets(dev, n, writes.data(), 0, nullptr);
    return {};
}

} // namespace iris::vk
