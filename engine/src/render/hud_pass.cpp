#include "render/hud_pass.h"

namespace iris::render {

Result HudPass::prepare(FrameContext& frame) {
    // Laid out for this target; the overview's thumbnail is the coarsest level's tiles (the
    // ones kept resident), placed at the thumbnail's downsample after the view's tiles in the
    // same instance buffer. While a shown thumbnail misses tiles of a level kept whole, the
    // frame is not complete.
    frame_ = overlays_.prepare(frame.slot, frame.snap, frame.extent);
    thumbnail_.clear();
    const Snapshot& snap = frame.snap;
    for (const overlay::OverlayDraw& d : frame_.plan.draws) {
        if (!d.thumbnail || !snap.slide) continue;
        if (!appendThumbnail(snap.slide->info, snap.slide->generation, frame.viewport.view.downsample, d.thumbnailView,
                             d.thumbnailRect.x, d.thumbnailRect.y, frame.instances.remaining(), frame.tiles,
                             thumbnail_))
            frame.complete = false;
    }
    thumbCount_ = uint32_t(thumbnail_.size());
    thumbFirst_ = frame.instances.append(thumbnail_.data(), thumbCount_);
    if (!frame_.fontError.ok()) return Result(frame_.fontError.status(), "font: " + frame_.fontError.message());
    return {};
}

void HudPass::recordUploads(VkCommandBuffer cmd, const FrameContext& frame) {
    overlays_.recordUploads(cmd, frame.slot, frame_);
}

Result HudPass::recordDraws(VkCommandBuffer cmd, const FrameContext& frame) {
    return overlays_.recordDraws(cmd, frame.slot, frame_, frame.format, frame.extent, [&](const overlay::OverlayDraw&) {
        tiles_.drawSpan(cmd, frame, thumbFirst_, thumbCount_, false, false);
    });
}

} // namespace iris::render
