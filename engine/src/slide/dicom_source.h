// DICOM VL Whole Slide Microscopy Image series (SOP class 1.2.840.10008.5.1.4.1.1.77.1.6) as a
// SlideSource: from local files (DicomSource, read with DCMTK) and, through the same mapping,
// from a DICOMweb server (DicomWebSource, slide/dicomweb_source.h). docs/DICOM.md says what is
// supported; in short:
//
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
// The mapping is written once, over a neutral description of each instance (dicom::Instance
// Description) that an attribute reader fills: dicom::Attributes is implemented over a DCMTK
// dataset here and over a DICOM JSON object in slide/dicom_json.h. dicom::SeriesSource turns
// the descriptions into levels and tiles and asks its subclass only for one frame's bytes.
//
// Local files: every file is parsed by DCMTK once at open, with values longer than a few
// hundred bytes left in the file (DCMTK's lazy loading), so frames are never read at open.
//
// Threading: readTile() may be called from any number of threads. A local frame is read with
// DcmElement::getPartialValue, which opens its own stream on the file for each call and changes
// nothing in the parsed dataset, so reads share no lock; decoded frames of a level whose frame
// size is not the engine's tile size go to a small shared LRU cache (neighbouring engine tiles
// share them).
#pragma once

#include <cstdint>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "slide/jp2k_decode.h"
#include "slide/jpeg_frame_decode.h"
#include "slide/slide_source.h"

namespace iris {
namespace dicom {

inline constexpr const char* kWsiSopClass = "1.2.840.10008.5.1.4.1.1.77.1.6";

// A tag as the 32-bit number DICOM JSON spells in hex: (group << 16) | element.
constexpr uint32_t tag(uint16_t group, uint16_t element) { return (uint32_t(group) << 16) | element; }

// Reads the attributes of one dataset (or sequence item), whatever it was parsed from. Each
// accessor returns nothing when the attribute is absent, empty or of another kind.
class Attributes {
public:
    virtual ~Attributes() = default;
    // Value `index` of a text or number attribute as text (numbers as the source writes them).
    virtual std::optional<std::string> text(uint32_t t, unsigned index = 0) const = 0;
    // Value `index` as an integer: an integral number, or text that is one.
    virtual std::optional<int64_t> integer(uint32_t t, unsigned index = 0) const = 0;
    // Value `index` as a finite real number.
    virtual std::optional<double> real(uint32_t t, unsigned index = 0) const = 0;
    // Items of a sequence (0 when absent), and item i (null past the end).
    virtual size_t items(uint32_t sequence) const = 0;
    virtual std::unique_ptr<Attributes> item(uint32_t sequence, size_t i) const = 0;
    // A binary value (OB/OW/UN): its bytes when they are in the dataset; else, where the
    // source left them on a server (DICOM JSON's BulkDataURI), that URI in *uri.
    virtual std::optional<std::vector<uint8_t>> binary(uint32_t t, std::string* uri) const = 0;
    // Every top-level attribute with a text or number value (not sequences, binary values or
    // pixel data), by tag, its values joined with '\'.
    virtual void forEachText(const std::function<void(uint32_t tag, const std::string& value)>& f) const = 0;
};

// Text to number as DICOM's IS and DS values (and renderings of binary numbers) write them,
// leading and trailing spaces allowed; nothing for anything else (or a non-finite real).
std::optional<int64_t> parseInteger(std::string_view s);
std::optional<double> parseReal(std::string_view s);

enum class Codec { Jpeg, Jp2k, Native };
enum class NativeLayout { RgbInterleaved, RgbPlanar, Grey };

// How an instance's frames decode: from the transfer syntax and the Image Pixel module.
struct PixelFormat {
    Codec codec = Codec::Native;
    JpegColour jpegColour = JpegColour::Auto;
    Jp2kColour jp2kColour = Jp2kColour::Rgb;
    NativeLayout native = NativeLayout::RgbInterleaved;
    uint32_t samples = 3;
};

// What the series → levels mapping needs of one instance.
struct InstanceDescription {
    std::string name; // how messages name it: "file 'x.dcm'", "instance 1.2.3…"
    std::string seriesUid;
    std::string sopInstanceUid;
    std::string flavour; // Image Type value 3: VOLUME, LABEL, OVERVIEW, THUMBNAIL
    std::string concatenationUid;
    uint32_t inConcatenationNumber = 0;
    uint32_t inConcatenationTotal = 0;
    uint32_t concatenationOffset = 0; // frames of the concatenation before this instance
    int32_t instanceNumber = 0;
    uint64_t totalW = 0, totalH = 0; // Total Pixel Matrix Columns / Rows
    uint32_t frameW = 0, frameH = 0, frames = 0;
    // Image Pixel module as stated; choosePixelFormat checks it against the transfer syntax.
    uint32_t samplesPerPixel = 0, bitsAllocated = 0, bitsStored = 0, pixelRepresentation = 0, planar = 0;
    std::string photometric;
    // Sparse tiling: each frame's top-left in the total pixel matrix (0-based); empty for TILED_FULL.
    std::vector<std::pair<int64_t, int64_t>> positions;
    std::string transferSyntax; // empty until known (DICOMweb learns it from the first frame)
    PixelFormat format;         // valid once choosePixelFormat succeeded
};

// The instance's description from its attributes; fails (naming `name`) for another SOP
// class, impossible sizes or inconsistent per-frame groups. Leaves the transfer syntax alone.
Expected<InstanceDescription> describeInstance(const Attributes& a, const std::string& name);
// Checks the instance's pixel module against `transferSyntax` and fills `format`.
Result choosePixelFormat(InstanceDescription& in, const std::string& transferSyntax);

// A level: the frame grid over its total pixel matrix. Cell (col, row) holds the frame drawn
// there, or none (background).
struct Level {
    struct Cell {
        int32_t instance = -1;
        uint32_t frame = 0;
    };
    uint64_t width = 0, height = 0;
    uint32_t frameW = 0, frameH = 0;
    uint64_t across = 0, down = 0;
    std::vector<Cell> cells; // row-major
};

// A series mapped onto the slide model: levels (finest first), the base instance (level 0's
// first frame), associated images (name → instance). Indices are into the description list.
struct SeriesLayout {
    std::vector<Level> levels;
    size_t base = 0;
    std::vector<std::pair<std::string, size_t>> associated;
};
// `seriesName` names the series in messages ("folder 'x'", "series 1.2.3 on host").
Result layoutSeries(const std::vector<InstanceDescription>& instances, const std::string& seriesName,
                    SeriesLayout* out);
// Where frame f of an instance lies in its total pixel matrix, in frame cells; false when the
// frame lies outside (another focal plane or optical path of TILED_FULL) or off the grid (then
// *why says so).
bool frameCell(const InstanceDescription& in, uint32_t f, uint64_t across, uint64_t down, uint64_t* cell,
               std::string* why);

// mpp, objective power, ICC profile, vendor and properties, from the base instance.
struct SeriesMetadata {
    std::string manufacturer;
    double rowSpacingMm = 0, columnSpacingMm = 0; // Pixel Spacing; 0: not stated
    double objectivePower = 0;
    std::vector<uint8_t> iccProfile;
    std::string iccBulkDataUri;                    // where the profile is when the attributes only point to it
    std::map<std::string, std::string> properties; // "dicom.<Keyword>" → value
};
SeriesMetadata describeMetadata(const Attributes& base);
// The keyword DCMTK's dictionary gives a tag, or "GGGG,EEEE" for private and unknown tags.
std::string keywordOf(uint32_t t);
// Fills info's levels (from the layout), mpp, objective power, ICC profile, vendor, properties
// and associated image names.
void fillSlideInfo(const std::vector<InstanceDescription>& instances, const SeriesLayout& layout,
                   const SeriesMetadata& meta, SlideInfo* info);

// Decodes one frame's bytes (as stored: a JPEG or JPEG 2000 stream, or native samples) into
// frameW × frameH RGBA8 at dst, rows `pitch` apart. Errors name the frame and the instance.
Result decodeFrame(const InstanceDescription& in, uint32_t frame, const uint8_t* bytes, size_t size, uint8_t* dst,
                   size_t pitch);

// The SlideSource of a laid-out series: tiles cut from frames (decoded frames that several
// tiles share are kept in a small LRU), associated images assembled from their frames. A
// subclass supplies one frame's decoded pixels.
class SeriesSource : public SlideSource {
public:
    const SlideInfo& info() const override { return info_; }
    Result readTile(int level, int64_t tx, int64_t ty, uint8_t* dst) override;
    Expected<Image> readAssociatedImage(const std::string& name) override;

protected:
    // Decodes frame `frame` of instance `instance` (frameW × frameH RGBA8) into dst, rows
    // `pitch` apart.
    virtual Result readFrame(size_t instance, uint32_t frame, uint8_t* dst, size_t pitch) = 0;
    // About to read these frames of one instance (an associated image): a network source
    // requests them together. Default: nothing.
    virtual void willReadFrames(size_t /*instance*/, const std::vector<uint32_t>& /*frames*/) {}
    // The frame cells an engine tile takes pixels from (cell indices into the level's grid;
    // background cells included).
    std::vector<uint64_t> cellsOfTile(int level, int64_t tx, int64_t ty) const;
    // Whether a decoded frame of this cell is in the LRU.
    bool hasDecodedFrame(size_t level, uint64_t cell) const;

    SlideInfo info_;
    std::vector<InstanceDescription> instances_;
    SeriesLayout layout_;

private:
    struct DecodedFrame {
        std::vector<uint8_t> rgba; // frameW × frameH RGBA8; empty: background
    };
    Expected<std::shared_ptr<const DecodedFrame>> cachedFrame(size_t level, uint64_t index);

    mutable std::mutex cacheMutex_;
    std::list<std::pair<uint64_t, std::shared_ptr<const DecodedFrame>>> lru_; // most recent first
    std::unordered_map<uint64_t, decltype(lru_)::iterator> cacheIndex_;
    size_t cacheBytes_ = 0;
};

} // namespace dicom

// A series from local files: open() takes a folder holding one series, or any one file of it
// (the series is every file in the same folder with the same Series Instance UID).
class DicomSource final : public dicom::SeriesSource {
public:
    // Cheap: true when the file has DICOM Part 10's 128-byte preamble and "DICM".
    static bool detect(const std::string& path);
    // A DICOM file, or a folder. A folder without any DICOM file is NotAFile (it is not a slide).
    static Expected<std::unique_ptr<SlideSource>> open(const std::string& path);
    ~DicomSource() override;

    struct File;

private:
    DicomSource() = default;
    Result readFrame(size_t instance, uint32_t frame, uint8_t* dst, size_t pitch) override;
    std::vector<std::unique_ptr<File>> files_; // parallel to instances_
};

} // namespace iris
