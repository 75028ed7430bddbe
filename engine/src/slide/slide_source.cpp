#include "slide/slide_source.h"

#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string_view>

#include "slide/dicom_source.h"
#include "slide/dicomweb_source.h"
#include "slide/iris_file.h"
#include "slide/openslide_source.h"
#include "slide/synthetic_source.h"
#include "slide/tiff_source.h"

namespace iris {

namespace fs = std::filesystem;

namespace {

// The format table: each entry detects cheaply, then opens. Order matters: specific,
// fast readers first; OpenSlide last as the universal reader for every vendor format.
struct SlideFormat {
    const char* name;
    bool (*detect)(const std::string& path);
    Expected<std::unique_ptr<SlideSource>> (*open)(const std::string& path);
    bool fallThrough; // UnsupportedFormat from open() means "not mine": try the next format
};

// http:// or https://, in any case: a DICOMweb series URL (the network source checks the rest).
bool isUrl(const std::string& path) {
    const auto starts = [&](std::string_view p) {
        if (path.size() < p.size()) return false;
        for (size_t i = 0; i < p.size(); ++i)
            if (std::tolower(static_cast<unsigned char>(path[i])) != p[i]) return false;
        return true;
    };
    return starts("http://") || starts("https://");
}

const SlideFormat kFormats[] = {
    {"iris", &IrisFileSource::detect, &IrisFileSource::open, false},
    // Aperio SVS and generic tiled TIFF decoded from the file's own tiles: exact pixels on
    // every level (OpenSlide resamples levels with non-integer downsamples) and faster.
    {"tiff", &TiffTileSource::detect, &TiffTileSource::tryOpen, true},
    // DICOM VL Whole Slide Microscopy: one file of a series (the rest is found beside it).
    {"dicom", &DicomSource::detect, &DicomSource::open, false},
    {"openslide", &OpenSlideSource::detect, &OpenSlideSource::open, false},
};

} // namespace

Expected<std::unique_ptr<SlideSource>> openSlideSource(const std::string& path, SourcePreference preference,
                                                       const NetworkOptions& network) {
    if (path.empty()) return Result(Status::InvalidArgument, "No slide path given");
    if (SyntheticSource::detect(path)) return SyntheticSource::open(path); // not a file
    // A DICOMweb series URL: not a file either. Only the Auto table reads it (OpenSlide and
    // .iris read files).
    if (isUrl(path)) {
        if (preference != SourcePreference::Auto) {
            return Result(Status::UnsupportedFormat,
                          "Cannot open '" + path + "': a DICOMweb URL is read by the DICOMweb source only, not by " +
                              (preference == SourcePreference::OpenSlide ? "OpenSlide" : "the .iris reader"));
        }
        return openDicomWebSource(path, network);
    }
    std::error_code ec;
    const fs::path p(path);
    const auto st = fs::status(p, ec);
    if (ec || !fs::exists(st)) {
        return Result(Status::NotFound, "Cannot open '" + path + "': no such file");
    }
    if (fs::is_directory(st)) {
        // A folder is a slide only as a DICOM series; one without DICOM files is NotAFile.
        if (preference == SourcePreference::Auto) return DicomSource::open(path);
        return Result(Status::NotAFile, "Cannot open '" + path + "': it is a directory, not a slide file");
    }
    if (!fs::is_regular_file(st)) {
        return Result(Status::NotAFile, "Cannot open '" + path + "': not a regular file");
    }
    {
        std::ifstream probe(p, std::ios::binary);
        if (!probe) {
            return Result(Status::IoError, "Cannot open '" + path + "': " + std::strerror(errno));
        }
    }
    if (fs::file_size(p, ec) == 0) {
        return Result(Status::UnsupportedFormat, "Cannot open '" + path + "': the file is empty");
    }
    for (const SlideFormat& f : kFormats) {
        const std::string name = f.name;
        if (preference == SourcePreference::OpenSlide && name != "openslide") continue;
        if (preference == SourcePreference::Iris && name != "iris") continue;
        if (!f.detect(path)) continue;
        auto r = f.open(path);
        if (!r.ok() && f.fallThrough && r.error().status() == Status::UnsupportedFormat) continue;
        return r;
    }
    if (preference == SourcePreference::Iris) {
        return Result(Status::UnsupportedFormat, "Cannot open '" + path + "' as .iris: it is not an Iris File Extension file");
    }
    return Result(Status::UnsupportedFormat,
                  "Cannot open '" + path + "': not a slide format Iris View can read");
}

} // namespace iris
