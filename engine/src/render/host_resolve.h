// Filtered frames resolved on the host, for CPU devices (docs/ARCHITECTURE.md, "The
// resolve on the host"). On a CPU device every filtered pixel of the tile pass goes through
// llvmpipe's general fragment path: four gathers a pixel, 12-16 ms for a 1080p frame on two
// cores, measured (BENCHMARKS.md), whatever the shader does around them. Where the atlas is
// written from the host (gpu/tile_atlas.h, hostWritten) its texels are in mapped memory, and a
// view of one level is a separable resampling: at LOD 0 (enlarged, or 1:1 off the pixel grid)
// each level row the frame reads is gathered from its tiles into one line and filtered
// horizontally once (SSE2, two columns a step) into a row of 16-bit channels, and each target
// row is the vertical blend of two such rows; shrunk, the same in each of the two mips the LOD
// falls between, blended (trilinear). This pass does that on the render thread and one
// helper, into a host-visible buffer that the frame copies into its target before the other
// passes (annotations, layers, HUD) draw over it.
//
// It serves settled frames and those of a field still loading, whatever levels they show: per
// pixel the finest of HR, LR and base whose tile is resident there (a coarser level past the
// HR level's edge or where its tiles are not in yet, then the background), every resident tile
// it reads opaque, nothing failing, the view unturned and unmirrored, no colour step, the HR
// level not drawn exactly (the exact copy's). Where a tap's tile is absent (the ring around the
// field, or a loading field's) the pixel comes from its own tile, as the quads draw it, so a
// view's frames do not switch between the two ways as tiles arrive. Filtering is the compute resolve's (shaders/tile_resolve.comp: each tap from the tile that
// holds it, clamped into the level, or into the edge tiles' mips) with 8-bit weights,
// lavapipe's sub-texel precision: the quads' picture, no channel more than two codes off
// (engine.host_resolve).
//
// Render thread only (its helper works inside prepare()).
#pragma once

#include <array>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

#include "core/log.h"
#include "gpu/tile_atlas.h"
#include "render/draw_list.h"
#include "render/frame_pass.h"

namespace iris::render {

// One level of a frame of the host resolve: its tiles and where the target lies in it.
struct HostLayer {
    TileRange grid;             // the level's tiles the filter may read: the drawn range grown by one
    std::vector<int32_t> slots; // atlas slot of each tile of `grid`, row by row; -1: absent or outside the level
    bool gaps = false;          // a tile of `grid` inside the level is absent
    float x0 = 0, y0 = 0;       // level position of the target's (0, 0) corner
    float scale = 1;            // level pixels per target pixel
    int32_t levelWidth = 0, levelHeight = 0;
    int64_t tilesX = 0, tilesY = 0; // the level's

    // Per target column: the columns of `grid` holding the filter's two taps.
    struct Column {
        int32_t tile0, tile1;
    };
    // The mips read: mip 0 alone at LOD 0; else floor(LOD) and the next, blended by
    // `mipWeight` (0..256; 0: the first alone).
    struct Mip {
        uint32_t level = 0;
        std::vector<Column> columns;
        // The mip texels [lo, hi] of a level row that the columns read. Each row read is first
        // gathered into one line of them (each tile's part), then filtered from it:
        int64_t lo = 0, hi = 0;
        std::vector<uint32_t> at; // per column: its first tap's byte offset in the line
        // Per column, the filter's weights as the kernel multiplies them: (256 − w) four
        // times, then w four times; w = 0 where both taps are one texel (clamped).
        std::vector<std::array<uint16_t, 8>> weights;
        // The columns in order, as spans filtered one way: a run of columns reading
        // consecutive texels with one weight (the view at the mip's own scale) as one loop
        // over bytes, which the compiler vectorises; other columns a pixel at a time.
        struct Span {
            uint32_t x0, x1; // [x0, x1)
            bool run;
        };
        std::vector<Span> spans;
    };
    Mip mips[2];
    int mipCount = 1;
    uint32_t mipWeight = 0;
    bool shrunk = false; // LOD > 0: positions clamped into the level, taps into its tiles' mips
    // Per target column: the column of `grid` holding the pixel's own tile (its centre's), or
    // -1 where the centre lies outside the level.
    std::vector<int32_t> own;
    bool ownAll = false; // every column's centre lies inside the level: own[0] .. own[width − 1]
    // Per target column: a tap, in a mip read, lies outside the pixel's own tile (which the
    // filter may then find absent: see gaps).
    std::vector<uint8_t> crosses;
};

// The target's columns cut wherever a layer's own tile column changes: along a target row,
// which layer shows (the finest whose own tile is resident) is one choice a segment, not one a
// pixel. Each layer's taps leave the own tile only at a segment's ends: [inner0, inner1) are
// the columns whose taps all stay inside it (in every mip read).
struct HostSegment {
    uint32_t x0, x1; // [x0, x1)
    int32_t own[3];  // per layer: HostLayer::own of its columns
    uint32_t inner0[3], inner1[3];
};

// One frame of the host resolve: its layers finest first (HR, LR, base); each pixel shows the
// finest whose own tile there is resident, else the background.
struct HostFrame {
    const gpu::TileAtlas* atlas = nullptr;
    HostLayer layers[3];
    int layerCount = 0;
    std::vector<HostSegment> segments; // in order, covering [0, width)
    uint32_t width = 0, height = 0; // the target's
    uint8_t background[4] = {};     // opaque, in the target's channel order
    bool swap = false;              // the target's red and blue are the atlas's blue and red
};

// Fills `f` for the frame when the host can resolve it (see above) and returns true; false
// leaves the frame to the tile pass. `list`: the tile pass's draw list for this frame.
// `background`: the clear colour (unorm, RGBA).
bool planHostFrame(const FrameContext& frame, const DrawList& list, const gpu::TileAtlas& atlas,
                   const std::array<float, 4>& background, HostFrame& f);

// Writes target rows [row0, row1) of a planned frame into dst (4 bytes a pixel, `stride` bytes
// a row, the target's channel order). Reads only `f` and the atlas's mapped texels.
void resolveRows(const HostFrame& f, uint32_t row0, uint32_t row1, uint8_t* dst, size_t stride);

class HostResolvePass {
public:
    HostResolvePass(gpu::Device& device, const gpu::TileAtlas& atlas, const Log& log)
        : device_(device), atlas_(atlas), log_(log) {}
    ~HostResolvePass();
    HostResolvePass(const HostResolvePass&) = delete;
    HostResolvePass& operator=(const HostResolvePass&) = delete;

    Result init(uint32_t frameSlots);
    // After the tile pass's prepare: resolves the frame into the slot's buffer and returns
    // true, or returns false (nothing done) when the frame is not one it serves. Each change
    // between the two is logged (Debug: "tile resolve: frame N on the host" / "... as quads").
    Expected<bool> prepare(const FrameContext& frame, const DrawList& list, const std::array<float, 4>& background,
                           bool targetTakesCopies);
    // Outside a render pass: the buffer into the target, which becomes a colour attachment
    // (loaded by the render pass that follows, for the other passes).
    void record(VkCommandBuffer cmd, const FrameContext& frame, VkImage target) const;

private:
    void helperLoop();

    gpu::Device& device_;
    const gpu::TileAtlas& atlas_;
    const Log& log_;
    bool serving_ = false;                // the last frame was resolved here
    std::vector<vk::MappedBuffer> slots_; // one per frame slot, grown to the target's size
    HostFrame frame_;                     // reused (its vectors keep their capacity)

    // The helper resolves the lower half of each frame's rows while the render thread does the
    // upper half.
    std::thread helper_;
    std::mutex mutex_;
    std::condition_variable cv_;
    uint8_t* jobDst_ = nullptr;
    size_t jobStride_ = 0;
    uint32_t jobRow0_ = 0, jobRow1_ = 0;
    uint64_t posted_ = 0, done_ = 0;
    bool stopping_ = false;
};

} // namespace iris::render
