#include "render/annotation_pass.h"

#include <algorithm>
#include <cstring>

namespace iris::render {

Result AnnotationPass::init(uint32_t frameSlots) {
    if (Result r = pipeline_.init(); !r.ok()) return r;
    slots_.resize(frameSlots);
    return {};
}

bool AnnotationPass::reserve(vk::MappedBuffer& buf, VkDeviceSize bytes, const char* what) {
    if (bytes <= buf.size) return true;
    if (bytes > kMaxBufferBytes) return false;
    VkDeviceSize size = VkDeviceSize(64) << 10;
    while (size < bytes) size *= 2;
    if (Result r = vk::createMappedBuffer(device_.physical(), device_.device(), size, VK_BUFFER_USAGE_VERTEX_BUFFER_BIT,
                                          false, buf);
        !r.ok()) {
        log_.warn(std::string("annotations: no ") + what + " buffer of " + std::to_string(size >> 10) +
                  " KiB: " + r.message());
        return false;
    }
    return true;
}

Result AnnotationPass::prepare(FrameContext& frame) {
    fillCount_ = strokeCount_ = 0;
    geometry_.clear();
    const Snapshot& snap = frame.snap;
    if (!snap.annotations || !snap.annotationsVisible || !snap.slide) return {};
    const std::shared_ptr<const AnnotationSnapshot> ann = snap.annotations->snapshot();
    buildAnnotationGeometry(*ann, frame.viewport, snap.selectedAnnotation, budget_, geometry_);
    if (!geometry_.complete) {
        frame.complete = false;
        frame.redraw = true; // the fills left for the next frame
    }
    if (!geometry_.errors.empty() && (ann->generation() != loggedGeneration_ || snap.annotations.get() != loggedStore_)) {
        loggedGeneration_ = ann->generation();
        loggedStore_ = snap.annotations.get();
        log_.warn("annotations: " + std::to_string(geometry_.errors.size()) + " fill(s) not drawn; first: " +
                  geometry_.errors.front());
    }

    Slot& s = slots_[frame.slot];
    // The slot's previous frame has completed (the render thread waited for its fence), so
    // its buffers can be rewritten or replaced.
    size_t fills = geometry_.fills.size(), strokes = geometry_.strokes.size();
    const size_t maxFills = size_t(kMaxBufferBytes / sizeof(gpu::AnnotationFillVertex)) / 3 * 3;
    const size_t maxStrokes = size_t(kMaxBufferBytes / sizeof(gpu::AnnotationStroke));
    if ((fills > maxFills || strokes > maxStrokes) && !warnedFull_) {
        warnedFull_ = true;
        log_.warn("annotations: a frame's geometry exceeds " + std::to_string(kMaxBufferBytes >> 20) +
                  " MiB; the rest is not drawn");
    }
    fills = std::min(fills, maxFills);
    strokes = std::min(strokes, maxStrokes);
    if (fills > 0 && !reserve(s.fills, fills * sizeof(gpu::AnnotationFillVertex), "fill")) fills = 0;
    if (strokes > 0 && !reserve(s.strokes, strokes * sizeof(gpu::AnnotationStroke), "stroke")) strokes = 0;
    if (fills > 0) std::memcpy(s.fills.mapped, geometry_.fills.data(), fills * sizeof(gpu::AnnotationFillVertex));
    if (strokes > 0) std::memcpy(s.strokes.mapped, geometry_.strokes.data(), strokes * sizeof(gpu::AnnotationStroke));
    // (Host-coherent memory, as on lavapipe and NVIDIA, needs no flush and cannot fail here.)
    if (fills > 0)
        if (Result r = vk::flush(device_.device(), s.fills); !r.ok()) return r;
    if (strokes > 0)
        if (Result r = vk::flush(device_.device(), s.strokes); !r.ok()) return r;
    fillCount_ = uint32_t(fills);
    strokeCount_ = uint32_t(strokes);
    return {};
}

Result AnnotationPass::recordDraws(VkCommandBuffer cmd, const FrameContext& frame) {
    if (fillCount_ == 0 && strokeCount_ == 0) return {};
    Expected<gpu::AnnotationPipeline::Pipelines> p = pipeline_.pipelinesFor(frame.format);
    if (!p) return p.error();
    const Slot& s = slots_[frame.slot];
    const VkViewport viewport{0, 0, float(frame.extent.width), float(frame.extent.height), 0, 1};
    const VkRect2D scissor{{0, 0}, frame.extent};
    const gpu::AnnotationPush push{{float(frame.extent.width), float(frame.extent.height)}};
    const VkDeviceSize offset = 0;
    // Fills, then strokes over them: the same state for both, each its own pipeline and buffer.
    const auto bind = [&](VkPipeline pipeline, VkBuffer buffer) {
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
        vkCmdSetViewport(cmd, 0, 1, &viewport);
        vkCmdSetScissor(cmd, 0, 1, &scissor);
        vkCmdPushConstants(cmd, pipeline_.layout(), VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(push), &push);
        vkCmdBindVertexBuffers(cmd, 0, 1, &buffer, &offset);
    };
    if (fillCount_ > 0) {
        bind(p->fill, s.fills.buffer);
        vkCmdDraw(cmd, fillCount_, 1, 0, 0);
    }
    if (strokeCount_ > 0) {
        bind(p->stroke, s.strokes.buffer);
        vkCmdDraw(cmd, 4, strokeCount_, 0, 0);
    }
    return {};
}

} // namespace iris::render
