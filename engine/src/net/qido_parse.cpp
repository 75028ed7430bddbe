#include "net/qido_parse.h"

#include <cstdio>

#include "slide/dicom_json.h"

namespace iris::net::qido {

namespace {

using dicom::tag;

constexpr uint32_t kStudyDate = tag(0x0008, 0x0020);
constexpr uint32_t kStudyTime = tag(0x0008, 0x0030);
constexpr uint32_t kAccessionNumber = tag(0x0008, 0x0050);
constexpr uint32_t kModality = tag(0x0008, 0x0060);
constexpr uint32_t kModalitiesInStudy = tag(0x0008, 0x0061);
constexpr uint32_t kStudyDescription = tag(0x0008, 0x1030);
constexpr uint32_t kSeriesDescription = tag(0x0008, 0x103E);
constexpr uint32_t kPatientName = tag(0x0010, 0x0010);
constexpr uint32_t kPatientId = tag(0x0010, 0x0020);
constexpr uint32_t kStudyInstanceUid = tag(0x0020, 0x000D);
constexpr uint32_t kSeriesInstanceUid = tag(0x0020, 0x000E);
constexpr uint32_t kSeriesNumber = tag(0x0020, 0x0011);
constexpr uint32_t kStudySeries = tag(0x0020, 0x1206);
constexpr uint32_t kStudyInstances = tag(0x0020, 0x1208);
constexpr uint32_t kSeriesInstances = tag(0x0020, 0x1209);

// "Keyword (gggg,eeee)", for messages.
std::string fieldName(const char* keyword, uint32_t t) {
    char code[16];
    std::snprintf(code, sizeof code, "(%04X,%04X)", unsigned(t >> 16), unsigned(t & 0xffff));
    return std::string(keyword) + " " + code;
}

// Text shown in a message: at most 80 bytes, control characters as '?'.
std::string shown(const std::string& s) {
    std::string out = s.substr(0, 80);
    for (char& c : out)
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
    return out + (s.size() > 80 ? "…" : "");
}

// Reads one element's fields, the first defect named.
class Reader {
public:
    Reader(const dicom::Attributes& a, std::string where) : a_(a), where_(std::move(where)) {}
    std::string text(uint32_t t) const { return a_.text(t).value_or(""); }
    std::vector<std::string> texts(uint32_t t) const {
        std::vector<std::string> out;
        for (unsigned i = 0; i < 64; ++i) {
            std::optional<std::string> v = a_.text(t, i);
            if (!v) break;
            out.push_back(std::move(*v));
        }
        return out;
    }
    // -1 when absent; an error when present but not a non-negative integer.
    Expected<int64_t> count(const char* keyword, uint32_t t) const {
        if (const std::optional<int64_t> n = a_.integer(t)) {
            if (*n >= 0) return *n;
            return error(fieldName(keyword, t) + " is " + std::to_string(*n) + ", not a count");
        }
        if (const std::optional<std::string> s = a_.text(t); s && !s->empty())
            return error(fieldName(keyword, t) + " is '" + shown(*s) + "', not an integer");
        return int64_t(-1);
    }
    // Any integer (a Series Number may be negative); -1 when absent, an error when not an integer.
    Expected<int64_t> number(const char* keyword, uint32_t t) const {
        if (const std::optional<int64_t> n = a_.integer(t)) return *n;
        if (const std::optional<std::string> s = a_.text(t); s && !s->empty())
            return error(fieldName(keyword, t) + " is '" + shown(*s) + "', not an integer");
        return int64_t(-1);
    }
    Expected<std::string> uid(const char* keyword, uint32_t t) const {
        const std::string u = text(t);
        if (dicom::isUid(u)) return u;
        return error(u.empty() ? "has no " + fieldName(keyword, t)
                               : fieldName(keyword, t) + " is '" + shown(u) + "', not a DICOM UID");
    }
    Result error(const std::string& why) const { return Result(Status::CorruptData, where_ + " " + why); }

private:
    const dicom::Attributes& a_;
    std::string where_;
};

std::string elementName(const std::string& what, size_t index) {
    return what + ": element " + std::to_string(index + 1);
}

bool isDate(const std::string& s) {
    if (s.size() != 8) return false;
    for (char c : s)
        if (c < '0' || c > '9') return false;
    return true;
}

// "&name=value" with the value encoded, or the error naming the field.
Result appendParam(std::string& out, const char* name, const std::string& value) {
    if (value.empty()) return {};
    auto v = encodeValue(name, value);
    if (!v.ok()) return v.error();
    out += out.empty() ? '?' : '&';
    out.append(name).append(1, '=').append(*v);
    return {};
}

Result checkPage(uint32_t limit) {
    if (limit == 0 || limit > kMaxLimit) {
        return Result(Status::InvalidArgument, "A QIDO-RS page must ask for 1 to " + std::to_string(kMaxLimit) +
                                                   " results, not " + std::to_string(limit));
    }
    return {};
}

} // namespace

Expected<std::string> encodeValue(const std::string& field, const std::string& value) {
    static const char* kHex = "0123456789ABCDEF";
    std::string out;
    for (const char ch : value) {
        const auto c = static_cast<unsigned char>(ch);
        if (c < 0x20 || c == 0x7f) {
            return Result(Status::InvalidArgument, "The QIDO-RS search field " + field +
                                                       " holds a control character (byte " +
                                                       std::to_string(unsigned(c)) + ")");
        }
        const bool plain = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' ||
                           c == '.' || c == '_' || c == '~' || c == '*' || c == '?' || c == '^';
        if (plain) {
            out += ch;
        } else if (c == ' ') {
            out += '?';
        } else {
            out += '%';
            out += kHex[c >> 4];
            out += kHex[c & 15];
        }
    }
    return out;
}

Expected<std::string> studyQueryString(const dicomweb::StudyQuery& q) {
    if (Result r = checkPage(q.limit); !r.ok()) return r;
    std::string s;
    for (const auto& [name, value] : {std::pair<const char*, const std::string&>{"PatientName", q.patientName},
                                      {"PatientID", q.patientId},
                                      {"AccessionNumber", q.accessionNumber},
                                      {"StudyDescription", q.studyDescription},
                                      {"ModalitiesInStudy", q.modality}}) {
        if (Result r = appendParam(s, name, value); !r.ok()) return r;
    }
    for (const auto& [name, date] :
         {std::pair<const char*, const std::string&>{"from", q.studyDateFrom}, {"to", q.studyDateTo}}) {
        if (!date.empty() && !isDate(date)) {
            return Result(Status::InvalidArgument, std::string("The QIDO-RS search's StudyDate ") + name + " '" +
                                                       shown(date) + "' is not a date as DICOM writes it (YYYYMMDD)");
        }
    }
    if (!q.studyDateFrom.empty() && !q.studyDateTo.empty() && q.studyDateFrom > q.studyDateTo) {
        return Result(Status::InvalidArgument, "The QIDO-RS search's StudyDate range " + q.studyDateFrom + "-" +
                                                   q.studyDateTo + " ends before it starts");
    }
    if (!q.studyDateFrom.empty() || !q.studyDateTo.empty()) {
        // A range "from-to"; an open end is left empty (PS3.4 C.2.2.2.5).
        s += s.empty() ? '?' : '&';
        s.append("StudyDate=").append(q.studyDateFrom).append(1, '-').append(q.studyDateTo);
    }
    // Fields a server need not return by default (PS3.18 Table 10.6.3-3 leaves them optional).
    s += (s.empty() ? "?" : "&") +
         std::string("includefield=00081030&includefield=00080061&includefield=00201206&includefield=00201208");
    const uint64_t limit = q.modality.empty() ? uint64_t(q.limit) + 1 : uint64_t(q.offset) + q.limit + 1;
    s += "&limit=" + std::to_string(limit) + "&offset=" + std::to_string(q.offset);
    return s;
}

Expected<std::string> seriesQueryString(const dicomweb::SeriesQuery& q) {
    if (Result r = checkPage(q.limit); !r.ok()) return r;
    std::string s;
    if (Result r = appendParam(s, "Modality", q.modality); !r.ok()) return r;
    s += (s.empty() ? "?" : "&") + std::string("includefield=0008103E&includefield=00200011&includefield=00201209");
    s += "&limit=" + std::to_string(uint64_t(q.limit) + 1) + "&offset=" + std::to_string(q.offset);
    return s;
}

Expected<std::vector<dicomweb::Study>> parseStudies(const uint8_t* json, size_t size, const std::string& what) {
    std::vector<dicomweb::Study> out;
    const Result r = dicom::forEachJsonObject(json, size, what, [&](size_t i, const dicom::Attributes& a) -> Result {
        const Reader f(a, elementName(what, i));
        dicomweb::Study s;
        auto uid = f.uid("StudyInstanceUID", kStudyInstanceUid);
        if (!uid.ok()) return uid.error();
        s.studyInstanceUid = std::move(*uid);
        s.patientName = f.text(kPatientName);
        s.patientId = f.text(kPatientId);
        s.accessionNumber = f.text(kAccessionNumber);
        s.studyDate = f.text(kStudyDate);
        s.studyTime = f.text(kStudyTime);
        s.studyDescription = f.text(kStudyDescription);
        s.modalities = f.texts(kModalitiesInStudy);
        auto series = f.count("NumberOfStudyRelatedSeries", kStudySeries);
        if (!series.ok()) return series.error();
        auto instances = f.count("NumberOfStudyRelatedInstances", kStudyInstances);
        if (!instances.ok()) return instances.error();
        s.numberOfSeries = *series;
        s.numberOfInstances = *instances;
        out.push_back(std::move(s));
        return {};
    });
    if (!r.ok()) return r;
    return out;
}

Expected<std::vector<dicomweb::Series>> parseSeries(const uint8_t* json, size_t size, const std::string& studyUid,
                                                    const std::string& what) {
    std::vector<dicomweb::Series> out;
    const Result r = dicom::forEachJsonObject(json, size, what, [&](size_t i, const dicom::Attributes& a) -> Result {
        const Reader f(a, elementName(what, i));
        dicomweb::Series s;
        auto uid = f.uid("SeriesInstanceUID", kSeriesInstanceUid);
        if (!uid.ok()) return uid.error();
        s.seriesInstanceUid = std::move(*uid);
        // Optional in a series answer (the study is in the URL); where given it must be that study.
        const std::string study = f.text(kStudyInstanceUid);
        if (!study.empty() && study != studyUid) {
            return f.error("is a series of study '" + shown(study) + "', not of the study asked for (" + studyUid +
                           ")");
        }
        s.studyInstanceUid = studyUid;
        s.modality = f.text(kModality);
        s.seriesDescription = f.text(kSeriesDescription);
        auto number = f.number("SeriesNumber", kSeriesNumber);
        if (!number.ok()) return number.error();
        auto instances = f.count("NumberOfSeriesRelatedInstances", kSeriesInstances);
        if (!instances.ok()) return instances.error();
        s.seriesNumber = *number;
        s.numberOfInstances = *instances;
        out.push_back(std::move(s));
        return {};
    });
    if (!r.ok()) return r;
    return out;
}

} // namespace iris::net::qido
