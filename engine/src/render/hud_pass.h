// The HUD pass: the overlays drawn over everything else and never transformed with the slide
// (scale bar, magnification, overview map with its thumbnail of the slide's coarsest tiles).
// OverlayRenderer lays them out and records them; the thumbnail's atlas tiles are drawn by the
// tile pass's pipeline (TilePass::drawSpan) under the overview's scissor.
#pragma once

#include <vector>

#include "render/overlay_renderer.h"
#include "render/tile_pass.h"

namespace iris::render {

class HudPass final : public FramePass {
public:
    HudPass(gpu::Device& device, const Log& log, TilePass& tiles) : overlays_(device, log), tiles_(tiles) {}

    Result init(uint32_t frameSlots) { return overlays_.init(frameSlots); }
    const char* name() const override { return "overlays"; }
    Result prepare(FrameContext& frame) override;
    void recordUploads(VkCommandBuffer cmd, const FrameContext& frame) override;
    Result recordDraws(VkCommandBuffer cmd, const FrameContext& frame) override;

    // The layout of the last prepared frame's overlays (published with the frame: hit tests).
    const OverlayLayout& layout() const { return frame_.plan.layout; }

private:
    OverlayRenderer overlays_;
    TilePass& tiles_;
    OverlayFrame frame_;                       // this frame's overlays
    std::vector<gpu::TileInstance> thumbnail_; // this frame's thumbnail tiles (reused)
    uint32_t thumbFirst_ = 0, thumbCount_ = 0; // their span of the arena
};

} // namespace iris::render
