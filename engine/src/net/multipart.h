// multipart/related bodies (RFC 2387, in RFC 2046's multipart syntax), the way DICOMweb's
// WADO-RS answers frames and bulk data (PS3.18 8.7.1.2), and the media types that describe them
// (RFC 9110: type/subtype plus parameters, quoted or not).
//
// Written like ife::Parser (slide/iris_file.cpp): every read is bounds-checked and each error
// says what is wrong and where (which part, which byte). Parts point into the body they came
// from; nothing is copied. Pure functions, no state: fuzzed by tests/fuzz/fuzz_multipart.cpp.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "iris/types.h"

namespace iris::net {

// "multipart/related; type=\"application/octet-stream\"; boundary=x": the type and the
// parameters' names lower-cased, values unquoted (backslash escapes undone), in their order.
struct MediaType {
    std::string type;
    std::vector<std::pair<std::string, std::string>> params;
    // The value of parameter `name` (lower case), or null.
    const std::string* param(std::string_view name) const;
};
// CorruptData naming the defect when `text` is not a media type.
Expected<MediaType> parseMediaType(std::string_view text);

struct Part {
    std::string contentType;       // the part's Content-Type header; empty when it has none
    std::string contentLocation;   // its Content-Location header; empty when it has none
    const uint8_t* data = nullptr; // the part's body, inside the buffer given to parseMultipart
    size_t size = 0;
};

// The parts of a multipart body, given the Content-Type of the message that carried it (any
// multipart/* type with a boundary). A body that is cut short (no closing delimiter, a part
// shorter than its Content-Length), malformed headers or a missing boundary give CorruptData.
// A part's own Content-Length, where given, must be followed by the delimiter exactly.
Expected<std::vector<Part>> parseMultipart(std::string_view contentType, const uint8_t* body, size_t size);

// The frame number a part's Content-Location names (…/frames/<n>, n ≥ 1), or 0 when it names
// none (no Content-Location, or one of another form, such as the request's frame list).
uint32_t locatedFrame(std::string_view contentLocation);

// Whether the parts of a WADO-RS frames answer hold the frames asked for (`frames`, numbered
// from 1, in the order of the request's list …/frames/<a>,<b>,…): one part per frame, in that
// order (PS3.18 8.7.3.5.2), and a part whose Content-Location names a frame names its own. A
// server that sends more or fewer parts, or parts in another order, would put frames in the
// wrong tiles: CorruptData naming the defect instead.
Result checkFrameParts(const std::vector<Part>& parts, const std::vector<uint32_t>& frames);

} // namespace iris::net
