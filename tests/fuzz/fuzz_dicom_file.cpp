// libFuzzer target for the local DICOM reader (engine/src/slide/dicom_source.cpp, with DCMTK,
// jpeg_frame_decode.cpp and jp2k_decode.cpp behind it), see README.md.
//
// Each input is one DICOM file. DicomSource opens paths (and gathers a file's series from
// its folder), so the input is written as the only file of a scratch folder and opened by
// its path, as the format table opens it: only when DicomSource::detect() says it is DICOM
// Part 10. Then, as showing the slide does: SlideInfo, a bounded walk of tiles on every level
// (coarsest first; first, middle and bottom-right edge tile), requests outside the grid, and
// every associated image. Only the reader's public surface is used (open, info, readTile,
// readAssociatedImage), so that the target does not depend on how the reader is built inside.
//
// One file is one instance: a level, a label, an overview or a thumbnail, never two. So that
// levels merged from several files, associated images and the series' level order are fuzzed
// too, an input that starts with "IRIS-FUZZ-DICOM-SERIES\n" holds several files, separated by
// "\n--iris-fuzz-next-file--\n"; they are written as 0.dcm, 1.dcm, … and 0.dcm is opened
// (its series is gathered from the folder). The seeds hold a few such series.
//
// Besides the sanitizers it checks what the reader promises the engine and aborts when a
// promise is broken:
//   * open either succeeds or fails with UnsupportedFormat or CorruptData (IoError for a read
//     the system refuses), and the message names the file;
//   * the SlideInfo is a pyramid the engine can use (levels of positive size, the engine's tile
//     grid, level 0 at downsample 1 and downsamples increasing, sorted unique properties), with
//     associated images among label, macro and thumbnail;
//   * a tile that reads is opaque and fills the whole tile (the buffer is pre-filled with a
//     pattern whose alpha is not 255), with the edge rule of readTile past the level's edge,
//     and nothing is written past it (a guard band: libjpeg and OpenJPEG are not
//     instrumented); reading it again gives the same pixels (the frame cache);
//   * a tile that does not read fails with CorruptData, UnsupportedFormat or IoError naming
//     the file;
//   * an associated image is w × h RGBA, opaque, or an error naming the file.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz_support.h"
#include "slide/dicom_source.h"

namespace {

using namespace iris;

constexpr const char* kName = "fuzz.dcm";
constexpr size_t kMaxTileReads = 16;
constexpr size_t kMaxSeriesFiles = 8;
const std::string kSeriesMarker = "IRIS-FUZZ-DICOM-SERIES\n";
const std::string kSeparator = "\n--iris-fuzz-next-file--\n";

// The names of the files of this input (messages must name one of them).
std::vector<std::string> g_names;

const fuzz::ScratchDir& scratch() {
    static const fuzz::ScratchDir dir;
    return dir;
}

bool namesFile(const Result& r) {
    return std::any_of(g_names.begin(), g_names.end(),
                       [&](const std::string& n) { return fuzz::contains(r.message(), "'" + n + "'"); });
}

// Writes the input's file(s) into the emptied scratch folder; returns the path to open.
std::string writeInput(const uint8_t* data, size_t size) {
    scratch().clear();
    g_names.clear();
    const std::string_view in(reinterpret_cast<const char*>(data), size);
    if (in.substr(0, kSeriesMarker.size()) != kSeriesMarker) {
        g_names.push_back(kName);
        return scratch().write(kName, data, size);
    }
    std::string first;
    size_t at = kSeriesMarker.size();
    while (g_names.size() < kMaxSeriesFiles) {
        const size_t end = std::min(in.find(kSeparator, at), size);
        const std::string name = std::to_string(g_names.size()) + ".dcm";
        const std::string path = scratch().write(name, data + at, end - at);
        if (first.empty()) first = path;
        g_names.push_back(name);
        if (end == size) break;
        at = end + kSeparator.size();
    }
    return first;
}

bool isReadError(const Result& r) {
    return r.status() == Status::CorruptData || r.status() == Status::UnsupportedFormat ||
           r.status() == Status::IoError;
}

void readTiles(SlideSource& src) {
    fuzz::readTileSample(src, kMaxTileReads, [](const Result& r) { return isReadError(r) && namesFile(r); });
}

void readImages(SlideSource& src) {
    for (const std::string& name : src.info().associatedImages) {
        Expected<Image> img = src.readAssociatedImage(name);
        if (img) {
            PROMISE(img->width > 0 && img->height > 0);
            PROMISE(img->rgba.size() == size_t(img->width) * img->height * 4);
            for (size_t i = 3; i < img->rgba.size(); i += 4) PROMISE(img->rgba[i] == 255);
        } else {
            if (fuzz::verbose() || !isReadError(img.error()) || !namesFile(img.error()))
                fuzz::note(name.c_str(), img.error());
            PROMISE(isReadError(img.error()));
            PROMISE(namesFile(img.error()));
        }
    }
    PROMISE(src.readAssociatedImage("no such image").error().status() == Status::InvalidArgument);
}

void readInput(const uint8_t* data, size_t size) {
    const std::string path = writeInput(data, size);
    if (!DicomSource::detect(path)) return; // the format table asks this reader only then

    auto opened = DicomSource::open(path);
    if (!opened) {
        const Result& e = opened.error();
        if (fuzz::verbose() || !isReadError(e) || !namesFile(e)) fuzz::note("open", e);
        PROMISE(isReadError(e));
        PROMISE(namesFile(e));
        return;
    }
    SlideSource& src = **opened;
    const SlideInfo& info = src.info();
    // Levels get coarser (a level of odd shape that would not is left out:
    // regressions/dicom_file/dicom-level-order.fuzz).
    fuzz::checkSlideInfo(info, true);
    PROMISE(info.levels.front().downsample == 1.0);
    PROMISE(info.iccProfile.size() < size);
    for (const std::string& name : info.associatedImages)
        PROMISE(name == "label" || name == "macro" || name == "thumbnail");
    if (fuzz::verbose()) {
        std::fprintf(stderr, "opened: %s, %zu levels, %lldx%lld, %zu images, %zu properties, ICC %zu bytes\n",
                     info.vendor.c_str(), info.levels.size(), (long long)info.width, (long long)info.height,
                     info.associatedImages.size(), info.properties.size(), info.iccProfile.size());
    }
    readTiles(src);
    readImages(src);
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0) return 0;
    readInput(data, size);
    return 0;
}
