// The frame as a fixed list of passes (docs/ARCHITECTURE.md, "The frame"). The render thread
// acquires the target image, builds one FrameContext, and then, for each pass in order:
//
//   prepare(frame)            CPU only: what the pass draws this frame, written into the frame
//                             slot's own buffers; clears frame.complete when what it shows is
//                             not whole yet;
//   recordUploads(cmd, frame) transfers before the render pass (glyphs, later layer data);
//   recordDraws(cmd, frame)   draws inside the one render pass, over the passes before it.
//
// The passes today: tiles (render/tile_pass.h: base, LR, HR, seams), annotations
// (render/annotation_pass.h), then the HUD (render/hud_pass.h: scale bar, magnification,
// overview map). Heat maps will go before the annotations; a colour transform is a step of the
// tile pass's shader.
//
// Passes are owned and called by the render thread only; they read nothing but the frame's
// snapshot and the context, so they need no synchronisation of their own.
#pragma once

#include <unordered_set>

#include <cstdint>

#include "core/shared_state.h"
#include "gpu/tile_instance.h"
#include "gpu/vk_util.h"
#include "render/draw_list.h"

namespace iris::render {

// The frame slot's tile instance buffer, shared by the passes that draw atlas tiles (the tile
// pass, the overview's thumbnail): each takes a contiguous span of it.
struct InstanceArena {
    gpu::TileInstance* mapped = nullptr;
    VkBuffer buffer = VK_NULL_HANDLE;
    uint32_t capacity = 0;
    uint32_t used = 0;

    uint32_t remaining() const { return capacity - used; }
    // Appends `n` instances and returns the index of the first.
    uint32_t append(const gpu::TileInstance* src, uint32_t n);
};

struct FrameContext {
    const Snapshot& snap;
    Viewport viewport;   // the snapshot's view at the target's size
    VkExtent2D extent{}; // the target image's size
    VkFormat format = VK_FORMAT_UNDEFINED;
    uint32_t slot = 0;   // frame slot index: per-slot buffers of the passes
    uint64_t serial = 0; // frame serial: pins taken for this frame are held until its fence
    // The target has the size the view was published for (see DrawOptions::sizeMatches).
    bool sizeMatches = true;
    // The tile pass may copy atlas tiles into the target (render/tile_pass.h, the exact copy):
    // the copy is on, the target takes transfers and has the atlas's format.
    bool copyTarget = false;
    TileResidency& tiles; // the GPU tile map, pinning what this frame samples
    InstanceArena& instances;
    // Tiles of the slide whose read failed for now (core/failing_tiles.h); null: none.
    const std::unordered_set<uint64_t>* failing = nullptr;
    // Cleared by any pass whose content is not whole: a complete frame is what TeFOV times and
    // what waitForFrame waits for.
    bool complete = true;
    // Set by a pass that has more to show than this frame could take (fills triangulated over
    // several frames): the render thread draws another frame after this one.
    bool redraw = false;
};

class FramePass {
public:
    virtual ~FramePass() = default;
    virtual const char* name() const = 0;
    // An error leaves the frame going on without what failed (logged, reported to the host).
    virtual Result prepare(FrameContext& frame) = 0;
    virtual void recordUploads(VkCommandBuffer /*cmd*/, const FrameContext& /*frame*/) {}
    virtual Result recordDraws(VkCommandBuffer cmd, const FrameContext& frame) = 0;
};

} // namespace iris::render
