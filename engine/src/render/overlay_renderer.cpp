#include "render/overlay_renderer.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace iris {

Result OverlayRenderer::init(uint32_t frameSlots) {
    if (Result r = glyphs_.init(); !r.ok()) return r;
    if (Result r = pipeline_.init(overlay::GlyphCache::kAtlasSize); !r.ok()) return r;
    slots_.resize(frameSlots);
    constexpr VkDeviceSize kStaging = VkDeviceSize(overlay::GlyphCache::kAtlasSize) * overlay::GlyphCache::kAtlasSize;
    for (Slot& s : slots_) {
        if (Result r = vk::createMappedBuffer(device_.physical(), device_.device(), sizeof(gpu::OverlayInstance) * kMaxInstances,
                                              VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, false, s.instances);
            !r.ok())
            return r;
        if (Result r = vk::createMappedBuffer(device_.physical(), device_.device(), kStaging,
                                              VK_BUFFER_USAGE_TRANSFER_SRC_BIT, false, s.staging);
            !r.ok())
            return r;
    }
    return {};
}

OverlayFrame OverlayRenderer::prepare(uint32_t slot, const Snapshot& snap, VkExtent2D extent) {
    OverlayFrame out;
    const overlay::OverlaySettings& settings = snap.overlays;
    if (!snap.slide || !settings.visibleAny()) return out;
    const uint64_t wanted = settings.font ? settings.font->id : 0;
    if (glyphs_.fontId() != wanted && (wanted == 0 || wanted != failedFontId_)) {
        out.fontError = glyphs_.setFont(settings.font); // leaves no face on error: no labels
        if (!out.fontError.ok()) failedFontId_ = wanted;  // reported once, not every frame
    }

    const double ratio = settings.devicePixelRatio;
    const int pixelSize = std::max(1, int(std::lround(overlay::Metrics::kTextSize * ratio)));
    Viewport vp = snap.viewport;
    vp.width = extent.width;
    vp.height = extent.height;
    bool atlasFull = false;
    const std::optional<overlay::LegendContent> legend =
        settings.visible[size_t(Overlay::Legend)] ? overlay::legendFor(*snap.layers) : std::nullopt;
    const overlay::LegendContent* legendPtr = legend ? &*legend : nullptr;
    const overlay::MeasureText measure = [&](const std::string& text) {
        overlay::TextMetrics m;
        const overlay::ShapedText shaped = glyphs_.shape(overlay::decodeUtf8(text), pixelSize);
        if (!shaped.ok) {
            atlasFull = atlasFull || glyphs_.hasFont();
            return m;
        }
        m.ok = true;
        m.width = shaped.width / ratio;
        m.ascent = shaped.ascent / ratio;
        m.descent = shaped.descent / ratio;
        return m;
    };
    out.plan = overlay::layoutOverlays(&snap.slide->info, vp, settings, measure, snap.background, legendPtr);
    if (atlasFull) {
        // Glyphs of earlier sizes filled the atlas: start it again with this frame's labels.
        glyphs_.clear();
        atlasFull = false;
        out.plan = overlay::layoutOverlays(&snap.slide->info, vp, settings, measure, snap.background, legendPtr);
    }

    Slot& s = slots_[slot];
    auto* inst = static_cast<gpu::OverlayInstance*>(s.instances.mapped);
    uint32_t n = 0;
    const auto push = [&](double x0, double y0, double x1, double y1, const std::array<float, 4>& c, float gx = 0,
                          float gy = 0, float glyph = 0) {
        if (n >= kMaxInstances) return;
        inst[n++] = gpu::OverlayInstance{.rect = {float(x0), float(y0), float(x1), float(y1)},
                                         .colour = {c[0], c[1], c[2], c[3]},
                                         .glyph = {gx, gy, glyph, 0}};
    };
    for (const overlay::OverlayDraw& d : out.plan.draws) {
        std::array<OverlayFrame::Range, 2> r{};
        r[0].first = n;
        for (const overlay::Quad& q : d.under) push(q.x0, q.y0, q.x1, q.y1, q.colour);
        r[0].count = n - r[0].first;
        r[1].first = n;
        for (const overlay::Quad& q : d.over) push(q.x0, q.y0, q.x1, q.y1, q.colour);
        for (const overlay::Label& l : d.labels) {
            // The layout measured this label, so its glyphs are in the cache (no new uploads).
            const overlay::ShapedText shaped = glyphs_.shape(overlay::decodeUtf8(l.text), pixelSize);
            if (!shaped.ok) continue;
            for (const auto& [g, penX] : shaped.glyphs) {
                if (g->width == 0) continue;
                const double x0 = l.x + penX + g->left, y0 = l.baseline - g->top;
                push(x0, y0, x0 + g->width, y0 + g->height, overlay::kTextColour, float(g->atlasX), float(g->atlasY), 1);
            }
        }
        r[1].count = n - r[1].first;
        out.ranges.push_back(r);
    }
    // (Host-coherent memory, as on lavapipe and NVIDIA, needs no flush and cannot fail here.)
    if (Result r = vk::flush(device_.device(), s.instances); !r.ok()) log_.error("overlay instances: " + r.message());

    // Glyphs rasterised for this frame: into the slot's staging buffer (the atlas is its size,
    // so everything pending fits).
    const auto& uploads = glyphs_.uploads();
    const auto& bytes = glyphs_.pending();
    if (!uploads.empty() && bytes.size() <= s.staging.size) {
        std::memcpy(s.staging.mapped, bytes.data(), bytes.size());
        if (Result r = vk::flush(device_.device(), s.staging); !r.ok()) log_.error("glyph upload: " + r.message());
        out.uploads = uint32_t(uploads.size());
    }
    return out;
}

void OverlayRenderer::recordUploads(VkCommandBuffer cmd, uint32_t slot, const OverlayFrame& frame) {
    std::vector<VkBufferImageCopy> regions;
    if (frame.uploads > 0) {
        for (const overlay::GlyphUpload& u : glyphs_.uploads()) {
            regions.push_back(VkBufferImageCopy{
                .bufferOffset = VkDeviceSize(u.offset),
                .bufferRowLength = 0, // tightly packed
                .bufferImageHeight = 0,
                .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
                .imageOffset = {u.x, u.y, 0},
                .imageExtent = {uint32_t(u.width), uint32_t(u.height), 1},
            });
        }
        glyphs_.clearUploads();
    }
    // The first frame with overlays also clears the atlas into its sampled layout.
    if (!frame.plan.draws.empty() || !regions.empty())
        pipeline_.recordUploads(cmd, slots_[slot].staging.buffer, regions.data(), uint32_t(regions.size()));
}

Result OverlayRenderer::recordDraws(VkCommandBuffer cmd, uint32_t slot, const OverlayFrame& frame, VkFormat format,
                                    VkExtent2D extent,
                                    const std::function<void(const overlay::OverlayDraw&)>& drawThumbnail) {
    if (frame.plan.draws.empty()) return {};
    Expected<VkPipeline> pipe = pipeline_.pipelineFor(format);
    if (!pipe) return pipe.error();
    const VkViewport viewport{0, 0, float(extent.width), float(extent.height), 0, 1};
    const gpu::OverlayPush push{{float(extent.width), float(extent.height)}};
    const VkDescriptorSet set = pipeline_.descriptorSet();
    const VkDeviceSize offset = 0;
    const auto bind = [&] {
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, *pipe);
        vkCmdSetViewport(cmd, 0, 1, &viewport);
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_.layout(), 0, 1, &set, 0, nullptr);
        vkCmdPushConstants(cmd, pipeline_.layout(), VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(push), &push);
        vkCmdBindVertexBuffers(cmd, 0, 1, &slots_[slot].instances.buffer, &offset);
    };
    // Each overlay is clipped to its own rectangle: whatever it draws stays inside the
    // rectangle the layout reports.
    const auto scissorTo = [&](const PixelRect& r) {
        const int32_t x0 = std::clamp<int32_t>(r.x, 0, int32_t(extent.width));
        const int32_t y0 = std::clamp<int32_t>(r.y, 0, int32_t(extent.height));
        const int32_t x1 = std::clamp<int32_t>(r.x + r.width, x0, int32_t(extent.width));
        const int32_t y1 = std::clamp<int32_t>(r.y + r.height, y0, int32_t(extent.height));
        const VkRect2D sc{{x0, y0}, {uint32_t(x1 - x0), uint32_t(y1 - y0)}};
        vkCmdSetScissor(cmd, 0, 1, &sc);
        return x1 > x0 && y1 > y0;
    };
    bind();
    for (size_t i = 0; i < frame.plan.draws.size(); ++i) {
        const overlay::OverlayDraw& d = frame.plan.draws[i];
        const auto& r = frame.ranges[i];
        if (!scissorTo(d.rect)) continue;
        if (r[0].count) vkCmdDraw(cmd, 4, r[0].count, 0, r[0].first);
        if (d.thumbnail) {
            if (scissorTo(d.thumbnailRect)) {
                drawThumbnail(d);
                bind();
            }
            scissorTo(d.rect);
        }
        if (r[1].count) vkCmdDraw(cmd, 4, r[1].count, 0, r[1].first);
    }
    return {};
}

} // namespace iris
