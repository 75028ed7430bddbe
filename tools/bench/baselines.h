// Baselines measured in the same run as the engine, over the same fields:
//  - a naive viewer: openslide_read_region of the whole field at the field's level, one thread;
//  - the same split into horizontal strips over all cores;
//  - the decode floor: the field's tiles decoded from their compressed bytes in parallel with
//    libjpeg-turbo (no GPU, no OpenSlide): the practical lower bound on this machine.
#pragma once

#include <cmath>
#include <optional>
#include <string>
#include <vector>

struct BenchField {
    double x0, y0;       // level-0 top-left of the field
    int level;           // the level a viewer would read (the engine's HR level)
    double levelDs;
    int64_t w, h;        // field size in that level's pixels
};

struct BaselineResult {
    std::vector<double> ms; // one per field
    std::string note;       // why it is missing, when it is
    double threadUsPerTile = NAN; // decode floor: one thread's read and decode of a tile, mean over all fields
    // Decode floor: one thread's read and entropy decode alone of the same tiles
    // (jpeg_read_coefficients: the Huffman decode, before the inverse DCT, upsampling and
    // colour conversion), in an untimed pass after each field's: the CPU part that would be left
    // if those three ran on the GPU.
    double entropyUsPerTile = NAN;
    // The decode floor split between the CPU and the GPU (gpu_split.h), in a third pass after
    // each field's: its wall time (entropy decodes on every core, then one GPU batch) and the
    // GPU's own time; the tiles it reconstructed, and how many of them differ in any byte from
    // libjpeg-turbo's decode (checked untimed). Empty with a note where it could not run.
    std::vector<double> splitMs, splitGpuMs, splitComputeMs; // wall; GPU; of which its dispatches
    uint64_t splitTiles = 0, splitMismatched = 0;
    double splitEntropyUsPerTile = NAN; // its threads' read and entropy decode into the GPU's input, a tile
    std::string splitNote;
};

BaselineResult openslideBaseline(const std::string& slide, const std::vector<BenchField>& fields, unsigned threads);
// Needs a TIFF whose level directories are JPEG-tiled (Aperio SVS, generic TIFF such as the
// sample slide); otherwise returns no figures and a note.
// `split`: the GPU half of the split floor, or null to leave it out.
namespace benchsplit { class GpuSplit; }
BaselineResult decodeFloorBaseline(const std::string& slide, const std::vector<BenchField>& fields, unsigned threads,
                                   benchsplit::GpuSplit* split = nullptr);
