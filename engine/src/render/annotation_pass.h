// The annotation pass: the host's annotations (Engine::setAnnotations) drawn over the tiles and
// under the HUD (render/frame_pass.h). prepare() takes the store's newest snapshot, builds the
// view's fills and strokes on the CPU (render/annotation_geometry.h) into the frame slot's own
// buffers; recordDraws() draws the fills, then the strokes. Colours are display colours: no
// colour transform applies to them (it is the slide's). Render thread only.
#pragma once

#include <array>
#include <memory>

#include "core/log.h"
#include "gpu/annotation_pipeline.h"
#include "render/annotation_geometry.h"
#include "render/frame_pass.h"

namespace iris::render {

class AnnotationPass final : public FramePass {
public:
    AnnotationPass(gpu::Device& device, const Log& log) : device_(device), log_(log), pipeline_(device) {}

    Result init(uint32_t frameSlots);
    const char* name() const override { return "annotations"; }
    Result prepare(FrameContext& frame) override;
    Result recordDraws(VkCommandBuffer cmd, const FrameContext& frame) override;

    // What the last prepared frame drew.
    const AnnotationGeometry& geometry() const { return geometry_; }

    // The most a frame slot's buffers grow to (each); geometry beyond it is left out, with a
    // warning once.
    static constexpr VkDeviceSize kMaxBufferBytes = VkDeviceSize(64) << 20;

private:
    struct Slot {
        vk::MappedBuffer fills, strokes;
    };
    // Grows `buf` to hold `bytes` (a power of two from 64 KiB); false when it cannot.
    bool reserve(vk::MappedBuffer& buf, VkDeviceSize bytes, const char* what);

    gpu::Device& device_;
    const Log& log_;
    gpu::AnnotationPipeline pipeline_;
    std::vector<Slot> slots_;
    AnnotationGeometry geometry_;
    AnnotationBudget budget_;
    uint32_t fillCount_ = 0, strokeCount_ = 0; // what the slot's buffers hold this frame
    // The snapshot generation whose fill errors were logged (once per generation, not per frame).
    uint64_t loggedGeneration_ = UINT64_MAX;
    const void* loggedStore_ = nullptr;
    bool warnedFull_ = false;
};

} // namespace iris::render
