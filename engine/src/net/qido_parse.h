// The pure half of the QIDO-RS client (iris/dicomweb.h): query strings and the parsing of
// answers, without I/O, so that tests/fuzz/fuzz_qido.cpp can fuzz it. net/qido.cpp sends.
//
// Answers are DICOM JSON arrays (one object per match), read through dicom::forEachJsonObject
// (slide/dicom_json.h), the same parser as WADO-RS metadata. Every error names the answer
// (`what`: "The QIDO-RS answer of GET <url>"), the element (1-based) and the field.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "iris/dicomweb.h"

namespace iris::net::qido {

// The most results a page may ask for; a larger StudyQuery/SeriesQuery::limit is refused.
inline constexpr uint32_t kMaxLimit = 1000;

// `value` for a query parameter, as Orthanc 1.10 / DICOMweb plugin 1.7 reads it: it does NOT
// percent-decode query values (measured: PatientName=Doe%5EJane* matches nothing, Doe^Jane*
// matches), so characters a URL query may carry as they are (RFC 3986: unreserved, '*', '?')
// and '^' (which libcurl sends unchanged) go as they are; a space goes as the one-character
// wildcard '?' (which matches it, on every server); anything else is percent-encoded (correct
// for servers that decode; Orthanc then matches nothing). Control characters are refused:
// InvalidArgument naming `field`.
Expected<std::string> encodeValue(const std::string& field, const std::string& value);

// The query string (from '?') of a study search: the filters that are set, the fields asked
// for beyond the defaults, limit and offset. With a ModalitiesInStudy filter Orthanc applies
// its limit before the offset (limit=3&offset=1 gives results 2 and 3, not 2 to 4), so then
// limit is sent as offset + limit + 1: a server that counts from the offset sends more than
// needed and the client keeps the first limit + 1. InvalidArgument naming the field at fault.
Expected<std::string> studyQueryString(const dicomweb::StudyQuery& q);
Expected<std::string> seriesQueryString(const dicomweb::SeriesQuery& q);

// The studies (series) in a QIDO-RS answer, in the server's order. CorruptData naming the
// element and field: not a DICOM JSON array, an element that is not an object, no usable
// Study (Series) Instance UID, a count that is not an integer, a series of another study.
Expected<std::vector<dicomweb::Study>> parseStudies(const uint8_t* json, size_t size, const std::string& what);
Expected<std::vector<dicomweb::Series>> parseSeries(const uint8_t* json, size_t size, const std::string& studyUid,
                                                    const std::string& what);

} // namespace iris::net::qido
