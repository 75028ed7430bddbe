// SlideSource: one open slide, whatever its format. Implementations live beside this file
// (openslide_source.cpp; later iris_file.cpp) and are picked by the format table in
// slide_source.cpp, fast paths first and OpenSlide last as the universal reader.
//
// Threading: readTile() and readAssociatedImage() may be called concurrently from any
// number of loader threads; implementations make that safe.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "iris/types.h"

namespace iris {

inline constexpr int kTileSize = 256;                        // the engine's tile grid, every level
inline constexpr int kTileBytes = kTileSize * kTileSize * 4; // RGBA8
// The most pixels an associated image (label, macro, thumbnail) may have: 64 Mpx, 256 MiB as
// RGBA. Scanners' are a few megapixels; a file stating more is refused before anything is
// allocated for it.
inline constexpr uint64_t kMaxAssociatedPixels = uint64_t(1) << 26;
// The longest side a slide file's own tile (a TIFF tile, before the engine's grid) may have.
// Scanners write 240 to 4096; OpenSlide 3.4.1 allocates a decoded tile whole (4 bytes a pixel,
// GLib aborting the process when that fails), so a file stating more is refused at open.
inline constexpr uint32_t kMaxFileTileSide = 16384;

// One tile of the engine's grid.
struct TileAddress {
    int level = 0;
    int64_t tx = 0;
    int64_t ty = 0;
};

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
    // The GPU's share of a JPEG decode (EngineTuning::JpegDecode::Gpu): whether tiles of `level`
    // may be read as coefficient records (slide/jpeg_coefficients.h, jpegrecord), and the read
    // itself, into dst (kTileBytes). Any failure — a layout the GPU path does not take, a
    // corrupt tile — leaves the tile to readTile, which says what is wrong as it always has.
    virtual bool readsCoefficients(int /*level*/) const { return false; }
    virtual Result readTileCoefficients(int /*level*/, int64_t /*tx*/, int64_t /*ty*/, uint8_t* /*dst*/) {
        return Result(Status::UnsupportedFormat, "this source has no coefficient records");
    }
    virtual Expected<Image> readAssociatedImage(const std::string& name) = 0;
    // The engine has let go of this slide (another was opened, it was closed, the engine is
    // going away). A read that takes long (a synthetic level's tile: many stored tiles) may
    // stop early and return Status::Cancelled; a one-tile read just finishes.
    virtual void abandon() {}

    // Sources that read over a network (DicomWebSource), so that the loaders never wait on a
    // round trip (docs/ARCHITECTURE.md, "The network source"). Local sources keep the defaults.
    //
    // True when reads go over a network: the loaders then hint each view's tiles with
    // prefetch(), read a tile only once requestTile() says it is there, and treat a failed read
    // with Status::IoError or Timeout as passing (the tile is not published; it is asked for
    // again at once with requestTile(), which such a source sends when its back-off ends, or
    // when a later view needs it).
    virtual bool readsOverNetwork() const { return false; }
    // The tiles the engine wants now, in priority order (a new view's buffer region, centre
    // out), replacing the previous list: start fetching them all, concurrently; what an
    // earlier list asked for and this one does not may be dropped unless it is already on the
    // wire. `arrived` runs (on any thread, quickly) each time something requested lands or
    // fails for good, until abandon().
    virtual void prefetch(const std::vector<TileAddress>& /*tiles*/, std::function<void()> /*arrived*/) {}
    // True when readTile(level, tx, ty) would return without waiting on the network (its data
    // is here, or its failure is known); otherwise makes sure the data is on the way (the
    // prefetch callback runs when it lands) and returns false.
    virtual bool requestTile(int /*level*/, int64_t /*tx*/, int64_t /*ty*/) { return true; }
};

// Opens `path` with the first format that recognises it, after checking that the path is
// an existing, readable regular file, or a folder (a DICOM series: DicomSource). Errors name
// the file and the reason.
// `preference` restricts the table to one reader (EngineConfig::source).
// A DICOMweb series URL (http:// or https://) opens through the network source with `network`.
Expected<std::unique_ptr<SlideSource>> openSlideSource(const std::string& path,
                                                       SourcePreference preference = SourcePreference::Auto,
                                                       const NetworkOptions& network = {});

// Fills the LevelInfo tile grid fields (tilesX/Y) from width/height.
void fillTileGrid(LevelInfo& level);

// Fills each level's mpp and magnification from the slide's (level-0) values and the
// level's downsample. Every reader calls it once its SlideInfo is complete.
void fillLevelPhysics(SlideInfo& info);

// Repeats the last valid column/row of a partially filled tile into its padding.
void padTileEdges(uint8_t* rgba, int validWidth, int validHeight);

// Fills a tile with the visible "could not be decoded" placeholder (grey with red diagonals).
void fillFailedTilePlaceholder(uint8_t* rgba);

// A file held open for the life of a source, and a name for it that libraries which reopen
// files by name can use — DCMTK loads deferred pixel data by reopening the file, OpenSlide
// opens more TIFF handles as threads need them: /proc/self/fd/N, which keeps naming the file
// that was opened after it is deleted or replaced (a scanner re-exporting a slide, a share
// cleaned up), as the readers that keep their own descriptor already do. Where that name cannot
// be opened (no /proc) it is the path itself, and the library sees what the path names then.
class PinnedFile {
public:
    explicit PinnedFile(const std::string& path);
    ~PinnedFile();
    PinnedFile(const PinnedFile&) = delete;
    PinnedFile& operator=(const PinnedFile&) = delete;
    // The name to hand the library.
    const std::string& name() const { return name_; }
    // Whether the file's first bytes are a TIFF or BigTIFF header.
    bool isTiff() const { return tiff_; }

private:
    int fd_ = -1;
    bool tiff_ = false;
    std::string name_;
};

} // namespace iris
