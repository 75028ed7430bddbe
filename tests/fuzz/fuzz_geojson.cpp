// libFuzzer target for the QuPath GeoJSON reader and writer (engine/src/annotations/geojson.cpp)
// and, behind it, the annotation store and GEOS triangulation: one input is one GeoJSON text.
// fuzz_annotations.h lists the promises checked.
#include "fuzz_annotations.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    fuzz_ann::check(
        std::string_view(reinterpret_cast<const char*>(data), size), "GeoJSON",
        [](std::string_view t) { return iris::readGeoJson(t); }, [](const iris::AnnotationDocument& d) { return iris::writeGeoJson(d); });
    return 0;
}
