// The render thread's overlay stage: per frame it lays out the visible overlays
// (overlay/overlay_layout), shapes their labels through the glyph cache (rasterising new
// glyphs), writes the quads and glyph bitmaps into the frame slot's own buffers, and records
// the atlas uploads (before the render pass) and the draws (inside it, after the tiles).
// Owned and used by the render thread only; it reads nothing but the frame's snapshot.
#pragma once

#include <array>
#include <functional>
#include <vector>

#include "core/log.h"
#include "core/shared_state.h"
#include "gpu/overlay_pipeline.h"
#include "overlay/glyph_cache.h"
#include "overlay/overlay_layout.h"

namespace iris {

struct OverlayFrame {
    overlay::OverlayPlan plan; // layout (published with the frame) and what each overlay draws
    struct Range {
        uint32_t first = 0, count = 0;
    };
    std::vector<std::array<Range, 2>> ranges; // per draw: instances under the thumbnail, over it
    uint32_t uploads = 0;                     // glyph copies waiting in the slot's staging buffer
    Result fontError;                         // the snapshot's font could not be made a face
};

class OverlayRenderer {
public:
    OverlayRenderer(gpu::Device& device, const Log& log) : device_(device), log_(log), pipeline_(device) {}
    OverlayRenderer(const OverlayRenderer&) = delete;
    OverlayRenderer& operator=(const OverlayRenderer&) = delete;

    Result init(uint32_t frameSlots);
    // Lays out the snapshot's overlays for a target of `extent` and fills frame slot `slot`'s
    // instance and staging buffers (the slot's previous frame must have completed).
    OverlayFrame prepare(uint32_t slot, const Snapshot& snap, VkExtent2D extent);
    // Outside the render pass, before it.
    void recordUploads(VkCommandBuffer cmd, uint32_t slot, const OverlayFrame& frame);
    // Inside the render pass, after the tiles. drawThumbnail records an overview's tiles; the
    // scissor is the thumbnail's rectangle when it is called, and the overlay pipeline's state
    // is bound again after it.
    Result recordDraws(VkCommandBuffer cmd, uint32_t slot, const OverlayFrame& frame, VkFormat format,
                       VkExtent2D extent, const std::function<void(const overlay::OverlayDraw&)>& drawThumbnail);

private:
    static constexpr uint32_t kMaxInstances = 4096;
    struct Slot {
        vk::MappedBuffer instances;
        vk::MappedBuffer staging;
    };

    gpu::Device& device_;
    const Log& log_;
    gpu::OverlayPipeline pipeline_;
    overlay::GlyphCache glyphs_;
    uint64_t failedFontId_ = 0; // a font FreeType could not make a face of
    std::vector<Slot> slots_;
};

} // namespace iris
