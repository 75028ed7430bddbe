// Iris View — the .iris encoder: converts any slide the engine can open into an Iris File
// Extension file (version 1.0, as the format's released reference encoder writes it).
//
// Qt-free and exception-free like the rest of the public API. encodeIris() blocks the calling
// thread until the file is complete, cancelled or failed; run it on a worker thread to keep a
// UI responsive, and watch it through EncodeOptions::progress and EncodeOptions::cancel.
//
// What is written (docs/ARCHITECTURE.md, "The .iris encoder", says why):
//   * every level of the source, layer 0 the lowest resolution, each a grid of 256×256 tiles
//     compressed as JPEG (TurboJPEG; quality 90 and 4:2:2 chroma by default). Tiles are the
//     engine's own tiles (SlideSource::readTile): decoded once, edge tiles padded by repeating
//     the last column and row. Transparent pixels are composited over white (JPEG has no
//     alpha; slides are opaque, so this only touches pixels outside a scanned region);
//   * the source's properties as FREE_TEXT attributes, except OpenSlide's own derived
//     "openslide.*" ones (the reference encoder skips them too); for an .iris source, its
//     attributes as stored;
//   * its associated images (label, macro, thumbnail, …) as JPEG with the same settings;
//   * its ICC profile, when it has one;
//   * microns per pixel and magnification of the lowest-resolution layer (scale 1).
//
// The file is written under a temporary name beside the output ("OUT.partial-PID"),
// flushed to disk and renamed to the output name only when complete: on cancel, error or
// crash no file ever appears under the output name, and the temporary file is removed
// (except after a crash).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "iris/export.h"
#include "iris/types.h"

namespace iris {

enum class ChromaSubsampling { S444, S422, S420 };

struct EncodeOptions {
    int quality = 90;                                      // JPEG quality, 1..100
    ChromaSubsampling subsampling = ChromaSubsampling::S422;
    uint32_t threads = 0;                                  // tile decode+encode threads; 0: one per hardware thread
    SourcePreference source = SourcePreference::Auto;      // which reader opens the source
    // Called after every tile written (tiles are written in file order), with the tiles
    // written so far and the total; also once with 0 before the first. It runs on the
    // thread that called encodeIris(); keep it quick and do not call encodeIris() from it.
    std::function<void(uint64_t tilesDone, uint64_t tilesTotal)> progress;
    // Polled between tiles: once it reads true the encode stops, the temporary file is
    // removed and encodeIris() returns Status::Cancelled. The flag must outlive the call.
    const std::atomic<bool>* cancel = nullptr;
};

struct EncodeStats {
    std::string outputPath;
    uint64_t tiles = 0;            // tiles encoded, all levels
    uint32_t levels = 0;
    uint32_t associatedImages = 0; // associated images written
    uint64_t bytesWritten = 0;     // the output file's size
    uint64_t sourceBytes = 0;      // the source file's size (0 for a synthetic slide)
    uint64_t pixelBytes = 0;       // decoded RGBA bytes compressed (tiles × 256 KiB)
    double seconds = 0;            // from opening the source to the renamed, synced output
    double tileSeconds = 0;        // the tiles alone: first tile claimed to last tile written
    uint32_t threads = 0;          // worker threads used
    // Things written differently from the source, in words: an associated image that could
    // not be read and was left out, an attribute key too long for the format, …
    std::vector<std::string> warnings;
};

// Converts the slide at sourcePath (any file the engine opens, or "synthetic:WxH") into an
// .iris file at outputPath, replacing any file of that name. Errors: the source's own open
// error (NotFound, UnsupportedFormat, CorruptData, …); InvalidArgument for bad options or an
// output that is the source itself; NotFound when the output's folder does not exist;
// IoError when it cannot be written (no permission, read-only file system, "disk full");
// a tile's decode error; Cancelled. No file exists under outputPath after any error unless
// one was there before (it is then left untouched).
IRIS_API Expected<EncodeStats> encodeIris(const std::string& sourcePath, const std::string& outputPath,
                                          const EncodeOptions& options = {});

// The default output file name for a source: its file name with the extension replaced by
// ".iris" ("CMU-1.svs" → "CMU-1.iris"; "synthetic:2000x1000" → "synthetic-2000x1000.iris").
// No folder.
IRIS_API std::string irisFileName(const std::string& sourcePath);

IRIS_API const char* chromaSubsamplingName(ChromaSubsampling s) noexcept; // "4:4:4", "4:2:2", "4:2:0"

} // namespace iris
