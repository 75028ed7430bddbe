// SlideSource over a DICOM VL Whole Slide Microscopy Image series (SOP class
// 1.2.840.10008.5.1.4.1.1.77.1.6), read from local files with DCMTK. docs/DICOM.md says what is
// supported; in short:
//
//   * open() takes a folder holding one series, or any one file of it: the series is every file
//     in the same folder with the same Series Instance UID.
//   * Levels are the VOLUME instances (Image Type value 3; an instance without Image Type counts
//     as VOLUME), ordered by Total Pixel Matrix size, largest first. Instances of one size (a
//     concatenation, or a level split over several files) make one level. LABEL, OVERVIEW and
//     THUMBNAIL instances are the associated images "label", "macro" and "thumbnail".
//   * Frames are placed by TILED_FULL order or, for sparse tiling, by each frame's Plane
//     Position (Slide); a position without a frame is background (opaque white). Frames of any
//     size are cut into the engine's 256×256 grid.
//   * Transfer syntaxes: JPEG Baseline (libjpeg, Photometric Interpretation honoured), JPEG 2000
//     (OpenJPEG), explicit and implicit VR little endian. Any other is refused by name.
//
// Parsing: every file is parsed by DCMTK once at open, with values longer than a few hundred
// bytes left in the file (DCMTK's lazy loading), so frames are never read at open. The
// metadata a read needs (frame grid, fragment lists) is mapped to plain tables at open.
//
// Threading: readTile() may be called from any number of threads. A frame is read with
// DcmElement::getPartialValue, which opens its own stream on the file for each call and changes
// nothing in the parsed dataset, so reads share no lock; decoded frames of a level whose frame
// size is not the engine's tile size go to a small shared LRU cache (neighbouring engine tiles
// share them).
#pragma once

#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

#include "slide/slide_source.h"

namespace iris {

class DicomSource final : public SlideSource {
public:
    // Cheap: true when the file has DICOM Part 10's 128-byte preamble and "DICM".
    static bool detect(const std::string& path);
    // A DICOM file, or a folder. A folder without any DICOM file is NotAFile (it is not a slide).
    static Expected<std::unique_ptr<SlideSource>> open(const std::string& path);
    ~DicomSource() override;

    const SlideInfo& info() const override;
    Result readTile(int level, int64_t tx, int64_t ty, uint8_t* dst) override;
    Expected<Image> readAssociatedImage(const std::string& name) override;

    struct Instance;
    struct Level;
    struct DecodedFrame;

private:
    DicomSource() = default;
    // Decodes frame `frame` of instance `inst` (frameW × frameH RGBA8) into dst, rows `pitch` apart.
    Result decodeFrame(const Instance& inst, uint32_t frame, uint8_t* dst, size_t pitch) const;
    Expected<std::shared_ptr<const DecodedFrame>> cachedFrame(size_t level, int64_t index);

    SlideInfo info_;
    std::vector<std::unique_ptr<Instance>> instances_;
    std::vector<Level> levels_;                              // parallel to info_.levels
    std::vector<std::pair<std::string, size_t>> associated_; // name → instance

    std::mutex cacheMutex_;
    std::list<std::pair<uint64_t, std::shared_ptr<const DecodedFrame>>> lru_; // most recent first
    std::unordered_map<uint64_t, decltype(lru_)::iterator> cacheIndex_;
    size_t cacheBytes_ = 0;
};

} // namespace iris
