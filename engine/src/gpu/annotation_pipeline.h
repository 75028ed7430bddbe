// The annotation pipelines (render/annotation_pass.h): translucent fill triangles, and strokes
// — capsules of constant screen width with round caps (outline segments; a capsule of zero
// length is a dot) and squares (vertex handles) — anti-aliased by their distance in the
// fragment shader. Both take target-pixel positions and blend premultiplied "over" the tiles,
// like the overlay pipeline. Used by the render thread only.
#pragma once

#include <cstdint>
#include <unordered_map>

#include "gpu/annotation_vertex.h"
#include "gpu/device.h"
#include "gpu/vk_handle.h"
#include "gpu/vk_util.h"

namespace iris::gpu {

struct AnnotationPush {
    float targetSize[2];
};

class AnnotationPipeline {
public:
    explicit AnnotationPipeline(Device& device) : device_(device) {}
    AnnotationPipeline(const AnnotationPipeline&) = delete;
    AnnotationPipeline& operator=(const AnnotationPipeline&) = delete;

    Result init();
    struct Pipelines {
        VkPipeline fill = VK_NULL_HANDLE;
        VkPipeline stroke = VK_NULL_HANDLE;
    };
    // The pipelines for a colour format, created on first use.
    Expected<Pipelines> pipelinesFor(VkFormat format);
    VkPipelineLayout layout() const { return layout_.get(); }

private:
    Device& device_;
    vk::ShaderModule fillVert_, fillFrag_, strokeVert_, strokeFrag_;
    vk::PipelineLayout layout_;
    std::unordered_map<int, std::pair<vk::Pipeline, vk::Pipeline>> pipelines_;
};

} // namespace iris::gpu
