#include "render/tile_pass.h"

#include <algorithm>
#include <cstring>
#include <utility>

namespace iris::render {

uint32_t InstanceArena::append(const gpu::TileInstance* src, uint32_t n) {
    const uint32_t first = used;
    if (n > 0) std::memcpy(mapped + first, src, n * sizeof(gpu::TileInstance));
    used += n;
    return first;
}

Result TilePass::prepare(FrameContext& frame) {
    progress_ = {};
    first_ = frame.instances.used;
    count_ = 0;
    copies_.clear();
    pipe_ = seamPipe_ = exactPipe_ = VK_NULL_HANDLE;
    // The colour transform: the snapshot's table into the GPU's, and the pipelines with the step.
    Result colorError;
    bool managed = frame.snap.colorLut != nullptr;
    if (Result r = pipeline_.colorLut().prepare(frame.slot, frame.snap.colorLut); !r.ok()) {
        colorError = Result(r.status(), "colour transform: " + r.message() + "; drawing without it");
        managed = false;
    }
    Expected<VkPipeline> pipe = pipeline_.pipelineFor(frame.format, managed);
    if (!pipe) {
        frame.complete = false;
        return pipe.error();
    }
    Expected<VkPipeline> seamPipe = pipeline_.seamPipelineFor(frame.format, managed);
    if (!seamPipe) {
        frame.complete = false;
        return seamPipe.error();
    }
    pipe_ = *pipe;
    seamPipe_ = *seamPipe;
    if (!frame.snap.slide) {
        frame.complete = false; // nothing to show is not a shown view (waitForFrame needs a slide)
        return colorError;
    }
    const DrawOptions options{.drawCovered = drawCovered_,
                              .sizeMatches = frame.sizeMatches,
                              .maxInstances = frame.instances.remaining(),
                              .failing = frame.failing,
                              .placeholder = placeholderKey(frame.snap.slide->generation)};
    buildDrawList(frame.snap.slide->info, frame.snap.slide->generation, frame.viewport, options, frame.tiles,
                  drawList_);
    takeCopies(frame, managed);
    count_ = drawList_.instanceCount();
    const auto drawnExactly = [](const LevelDraw& d) { return d.exact && !d.instances.empty(); };
    if (drawLevels_ && std::any_of(drawList_.levels.begin(), drawList_.levels.end(), drawnExactly)) {
        Expected<VkPipeline> exactPipe = pipeline_.pipelineFor(frame.format, managed, true);
        if (!exactPipe) {
            frame.complete = false;
            count_ = 0;
            return exactPipe.error();
        }
        exactPipe_ = *exactPipe;
    }
    drawList_.copyInstances(frame.instances.mapped + first_);
    frame.instances.used += count_;
    // Tiles drawn for the first time: an atlas layer whose upload this pass has not drawn yet
    // (each upload has its own sequence number; 0, unknown, is never counted).
    uint32_t newlyShown = 0;
    for (const LevelDraw& d : drawList_.levels)
        for (const int32_t layer : d.layers) {
            if (layer < 0 || layer == drawList_.placeholderLayer) continue;
            if (size_t(layer) >= shownUploads_.size()) shownUploads_.resize(size_t(layer) + 1, 0);
            const uint64_t seq = frame.tiles.uploadSeq(layer);
            if (seq != 0 && std::exchange(shownUploads_[size_t(layer)], seq) != seq) ++newlyShown;
        }
    progress_ = metrics::FieldProgress{.hasLr = drawList_.hasLr,
                                       .lrComplete = drawList_.lrComplete,
                                       .hrComplete = drawList_.hrComplete,
                                       .lrTiles = drawList_.lrTiles,
                                       .hrTiles = drawList_.hrTiles,
                                       .newestUpload = drawList_.newestUpload,
                                       .newlyShown = newlyShown};
    if (!drawList_.hrComplete) frame.complete = false;
    return colorError;
}

void TilePass::takeCopies(const FrameContext& frame, bool managed) {
    LevelDraw& hr = drawList_.levels[2];
    if (!frame.copyTarget || !drawLevels_ || managed || !hr.exact || hr.instances.empty()) return;
    // Unturned and unmirrored: a right-angle turn or a flip is drawn exactly, but not copied.
    const ViewTransform t = ViewTransform::of(frame.viewport.view, frame.viewport.width, frame.viewport.height);
    if (t.m != std::array<double, 4>{1, 0, 0, 1}) return;
    const int64_t w = frame.extent.width, h = frame.extent.height;
    size_t kept = 0;
    for (const gpu::TileInstance& inst : hr.instances) {
        // Exact: the tile's origin is on a whole pixel (drawsExact), one texel a pixel.
        int64_t dx = std::llround(inst.rect[0]), dy = std::llround(inst.rect[1]);
        int64_t sx = 0, sy = 0, cw = int64_t(inst.texel[0]), ch = int64_t(inst.texel[1]);
        if (dx < 0) sx = -dx, cw += dx, dx = 0;
        if (dy < 0) sy = -dy, ch += dy, dy = 0;
        cw = std::min(cw, w - dx);
        ch = std::min(ch, h - dy);
        // Drawn as before: a tile not known opaque ("over" what lies beneath is not a copy), and
        // one with nothing in the target (the rasteriser clips it away).
        if (cw <= 0 || ch <= 0 || !frame.tiles.opaque(int(inst.texel[2]))) {
            hr.instances[kept++] = inst;
            continue;
        }
        copies_.push_back(VkImageCopy{
            .srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, uint32_t(inst.texel[2]), 1},
            .srcOffset = {int32_t(sx), int32_t(sy), 0},
            .dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
            .dstOffset = {int32_t(dx), int32_t(dy), 0},
            .extent = {uint32_t(cw), uint32_t(ch), 1},
        });
    }
    hr.instances.resize(kept);
}

void TilePass::recordCopies(VkCommandBuffer cmd, VkImage atlas, VkImage target) const {
    if (copies_.empty()) return;
    vkCmdCopyImage(cmd, atlas, VK_IMAGE_LAYOUT_GENERAL, target, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                   uint32_t(copies_.size()), copies_.data());
}

void TilePass::recordUploads(VkCommandBuffer cmd, const FrameContext& frame) {
    pipeline_.colorLut().recordUpload(cmd, frame.slot);
}

Result TilePass::recordDraws(VkCommandBuffer cmd, const FrameContext& frame) {
    if (count_ == 0 || !drawLevels_) return {};
    const VkRect2D scissor{{0, 0}, frame.extent};
    vkCmdSetScissor(cmd, 0, 1, &scissor);
    // Level by level in painter's order: a level's seam bands go on before finer levels.
    uint32_t first = first_;
    for (const LevelDraw& d : drawList_.levels) {
        const uint32_t n = uint32_t(d.instances.size());
        if (n > 0) drawSpan(cmd, frame, first, n, d.linked, true, d.exact);
        first += n;
    }
    return {};
}

void TilePass::drawSpan(VkCommandBuffer cmd, const FrameContext& frame, uint32_t first, uint32_t n, bool seams,
                        bool turned, bool exact) {
    const VkPipeline pipe = exact ? exactPipe_ : pipe_;
    if (!pipe || n == 0) return; // prepare failed to make the pipelines (and said so)
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
    const VkViewport viewport{0, 0, float(frame.extent.width), float(frame.extent.height), 0, 1};
    vkCmdSetViewport(cmd, 0, 1, &viewport);
    VkDescriptorSet set = pipeline_.descriptorSet();
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_.layout(), 0, 1, &set, 0, nullptr);
    gpu::TilePush push{{float(frame.extent.width), float(frame.extent.height)}};
    int edges = 4;
    if (turned) {
        const ViewTransform t = ViewTransform::of(frame.viewport.view, frame.viewport.width, frame.viewport.height);
        if (!t.axisAligned()) {
            push.fullBands = 1;
            edges = 8;
        }
        for (int i = 0; i < 4; ++i) push.turn[i] = float(t.m[size_t(i)]);
        push.centre[0] = float(t.targetCX);
        push.centre[1] = float(t.targetCY);
    }
    vkCmdPushConstants(cmd, pipeline_.layout(), VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(push), &push);
    const VkDeviceSize offset = 0;
    vkCmdBindVertexBuffers(cmd, 0, 1, &frame.instances.buffer, &offset);
    vkCmdDraw(cmd, 4, n, 0, first);
    if (!seams) return;
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, seamPipe_);
    for (push.edge = 1; push.edge <= edges; ++push.edge) {
        vkCmdPushConstants(cmd, pipeline_.layout(), VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(push), &push);
        vkCmdDraw(cmd, 4, n, 0, first);
    }
}

} // namespace iris::render
