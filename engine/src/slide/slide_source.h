// SlideSource: one open slide, whatever its format. Implementations live beside this file
// (openslide_source.cpp; later iris_file.cpp) and are picked by the format table in
// slide_source.cpp, fast paths first and OpenSlide last as the universal reader.
//
// Threading: readTile() and readAssociatedImage() may be called concurrently from any
// number of loader threads; implementations make that safe.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "iris/types.h"

namespace iris {

inline constexpr int kTileSize = 256;                        // the engine's tile grid, every level
inline constexpr int kTileBytes = kTileSize * kTileSize * 4; // RGBA8

class SlideSource {
public:
    virtual ~SlideSource() = default;
    // Metadata, filled at open; levels carry the engine's tile grid.
    virtual const SlideInfo& info() const = 0;
    // Decodes tile (tx, ty) of `level` into dst (kTileSize² RGBA8, premultiplied alpha,
    // row stride kTileSize·4). Pixels past the level's edge are filled by repeating the
    // last valid column and row, so that mip levels do not darken at slide edges.
    // On failure dst holds nothing usable (the loader draws the failed-tile placeholder there),
    // unless keepsPartialTiles(level) says otherwise.
    virtual Result readTile(int level, int64_t tx, int64_t ty, uint8_t* dst) = 0;
    // True when a failed readTile of `level` (other than Status::Cancelled) still leaves the
    // whole tile in dst, with only the parts it could not read drawn as the failed-tile
    // placeholder: a tile computed from many stored tiles (PyramidSource) loses only the area
    // of a broken one, not all of it. The error is still reported.
    virtual bool keepsPartialTiles(int /*level*/) const { return false; }
    virtual Expected<Image> readAssociatedImage(const std::string& name) = 0;
    // The engine has let go of this slide (another was opened, it was closed, the engine is
    // going away). A read that takes long (a synthetic level's tile: many stored tiles) may
    // stop early and return Status::Cancelled; a one-tile read just finishes.
    virtual void abandon() {}
};

// Opens `path` with the first format that recognises it, after checking that the path is
// an existing, readable regular file, or a folder (a DICOM series: DicomSource). Errors name
// the file and the reason.
// `preference` restricts the table to one reader (EngineConfig::source).
Expected<std::unique_ptr<SlideSource>> openSlideSource(const std::string& path,
                                                       SourcePreference preference = SourcePreference::Auto);

// Fills the LevelInfo tile grid fields (tilesX/Y) from width/height.
void fillTileGrid(LevelInfo& level);

// Fills each level's mpp and magnification from the slide's (level-0) values and the
// level's downsample. Every reader calls it once its SlideInfo is complete.
void fillLevelPhysics(SlideInfo& info);

// Repeats the last valid column/row of a partially filled tile into its padding.
void padTileEdges(uint8_t* rgba, int validWidth, int validHeight);

// Fills a tile with the visible "could not be decoded" placeholder (grey with red diagonals).
void fillFailedTilePlaceholder(uint8_t* rgba);

} // namespace iris
