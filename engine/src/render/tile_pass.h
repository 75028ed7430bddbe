// The tile pass: the slide's tiles of the base, LR and HR levels in painter's order, each only
// where it is resident (render/draw_list builds the list, without Vulkan), with the seam bands
// of levels drawn zoomed in (gpu/tile_pipeline.h). It also draws other spans of atlas tiles
// for later passes: the overview map's thumbnail (render/hud_pass.h).
//
// The exact copy (EngineTuning::exactCopy): where the HR level is drawn exactly (drawsExact),
// unturned and unmirrored, with no colour step, into a target that takes copies of the atlas's
// format (FrameContext::copyTarget), its opaque tiles are copied from the atlas (vkCmdCopyImage)
// instead of drawn. Their pixels are the texels' bytes either way: the exact pipeline fetches
// them, and an opaque premultiplied pixel drawn "over" is itself. The render thread records the
// copies after the levels still drawn (coarser tiles and tiles not known opaque, which no copied
// tile overlaps), and the other passes after the copies.
#pragma once

#include "gpu/tile_pipeline.h"
#include "metrics/field_metrics.h"
#include "render/frame_pass.h"

namespace iris::render {

class TilePass final : public FramePass {
public:
    // drawCovered: EngineTuning::drawCovered (coarse tiles also under resident finer ones).
    TilePass(gpu::TilePipeline& pipeline, bool drawCovered) : pipeline_(pipeline), drawCovered_(drawCovered) {}

    const char* name() const override { return "tiles"; }
    // Also stages a new colour table (the snapshot's) for upload.
    Result prepare(FrameContext& frame) override;
    void recordUploads(VkCommandBuffer cmd, const FrameContext& frame) override;
    Result recordDraws(VkCommandBuffer cmd, const FrameContext& frame) override;

    // What the last prepared frame showed of its view's field (metrics/field_metrics.h).
    const metrics::FieldProgress& progress() const { return progress_; }
    // Tiles the last prepared frame shows, drawn or copied.
    uint32_t tilesDrawn() const { return count_ + uint32_t(copies_.size()); }
    // Of those, the tiles it copies (recordCopies).
    uint32_t tilesCopied() const { return uint32_t(copies_.size()); }
    // The exact copy's regions (target in TRANSFER_DST_OPTIMAL, the atlas in GENERAL), in one
    // command; outside a render pass, after recordDraws' levels.
    void recordCopies(VkCommandBuffer cmd, VkImage atlas, VkImage target) const;
    // The last prepared frame's draw list (the per-pixel resolve's page table comes from it).
    const DrawList& drawList() const { return drawList_; }
    // Off: the frame's levels are resolved elsewhere (render/resolve_pass.h); recordDraws then
    // draws nothing, and drawSpan still serves the HUD's thumbnail.
    void setDrawLevels(bool on) { drawLevels_ = on; }

    // Records instances [first, first + n) of the frame's arena as tile quads; with `seams`,
    // then the seam pass's four bands of each. Binds its own pipeline and state. Only after
    // this frame's prepare() (which makes the pipelines for the frame's format).
    // `turned`: the instances are the view's tiles, in its unturned frame (the view's rotation
    // and flips are applied); else they are placed as they are (the thumbnail). `exact`: a level
    // drawn exactly (LevelDraw::exact), with the pipeline that fetches texels.
    void drawSpan(VkCommandBuffer cmd, const FrameContext& frame, uint32_t first, uint32_t n, bool seams,
                  bool turned, bool exact = false);

private:
    // Moves the HR level's opaque instances out of the draw list into copies_, where the frame
    // allows the exact copy.
    void takeCopies(const FrameContext& frame, bool managed);

    gpu::TilePipeline& pipeline_;
    const bool drawCovered_;
    bool drawLevels_ = true;
    DrawList drawList_; // reused from frame to frame
    std::vector<VkImageCopy> copies_; // this frame's exact copies, atlas → target
    metrics::FieldProgress progress_;
    std::vector<uint64_t> shownUploads_; // by atlas layer: the upload sequence number last drawn there
    uint32_t first_ = 0, count_ = 0;                               // this frame's span of the arena
    VkPipeline pipe_ = VK_NULL_HANDLE, seamPipe_ = VK_NULL_HANDLE; // for this frame's format
    VkPipeline exactPipe_ = VK_NULL_HANDLE; // and for its levels drawn exactly (made when one is)
};

} // namespace iris::render
