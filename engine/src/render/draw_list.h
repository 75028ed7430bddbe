// The frame's draw list, built without Vulkan: which tiles of which level are drawn and in
// which order, which are culled, and whether the LR and HR layers are whole. The render thread
// copies the instances into its instance buffer and records them; tests build lists against a
// fake tile map and check them with a CPU rasteriser (tests/render).
//
// Layers (docs/ARCHITECTURE.md): the base level (the slide's coarsest, kept resident), LR and
// HR (view_model's chooseLevels), drawn coarsest first so finer tiles cover coarser ones; a
// tile that is not resident is left out and what lies under it shows through. A coarse tile
// lying wholly under finer tiles this frame draws is culled: drawn, it would only cost fill
// (3x overdraw on a CPU device), and the frame is byte-identical without it.
#pragma once

#include <array>
#include <cstdint>
#include <unordered_set>
#include <vector>

#include "gpu/tile_instance.h"
#include "view/view_model.h"

namespace iris::render {

// What the builder asks of the tile map (TileMap, core/tile_map.h, on the render thread).
class TileResidency {
public:
    // The atlas layer of `key` when its tile is resident, pinned until the frame that draws
    // it has finished; -1 when it is not resident.
    virtual int pin(uint64_t key) = 0;
    // Whether `key`'s tile is resident (no pin).
    virtual bool isActive(uint64_t key) const = 0;
    // The upload sequence number of the tile this frame pinned in `layer` (UploadCounters::tiles
    // once its upload was counted); 0 where unknown.
    virtual uint64_t uploadSeq(int /*layer*/) const { return 0; }
    // Whether every pixel of the tile this frame pinned in `layer` is opaque; false where unknown.
    virtual bool opaque(int /*layer*/) const { return false; }
    // Whether the tile this frame pinned in `layer` has its mip levels (TileMap::mipsReadyOf).
    // One without them is drawn only where it samples level 0 alone (lod 0), else left out as
    // if it were not resident.
    virtual bool mipsReady(int /*layer*/) const { return true; }

protected:
    ~TileResidency() = default;
};

struct DrawOptions {
    // Draw coarse tiles also where finer drawn tiles cover them (A/B measurements, tests).
    bool drawCovered = false;
    // The target has the size the view was published for. A frame drawn at another size (a
    // resize the window system has not applied yet) shows the right view at the wrong size
    // and is never complete.
    bool sizeMatches = true;
    // Instances the frame can hold; tiles past it are left out (and the frame is incomplete).
    uint32_t maxInstances = 16384;
    // Tiles whose read failed for now (core/failing_tiles.h; null: none): one that is not
    // resident is drawn with the atlas tile `placeholder` names, when that is resident, and
    // covers what lies beneath like a drawn tile. The frame stays incomplete: the tile is read
    // again, and the frame that shows it is the complete one.
    const std::unordered_set<uint64_t>* failing = nullptr;
    uint64_t placeholder = 0;
};

// One drawn level: its visible range, the atlas layer of each tile drawn (row-major over the
// range, -1 where none) and their instances.
struct LevelDraw {
    int level = -1; // -1: not drawn this frame
    TileRange range; // area.range
    Footprint area;  // what the target shows of the level: tiles of the range outside it are not visible
    std::vector<int32_t> layers;
    std::vector<gpu::TileInstance> instances;
    std::vector<int32_t> around; // scratch: layers of the range grown by one tile (linkNeighbours)
    bool linked = false;         // neighbours named: the seam pass draws its bands
    bool exact = false;          // drawn 1:1 on whole pixels (drawsExact): fetched, not filtered; no bands

    bool isDrawn(int64_t tx, int64_t ty) const {
        return range.contains(tx, ty) && layers[size_t((ty - range.y0) * (range.x1 - range.x0 + 1) + (tx - range.x0))] >= 0;
    }
};

struct DrawList {
    std::array<LevelDraw, 3> levels; // base, LR, HR: painter's order
    bool hasLr = false;              // the view has an LR layer
    bool lrComplete = false;         // every visible LR tile is resident (drawn or culled)
    bool hrComplete = false;         // every visible HR tile is drawn: the frame is complete
    uint32_t lrTiles = 0, hrTiles = 0; // visible tiles of each layer
    uint64_t newestUpload = 0;         // the highest upload sequence number among drawn LR and HR tiles
    int32_t placeholderLayer = -1;     // the atlas layer drawn for failing tiles this frame (-1: none)
    uint32_t placeholders = 0;         // failing tiles drawn as the placeholder

    uint32_t instanceCount() const;
    // The instances in painter's order (base, LR, HR) into `out`, which holds instanceCount().
    void copyInstances(gpu::TileInstance* out) const;
};

// Builds the draw list of `vp` (its width and height are the target's) over a slide whose
// tiles carry `generation`. `out` is reused from frame to frame (its vectors keep their
// capacity). With no resident tile the list is empty and incomplete.
void buildDrawList(const SlideInfo& info, uint32_t generation, const Viewport& vp, const DrawOptions& options,
                   TileResidency& tiles, DrawList& out);

// Names in each of `d`'s instances (a level not drawn exactly) the atlas layers of the
// tile's eight neighbours in the level, so that the tile shader interpolates across the seams:
// drawn tiles' layers as they are, any other neighbour pinned for the frame when resident (and,
// drawn at `lod` > 0, when it has its mip levels).
void linkNeighbours(const LevelInfo& level, int levelIndex, uint32_t generation, TileResidency& tiles, double lod,
                    LevelDraw& d);

// Whether `level` is drawn exactly in `vp`: one texel a target pixel, the view unturned or
// turned by a multiple of 90° (flips included), and every target pixel's centre on a texel's
// centre (the view's centre on whole pixels of the level). Such a level's pixels are its
// texels' bytes, which filtering would reproduce with weights of 0 (at LOD 0, and across a
// seam too), so the tile pass fetches them (the exact pipeline: on lavapipe the filtered fetch
// is most of a frame's cost) and draws the whole tile without seam bands. The mapping tested is
// the fragment shader's (shaders/tile_turn.glsl) on the draw list's float rectangles.
bool drawsExact(const LevelInfo& level, const Viewport& vp);

// Whether every tile of `level` visible in `vp` is resident.
bool allResident(const SlideInfo& info, uint32_t generation, int level, const Viewport& vp,
                 const TileResidency& tiles);

// The overview's thumbnail: the tiles of the view's base level visible in `thumbnailView`,
// placed at (originX, originY) in the target, appended to `out` while fewer than `budget` are
// there. Returns false when a tile is missing from a base level kept whole
// (kMaxResidentBaseTiles), which makes the frame incomplete; a base level too large to keep
// whole is never waited for.
bool appendThumbnail(const SlideInfo& info, uint32_t generation, double viewDownsample, const Viewport& thumbnailView,
                     double originX, double originY, uint32_t budget, TileResidency& tiles,
                     std::vector<gpu::TileInstance>& out);

// Whether the visible part of tile (tx, ty) of `coarse`, grown by one target pixel, lies
// under tiles of `fine` that `drawn` drew.
bool coveredBy(const LevelInfo& coarse, int64_t tx, int64_t ty, const LevelInfo& fine, const LevelDraw& drawn,
               const Viewport& vp);

} // namespace iris::render
