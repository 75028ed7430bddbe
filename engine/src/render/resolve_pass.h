// The per-pixel resolve (EngineTuning::TileResolve::Compute): instead of the tile pass's
// instanced quads and seam bands, one compute dispatch writes every pixel of an offscreen
// target from a page table of the frame's resident tiles (shaders/tile_resolve.comp). The
// draw list is the same (render/draw_list, built by the tile pass); this pass only turns its
// per-level atlas layers into the table. An evaluation of the design the virtual-texturing
// systems use (docs/ARCHITECTURE.md, "Per-tile quads or a per-pixel resolve"); swapchains keep
// quads (their images need not support storage).
//
// Render thread only.
#pragma once

#include <vector>

#include "gpu/tile_atlas.h"
#include "gpu/tile_pipeline.h"
#include "gpu/vk_handle.h"
#include "render/frame_pass.h"

namespace iris::render {

class ResolvePass {
public:
    ResolvePass(gpu::Device& device, gpu::TileAtlas& atlas, gpu::TilePipeline& tiles)
        : device_(device), atlas_(atlas), tiles_(tiles) {}
    ResolvePass(const ResolvePass&) = delete;
    ResolvePass& operator=(const ResolvePass&) = delete;

    Result init(uint32_t frameSlots);
    // Writes the frame slot's page table from `list` (the tile pass's, for this frame) and
    // points the slot's descriptor set at the target. `background`: the clear colour.
    Result prepare(const FrameContext& frame, const DrawList& list, const std::array<float, 4>& background,
                   VkImageView target);
    // Outside the render pass: the target goes to GENERAL, the dispatch writes every pixel,
    // then the target becomes a colour attachment (loaded, not cleared) for the HUD.
    void record(VkCommandBuffer cmd, const FrameContext& frame, VkImage target);

private:
    gpu::Device& device_;
    gpu::TileAtlas& atlas_;
    gpu::TilePipeline& tiles_; // its colour table
    vk::ShaderModule shader_;
    vk::DescriptorSetLayout setLayout_;
    vk::PipelineLayout layout_;
    vk::DescriptorPool pool_;
    vk::Pipeline pipelines_[2]; // colour step off, on
    struct Slot {
        vk::MappedBuffer table;
        VkDescriptorSet set = VK_NULL_HANDLE;
        VkImageView target = VK_NULL_HANDLE; // what `set` points at
    };
    std::vector<Slot> slots_;
    bool colorManaged_ = false; // this frame's
};

} // namespace iris::render
