// DICOM JSON (PS3.18 Annex F: {"GGGGEEEE": {"vr": …, "Value": […]}}) as dicom::Attributes, and
// a series' WADO-RS metadata (a JSON array of its instances) described for the mapping in
// slide/dicom_source.h. Parsed with nlohmann-json without exceptions; every value is checked
// for its JSON type before use, and nesting deeper than kMaxJsonDepth is refused before
// parsing. Pure (no I/O): fuzzed by tests/fuzz/fuzz_dicom_json.cpp.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "slide/dicom_source.h"

namespace iris::dicom {

inline constexpr int kMaxJsonDepth = 64;

struct JsonSeries {
    std::vector<InstanceDescription> instances; // the whole-slide instances, in the server's order
    SeriesLayout layout;
    SeriesMetadata metadata;   // the base instance's
    size_t otherInstances = 0; // instances of other SOP classes (annotations, …), left out
};

// The series in `json` (WADO-RS …/series/<uid>/metadata). `seriesUid` is the series asked for
// (an instance of another series is an error); `seriesName` names it in messages. Instances
// are named "DICOMweb instance <SOP Instance UID>". Their transfer syntax is left empty (the
// metadata does not carry it). Errors: CorruptData for JSON that is not a DICOM JSON array or
// an instance the mapping refuses; UnsupportedFormat when no instance is a whole-slide image.
Expected<JsonSeries> describeJsonSeries(const uint8_t* json, size_t size, const std::string& seriesUid,
                                        const std::string& seriesName);

// `json` parsed as a DICOM JSON array of objects (a QIDO-RS answer: one object per match), each
// object handed to `each` as Attributes, in order, with its 0-based index; stops at the first
// error `each` returns and returns it. CorruptData "<what> is empty / is nested deeper than … /
// is not valid JSON / is not a JSON array / element N is not a DICOM JSON object" otherwise.
// The same checks as describeJsonSeries (nesting limit, no exceptions), shared rather than copied.
Result forEachJsonObject(const uint8_t* json, size_t size, const std::string& what,
                         const std::function<Result(size_t index, const Attributes& object)>& each);

// Whether `uid` is a DICOM UID (digits and dots, 1 to 64 characters): one that can go into a URL.
bool isUid(const std::string& uid);

} // namespace iris::dicom
