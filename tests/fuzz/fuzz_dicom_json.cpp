// libFuzzer target for the DICOMweb source's metadata mapping: DICOM JSON (WADO-RS …/metadata)
// to the slide's structure (engine/src/slide/dicom_json.cpp, and dicom::layoutSeries /
// describeMetadata / fillSlideInfo in engine/src/slide/dicom_source.cpp), see README.md.
//
// Each input is a metadata answer. It goes through what DicomWebSource::open() does with one
// before it asks for frames: describeJsonSeries() (parse, describe every instance, lay the
// series out, the base instance's metadata), then each instance's pixel format for the
// transfer syntaxes a server may name, and the SlideInfo. Besides the sanitizers, it checks
// what the layout promises the tile reader (every cell names an instance and frame that
// exist, level sizes and frame grids agree, levels get smaller) and aborts when one is broken.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "fuzz_signals.h"
#include "slide/dicom_json.h"

namespace {

[[noreturn]] void broken(const char* what, int line) {
    std::fprintf(stderr, "fuzz_dicom_json.cpp:%d: broken promise: %s\n", line, what);
    std::abort();
}
#define PROMISE(cond)                                                                                                  \
    do {                                                                                                               \
        if (!(cond)) broken(#cond, __LINE__);                                                                          \
    } while (0)

const char* const kTransferSyntaxes[] = {"1.2.840.10008.1.2.4.50", "1.2.840.10008.1.2.4.90", "1.2.840.10008.1.2.1",
                                         "1.2.840.10008.1.2.5"};

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string seriesUid = "1.2.3.4";
    auto series = iris::dicom::describeJsonSeries(data, size, seriesUid, "DICOMweb series 1.2.3.4 on fuzz:1");
    if (!series.ok()) {
        PROMISE(!series.error().message().empty());
        return 0;
    }
    const auto& instances = series->instances;
    const auto& layout = series->layout;
    PROMISE(!instances.empty() && !layout.levels.empty());
    PROMISE(layout.base < instances.size());
    uint64_t previousArea = UINT64_MAX;
    for (const iris::dicom::Level& L : layout.levels) {
        PROMISE(L.width > 0 && L.height > 0 && L.frameW > 0 && L.frameH > 0);
        PROMISE(L.across == (L.width + L.frameW - 1) / L.frameW && L.down == (L.height + L.frameH - 1) / L.frameH);
        PROMISE(L.cells.size() == L.across * L.down);
        PROMISE(L.width * L.height <= previousArea);
        previousArea = L.width * L.height;
        for (const iris::dicom::Level::Cell& c : L.cells) {
            if (c.instance < 0) continue;
            PROMISE(size_t(c.instance) < instances.size());
            PROMISE(c.frame < instances[size_t(c.instance)].frames);
            PROMISE(instances[size_t(c.instance)].frameW == L.frameW);
        }
    }
    for (const auto& [name, index] : layout.associated) PROMISE(index < instances.size() && !name.empty());
    for (const auto& in : instances) PROMISE(iris::dicom::isUid(in.sopInstanceUid) && in.seriesUid == seriesUid);

    // The pixel format each transfer syntax would give, and the slide's information.
    std::vector<iris::dicom::InstanceDescription> described = instances;
    const char* ts = kTransferSyntaxes[size % (sizeof kTransferSyntaxes / sizeof *kTransferSyntaxes)];
    bool usable = true;
    for (auto& in : described) {
        const iris::Result r = iris::dicom::choosePixelFormat(in, ts);
        PROMISE(r.ok() || !r.message().empty());
        usable = usable && r.ok();
    }
    if (usable) {
        iris::SlideInfo info;
        iris::dicom::fillSlideInfo(described, layout, series->metadata, &info);
        PROMISE(info.levels.size() == layout.levels.size());
        PROMISE(info.width == int64_t(layout.levels[0].width));
        for (const auto& l : info.levels) PROMISE(l.tilesX > 0 && l.tilesY > 0 && l.downsample >= 1);
    }
    return 0;
}
