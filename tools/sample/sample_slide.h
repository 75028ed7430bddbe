// iris_sample: writes a procedurally generated, H&E-looking whole-slide image as a
// pyramidal tiled-JPEG TIFF that OpenSlide (3.4.1 and later) opens as "generic-tiff".
//
// Every level-0 pixel depends only on (seed, width, height, x, y), so any tile can be
// generated on its own (tests compare what OpenSlide decodes with generateTile()).
// Reduced levels are 2x box-filter downsamples of the level above. No exceptions cross
// this interface.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace iris::sample {

inline constexpr int kTileSize = 256;
inline constexpr int64_t kMaxDimension = 1'000'000;
inline constexpr double kMicronsPerPixel = 0.25; // a 40x scan

struct Options {
    std::string outPath = "iris-sample.tiff";
    int64_t width = 50000;
    int64_t height = 40000;
    uint64_t seed = 1;
    int quality = 90; // JPEG quality, 1..100
    int threads = 0;  // 0: std::thread::hardware_concurrency()
    std::vector<uint8_t> iccProfile; // embedded in level 0 (TIFF tag 34675) when not empty
};

struct Result {
    bool ok = false;
    std::string message; // error text when !ok, a one-line summary when ok
};

struct LevelInfo {
    int64_t width = 0;
    int64_t height = 0;
};

// Progress: fraction done in [0, 1]. Called from the writing thread only.
using ProgressCallback = std::function<void(double fraction)>;

// Validates the options; returns ok=false with a message when they are unusable.
Result validateOptions(const Options& options);

// The pyramid written for these dimensions: level 0 first; each level halves (rounding
// up) until the level fits in one tile.
std::vector<LevelInfo> pyramidLevels(int64_t width, int64_t height);

// Writes the slide. Deterministic: the same options give a byte-identical file.
Result writeSampleSlide(const Options& options, const ProgressCallback& progress = {});

// RGB pixels (row-major, 3 bytes a pixel, kTileSize x kTileSize) of the level-0 tile
// (tileX, tileY) exactly as they were handed to the JPEG encoder. Pixels beyond the
// image's right/bottom edge are generated as well (they lie in the tile's padding).
// Returns false (and leaves rgb untouched) for bad arguments.
bool generateTile(const Options& options, int64_t tileX, int64_t tileY, std::vector<uint8_t>& rgb);

// True when level-0 tile (tileX, tileY) is pure empty glass.
bool isGlassTile(const Options& options, int64_t tileX, int64_t tileY);

} // namespace iris::sample
