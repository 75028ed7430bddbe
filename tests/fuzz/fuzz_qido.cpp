// libFuzzer target for the QIDO-RS client's own parsing (engine/src/net/qido_parse.cpp, over
// slide/dicom_json.cpp's DICOM JSON reader), see README.md.
//
// The first byte picks what the rest is: 'E' a series answer (GET …/studies/1.2.3/series),
// 'Q' search fields, one a line, made into a study query string, anything else a study answer
// (GET …/studies). Besides the sanitizers it checks what the client promises its callers and
// aborts when one is broken: every study and series has a valid UID, a series belongs to the
// study asked for, counts are -1 or more, every error has a message; a query string starts with
// '?', holds no control character or space, and ends with limit and offset.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "fuzz_signals.h"
#include "net/qido_parse.h"
#include "slide/dicom_json.h"

namespace {

[[noreturn]] void broken(const char* what, int line) {
    std::fprintf(stderr, "fuzz_qido.cpp:%d: broken promise: %s\n", line, what);
    std::abort();
}
#define PROMISE(cond)                                                                                                  \
    do {                                                                                                               \
        if (!(cond)) broken(#cond, __LINE__);                                                                          \
    } while (0)

void checkQuery(const std::string& body, uint8_t pageByte) {
    std::vector<std::string> lines(7);
    size_t field = 0;
    for (char c : body) {
        if (c == '\n' && field + 1 < lines.size())
            ++field;
        else
            lines[field] += c;
    }
    iris::dicomweb::StudyQuery q;
    q.patientName = lines[0];
    q.patientId = lines[1];
    q.accessionNumber = lines[2];
    q.studyDateFrom = lines[3];
    q.studyDateTo = lines[4];
    q.studyDescription = lines[5];
    q.modality = lines[6];
    q.limit = pageByte % 5 == 0 ? 0u : pageByte * 7u;
    q.offset = pageByte * 1000u;
    auto s = iris::net::qido::studyQueryString(q);
    if (!s.ok()) {
        PROMISE(!s.error().message().empty());
        return;
    }
    PROMISE(!s->empty() && (*s)[0] == '?');
    for (char c : *s) PROMISE(static_cast<unsigned char>(c) > 0x20 && c != 0x7f);
    PROMISE(s->find("&limit=") != std::string::npos && s->find("&offset=") != std::string::npos);
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0) return 0;
    const uint8_t* json = data + 1;
    const size_t n = size - 1;
    if (data[0] == 'Q') {
        checkQuery(std::string(reinterpret_cast<const char*>(json), n), size > 1 ? data[size - 1] : 0);
        return 0;
    }
    if (data[0] == 'E') {
        auto series = iris::net::qido::parseSeries(json, n, "1.2.3", "answer");
        if (!series.ok()) {
            PROMISE(!series.error().message().empty());
            return 0;
        }
        for (const auto& s : *series) {
            PROMISE(iris::dicom::isUid(s.seriesInstanceUid));
            PROMISE(s.studyInstanceUid == "1.2.3");
            PROMISE(s.numberOfInstances >= -1);
        }
        return 0;
    }
    auto studies = iris::net::qido::parseStudies(json, n, "answer");
    if (!studies.ok()) {
        PROMISE(!studies.error().message().empty());
        return 0;
    }
    for (const auto& s : *studies) {
        PROMISE(iris::dicom::isUid(s.studyInstanceUid));
        PROMISE(s.numberOfSeries >= -1 && s.numberOfInstances >= -1);
    }
    return 0;
}
