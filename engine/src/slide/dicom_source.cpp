#include "slide/dicom_source.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>

#include <dcmtk/config/osconfig.h> // first, as DCMTK asks

#include <dcmtk/dcmdata/dcdatset.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcdict.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcmetinf.h>
#include <dcmtk/dcmdata/dcpixel.h>
#include <dcmtk/dcmdata/dcpixseq.h>
#include <dcmtk/dcmdata/dcpxitem.h>
#include <dcmtk/dcmdata/dcsequen.h>
#include <dcmtk/dcmdata/dcuid.h>
#include <dcmtk/dcmdata/dcxfer.h>
#include <dcmtk/oflog/oflog.h>

namespace iris {

namespace fs = std::filesystem;

// ---- the mapping, over any dicom::Attributes ----------------------------------------------

namespace dicom {

namespace {

constexpr uint32_t kMaxFrameSide = 16384;
constexpr uint64_t kMaxFramePixels = uint64_t(1) << 24; // 16 Mpx: 64 MiB decoded
constexpr uint32_t kMaxFrames = uint32_t(1) << 24;      // per instance
constexpr uint64_t kMaxGridCells = uint64_t(1) << 25;   // frame positions per level
constexpr uint64_t kMaxMatrixSide = uint64_t(1) << 24;  // 16 Mpx across: beyond any scanner
constexpr size_t kCacheBudgetBytes = size_t(32) << 20; // decoded frames kept

// The attributes the mapping reads.
constexpr uint32_t kSopClassUid = tag(0x0008, 0x0016);
constexpr uint32_t kSopInstanceUid = tag(0x0008, 0x0018);
constexpr uint32_t kImageType = tag(0x0008, 0x0008);
constexpr uint32_t kManufacturer = tag(0x0008, 0x0070);
constexpr uint32_t kSeriesInstanceUid = tag(0x0020, 0x000e);
constexpr uint32_t kInstanceNumber = tag(0x0020, 0x0013);
constexpr uint32_t kConcatenationUid = tag(0x0020, 0x9161);
constexpr uint32_t kInConcatenationNumber = tag(0x0020, 0x9162);
constexpr uint32_t kInConcatenationTotal = tag(0x0020, 0x9163);
constexpr uint32_t kConcatenationFrameOffset = tag(0x0020, 0x9228);
constexpr uint32_t kDimensionOrganizationType = tag(0x0020, 0x9311);
constexpr uint32_t kSamplesPerPixel = tag(0x0028, 0x0002);
constexpr uint32_t kPhotometric = tag(0x0028, 0x0004);
constexpr uint32_t kPlanarConfiguration = tag(0x0028, 0x0006);
constexpr uint32_t kNumberOfFrames = tag(0x0028, 0x0008);
constexpr uint32_t kRows = tag(0x0028, 0x0010);
constexpr uint32_t kColumns = tag(0x0028, 0x0011);
constexpr uint32_t kPixelSpacing = tag(0x0028, 0x0030);
constexpr uint32_t kBitsAllocated = tag(0x0028, 0x0100);
constexpr uint32_t kBitsStored = tag(0x0028, 0x0101);
constexpr uint32_t kPixelRepresentation = tag(0x0028, 0x0103);
constexpr uint32_t kIccProfile = tag(0x0028, 0x2000);
constexpr uint32_t kPixelMeasures = tag(0x0028, 0x9110);
constexpr uint32_t kSpecimenIdentifier = tag(0x0040, 0x0551);
constexpr uint32_t kSpecimenDescription = tag(0x0040, 0x0560);
constexpr uint32_t kTotalPixelMatrixColumns = tag(0x0048, 0x0006);
constexpr uint32_t kTotalPixelMatrixRows = tag(0x0048, 0x0007);
constexpr uint32_t kOpticalPath = tag(0x0048, 0x0105);
constexpr uint32_t kObjectiveLensPower = tag(0x0048, 0x0112);
constexpr uint32_t kPlanePositionSlide = tag(0x0048, 0x021a);
constexpr uint32_t kColumnPosition = tag(0x0048, 0x021e);
constexpr uint32_t kRowPosition = tag(0x0048, 0x021f);
constexpr uint32_t kSharedFunctionalGroups = tag(0x5200, 0x9229);
constexpr uint32_t kPerFrameFunctionalGroups = tag(0x5200, 0x9230);

Result corrupt(const std::string& name, const std::string& why) {
    return Result(Status::CorruptData, "Cannot open " + name + ": " + why);
}
Result unsupported(const std::string& name, const std::string& why) {
    return Result(Status::UnsupportedFormat, "Cannot open " + name + ": " + why);
}

// Sparse tiling: each frame's position from the Per-Frame Functional Groups.
Result readPositions(const Attributes& a, InstanceDescription& in) {
    const size_t n = a.items(kPerFrameFunctionalGroups);
    if (n == 0) return {};
    if (n != in.frames) {
        return corrupt(in.name, "Number of Frames is " + std::to_string(in.frames) +
                                    " but the Per-Frame Functional Groups Sequence has " + std::to_string(n) +
                                    " items");
    }
    in.positions.reserve(in.frames);
    for (uint32_t f = 0; f < in.frames; ++f) {
        const std::unique_ptr<Attributes> frame = a.item(kPerFrameFunctionalGroups, f);
        const std::unique_ptr<Attributes> pos = frame ? frame->item(kPlanePositionSlide, 0) : nullptr;
        const std::optional<int64_t> col = pos ? pos->integer(kColumnPosition) : std::nullopt;
        const std::optional<int64_t> row = pos ? pos->integer(kRowPosition) : std::nullopt;
        if (!col || !row || *col < INT32_MIN || *col > INT32_MAX || *row < INT32_MIN || *row > INT32_MAX) {
            if (f == 0) return {}; // no positions at all: frames are in TILED_FULL order
            return corrupt(in.name, "frame " + std::to_string(f + 1) + " has no Plane Position (Slide)");
        }
        in.positions.emplace_back(*col - 1, *row - 1);
    }
    return {};
}

void fillWhite(uint8_t* dst, size_t pitch, int w, int h) {
    for (int y = 0; y < h; ++y) std::memset(dst + size_t(y) * pitch, 0xff, size_t(w) * 4);
}

// One level from the VOLUME instances of one total pixel matrix size (`members`, indices into
// `instances`): its frame grid, each cell the frame drawn there.
Result buildLevel(const std::vector<InstanceDescription>& instances, std::vector<size_t> members,
                  const std::string& seriesName, size_t levelIndex, Level* out) {
    const InstanceDescription& first = instances[members.front()];
    const std::string levelName = "level " + std::to_string(levelIndex) + " (" + std::to_string(first.totalW) + "x" +
                                  std::to_string(first.totalH) + ")";
    const auto seriesError = [&](const std::string& why) {
        return Result(Status::CorruptData, "Cannot open " + seriesName + ": " + why);
    };
    // Concatenation parts, then instance numbers, then names.
    std::sort(members.begin(), members.end(), [&](size_t a, size_t b) {
        const InstanceDescription& x = instances[a];
        const InstanceDescription& y = instances[b];
        return std::tie(x.concatenationUid, x.inConcatenationNumber, x.instanceNumber, x.name) <
               std::tie(y.concatenationUid, y.inConcatenationNumber, y.instanceNumber, y.name);
    });
    Level L;
    L.width = first.totalW;
    L.height = first.totalH;
    L.frameW = first.frameW;
    L.frameH = first.frameH;
    L.across = (L.width + L.frameW - 1) / L.frameW;
    L.down = (L.height + L.frameH - 1) / L.frameH;
    if (L.across * L.down > kMaxGridCells) {
        return corrupt(first.name, levelName + " has " + std::to_string(L.across * L.down) + " frame positions");
    }
    L.cells.resize(size_t(L.across * L.down));
    bool tiledFull = false;
    std::map<std::string, std::vector<uint32_t>> parts; // concatenation → its parts' numbers
    for (size_t idx : members) {
        const InstanceDescription& in = instances[idx];
        if (in.frameW != L.frameW || in.frameH != L.frameH) {
            return corrupt(in.name, "its frames are " + std::to_string(in.frameW) + "x" + std::to_string(in.frameH) +
                                        " but other instances of " + levelName + " have " + std::to_string(L.frameW) +
                                        "x" + std::to_string(L.frameH));
        }
        if (!in.concatenationUid.empty()) parts[in.concatenationUid].push_back(in.inConcatenationNumber);
        tiledFull = tiledFull || in.positions.empty();
        for (uint32_t f = 0; f < in.frames; ++f) {
            uint64_t cell = 0;
            std::string why;
            if (!frameCell(in, f, L.across, L.down, &cell, &why)) {
                if (!why.empty()) return seriesError(why);
                continue; // another focal plane or optical path
            }
            if (L.cells[cell].instance < 0) L.cells[cell] = {int32_t(idx), f}; // the first focal plane wins
        }
    }
    for (const auto& [uid, numbers] : parts) {
        const uint32_t total = instances[members.front()].inConcatenationTotal;
        for (size_t k = 0; k < numbers.size(); ++k) {
            if (numbers[k] != k + 1 || (total && numbers.size() != total)) {
                return seriesError(levelName + " is a concatenation of " +
                                   (total ? std::to_string(total) : std::string("several")) + " instances but only " +
                                   std::to_string(numbers.size()) + " are present (a file is missing)");
            }
        }
    }
    if (tiledFull) {
        const auto missing =
            std::count_if(L.cells.begin(), L.cells.end(), [](const Level::Cell& c) { return c.instance < 0; });
        if (missing > 0) {
            return seriesError(levelName + " is TILED_FULL but " + std::to_string(missing) + " of its " +
                               std::to_string(L.cells.size()) +
                               " frames are missing (a file of the level is missing, or Number of Frames is wrong)");
        }
    }
    *out = std::move(L);
    return {};
}

} // namespace

namespace {
std::string_view trimSpaces(std::string_view s) {
    while (!s.empty() && s.back() == ' ') s.remove_suffix(1);
    while (!s.empty() && s.front() == ' ') s.remove_prefix(1);
    return s;
}
} // namespace

std::optional<int64_t> parseInteger(std::string_view text) {
    std::string_view s = trimSpaces(text);
    if (!s.empty() && s.front() == '+') s.remove_prefix(1);
    int64_t v = 0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (!s.empty() && ec == std::errc() && end == s.data() + s.size()) return v;
    return std::nullopt;
}

std::optional<double> parseReal(std::string_view text) {
    std::string_view s = trimSpaces(text);
    if (!s.empty() && s.front() == '+') s.remove_prefix(1);
    double v = 0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (!s.empty() && ec == std::errc() && end == s.data() + s.size() && std::isfinite(v)) return v;
    return std::nullopt;
}

Expected<InstanceDescription> describeInstance(const Attributes& a, const std::string& name) {
    InstanceDescription in;
    in.name = name;
    const std::string sopClass = a.text(kSopClassUid).value_or("");
    if (sopClass != kWsiSopClass) {
        const char* known = dcmFindNameOfUID(sopClass.c_str(), nullptr);
        return unsupported(name, "it is not a VL Whole Slide Microscopy Image but SOP class " +
                                     (sopClass.empty() ? std::string("(none)") : sopClass) +
                                     (known ? " (" + std::string(known) + ")" : std::string()));
    }
    in.seriesUid = a.text(kSeriesInstanceUid).value_or("");
    in.sopInstanceUid = a.text(kSopInstanceUid).value_or("");
    in.flavour = a.text(kImageType, 2).value_or("");
    if (in.flavour.empty()) in.flavour = "VOLUME"; // Orthanc's dicomizer writes no Image Type
    in.concatenationUid = a.text(kConcatenationUid).value_or("");
    const auto number = [&](uint32_t t, int64_t lo, int64_t hi) -> uint64_t {
        const std::optional<int64_t> v = a.integer(t);
        return v && *v >= lo && *v <= hi ? uint64_t(*v) : 0;
    };
    in.inConcatenationNumber = uint32_t(number(kInConcatenationNumber, 0, UINT16_MAX));
    in.inConcatenationTotal = uint32_t(number(kInConcatenationTotal, 0, UINT16_MAX));
    in.concatenationOffset = uint32_t(number(kConcatenationFrameOffset, 0, UINT32_MAX));
    if (const std::optional<int64_t> v = a.integer(kInstanceNumber); v && *v >= INT32_MIN && *v <= INT32_MAX)
        in.instanceNumber = int32_t(*v);
    in.totalW = number(kTotalPixelMatrixColumns, 0, UINT32_MAX);
    in.totalH = number(kTotalPixelMatrixRows, 0, UINT32_MAX);
    const int64_t frames = a.integer(kNumberOfFrames).value_or(1);
    if (frames < 1 || frames > int64_t(kMaxFrames)) {
        return corrupt(name, "impossible Number of Frames " + std::to_string(frames));
    }
    in.frames = uint32_t(frames);

    const uint64_t rows = number(kRows, 0, UINT16_MAX), cols = number(kColumns, 0, UINT16_MAX);
    if (rows == 0 || cols == 0 || cols > kMaxFrameSide || rows > kMaxFrameSide || rows * cols > kMaxFramePixels) {
        return corrupt(name, "impossible frame size " + std::to_string(cols) + "x" + std::to_string(rows) +
                                 " (Columns x Rows)");
    }
    in.frameW = uint32_t(cols);
    in.frameH = uint32_t(rows);
    in.samplesPerPixel = uint32_t(number(kSamplesPerPixel, 0, UINT16_MAX));
    in.bitsAllocated = uint32_t(number(kBitsAllocated, 0, UINT16_MAX));
    in.bitsStored = uint32_t(number(kBitsStored, 0, UINT16_MAX));
    in.pixelRepresentation = uint32_t(number(kPixelRepresentation, 0, UINT16_MAX));
    in.planar = uint32_t(number(kPlanarConfiguration, 0, UINT16_MAX));
    in.photometric = a.text(kPhotometric).value_or("");
    if (in.bitsAllocated != 8 || in.bitsStored != 8 || in.pixelRepresentation != 0) {
        return unsupported(name, "pixels of " + std::to_string(in.bitsStored) + " bits stored in " +
                                     std::to_string(in.bitsAllocated) + " (only 8-bit unsigned samples are supported)");
    }
    if (in.totalW == 0 || in.totalH == 0) { // single-frame images (labels) may leave the matrix out
        in.totalW = in.frameW;
        in.totalH = in.frameH;
    }
    if (in.totalW > kMaxMatrixSide || in.totalH > kMaxMatrixSide) {
        return corrupt(name,
                       "impossible Total Pixel Matrix " + std::to_string(in.totalW) + "x" + std::to_string(in.totalH));
    }
    const std::string organisation = a.text(kDimensionOrganizationType).value_or("");
    if (organisation != "TILED_FULL") {
        if (Result r = readPositions(a, in); !r.ok()) return r;
        if (organisation == "TILED_SPARSE" && in.positions.empty() && in.frames > 1) {
            return corrupt(name, "TILED_SPARSE without Plane Position (Slide) for its frames");
        }
    }
    return in;
}

Result choosePixelFormat(InstanceDescription& in, const std::string& ts) {
    PixelFormat& p = in.format;
    if (ts == UID_JPEGProcess1TransferSyntax) {
        p.codec = Codec::Jpeg;
    } else if (ts == UID_JPEG2000LosslessOnlyTransferSyntax || ts == UID_JPEG2000TransferSyntax) {
        p.codec = Codec::Jp2k;
    } else if (ts == UID_LittleEndianExplicitTransferSyntax || ts == UID_LittleEndianImplicitTransferSyntax) {
        p.codec = Codec::Native;
    } else {
        const DcmXfer x(ts.c_str());
        const std::string what =
            x.getXfer() == EXS_Unknown ? std::string("an unknown one") : std::string(x.getXferName());
        return unsupported(in.name, "transfer syntax " + ts + " (" + what +
                                        ") is not supported; Iris View reads JPEG Baseline, JPEG 2000 and "
                                        "uncompressed little endian");
    }
    in.transferSyntax = ts;
    const uint32_t spp = in.samplesPerPixel;
    const std::string& pi = in.photometric;
    const auto badPhotometric = [&] {
        return unsupported(in.name, "photometric interpretation '" + pi + "' with " + std::to_string(spp) +
                                        " samples is not supported for this transfer syntax");
    };
    p.samples = spp;
    switch (p.codec) {
    case Codec::Jpeg:
        if (spp == 3 && (pi == "YBR_FULL_422" || pi == "YBR_FULL"))
            p.jpegColour = JpegColour::YCbCr;
        else if (spp == 3 && pi == "RGB")
            p.jpegColour = JpegColour::Rgb;
        else if (spp == 1 && pi == "MONOCHROME2")
            p.jpegColour = JpegColour::Auto;
        else
            return badPhotometric();
        break;
    case Codec::Jp2k:
        // OpenJPEG undoes the codestream's own colour transform (YBR_ICT, YBR_RCT), so those
        // decode to RGB. YBR_FULL_422 is not a valid JPEG 2000 interpretation, but Orthanc's
        // dicomizer writes it for codestreams with that transform: they decode to RGB too.
        if (spp == 3 && (pi == "RGB" || pi == "YBR_ICT" || pi == "YBR_RCT" || pi == "YBR_FULL_422")) {
            p.jp2kColour = Jp2kColour::Rgb;
        } else if (spp == 3 && pi == "YBR_FULL") {
            p.jp2kColour = Jp2kColour::YCbCr;
        } else {
            return badPhotometric();
        }
        break;
    case Codec::Native:
        if (spp == 3 && pi == "RGB")
            p.native = in.planar == 1 ? NativeLayout::RgbPlanar : NativeLayout::RgbInterleaved;
        else if (spp == 1 && pi == "MONOCHROME2")
            p.native = NativeLayout::Grey;
        else
            return badPhotometric();
        break;
    }
    return {};
}

bool frameCell(const InstanceDescription& in, uint32_t f, uint64_t across, uint64_t down, uint64_t* cell,
               std::string* why) {
    if (in.positions.empty()) {
        const uint64_t k = uint64_t(in.concatenationOffset) + f;
        if (k >= across * down) return false;
        *cell = k;
        return true;
    }
    if (f >= in.positions.size()) return false;
    const auto [x, y] = in.positions[f];
    if (x < 0 || y < 0 || uint64_t(x) >= in.totalW || uint64_t(y) >= in.totalH || x % in.frameW != 0 ||
        y % in.frameH != 0) {
        *why = "frame " + std::to_string(f + 1) + " of " + in.name + " is at column " + std::to_string(x + 1) +
               ", row " + std::to_string(y + 1) + ", not on the " + std::to_string(in.frameW) + "x" +
               std::to_string(in.frameH) + " frame grid of the total pixel matrix";
        return false;
    }
    *cell = uint64_t(y / in.frameH) * across + uint64_t(x / in.frameW);
    return true;
}

Result layoutSeries(const std::vector<InstanceDescription>& instances, const std::string& seriesName,
                    SeriesLayout* out) {
    // Levels: VOLUME instances grouped by total pixel matrix, largest first.
    std::map<std::pair<uint64_t, uint64_t>, std::vector<size_t>, std::greater<>> bySize;
    for (size_t i = 0; i < instances.size(); ++i) {
        const InstanceDescription& in = instances[i];
        if (in.flavour == "VOLUME") bySize[{in.totalW * in.totalH, (in.totalW << 24) | in.totalH}].push_back(i);
    }
    if (bySize.empty()) {
        return Result(Status::CorruptData, "Cannot open " + seriesName +
                                               ": it has no VOLUME instance (only labels, overviews or thumbnails)");
    }
    SeriesLayout layout;
    for (auto& [key, members] : bySize) {
        // A level must be coarser than the one before it on both axes: the engine's level
        // choice assumes downsamples that grow with the level. An instance of odd shape that is
        // not (999x1 after 100x100, found by tests/fuzz: regressions/dicom_file/dicom-level-order.fuzz)
        // is left out, as OpenSlide leaves out such a level.
        const InstanceDescription& first = instances[members.front()];
        if (!layout.levels.empty()) {
            const Level& prev = layout.levels.back();
            if (first.totalW > prev.width || first.totalH > prev.height ||
                (first.totalW == prev.width && first.totalH == prev.height))
                continue;
        }
        Level L;
        if (Result r = buildLevel(instances, members, seriesName, layout.levels.size(), &L); !r.ok()) return r;
        layout.levels.push_back(std::move(L));
    }
    // The base instance: the one holding level 0's first frame (its first file).
    for (const Level::Cell& c : layout.levels[0].cells) {
        if (c.instance >= 0) {
            layout.base = size_t(c.instance);
            break;
        }
    }
    // Associated images: the first instance of each kind.
    const std::pair<const char*, const char*> kinds[] = {
        {"LABEL", "label"}, {"OVERVIEW", "macro"}, {"THUMBNAIL", "thumbnail"}};
    for (const auto& [flavour, name] : kinds) {
        for (size_t i = 0; i < instances.size(); ++i) {
            if (instances[i].flavour == flavour) {
                layout.associated.emplace_back(name, i);
                break;
            }
        }
    }
    *out = std::move(layout);
    return {};
}

std::string keywordOf(uint32_t t) {
    DcmTag dt(DcmTagKey(Uint16(t >> 16), Uint16(t & 0xffff))); // getTagName() is not const
    std::string key = dt.getTagName();
    if (key.empty() || key == DcmTag_ERROR_TagName) {
        char hex[16];
        std::snprintf(hex, sizeof hex, "%04X,%04X", unsigned(t >> 16), unsigned(t & 0xffff));
        key = hex;
    }
    return key;
}

SeriesMetadata describeMetadata(const Attributes& a) {
    SeriesMetadata m;
    m.manufacturer = a.text(kManufacturer).value_or("");
    if (const std::unique_ptr<Attributes> shared = a.item(kSharedFunctionalGroups, 0)) {
        if (const std::unique_ptr<Attributes> measures = shared->item(kPixelMeasures, 0)) {
            const std::optional<double> rowSpacing = measures->real(kPixelSpacing, 0);
            const std::optional<double> colSpacing = measures->real(kPixelSpacing, 1);
            if (rowSpacing && colSpacing && *rowSpacing > 0 && *colSpacing > 0) {
                m.rowSpacingMm = *rowSpacing;
                m.columnSpacingMm = *colSpacing;
            }
        }
    }
    const auto icc = [&](const Attributes& item) {
        if (!m.iccProfile.empty() || !m.iccBulkDataUri.empty()) return;
        std::string uri;
        std::optional<std::vector<uint8_t>> bytes = item.binary(kIccProfile, &uri);
        if (bytes && !bytes->empty())
            m.iccProfile = std::move(*bytes);
        else
            m.iccBulkDataUri = uri;
    };
    if (const std::unique_ptr<Attributes> path0 = a.item(kOpticalPath, 0)) {
        if (const std::optional<double> power = path0->real(kObjectiveLensPower); power && *power > 0)
            m.objectivePower = *power;
        icc(*path0);
    }
    icc(a);
    a.forEachText([&](uint32_t t, const std::string& value) { m.properties["dicom." + keywordOf(t)] = value; });
    if (const std::unique_ptr<Attributes> specimen = a.item(kSpecimenDescription, 0)) {
        const std::string id = specimen->text(kSpecimenIdentifier).value_or("");
        if (!id.empty()) m.properties["dicom.SpecimenIdentifier"] = id;
    }
    return m;
}

void fillSlideInfo(const std::vector<InstanceDescription>& instances, const SeriesLayout& layout,
                   const SeriesMetadata& meta, SlideInfo* info) {
    const Level& L0 = layout.levels[0];
    info->width = int64_t(L0.width);
    info->height = int64_t(L0.height);
    info->levels.clear();
    for (const Level& L : layout.levels) {
        LevelInfo li;
        li.width = int64_t(L.width);
        li.height = int64_t(L.height);
        li.downsample = (double(L0.width) / double(L.width) + double(L0.height) / double(L.height)) / 2;
        fillTileGrid(li);
        info->levels.push_back(li);
    }
    info->vendor = meta.manufacturer.empty() ? std::string("dicom") : meta.manufacturer;
    if (meta.rowSpacingMm > 0 && meta.columnSpacingMm > 0) {
        // Pixel Spacing is (row spacing, column spacing) in mm: the distance between rows is the
        // height of a pixel.
        info->mppX = meta.columnSpacingMm * 1000.0;
        info->mppY = meta.rowSpacingMm * 1000.0;
    }
    info->objectivePower = meta.objectivePower;
    info->iccProfile = meta.iccProfile;
    std::map<std::string, std::string> props = meta.properties;
    props["dicom.TransferSyntaxUID"] = instances[layout.base].transferSyntax;
    info->properties.assign(props.begin(), props.end());
    info->associatedImages.clear();
    for (const auto& a : layout.associated) info->associatedImages.push_back(a.first);
    fillLevelPhysics(*info);
}

Result decodeFrame(const InstanceDescription& in, uint32_t frame, const uint8_t* bytes, size_t size, uint8_t* dst,
                   size_t pitch) {
    const auto fail = [&](Status s, const std::string& why) {
        return Result(s, "Cannot read frame " + std::to_string(frame + 1) + " of " + in.name + ": " + why);
    };
    const PixelFormat& p = in.format;
    if (p.codec == Codec::Native) {
        const uint64_t need = uint64_t(in.frameW) * in.frameH * p.samples;
        if (size < need) {
            return fail(Status::CorruptData,
                        "it holds " + std::to_string(size) + " bytes, a frame needs " + std::to_string(need));
        }
        const size_t plane = size_t(in.frameW) * in.frameH;
        for (uint32_t y = 0; y < in.frameH; ++y) {
            uint8_t* d = dst + size_t(y) * pitch;
            const size_t row = size_t(y) * in.frameW;
            for (uint32_t x = 0; x < in.frameW; ++x, d += 4) {
                const size_t q = row + x;
                switch (p.native) {
                case NativeLayout::RgbInterleaved:
                    d[0] = bytes[3 * q];
                    d[1] = bytes[3 * q + 1];
                    d[2] = bytes[3 * q + 2];
                    break;
                case NativeLayout::RgbPlanar:
                    d[0] = bytes[q];
                    d[1] = bytes[plane + q];
                    d[2] = bytes[2 * plane + q];
                    break;
                case NativeLayout::Grey: d[0] = d[1] = d[2] = bytes[q]; break;
                }
                d[3] = 255;
            }
        }
        return {};
    }
    if (size == 0) return fail(Status::CorruptData, "the frame is empty");
    Result r;
    if (p.codec == Codec::Jpeg) {
        r = decodeJpegFrameRgba(bytes, size, int(in.frameW), int(in.frameH), p.jpegColour, dst, pitch);
    } else {
        static const uint8_t kJp2Signature[] = {0, 0, 0, 0x0c, 'j', 'P', ' ', ' '};
        if (size >= 8 && std::memcmp(bytes, kJp2Signature, 8) == 0) {
            return fail(Status::CorruptData,
                        "the frame is a JP2 file, not the bare JPEG 2000 codestream DICOM requires");
        }
        r = decodeJp2kRgba(bytes, size, int(in.frameW), int(in.frameH), p.jp2kColour, dst, pitch);
    }
    if (!r.ok()) return fail(r.status(), r.message());
    return {};
}

// ---- SeriesSource: tiles from frames ------------------------------------------------------

std::vector<uint64_t> SeriesSource::cellsOfTile(int level, int64_t tx, int64_t ty) const {
    std::vector<uint64_t> cells;
    if (level < 0 || size_t(level) >= info_.levels.size()) return cells;
    const LevelInfo& li = info_.levels[size_t(level)];
    if (tx < 0 || ty < 0 || tx >= li.tilesX || ty >= li.tilesY) return cells;
    const Level& L = layout_.levels[size_t(level)];
    const int64_t x0 = tx * kTileSize, y0 = ty * kTileSize;
    const int64_t w = std::min<int64_t>(kTileSize, li.width - x0), h = std::min<int64_t>(kTileSize, li.height - y0);
    for (int64_t row = y0 / L.frameH; row <= (y0 + h - 1) / int64_t(L.frameH); ++row)
        for (int64_t col = x0 / L.frameW; col <= (x0 + w - 1) / int64_t(L.frameW); ++col)
            cells.push_back(uint64_t(row) * L.across + uint64_t(col));
    return cells;
}

bool SeriesSource::hasDecodedFrame(size_t level, uint64_t cell) const {
    std::lock_guard lock(cacheMutex_);
    return cacheIndex_.count((uint64_t(level) << 40) | cell) != 0;
}

Expected<std::shared_ptr<const SeriesSource::DecodedFrame>> SeriesSource::cachedFrame(size_t level, uint64_t index) {
    const uint64_t key = (uint64_t(level) << 40) | index;
    {
        std::lock_guard lock(cacheMutex_);
        if (auto it = cacheIndex_.find(key); it != cacheIndex_.end()) {
            lru_.splice(lru_.begin(), lru_, it->second);
            return it->second->second;
        }
    }
    const Level& L = layout_.levels[level];
    const Level::Cell& cell = L.cells[size_t(index)];
    auto frame = std::make_shared<DecodedFrame>();
    if (cell.instance >= 0) {
        frame->rgba.resize(size_t(L.frameW) * L.frameH * 4);
        if (Result r = readFrame(size_t(cell.instance), cell.frame, frame->rgba.data(), size_t(L.frameW) * 4); !r.ok())
            return r;
    }
    std::shared_ptr<const DecodedFrame> out = std::move(frame);
    std::lock_guard lock(cacheMutex_);
    if (auto it = cacheIndex_.find(key); it != cacheIndex_.end()) return it->second->second; // raced: keep one
    lru_.emplace_front(key, out);
    cacheIndex_[key] = lru_.begin();
    cacheBytes_ += out->rgba.size();
    while (cacheBytes_ > kCacheBudgetBytes && lru_.size() > 1) {
        cacheBytes_ -= lru_.back().second->rgba.size();
        cacheIndex_.erase(lru_.back().first);
        lru_.pop_back();
    }
    return out;
}

Result SeriesSource::readTile(int level, int64_t tx, int64_t ty, uint8_t* dst) {
    if (level < 0 || size_t(level) >= info_.levels.size()) return Result(Status::InvalidArgument, "no such level");
    const LevelInfo& li = info_.levels[size_t(level)];
    if (tx < 0 || ty < 0 || tx >= li.tilesX || ty >= li.tilesY) return Result(Status::InvalidArgument, "no such tile");
    const Level& L = layout_.levels[size_t(level)];
    const int64_t x0 = tx * kTileSize, y0 = ty * kTileSize;
    const int w = int(std::min<int64_t>(kTileSize, li.width - x0));
    const int h = int(std::min<int64_t>(kTileSize, li.height - y0));
    constexpr size_t pitch = size_t(kTileSize) * 4;
    if (L.frameW == uint32_t(kTileSize) && L.frameH == uint32_t(kTileSize)) {
        // The frame grid is the engine's: decode straight into the tile.
        const Level::Cell& cell = L.cells[size_t(ty) * L.across + size_t(tx)];
        if (cell.instance < 0) {
            fillWhite(dst, pitch, kTileSize, kTileSize);
        } else if (Result r = readFrame(size_t(cell.instance), cell.frame, dst, pitch); !r.ok()) {
            return r;
        }
        padTileEdges(dst, w, h);
        return {};
    }
    const int64_t col0 = x0 / L.frameW, col1 = (x0 + w - 1) / L.frameW;
    const int64_t row0 = y0 / L.frameH, row1 = (y0 + h - 1) / L.frameH;
    for (int64_t row = row0; row <= row1; ++row) {
        for (int64_t col = col0; col <= col1; ++col) {
            // The overlap of frame (col, row) and the engine tile, in level pixels.
            const int64_t fx = col * L.frameW, fy = row * L.frameH;
            const int64_t ax = std::max(fx, x0), bx = std::min(fx + int64_t(L.frameW), x0 + w);
            const int64_t ay = std::max(fy, y0), by = std::min(fy + int64_t(L.frameH), y0 + h);
            if (ax >= bx || ay >= by) continue;
            uint8_t* d0 = dst + (size_t(ay - y0) * kTileSize + size_t(ax - x0)) * 4;
            const uint64_t index = uint64_t(row) * L.across + uint64_t(col);
            if (L.cells[size_t(index)].instance < 0) {
                fillWhite(d0, pitch, int(bx - ax), int(by - ay));
                continue;
            }
            auto f = cachedFrame(size_t(level), index);
            if (!f.ok()) return f.error();
            const DecodedFrame& fr = **f;
            for (int64_t y = ay; y < by; ++y) {
                const uint8_t* s = fr.rgba.data() + (size_t(y - fy) * L.frameW + size_t(ax - fx)) * 4;
                std::memcpy(d0 + size_t(y - ay) * pitch, s, size_t(bx - ax) * 4);
            }
        }
    }
    padTileEdges(dst, w, h);
    return {};
}

Expected<Image> SeriesSource::readAssociatedImage(const std::string& name) {
    const auto it = std::find_if(layout_.associated.begin(), layout_.associated.end(),
                                 [&](const auto& a) { return a.first == name; });
    if (it == layout_.associated.end())
        return Result(Status::InvalidArgument, "The slide has no associated image '" + name + "'");
    const size_t index = it->second;
    const InstanceDescription& in = instances_[index];
    if (in.totalW * in.totalH > kMaxAssociatedPixels) {
        return Result(Status::CorruptData, "The " + name + " image of " + in.name + " is too large (" +
                                               std::to_string(in.totalW) + "x" + std::to_string(in.totalH) + ")");
    }
    Image img;
    img.width = uint32_t(in.totalW);
    img.height = uint32_t(in.totalH);
    img.rgba.assign(size_t(in.totalW) * in.totalH * 4, 0xff); // frames that are absent: background
    const uint64_t across = (in.totalW + in.frameW - 1) / in.frameW, down = (in.totalH + in.frameH - 1) / in.frameH;
    std::vector<std::pair<uint32_t, uint64_t>> placed; // frame → cell
    for (uint32_t f = 0; f < in.frames; ++f) {
        uint64_t cell = 0;
        std::string why;
        if (frameCell(in, f, across, down, &cell, &why)) placed.emplace_back(f, cell);
    }
    std::vector<uint32_t> frames;
    for (const auto& p : placed) frames.push_back(p.first);
    willReadFrames(index, frames);
    std::vector<uint8_t> frame(size_t(in.frameW) * in.frameH * 4);
    for (const auto& [f, cell] : placed) {
        if (Result r = readFrame(index, f, frame.data(), size_t(in.frameW) * 4); !r.ok()) return r;
        const uint64_t fx = (cell % across) * in.frameW, fy = (cell / across) * in.frameH;
        const uint64_t w = std::min<uint64_t>(in.frameW, in.totalW - fx),
                       h = std::min<uint64_t>(in.frameH, in.totalH - fy);
        for (uint64_t y = 0; y < h; ++y) {
            std::memcpy(img.rgba.data() + ((fy + y) * in.totalW + fx) * 4, frame.data() + y * in.frameW * 4,
                        size_t(w) * 4);
        }
    }
    return img;
}

} // namespace dicom

// ---- local files, through DCMTK -----------------------------------------------------------

namespace {

// Values longer than this stay in the file until asked for (DCMTK's lazy loading): frames,
// and nothing a reader needs at open but the ICC profile, which is loaded on request.
constexpr Uint32 kMaxReadLength = 256;
constexpr uint64_t kMaxFrameBytes = uint64_t(256) << 20; // a compressed or native frame
constexpr size_t kMaxFolderEntries = 100000;

std::string fileNameOf(const std::string& path) {
    fs::path p(path);
    if (p.filename().empty()) p = p.parent_path(); // "folder/"
    return p.filename().string();
}

DcmTagKey keyOf(uint32_t t) { return DcmTagKey(Uint16(t >> 16), Uint16(t & 0xffff)); }

std::string str(DcmItem* item, const DcmTagKey& tag, unsigned long pos = 0) {
    OFString s;
    if (item && item->findAndGetOFString(tag, s, pos).good()) return std::string(s.c_str());
    return {};
}

// Whether a value of this VR reads as text: strings and numbers, not sequences, binary values
// (OB, OW, UN, …) or pixel data.
bool hasTextValue(DcmEVR vr) {
    static constexpr DcmEVR kNumbers[] = {EVR_US, EVR_SS, EVR_UL, EVR_SL, EVR_FL, EVR_FD, EVR_AT, EVR_SV, EVR_UV};
    return DcmVR(vr).isaString() || std::find(std::begin(kNumbers), std::end(kNumbers), vr) != std::end(kNumbers);
}

// dicom::Attributes over a DCMTK item (a dataset or a sequence item).
class DcmAttributes final : public dicom::Attributes {
public:
    explicit DcmAttributes(DcmItem* item) : item_(item) {}
    std::optional<std::string> text(uint32_t t, unsigned index) const override {
        OFString s;
        if (item_->findAndGetOFString(keyOf(t), s, index).bad()) return std::nullopt;
        return std::string(s.c_str());
    }
    std::optional<int64_t> integer(uint32_t t, unsigned index) const override {
        const std::optional<std::string> s = text(t, index);
        return s ? dicom::parseInteger(*s) : std::nullopt;
    }
    std::optional<double> real(uint32_t t, unsigned index) const override {
        Float64 v = 0;
        if (item_->findAndGetFloat64(keyOf(t), v, index).bad() || !std::isfinite(v)) return std::nullopt;
        return v;
    }
    size_t items(uint32_t sequence) const override {
        DcmSequenceOfItems* seq = nullptr;
        if (item_->findAndGetSequence(keyOf(sequence), seq).bad() || !seq) return 0;
        return seq->card();
    }
    std::unique_ptr<dicom::Attributes> item(uint32_t sequence, size_t i) const override {
        DcmItem* it = nullptr;
        if (item_->findAndGetSequenceItem(keyOf(sequence), it, long(i)).bad() || !it) return nullptr;
        return std::make_unique<DcmAttributes>(it);
    }
    std::optional<std::vector<uint8_t>> binary(uint32_t t, std::string*) const override {
        const Uint8* bytes = nullptr;
        unsigned long length = 0;
        if (item_->findAndGetUint8Array(keyOf(t), bytes, &length).bad() || !bytes) return std::nullopt;
        return std::vector<uint8_t>(bytes, bytes + length);
    }
    void forEachText(const std::function<void(uint32_t, const std::string&)>& f) const override {
        for (unsigned long i = 0; i < item_->card(); ++i) {
            DcmElement* el = item_->getElement(i);
            if (!el || !hasTextValue(el->ident())) continue;
            OFString value;
            if (el->getOFStringArray(value).good())
                f(dicom::tag(el->getGTag(), el->getETag()), std::string(value.c_str()));
        }
    }

private:
    DcmItem* item_;
};

// DCMTK's dcmdata logger prints every oddity of a file to stderr; an engine reports errors as
// values instead. Only dcmdata's logger is quietened, once.
void quietDcmtk() {
    static std::once_flag once;
    std::call_once(once, [] { OFLog::getLogger("dcmtk.dcmdata").setLogLevel(OFLogger::FATAL_LOG_LEVEL); });
}

} // namespace

// What a local instance's frames are read through: the parsed file and its pixel items.
struct DicomSource::File {
    // The file as opened: DCMTK reopens it by this name to load pixel data (declared first, so
    // it closes after DCMTK is done with it).
    std::unique_ptr<PinnedFile> pinned;
    std::unique_ptr<DcmFileFormat> file;
    // Encapsulated: the fragments of frame f are items[firstItem[f] .. firstItem[f + 1]).
    std::vector<DcmPixelItem*> items;
    std::vector<uint32_t> firstItem;
    DcmElement* pixelData = nullptr; // native
};

namespace {

using dicom::Codec;
using dicom::InstanceDescription;

struct Parsed {
    InstanceDescription desc;
    std::unique_ptr<DicomSource::File> file;
};

Result corruptFile(const InstanceDescription& in, const std::string& why) {
    return Result(Status::CorruptData, "Cannot open " + in.name + ": " + why);
}

// Maps the encapsulated pixel data's fragments to frames: one fragment a frame; else the Basic
// Offset Table; else a single frame of all fragments; else fragments that start a JPEG (SOI) or
// a JPEG 2000 codestream (SOC) start a frame.
Result mapFragments(const InstanceDescription& in, DcmDataset* ds, DicomSource::File& file) {
    DcmElement* el = nullptr;
    if (ds->findAndGetElement(DCM_PixelData, el).bad() || !el) return corruptFile(in, "no Pixel Data");
    auto* pd = OFstatic_cast(DcmPixelData*, el);
    DcmPixelSequence* seq = nullptr;
    const E_TransferSyntax xfer = DcmXfer(in.transferSyntax.c_str()).getXfer();
    if (pd->getEncapsulatedRepresentation(xfer, nullptr, seq).bad() || !seq) {
        return corruptFile(in, "the Pixel Data is not encapsulated, as transfer syntax " + in.transferSyntax + " says");
    }
    const unsigned long n = seq->card();
    if (n < 2) return corruptFile(in, "the encapsulated Pixel Data holds no fragment");
    std::vector<DcmPixelItem*> items;
    items.reserve(n);
    for (unsigned long i = 0; i < n; ++i) {
        DcmPixelItem* it = nullptr;
        if (seq->getItem(it, i).bad() || !it) return corruptFile(in, "cannot read pixel item " + std::to_string(i));
        items.push_back(it);
    }
    const uint32_t fragments = uint32_t(n - 1);
    file.items.assign(items.begin() + 1, items.end());
    file.firstItem.clear();
    if (fragments == in.frames) {
        for (uint32_t f = 0; f <= in.frames; ++f) file.firstItem.push_back(f);
        return {};
    }
    if (in.frames == 1) {
        file.firstItem = {0, fragments};
        return {};
    }
    // The Basic Offset Table: frame f starts offsets[f] bytes after the first fragment's item tag.
    DcmPixelItem* bot = items[0];
    const Uint32 botLength = bot->getLength();
    if (botLength == uint64_t(in.frames) * 4) {
        std::vector<Uint32> offsets(in.frames);
        if (bot->getPartialValue(offsets.data(), 0, botLength, nullptr, EBO_LittleEndian).good()) {
            std::vector<uint64_t> starts; // each fragment's item offset
            uint64_t pos = 0;
            for (DcmPixelItem* it : file.items) {
                starts.push_back(pos);
                pos += 8 + uint64_t(it->getLength());
            }
            bool ok = offsets[0] == 0;
            for (uint32_t f = 0; ok && f < in.frames; ++f) {
                auto at = std::lower_bound(starts.begin(), starts.end(), uint64_t(offsets[f]));
                ok = at != starts.end() && *at == offsets[f] &&
                     (file.firstItem.empty() || uint32_t(at - starts.begin()) > file.firstItem.back());
                if (ok) file.firstItem.push_back(uint32_t(at - starts.begin()));
            }
            if (ok) {
                file.firstItem.push_back(fragments);
                return {};
            }
            file.firstItem.clear();
        }
    }
    // Frame starts by marker.
    for (uint32_t i = 0; i < fragments; ++i) {
        uint8_t head[2] = {0, 0};
        if (file.items[i]->getLength() < 2 ||
            file.items[i]->getPartialValue(head, 0, 2, nullptr, EBO_LittleEndian).bad()) {
            continue;
        }
        const bool start = head[0] == 0xff && (in.format.codec == Codec::Jpeg ? head[1] == 0xd8 : head[1] == 0x4f);
        if (start || i == 0) file.firstItem.push_back(i);
    }
    if (file.firstItem.size() != in.frames) {
        return corruptFile(in, "Number of Frames is " + std::to_string(in.frames) + " but the Pixel Data holds " +
                                   std::to_string(fragments) + " fragments that make " +
                                   std::to_string(file.firstItem.size()) + " frames");
    }
    file.firstItem.push_back(fragments);
    return {};
}

// Parses one file: headers, pixel format, frame map. The frames stay in the file.
Expected<Parsed> parseFile(const std::string& path) {
    Parsed p;
    p.file = std::make_unique<DicomSource::File>();
    const std::string name = "DICOM file '" + fileNameOf(path) + "'";
    p.file->file = std::make_unique<DcmFileFormat>();
    p.file->pinned = std::make_unique<PinnedFile>(path);
    const OFCondition c = p.file->file->loadFile(OFFilename(p.file->pinned->name().c_str()), EXS_Unknown, EGL_noChange,
                                                 kMaxReadLength, ERM_fileOnly);
    if (c.bad()) {
        return Result(Status::CorruptData, "Cannot open " + name + ": DCMTK cannot parse it (" + c.text() + ")");
    }
    DcmDataset* ds = p.file->file->getDataset();
    auto desc = dicom::describeInstance(DcmAttributes(ds), name);
    if (!desc.ok()) return desc.error();
    p.desc = std::move(*desc);
    InstanceDescription& in = p.desc;
    if (Result r = dicom::choosePixelFormat(in, str(p.file->file->getMetaInfo(), DCM_TransferSyntaxUID)); !r.ok())
        return r;
    if (in.format.codec == Codec::Native) {
        DcmElement* el = nullptr;
        if (ds->findAndGetElement(DCM_PixelData, el).bad() || !el) return corruptFile(in, "no Pixel Data");
        const uint64_t need = uint64_t(in.frameW) * in.frameH * in.format.samples * in.frames;
        if (uint64_t(el->getLength()) < need) {
            return corruptFile(in, "the Pixel Data holds " + std::to_string(el->getLength()) + " bytes, " +
                                       std::to_string(in.frames) + " frames need " + std::to_string(need));
        }
        p.file->pixelData = el;
    } else if (Result r = mapFragments(in, ds, *p.file); !r.ok()) {
        return r;
    }
    // The per-frame groups are mapped; DCMTK's copy of them can be large (one item a frame).
    ds->findAndDeleteElement(DCM_PerFrameFunctionalGroupsSequence);
    return p;
}

// A file's Series Instance UID, read without parsing past it (a folder may hold many series,
// whose per-frame groups are costly to parse); empty when the file cannot say.
std::string seriesOf(const fs::path& file) {
    DcmFileFormat ff;
    const DcmTagKey afterSeriesUid(0x0020, 0x000f); // parsing stops before the first tag at or after it
    if (ff.loadFileUntilTag(OFFilename(file.c_str()), EXS_Unknown, EGL_noChange, kMaxReadLength, ERM_fileOnly,
                            afterSeriesUid)
            .bad()) {
        return {};
    }
    return str(ff.getDataset(), DCM_SeriesInstanceUID);
}

// The series' instances: the file given (which must be a whole-slide instance itself) and the
// files beside it of its series; or, for a folder, its whole-slide instances, which must be of
// one series. Other DICOM files, broken ones and copies of an instance are skipped.
Result gatherSeries(const std::string& path, bool isFolder, std::vector<Parsed>* found) {
    const std::string shown = fileNameOf(path);
    // DCMTK parses nothing without its data dictionary; asked only once there is a DICOM file
    // to parse (a folder without any is NotAFile, whatever the installation).
    const auto dictionary = [&]() -> Result {
        if (dcmDataDict.isDictionaryLoaded()) return {};
        return Result(Status::UnsupportedFormat, "Cannot open '" + shown +
                                                     "' as DICOM: DCMTK's data dictionary is not loaded (is "
                                                     "libdcmtk's dicom.dic installed, or DCMDICTPATH set?)");
    };
    const fs::path folder = isFolder ? fs::path(path) : fs::path(path).parent_path();
    std::set<std::string> sopInstances;
    std::string series;
    if (!isFolder) {
        if (Result r = dictionary(); !r.ok()) return r;
        auto first = parseFile(path);
        if (!first.ok()) return first.error();
        series = first->desc.seriesUid;
        sopInstances.insert(first->desc.sopInstanceUid);
        found->push_back(std::move(*first));
    }
    // The other files of the folder (not its subfolders), in name order.
    std::vector<fs::path> files;
    std::error_code ec;
    for (fs::directory_iterator it(folder.empty() ? fs::path(".") : folder, ec), end; !ec && it != end;
         it.increment(ec)) {
        if (files.size() >= kMaxFolderEntries) break;
        std::error_code fe;
        if (!it->is_regular_file(fe)) continue;
        if (!isFolder && fs::equivalent(it->path(), path, fe)) continue;
        files.push_back(it->path());
    }
    if (ec && isFolder) return Result(Status::IoError, "Cannot list folder '" + shown + "': " + ec.message());
    std::sort(files.begin(), files.end());
    size_t dicomFiles = found->size();
    for (const fs::path& f : files) {
        if (!DicomSource::detect(f.string())) continue;
        if (++dicomFiles == 1)
            if (Result r = dictionary(); !r.ok()) return r;
        if (!series.empty() && seriesOf(f) != series) continue;
        auto in = parseFile(f.string());
        if (!in.ok()) continue; // another kind of DICOM file, or a broken one of another series
        if (!series.empty() && in->desc.seriesUid != series) continue;
        if (!in->desc.sopInstanceUid.empty() && !sopInstances.insert(in->desc.sopInstanceUid).second) continue;
        found->push_back(std::move(*in));
    }
    if (!isFolder) return {};
    if (dicomFiles == 0) {
        return Result(Status::NotAFile, "Cannot open '" + shown +
                                            "': it is a folder without DICOM files, not a slide (a DICOM series "
                                            "is opened as its folder or one of its .dcm files)");
    }
    std::set<std::string> seriesSeen;
    for (const Parsed& in : *found) seriesSeen.insert(in.desc.seriesUid);
    if (seriesSeen.empty()) {
        return Result(Status::UnsupportedFormat, "Cannot open folder '" + shown + "': none of its " +
                                                     std::to_string(dicomFiles) +
                                                     " DICOM files is a VL Whole Slide Microscopy Image");
    }
    if (seriesSeen.size() > 1) {
        return Result(Status::UnsupportedFormat, "Cannot open folder '" + shown + "': it holds " +
                                                     std::to_string(seriesSeen.size()) +
                                                     " whole-slide series; open one file of the one you want");
    }
    return {};
}

} // namespace

bool DicomSource::detect(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return false;
    char m[4] = {};
    const ssize_t n = ::pread(fd, m, 4, 128);
    ::close(fd);
    return n == 4 && std::memcmp(m, "DICM", 4) == 0;
}

Expected<std::unique_ptr<SlideSource>> DicomSource::open(const std::string& path) {
    quietDcmtk();
    const std::string shown = fileNameOf(path);
    std::error_code ec;
    const bool isFolder = fs::is_directory(path, ec);
    std::vector<Parsed> parsed;
    if (Result r = gatherSeries(path, isFolder, &parsed); !r.ok()) return r;
    std::unique_ptr<DicomSource> src(new DicomSource());
    for (Parsed& p : parsed) {
        src->instances_.push_back(std::move(p.desc));
        src->files_.push_back(std::move(p.file));
    }
    if (Result r = dicom::layoutSeries(src->instances_, "DICOM series of '" + shown + "'", &src->layout_); !r.ok())
        return r;
    const DcmAttributes base(src->files_[src->layout_.base]->file->getDataset());
    dicom::fillSlideInfo(src->instances_, src->layout_, dicom::describeMetadata(base), &src->info_);
    src->info_.path = path;
    return std::unique_ptr<SlideSource>(std::move(src));
}

DicomSource::~DicomSource() = default;

Result DicomSource::readFrame(size_t instance, uint32_t frame, uint8_t* dst, size_t pitch) {
    const InstanceDescription& in = instances_[instance];
    const File& file = *files_[instance];
    const auto fail = [&](Status s, const std::string& why) {
        return Result(s, "Cannot read frame " + std::to_string(frame + 1) + " of " + in.name + ": " + why);
    };
    thread_local std::vector<uint8_t> buf;
    if (in.format.codec == Codec::Native) {
        const uint64_t bytes = uint64_t(in.frameW) * in.frameH * in.format.samples;
        buf.resize(size_t(bytes));
        const OFCondition c = file.pixelData->getPartialValue(buf.data(), Uint32(bytes * frame), Uint32(bytes), nullptr,
                                                              EBO_LittleEndian);
        if (c.bad()) return fail(Status::IoError, c.text());
        return dicom::decodeFrame(in, frame, buf.data(), buf.size(), dst, pitch);
    }
    const uint32_t i0 = file.firstItem[frame], i1 = file.firstItem[frame + 1];
    uint64_t total = 0;
    for (uint32_t i = i0; i < i1; ++i) total += file.items[i]->getLength();
    if (total == 0 || total > kMaxFrameBytes)
        return fail(Status::CorruptData, "impossible size " + std::to_string(total));
    buf.resize(size_t(total));
    size_t at = 0;
    for (uint32_t i = i0; i < i1; ++i) {
        const Uint32 n = file.items[i]->getLength();
        if (n == 0) continue;
        const OFCondition c = file.items[i]->getPartialValue(buf.data() + at, 0, n, nullptr, EBO_LittleEndian);
        if (c.bad())
            return fail(Status::IoError, std::string("the file is truncated or unreadable (") + c.text() + ")");
        at += n;
    }
    return dicom::decodeFrame(in, frame, buf.data(), at, dst, pitch);
}

} // namespace iris
