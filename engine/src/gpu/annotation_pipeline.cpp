#include "gpu/annotation_pipeline.h"

#include <cstddef>

#include <iris_shaders/annotation_fill_frag.h>
#include <iris_shaders/annotation_fill_vert.h>
#include <iris_shaders/annotation_stroke_frag.h>
#include <iris_shaders/annotation_stroke_vert.h>

namespace iris::gpu {

Result AnnotationPipeline::init() {
    VkDevice dev = device_.device();
    struct Module {
        const uint32_t* code;
        size_t bytes;
        vk::ShaderModule& out;
    };
    const Module modules[] = {
        {annotation_fill_vert_spv, sizeof(annotation_fill_vert_spv), fillVert_},
        {annotation_fill_frag_spv, sizeof(annotation_fill_frag_spv), fillFrag_},
        {annotation_stroke_vert_spv, sizeof(annotation_stroke_vert_spv), strokeVert_},
        {annotation_stroke_frag_spv, sizeof(annotation_stroke_frag_spv), strokeFrag_},
    };
    for (const Module& m : modules)
        if (Result r = vk::createShaderModule(dev, m.code, m.bytes, *m.out.replace(dev)); !r.ok()) return r;
    const VkPushConstantRange push{.stageFlags = VK_SHADER_STAGE_VERTEX_BIT, .offset = 0, .size = sizeof(AnnotationPush)};
    const VkPipelineLayoutCreateInfo plci{.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                          .pNext = nullptr,
                                          .flags = 0,
                                          .setLayoutCount = 0,
                                          .pSetLayouts = nullptr,
                                          .pushConstantRangeCount = 1,
                                          .pPushConstantRanges = &push};
    IRIS_VK_TRY(vkCreatePipelineLayout(dev, &plci, nullptr, layout_.replace(dev)));
    return {};
}

Expected<AnnotationPipeline::Pipelines> AnnotationPipeline::pipelinesFor(VkFormat format) {
    if (auto it = pipelines_.find(int(format)); it != pipelines_.end())
        return Pipelines{it->second.first.get(), it->second.second.get()};
    VkDevice dev = device_.device();
    const VkVertexInputAttributeDescription fillAttrs[2] = {
        {.location = 0, .binding = 0, .format = VK_FORMAT_R32G32_SFLOAT, .offset = offsetof(AnnotationFillVertex, p)},
        {.location = 1, .binding = 0, .format = VK_FORMAT_R8G8B8A8_UNORM, .offset = offsetof(AnnotationFillVertex, colour)},
    };
    Expected<VkPipeline> fill = vk::createBlendedPipeline(
        dev, layout_.get(), fillVert_.get(), fillFrag_.get(), sizeof(AnnotationFillVertex), VK_VERTEX_INPUT_RATE_VERTEX,
        VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST, fillAttrs, 2, format);
    if (!fill) return fill.error();
    vk::Pipeline fillOwned(dev, *fill);
    const VkVertexInputAttributeDescription strokeAttrs[3] = {
        {.location = 0, .binding = 0, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .offset = offsetof(AnnotationStroke, p0)},
        {.location = 1, .binding = 0, .format = VK_FORMAT_R32_SFLOAT, .offset = offsetof(AnnotationStroke, halfWidth)},
        {.location = 2, .binding = 0, .format = VK_FORMAT_R8G8B8A8_UNORM, .offset = offsetof(AnnotationStroke, colour)},
    };
    Expected<VkPipeline> stroke = vk::createInstancedQuadPipeline(dev, layout_.get(), strokeVert_.get(), strokeFrag_.get(),
                                                                  sizeof(AnnotationStroke), strokeAttrs, 3, format);
    if (!stroke) return stroke.error();
    auto& entry = pipelines_[int(format)];
    entry.first = std::move(fillOwned);
    entry.second = vk::Pipeline(dev, *stroke);
    return Pipelines{entry.first.get(), entry.second.get()};
}

} // namespace iris::gpu
