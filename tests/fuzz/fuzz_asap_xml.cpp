// libFuzzer target for the ASAP XML reader and writer (engine/src/annotations/asap_xml.cpp)
// and, behind it, the annotation store and GEOS triangulation: one input is one XML text.
// fuzz_annotations.h lists the promises checked.
#include "fuzz_annotations.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    fuzz_ann::check(
        std::string_view(reinterpret_cast<const char*>(data), size), "ASAP XML",
        [](std::string_view t) { return iris::readAsapXml(t); }, [](const iris::AnnotationDocument& d) { return iris::writeAsapXml(d); });
    return 0;
}
