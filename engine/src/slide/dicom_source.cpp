#include "slide/dicom_source.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
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

#include "slide/jp2k_decode.h"
#include "slide/jpeg_frame_decode.h"

namespace iris {

namespace fs = std::filesystem;

namespace {

constexpr const char* kWsiSopClass = "1.2.840.10008.5.1.4.1.1.77.1.6";
// Values longer than this stay in the file until asked for (DCMTK's lazy loading): frames,
// and nothing a reader needs at open but the ICC profile, which is loaded on request.
constexpr Uint32 kMaxReadLength = 256;
constexpr uint32_t kMaxFrameSide = 16384;
constexpr uint64_t kMaxFramePixels = uint64_t(1) << 24;  // 16 Mpx: 64 MiB decoded
constexpr uint64_t kMaxFrameBytes = uint64_t(256) << 20; // a compressed or native frame
constexpr uint32_t kMaxFrames = uint32_t(1) << 24;       // per instance
constexpr uint64_t kMaxGridCells = uint64_t(1) << 25;    // frame positions per level
constexpr uint64_t kMaxMatrixSide = uint64_t(1) << 24;   // 16 Mpx across: beyond any scanner
constexpr uint64_t kMaxAssociatedPixels = uint64_t(1) << 26;
constexpr size_t kMaxFolderEntries = 100000;
constexpr size_t kCacheBudgetBytes = size_t(32) << 20; // decoded frames kept

enum class Codec { Jpeg, Jp2k, Native };
enum class NativeLayout { RgbInterleaved, RgbPlanar, Grey };

std::string fileNameOf(const std::string& path) {
    fs::path p(path);
    if (p.filename().empty()) p = p.parent_path(); // "folder/"
    return p.filename().string();
}

std::string str(DcmItem* item, const DcmTagKey& tag, unsigned long pos = 0) {
    OFString s;
    if (item && item->findAndGetOFString(tag, s, pos).good()) return std::string(s.c_str());
    return {};
}

// DCMTK's dcmdata logger prints every oddity of a file to stderr; an engine reports errors as
// values instead. Only dcmdata's logger is quietened, once.
void quietDcmtk() {
    static std::once_flag once;
    std::call_once(once, [] { OFLog::getLogger("dcmtk.dcmdata").setLogLevel(OFLogger::FATAL_LOG_LEVEL); });
}

} // namespace

struct DicomSource::Instance {
    std::string path;
    std::string name; // file name, for messages
    std::unique_ptr<DcmFileFormat> file;
    DcmDataset* ds = nullptr;
    std::string seriesUid;
    std::string sopInstanceUid;
    std::string flavour; // Image Type value 3: VOLUME, LABEL, OVERVIEW, THUMBNAIL
    std::string transferSyntax;
    std::string concatenationUid;
    uint32_t inConcatenationNumber = 0;
    uint32_t inConcatenationTotal = 0;
    uint32_t concatenationOffset = 0; // frames of the concatenation before this instance
    int32_t instanceNumber = 0;
    uint64_t totalW = 0, totalH = 0; // Total Pixel Matrix Columns / Rows
    uint32_t frameW = 0, frameH = 0, frames = 0;
    Codec codec = Codec::Native;
    JpegColour jpegColour = JpegColour::Auto;
    Jp2kColour jp2kColour = Jp2kColour::Rgb;
    NativeLayout native = NativeLayout::RgbInterleaved;
    uint32_t samples = 3;
    // Encapsulated: the fragments of frame f are items[firstItem[f] .. firstItem[f + 1]).
    std::vector<DcmPixelItem*> items;
    std::vector<uint32_t> firstItem;
    DcmElement* pixelData = nullptr; // native
    // Sparse tiling: each frame's top-left in the total pixel matrix (0-based); empty for TILED_FULL.
    std::vector<std::pair<int64_t, int64_t>> positions;
};

// A level: the frame grid over its total pixel matrix. Cell (col, row) holds the frame drawn
// there, or none (background).
struct DicomSource::Level {
    struct Cell {
        int32_t instance = -1;
        uint32_t frame = 0;
    };
    uint64_t width = 0, height = 0;
    uint32_t frameW = 0, frameH = 0;
    uint64_t across = 0, down = 0;
    std::vector<Cell> cells; // row-major
};

struct DicomSource::DecodedFrame {
    std::vector<uint8_t> rgba; // frameW × frameH RGBA8; empty: background
};

namespace {

using Instance = DicomSource::Instance;

Result corrupt(const std::string& name, const std::string& why) {
    return Result(Status::CorruptData, "Cannot open DICOM file '" + name + "': " + why);
}
Result unsupported(const std::string& name, const std::string& why) {
    return Result(Status::UnsupportedFormat, "Cannot open DICOM file '" + name + "': " + why);
}

// The pixel format and codec, from the transfer syntax and the image pixel module.
Result readPixelFormat(Instance& in) {
    DcmDataset* ds = in.ds;
    const std::string& ts = in.transferSyntax;
    if (ts == UID_JPEGProcess1TransferSyntax) {
        in.codec = Codec::Jpeg;
    } else if (ts == UID_JPEG2000LosslessOnlyTransferSyntax || ts == UID_JPEG2000TransferSyntax) {
        in.codec = Codec::Jp2k;
    } else if (ts == UID_LittleEndianExplicitTransferSyntax || ts == UID_LittleEndianImplicitTransferSyntax) {
        in.codec = Codec::Native;
    } else {
        const DcmXfer x(ts.c_str());
        const std::string what =
            x.getXfer() == EXS_Unknown ? std::string("an unknown one") : std::string(x.getXferName());
        return unsupported(in.name, "transfer syntax " + ts + " (" + what +
                                        ") is not supported; Iris View reads JPEG Baseline, JPEG 2000 and "
                                        "uncompressed little endian");
    }
    Uint16 rows = 0, cols = 0, spp = 0, bitsAlloc = 0, bitsStored = 0, pixelRep = 0, planar = 0;
    ds->findAndGetUint16(DCM_Rows, rows);
    ds->findAndGetUint16(DCM_Columns, cols);
    ds->findAndGetUint16(DCM_SamplesPerPixel, spp);
    ds->findAndGetUint16(DCM_BitsAllocated, bitsAlloc);
    ds->findAndGetUint16(DCM_BitsStored, bitsStored);
    ds->findAndGetUint16(DCM_PixelRepresentation, pixelRep);
    ds->findAndGetUint16(DCM_PlanarConfiguration, planar);
    if (rows == 0 || cols == 0 || cols > kMaxFrameSide || rows > kMaxFrameSide ||
        uint64_t(rows) * cols > kMaxFramePixels) {
        return corrupt(in.name, "impossible frame size " + std::to_string(cols) + "x" + std::to_string(rows) +
                                    " (Columns x Rows)");
    }
    in.frameW = cols;
    in.frameH = rows;
    if (bitsAlloc != 8 || bitsStored != 8 || pixelRep != 0) {
        return unsupported(in.name, "pixels of " + std::to_string(bitsStored) + " bits stored in " +
                                        std::to_string(bitsAlloc) + " (only 8-bit unsigned samples are supported)");
    }
    const std::string pi = str(ds, DCM_PhotometricInterpretation);
    const auto badPhotometric = [&] {
        return unsupported(in.name, "photometric interpretation '" + pi + "' with " + std::to_string(spp) +
                                        " samples is not supported for this transfer syntax");
    };
    in.samples = spp;
    switch (in.codec) {
    case Codec::Jpeg:
        if (spp == 3 && (pi == "YBR_FULL_422" || pi == "YBR_FULL"))
            in.jpegColour = JpegColour::YCbCr;
        else if (spp == 3 && pi == "RGB")
            in.jpegColour = JpegColour::Rgb;
        else if (spp == 1 && pi == "MONOCHROME2")
            in.jpegColour = JpegColour::Auto;
        else
            return badPhotometric();
        break;
    case Codec::Jp2k:
        // OpenJPEG undoes the codestream's own colour transform (YBR_ICT, YBR_RCT), so those
        // decode to RGB. YBR_FULL_422 is not a valid JPEG 2000 interpretation, but Orthanc's
        // dicomizer writes it for codestreams with that transform: they decode to RGB too.
        if (spp == 3 && (pi == "RGB" || pi == "YBR_ICT" || pi == "YBR_RCT" || pi == "YBR_FULL_422")) {
            in.jp2kColour = Jp2kColour::Rgb;
        } else if (spp == 3 && pi == "YBR_FULL") {
            in.jp2kColour = Jp2kColour::YCbCr;
        } else {
            return badPhotometric();
        }
        break;
    case Codec::Native:
        if (spp == 3 && pi == "RGB")
            in.native = planar == 1 ? NativeLayout::RgbPlanar : NativeLayout::RgbInterleaved;
        else if (spp == 1 && pi == "MONOCHROME2")
            in.native = NativeLayout::Grey;
        else
            return badPhotometric();
        break;
    }
    return {};
}

// Maps the encapsulated pixel data's fragments to frames: one fragment a frame; else the Basic
// Offset Table; else a single frame of all fragments; else fragments that start a JPEG (SOI) or
// a JPEG 2000 codestream (SOC) start a frame.
Result mapFragments(Instance& in) {
    DcmElement* el = nullptr;
    if (in.ds->findAndGetElement(DCM_PixelData, el).bad() || !el) return corrupt(in.name, "no Pixel Data");
    auto* pd = OFstatic_cast(DcmPixelData*, el);
    DcmPixelSequence* seq = nullptr;
    const E_TransferSyntax xfer = DcmXfer(in.transferSyntax.c_str()).getXfer();
    if (pd->getEncapsulatedRepresentation(xfer, nullptr, seq).bad() || !seq) {
        return corrupt(in.name,
                       "the Pixel Data is not encapsulated, as transfer syntax " + in.transferSyntax + " says");
    }
    const unsigned long n = seq->card();
    if (n < 2) return corrupt(in.name, "the encapsulated Pixel Data holds no fragment");
    std::vector<DcmPixelItem*> items;
    items.reserve(n);
    for (unsigned long i = 0; i < n; ++i) {
        DcmPixelItem* it = nullptr;
        if (seq->getItem(it, i).bad() || !it) return corrupt(in.name, "cannot read pixel item " + std::to_string(i));
        items.push_back(it);
    }
    const uint32_t fragments = uint32_t(n - 1);
    in.items.assign(items.begin() + 1, items.end());
    in.firstItem.clear();
    if (fragments == in.frames) {
        for (uint32_t f = 0; f <= in.frames; ++f) in.firstItem.push_back(f);
        return {};
    }
    if (in.frames == 1) {
        in.firstItem = {0, fragments};
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
            for (DcmPixelItem* it : in.items) {
                starts.push_back(pos);
                pos += 8 + uint64_t(it->getLength());
            }
            bool ok = offsets[0] == 0;
            for (uint32_t f = 0; ok && f < in.frames; ++f) {
                auto at = std::lower_bound(starts.begin(), starts.end(), uint64_t(offsets[f]));
                ok = at != starts.end() && *at == offsets[f] &&
                     (in.firstItem.empty() || uint32_t(at - starts.begin()) > in.firstItem.back());
                if (ok) in.firstItem.push_back(uint32_t(at - starts.begin()));
            }
            if (ok) {
                in.firstItem.push_back(fragments);
                return {};
            }
            in.firstItem.clear();
        }
    }
    // Frame starts by marker.
    for (uint32_t i = 0; i < fragments; ++i) {
        uint8_t head[2] = {0, 0};
        if (in.items[i]->getLength() < 2 || in.items[i]->getPartialValue(head, 0, 2, nullptr, EBO_LittleEndian).bad()) {
            continue;
        }
        const bool start = head[0] == 0xff && (in.codec == Codec::Jpeg ? head[1] == 0xd8 : head[1] == 0x4f);
        if (start || i == 0) in.firstItem.push_back(i);
    }
    if (in.firstItem.size() != in.frames) {
        return corrupt(in.name, "Number of Frames is " + std::to_string(in.frames) + " but the Pixel Data holds " +
                                    std::to_string(fragments) + " fragments that make " +
                                    std::to_string(in.firstItem.size()) + " frames");
    }
    in.firstItem.push_back(fragments);
    return {};
}

// Sparse tiling: each frame's position from the Per-Frame Functional Groups.
Result readPositions(Instance& in) {
    DcmSequenceOfItems* perFrame = nullptr;
    if (in.ds->findAndGetSequence(DCM_PerFrameFunctionalGroupsSequence, perFrame).bad() || !perFrame) {
        return {};
    }
    if (perFrame->card() != in.frames) {
        return corrupt(in.name, "Number of Frames is " + std::to_string(in.frames) +
                                    " but the Per-Frame Functional Groups Sequence has " +
                                    std::to_string(perFrame->card()) + " items");
    }
    in.positions.reserve(in.frames);
    for (uint32_t f = 0; f < in.frames; ++f) {
        DcmItem* pos = nullptr;
        Sint32 col = 0, row = 0;
        if (perFrame->getItem(f)->findAndGetSequenceItem(DCM_PlanePositionSlideSequence, pos, 0).bad() || !pos ||
            pos->findAndGetSint32(DCM_ColumnPositionInTotalImagePixelMatrix, col).bad() ||
            pos->findAndGetSint32(DCM_RowPositionInTotalImagePixelMatrix, row).bad()) {
            if (f == 0) return {}; // no positions at all: frames are in TILED_FULL order
            return corrupt(in.name, "frame " + std::to_string(f + 1) + " has no Plane Position (Slide)");
        }
        in.positions.emplace_back(int64_t(col) - 1, int64_t(row) - 1);
    }
    return {};
}

// Parses one file: headers, pixel format, frame map. The frames stay in the file.
Expected<std::unique_ptr<Instance>> parseInstance(const std::string& path) {
    auto in = std::make_unique<Instance>();
    in->path = path;
    in->name = fileNameOf(path);
    in->file = std::make_unique<DcmFileFormat>();
    const OFCondition c =
        in->file->loadFile(OFFilename(path.c_str()), EXS_Unknown, EGL_noChange, kMaxReadLength, ERM_fileOnly);
    if (c.bad()) return corrupt(in->name, std::string("DCMTK cannot parse it (") + c.text() + ")");
    in->ds = in->file->getDataset();
    DcmMetaInfo* meta = in->file->getMetaInfo();
    const std::string sopClass = str(in->ds, DCM_SOPClassUID);
    if (sopClass != kWsiSopClass) {
        const char* known = dcmFindNameOfUID(sopClass.c_str(), nullptr);
        return unsupported(in->name, "it is not a VL Whole Slide Microscopy Image but SOP class " +
                                         (sopClass.empty() ? std::string("(none)") : sopClass) +
                                         (known ? " (" + std::string(known) + ")" : std::string()));
    }
    in->transferSyntax = str(meta, DCM_TransferSyntaxUID);
    in->seriesUid = str(in->ds, DCM_SeriesInstanceUID);
    in->sopInstanceUid = str(in->ds, DCM_SOPInstanceUID);
    in->flavour = str(in->ds, DCM_ImageType, 2);
    if (in->flavour.empty()) in->flavour = "VOLUME"; // Orthanc's dicomizer writes no Image Type
    in->concatenationUid = str(in->ds, DCM_ConcatenationUID);
    {
        Uint16 v16 = 0;
        Uint32 v32 = 0;
        Sint32 s32 = 0;
        if (in->ds->findAndGetUint16(DCM_InConcatenationNumber, v16).good()) in->inConcatenationNumber = v16;
        if (in->ds->findAndGetUint16(DCM_InConcatenationTotalNumber, v16).good()) in->inConcatenationTotal = v16;
        if (in->ds->findAndGetUint32(DCM_ConcatenationFrameOffsetNumber, v32).good()) in->concatenationOffset = v32;
        if (in->ds->findAndGetSint32(DCM_InstanceNumber, s32).good()) in->instanceNumber = s32;
        Uint32 tw = 0, th = 0;
        if (in->ds->findAndGetUint32(DCM_TotalPixelMatrixColumns, tw).good()) in->totalW = tw;
        if (in->ds->findAndGetUint32(DCM_TotalPixelMatrixRows, th).good()) in->totalH = th;
        Sint32 frames = 1;
        if (in->ds->findAndGetSint32(DCM_NumberOfFrames, frames).bad()) frames = 1;
        if (frames < 1 || uint32_t(frames) > kMaxFrames) {
            return corrupt(in->name, "impossible Number of Frames " + std::to_string(frames));
        }
        in->frames = uint32_t(frames);
    }
    if (Result r = readPixelFormat(*in); !r.ok()) return r;
    if (in->totalW == 0 || in->totalH == 0) { // single-frame images (labels) may leave the matrix out
        in->totalW = in->frameW;
        in->totalH = in->frameH;
    }
    if (in->totalW > kMaxMatrixSide || in->totalH > kMaxMatrixSide) {
        return corrupt(in->name, "impossible Total Pixel Matrix " + std::to_string(in->totalW) + "x" +
                                     std::to_string(in->totalH));
    }
    if (in->codec == Codec::Native) {
        DcmElement* el = nullptr;
        if (in->ds->findAndGetElement(DCM_PixelData, el).bad() || !el) return corrupt(in->name, "no Pixel Data");
        const uint64_t need = uint64_t(in->frameW) * in->frameH * in->samples * in->frames;
        if (uint64_t(el->getLength()) < need) {
            return corrupt(in->name, "the Pixel Data holds " + std::to_string(el->getLength()) + " bytes, " +
                                         std::to_string(in->frames) + " frames need " + std::to_string(need));
        }
        in->pixelData = el;
    } else if (Result r = mapFragments(*in); !r.ok()) {
        return r;
    }
    const std::string organisation = str(in->ds, DCM_DimensionOrganizationType);
    if (organisation != "TILED_FULL") {
        if (Result r = readPositions(*in); !r.ok()) return r;
        if (organisation == "TILED_SPARSE" && in->positions.empty() && in->frames > 1) {
            return corrupt(in->name, "TILED_SPARSE without Plane Position (Slide) for its frames");
        }
    }
    // The per-frame groups are mapped; DCMTK's copy of them can be large (one item a frame).
    in->ds->findAndDeleteElement(DCM_PerFrameFunctionalGroupsSequence);
    return in;
}

// Where frame f of an instance lies in its total pixel matrix, in frame cells; false when the
// frame lies outside (another focal plane or optical path of TILED_FULL) or off the grid.
bool frameCell(const Instance& in, uint32_t f, uint64_t across, uint64_t down, uint64_t* cell, std::string* why) {
    if (in.positions.empty()) {
        const uint64_t k = uint64_t(in.concatenationOffset) + f;
        if (k >= across * down) return false;
        *cell = k;
        return true;
    }
    const auto [x, y] = in.positions[f];
    if (x < 0 || y < 0 || uint64_t(x) >= in.totalW || uint64_t(y) >= in.totalH || x % in.frameW != 0 ||
        y % in.frameH != 0) {
        *why = "frame " + std::to_string(f + 1) + " of '" + in.name + "' is at column " + std::to_string(x + 1) +
               ", row " + std::to_string(y + 1) + ", not on the " + std::to_string(in.frameW) + "x" +
               std::to_string(in.frameH) + " frame grid of the total pixel matrix";
        return false;
    }
    *cell = uint64_t(y / in.frameH) * across + uint64_t(x / in.frameW);
    return true;
}

void fillWhite(uint8_t* dst, size_t pitch, int w, int h) {
    for (int y = 0; y < h; ++y) std::memset(dst + size_t(y) * pitch, 0xff, size_t(w) * 4);
}

using InstanceList = std::vector<std::unique_ptr<Instance>>;

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
Result gatherSeries(const std::string& path, bool isFolder, InstanceList* found) {
    const std::string shown = fileNameOf(path);
    const fs::path folder = isFolder ? fs::path(path) : fs::path(path).parent_path();
    std::set<std::string> sopInstances;
    std::string series;
    if (!isFolder) {
        auto first = parseInstance(path);
        if (!first.ok()) return first.error();
        series = (*first)->seriesUid;
        sopInstances.insert((*first)->sopInstanceUid);
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
        ++dicomFiles;
        if (!series.empty() && seriesOf(f) != series) continue;
        auto in = parseInstance(f.string());
        if (!in.ok()) continue; // another kind of DICOM file, or a broken one of another series
        if (!series.empty() && (*in)->seriesUid != series) continue;
        if (!(*in)->sopInstanceUid.empty() && !sopInstances.insert((*in)->sopInstanceUid).second) continue;
        found->push_back(std::move(*in));
    }
    if (!isFolder) return {};
    if (dicomFiles == 0) {
        return Result(Status::NotAFile, "Cannot open '" + shown +
                                            "': it is a folder without DICOM files, not a slide (a DICOM series "
                                            "is opened as its folder or one of its .dcm files)");
    }
    std::set<std::string> seriesSeen;
    for (const auto& in : *found) seriesSeen.insert(in->seriesUid);
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

// One level from the VOLUME instances of one total pixel matrix size (`members`, indices into
// `instances`): its frame grid, each cell the frame drawn there.
Result buildLevel(const InstanceList& instances, std::vector<size_t> members, const std::string& seriesName,
                  size_t levelIndex, DicomSource::Level* out) {
    using Level = DicomSource::Level;
    const Instance& first = *instances[members.front()];
    const std::string levelName = "level " + std::to_string(levelIndex) + " (" + std::to_string(first.totalW) + "x" +
                                  std::to_string(first.totalH) + ")";
    const auto seriesError = [&](const std::string& why) {
        return Result(Status::CorruptData, "Cannot open DICOM series of '" + seriesName + "': " + why);
    };
    // Concatenation parts, then instance numbers, then file names.
    std::sort(members.begin(), members.end(), [&](size_t a, size_t b) {
        const Instance& x = *instances[a];
        const Instance& y = *instances[b];
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
        const Instance& in = *instances[idx];
        if (in.frameW != L.frameW || in.frameH != L.frameH) {
            return corrupt(in.name, "its frames are " + std::to_string(in.frameW) + "x" + std::to_string(in.frameH) +
                                        " but other files of " + levelName + " have " + std::to_string(L.frameW) + "x" +
                                        std::to_string(L.frameH));
        }
        if (!in.concatenationUid.empty()) parts[in.concatenationUid].push_back(in.inConcatenationNumber);
        tiledFull = tiledFull || in.positions.empty();
        for (uint32_t f = 0; f < in.frames; ++f) {
            uint64_t cell = 0;
            std::string why;
            if (!frameCell(in, f, L.across, L.down, &cell, &why)) {
                if (!why.empty()) return Result(Status::CorruptData, "Cannot open DICOM series: " + why);
                continue; // another focal plane or optical path
            }
            if (L.cells[cell].instance < 0) L.cells[cell] = {int32_t(idx), f}; // the first focal plane wins
        }
    }
    for (const auto& [uid, numbers] : parts) {
        const uint32_t total = instances[members.front()]->inConcatenationTotal;
        for (size_t k = 0; k < numbers.size(); ++k) {
            if (numbers[k] != k + 1 || (total && numbers.size() != total)) {
                return seriesError(levelName + " is a concatenation of " +
                                   (total ? std::to_string(total) : std::string("several")) + " files but only " +
                                   std::to_string(numbers.size()) + " are in the folder (a file is missing)");
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

// Whether a value of this VR reads as text: strings and numbers, not sequences, binary values
// (OB, OW, UN, …) or pixel data.
bool hasTextValue(DcmEVR vr) {
    static constexpr DcmEVR kNumbers[] = {EVR_US, EVR_SS, EVR_UL, EVR_SL, EVR_FL, EVR_FD, EVR_AT, EVR_SV, EVR_UV};
    return DcmVR(vr).isaString() || std::find(std::begin(kNumbers), std::end(kNumbers), vr) != std::end(kNumbers);
}

// mpp, objective power, ICC profile, vendor and properties, from the base instance.
void readMetadata(const Instance& base, SlideInfo* info) {
    DcmDataset* ds = base.ds;
    const std::string manufacturer = str(ds, DCM_Manufacturer);
    info->vendor = manufacturer.empty() ? std::string("dicom") : manufacturer;
    DcmItem* shared = nullptr;
    DcmItem* measures = nullptr;
    Float64 rowSpacing = 0, colSpacing = 0;
    if (ds->findAndGetSequenceItem(DCM_SharedFunctionalGroupsSequence, shared, 0).good() && shared &&
        shared->findAndGetSequenceItem(DCM_PixelMeasuresSequence, measures, 0).good() && measures &&
        measures->findAndGetFloat64(DCM_PixelSpacing, rowSpacing, 0).good() &&
        measures->findAndGetFloat64(DCM_PixelSpacing, colSpacing, 1).good() && std::isfinite(rowSpacing) &&
        std::isfinite(colSpacing) && rowSpacing > 0 && colSpacing > 0) {
        // Pixel Spacing is (row spacing, column spacing) in mm: the distance between rows is the
        // height of a pixel.
        info->mppX = colSpacing * 1000.0;
        info->mppY = rowSpacing * 1000.0;
    }
    const auto icc = [&](DcmItem* item) {
        const Uint8* bytes = nullptr;
        unsigned long length = 0;
        if (info->iccProfile.empty() && item->findAndGetUint8Array(DCM_ICCProfile, bytes, &length).good() && bytes &&
            length > 0) {
            info->iccProfile.assign(bytes, bytes + length);
        }
    };
    DcmItem* path0 = nullptr;
    if (ds->findAndGetSequenceItem(DCM_OpticalPathSequence, path0, 0).good() && path0) {
        Float64 power = 0;
        if (path0->findAndGetFloat64(DCM_ObjectiveLensPower, power).good() && std::isfinite(power) && power > 0) {
            info->objectivePower = power;
        }
        icc(path0);
    }
    icc(ds);

    // Every attribute with a text or number value, by keyword.
    std::map<std::string, std::string> props;
    for (unsigned long i = 0; i < ds->card(); ++i) {
        DcmElement* el = ds->getElement(i);
        if (!el) continue;
        if (!hasTextValue(el->ident())) continue;
        DcmTag tag = el->getTag();
        std::string key = tag.getTagName();
        if (key.empty() || key == DcmTag_ERROR_TagName) {
            char hex[16];
            std::snprintf(hex, sizeof hex, "%04X,%04X", unsigned(tag.getGTag()), unsigned(tag.getETag()));
            key = hex;
        }
        OFString value;
        if (el->getOFStringArray(value).good()) props["dicom." + key] = value.c_str();
    }
    props["dicom.TransferSyntaxUID"] = base.transferSyntax;
    DcmItem* specimen = nullptr;
    if (ds->findAndGetSequenceItem(DCM_SpecimenDescriptionSequence, specimen, 0).good() && specimen) {
        const std::string id = str(specimen, DCM_SpecimenIdentifier);
        if (!id.empty()) props["dicom.SpecimenIdentifier"] = id;
    }
    info->properties.assign(props.begin(), props.end());
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
    if (!dcmDataDict.isDictionaryLoaded()) {
        return Result(Status::UnsupportedFormat, "Cannot open '" + shown +
                                                     "' as DICOM: DCMTK's data dictionary is not loaded (is "
                                                     "libdcmtk's dicom.dic installed, or DCMDICTPATH set?)");
    }
    std::error_code ec;
    const bool isFolder = fs::is_directory(path, ec);
    std::unique_ptr<DicomSource> src(new DicomSource());
    if (Result r = gatherSeries(path, isFolder, &src->instances_); !r.ok()) return r;

    // Levels: VOLUME instances grouped by total pixel matrix, largest first.
    std::map<std::pair<uint64_t, uint64_t>, std::vector<size_t>, std::greater<>> bySize;
    for (size_t i = 0; i < src->instances_.size(); ++i) {
        const Instance& in = *src->instances_[i];
        if (in.flavour == "VOLUME") bySize[{in.totalW * in.totalH, (in.totalW << 24) | in.totalH}].push_back(i);
    }
    if (bySize.empty()) {
        return Result(Status::CorruptData, "Cannot open DICOM series of '" + shown +
                                               "': it has no VOLUME instance (only labels, overviews or thumbnails)");
    }
    for (auto& [key, members] : bySize) {
        Level L;
        if (Result r = buildLevel(src->instances_, members, shown, src->levels_.size(), &L); !r.ok()) return r;
        src->levels_.push_back(std::move(L));
    }

    SlideInfo& info = src->info_;
    info.path = path;
    const Level& L0 = src->levels_[0];
    info.width = int64_t(L0.width);
    info.height = int64_t(L0.height);
    for (const Level& L : src->levels_) {
        LevelInfo li;
        li.width = int64_t(L.width);
        li.height = int64_t(L.height);
        li.downsample = (double(L0.width) / double(L.width) + double(L0.height) / double(L.height)) / 2;
        fillTileGrid(li);
        info.levels.push_back(li);
    }
    // The base instance: the one holding level 0's first frame (its first file).
    size_t base = 0;
    for (const Level::Cell& c : L0.cells) {
        if (c.instance >= 0) {
            base = size_t(c.instance);
            break;
        }
    }
    readMetadata(*src->instances_[base], &info);

    // Associated images: the first instance of each kind.
    const std::pair<const char*, const char*> kinds[] = {
        {"LABEL", "label"}, {"OVERVIEW", "macro"}, {"THUMBNAIL", "thumbnail"}};
    for (const auto& [flavour, name] : kinds) {
        for (size_t i = 0; i < src->instances_.size(); ++i) {
            if (src->instances_[i]->flavour == flavour) {
                src->associated_.emplace_back(name, i);
                info.associatedImages.emplace_back(name);
                break;
            }
        }
    }
    fillLevelPhysics(info);
    return std::unique_ptr<SlideSource>(std::move(src));
}

DicomSource::~DicomSource() = default;

const SlideInfo& DicomSource::info() const { return info_; }

Result DicomSource::decodeFrame(const Instance& in, uint32_t frame, uint8_t* dst, size_t pitch) const {
    const auto fail = [&](Status s, const std::string& why) {
        return Result(s, "Cannot read frame " + std::to_string(frame + 1) + " of DICOM file '" + in.name + "': " + why);
    };
    thread_local std::vector<uint8_t> buf;
    if (in.codec == Codec::Native) {
        const uint64_t bytes = uint64_t(in.frameW) * in.frameH * in.samples;
        buf.resize(size_t(bytes));
        const OFCondition c =
            in.pixelData->getPartialValue(buf.data(), Uint32(bytes * frame), Uint32(bytes), nullptr, EBO_LittleEndian);
        if (c.bad()) return fail(Status::IoError, c.text());
        const size_t plane = size_t(in.frameW) * in.frameH;
        for (uint32_t y = 0; y < in.frameH; ++y) {
            uint8_t* d = dst + size_t(y) * pitch;
            const size_t row = size_t(y) * in.frameW;
            for (uint32_t x = 0; x < in.frameW; ++x, d += 4) {
                const size_t p = row + x;
                switch (in.native) {
                case NativeLayout::RgbInterleaved:
                    d[0] = buf[3 * p];
                    d[1] = buf[3 * p + 1];
                    d[2] = buf[3 * p + 2];
                    break;
                case NativeLayout::RgbPlanar:
                    d[0] = buf[p];
                    d[1] = buf[plane + p];
                    d[2] = buf[2 * plane + p];
                    break;
                case NativeLayout::Grey: d[0] = d[1] = d[2] = buf[p]; break;
                }
                d[3] = 255;
            }
        }
        return {};
    }
    const uint32_t i0 = in.firstItem[frame], i1 = in.firstItem[frame + 1];
    uint64_t total = 0;
    for (uint32_t i = i0; i < i1; ++i) total += in.items[i]->getLength();
    if (total == 0 || total > kMaxFrameBytes)
        return fail(Status::CorruptData, "impossible size " + std::to_string(total));
    buf.resize(size_t(total));
    size_t at = 0;
    for (uint32_t i = i0; i < i1; ++i) {
        const Uint32 n = in.items[i]->getLength();
        if (n == 0) continue;
        const OFCondition c = in.items[i]->getPartialValue(buf.data() + at, 0, n, nullptr, EBO_LittleEndian);
        if (c.bad())
            return fail(Status::IoError, std::string("the file is truncated or unreadable (") + c.text() + ")");
        at += n;
    }
    Result r;
    if (in.codec == Codec::Jpeg) {
        r = decodeJpegFrameRgba(buf.data(), at, int(in.frameW), int(in.frameH), in.jpegColour, dst, pitch);
    } else {
        static const uint8_t kJp2Signature[] = {0, 0, 0, 0x0c, 'j', 'P', ' ', ' '};
        if (at >= 8 && std::memcmp(buf.data(), kJp2Signature, 8) == 0) {
            return fail(Status::CorruptData,
                        "the frame is a JP2 file, not the bare JPEG 2000 codestream DICOM requires");
        }
        r = decodeJp2kRgba(buf.data(), at, int(in.frameW), int(in.frameH), in.jp2kColour, dst, pitch);
    }
    if (!r.ok()) return fail(r.status(), r.message());
    return {};
}

Expected<std::shared_ptr<const DicomSource::DecodedFrame>> DicomSource::cachedFrame(size_t level, int64_t index) {
    const uint64_t key = (uint64_t(level) << 40) | uint64_t(index);
    {
        std::lock_guard lock(cacheMutex_);
        if (auto it = cacheIndex_.find(key); it != cacheIndex_.end()) {
            lru_.splice(lru_.begin(), lru_, it->second);
            return it->second->second;
        }
    }
    const Level& L = levels_[level];
    const Level::Cell& cell = L.cells[size_t(index)];
    auto frame = std::make_shared<DecodedFrame>();
    if (cell.instance >= 0) {
        frame->rgba.resize(size_t(L.frameW) * L.frameH * 4);
        if (Result r =
                decodeFrame(*instances_[size_t(cell.instance)], cell.frame, frame->rgba.data(), size_t(L.frameW) * 4);
            !r.ok()) {
            return r;
        }
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

Result DicomSource::readTile(int level, int64_t tx, int64_t ty, uint8_t* dst) {
    if (level < 0 || size_t(level) >= info_.levels.size()) return Result(Status::InvalidArgument, "no such level");
    const LevelInfo& li = info_.levels[size_t(level)];
    if (tx < 0 || ty < 0 || tx >= li.tilesX || ty >= li.tilesY) return Result(Status::InvalidArgument, "no such tile");
    const Level& L = levels_[size_t(level)];
    const int64_t x0 = tx * kTileSize, y0 = ty * kTileSize;
    const int w = int(std::min<int64_t>(kTileSize, li.width - x0));
    const int h = int(std::min<int64_t>(kTileSize, li.height - y0));
    constexpr size_t pitch = size_t(kTileSize) * 4;
    if (L.frameW == uint32_t(kTileSize) && L.frameH == uint32_t(kTileSize)) {
        // The frame grid is the engine's: decode straight into the tile.
        const Level::Cell& cell = L.cells[size_t(ty) * L.across + size_t(tx)];
        if (cell.instance < 0) {
            fillWhite(dst, pitch, kTileSize, kTileSize);
        } else if (Result r = decodeFrame(*instances_[size_t(cell.instance)], cell.frame, dst, pitch); !r.ok()) {
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
            const int64_t index = row * int64_t(L.across) + col;
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

Expected<Image> DicomSource::readAssociatedImage(const std::string& name) {
    const auto it =
        std::find_if(associated_.begin(), associated_.end(), [&](const auto& a) { return a.first == name; });
    if (it == associated_.end())
        return Result(Status::InvalidArgument, "The slide has no associated image '" + name + "'");
    const Instance& in = *instances_[it->second];
    if (in.totalW * in.totalH > kMaxAssociatedPixels) {
        return Result(Status::CorruptData, "The " + name + " image of DICOM file '" + in.name + "' is too large (" +
                                               std::to_string(in.totalW) + "x" + std::to_string(in.totalH) + ")");
    }
    Image img;
    img.width = uint32_t(in.totalW);
    img.height = uint32_t(in.totalH);
    img.rgba.assign(size_t(in.totalW) * in.totalH * 4, 0xff); // frames that are absent: background
    const uint64_t across = (in.totalW + in.frameW - 1) / in.frameW, down = (in.totalH + in.frameH - 1) / in.frameH;
    std::vector<uint8_t> frame(size_t(in.frameW) * in.frameH * 4);
    for (uint32_t f = 0; f < in.frames; ++f) {
        uint64_t cell = 0;
        std::string why;
        if (!frameCell(in, f, across, down, &cell, &why)) continue;
        if (Result r = decodeFrame(in, f, frame.data(), size_t(in.frameW) * 4); !r.ok()) return r;
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

} // namespace iris
