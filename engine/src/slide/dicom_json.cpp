#include "slide/dicom_json.h"

#include <cmath>
#include <cstdio>
#include <set>

#include <nlohmann/json.hpp>

#include <dcmtk/config/osconfig.h> // first, as DCMTK asks

#include <dcmtk/ofstd/ofstd.h>

namespace iris::dicom {

namespace {

using Json = nlohmann::json;

// The value representations whose values are not text or numbers.
bool binaryOrSequence(const std::string& vr) {
    static const std::set<std::string> kVrs = {"SQ", "OB", "OD", "OF", "OL", "OV", "OW", "UN"};
    return kVrs.count(vr) != 0;
}

// The deepest nesting of arrays and objects in `text`, outside strings (stops counting past `limit`).
int nesting(const uint8_t* p, size_t n, int limit) {
    int depth = 0, deepest = 0;
    bool inString = false, escaped = false;
    for (size_t i = 0; i < n; ++i) {
        const char c = char(p[i]);
        if (inString) {
            if (escaped)
                escaped = false;
            else if (c == '\\')
                escaped = true;
            else if (c == '"')
                inString = false;
            continue;
        }
        if (c == '"') {
            inString = true;
        } else if (c == '[' || c == '{') {
            deepest = std::max(deepest, ++depth);
            if (deepest > limit) return deepest;
        } else if (c == ']' || c == '}') {
            --depth;
        }
    }
    return deepest;
}

class JsonAttributes final : public Attributes {
public:
    explicit JsonAttributes(const Json& object) : o_(object) {}

    std::optional<std::string> text(uint32_t t, unsigned index) const override {
        const Json* v = value(t, index);
        if (!v) return std::nullopt;
        return asText(*v, vrOf(t));
    }
    std::optional<int64_t> integer(uint32_t t, unsigned index) const override {
        const Json* v = value(t, index);
        if (!v) return std::nullopt;
        if (v->is_number_integer()) {
            if (v->is_number_unsigned() && v->get<uint64_t>() > uint64_t(INT64_MAX)) return std::nullopt;
            return v->get<int64_t>();
        }
        if (v->is_number_float()) {
            const double d = v->get<double>();
            if (!std::isfinite(d) || d != std::floor(d) || std::abs(d) > 9.0e15) return std::nullopt;
            return int64_t(d);
        }
        if (v->is_string()) return parseInteger(v->get_ref<const std::string&>());
        return std::nullopt;
    }
    std::optional<double> real(uint32_t t, unsigned index) const override {
        const Json* v = value(t, index);
        if (!v) return std::nullopt;
        if (v->is_number()) {
            const double d = v->get<double>();
            return std::isfinite(d) ? std::optional<double>(d) : std::nullopt;
        }
        if (v->is_string()) return parseReal(v->get_ref<const std::string&>());
        return std::nullopt;
    }
    size_t items(uint32_t sequence) const override {
        const Json* values = valuesOf(sequence);
        if (!values) return 0;
        size_t n = 0;
        while (n < values->size() && (*values)[n].is_object()) ++n;
        return n;
    }
    std::unique_ptr<Attributes> item(uint32_t sequence, size_t i) const override {
        const Json* values = valuesOf(sequence);
        if (!values || i >= values->size() || !(*values)[i].is_object()) return nullptr;
        return std::make_unique<JsonAttributes>((*values)[i]);
    }
    std::optional<std::vector<uint8_t>> binary(uint32_t t, std::string* uri) const override {
        const Json* a = attribute(t);
        if (!a) return std::nullopt;
        if (const auto it = a->find("InlineBinary"); it != a->end() && it->is_string()) {
            unsigned char* bytes = nullptr;
            const size_t n = OFStandard::decodeBase64(OFString(it->get_ref<const std::string&>().c_str()), bytes);
            std::vector<uint8_t> out(bytes, bytes + n);
            delete[] bytes;
            return out;
        }
        if (const auto it = a->find("BulkDataURI"); it != a->end() && it->is_string() && uri) {
            *uri = it->get_ref<const std::string&>();
        }
        return std::nullopt;
    }
    void forEachText(const std::function<void(uint32_t, const std::string&)>& f) const override {
        for (const auto& [key, a] : o_.items()) {
            const std::optional<uint32_t> t = tagOf(key);
            if (!t || !a.is_object()) continue;
            const std::string vr = vrOf(*t);
            if (vr.empty() || binaryOrSequence(vr)) continue;
            const auto values = a.find("Value");
            if (values == a.end() || !values->is_array() || values->empty()) { // present, empty
                f(*t, std::string());
                continue;
            }
            std::string joined;
            bool ok = true;
            for (size_t i = 0; i < values->size() && ok; ++i) {
                const std::optional<std::string> s = asText((*values)[i], vr);
                ok = s.has_value();
                if (ok) joined += (i ? "\\" : "") + *s;
            }
            if (ok) f(*t, joined);
        }
    }

private:
    static std::optional<uint32_t> tagOf(const std::string& key) {
        if (key.size() != 8) return std::nullopt;
        uint32_t t = 0;
        for (char c : key) {
            const int d = c >= '0' && c <= '9'   ? c - '0'
                          : c >= 'A' && c <= 'F' ? c - 'A' + 10
                          : c >= 'a' && c <= 'f' ? c - 'a' + 10
                                                 : -1;
            if (d < 0) return std::nullopt;
            t = (t << 4) | uint32_t(d);
        }
        return t;
    }
    const Json* attribute(uint32_t t) const {
        char key[9];
        std::snprintf(key, sizeof key, "%08X", unsigned(t));
        const auto it = o_.find(key);
        return it != o_.end() && it->is_object() ? &*it : nullptr;
    }
    std::string vrOf(uint32_t t) const {
        const Json* a = attribute(t);
        if (!a) return {};
        const auto it = a->find("vr");
        return it != a->end() && it->is_string() ? it->get<std::string>() : std::string();
    }
    const Json* valuesOf(uint32_t t) const {
        const Json* a = attribute(t);
        if (!a) return nullptr;
        const auto it = a->find("Value");
        return it != a->end() && it->is_array() ? &*it : nullptr;
    }
    const Json* value(uint32_t t, unsigned index) const {
        const Json* values = valuesOf(t);
        if (!values || index >= values->size() || (*values)[index].is_null()) return nullptr;
        return &(*values)[index];
    }
    // One value as DICOM text: strings as they are, numbers as JSON writes them, a person name's
    // alphabetic (=ideographic=phonetic) groups, an attribute tag as "(gggg,eeee)" like DCMTK.
    static std::optional<std::string> asText(const Json& v, const std::string& vr) {
        if (v.is_string()) {
            const std::string& s = v.get_ref<const std::string&>();
            if (vr == "AT") {
                if (const std::optional<uint32_t> t = tagOf(s)) {
                    char out[16];
                    std::snprintf(out, sizeof out, "(%04x,%04x)", unsigned(*t >> 16), unsigned(*t & 0xffff));
                    return std::string(out);
                }
            }
            return s;
        }
        if (v.is_number()) return v.dump();
        if (v.is_object() && vr == "PN") {
            std::string groups[3];
            int last = -1;
            const char* names[3] = {"Alphabetic", "Ideographic", "Phonetic"};
            for (int k = 0; k < 3; ++k) {
                const auto it = v.find(names[k]);
                if (it == v.end() || !it->is_string()) continue;
                groups[k] = it->get<std::string>();
                last = k;
            }
            std::string name = groups[0];
            for (int k = 1; k <= last; ++k) name += "=" + groups[k];
            return name;
        }
        return std::nullopt;
    }

    const Json& o_;
};

// `json` parsed as a JSON array, or CorruptData "<what> <why>".
Expected<Json> parseArray(const uint8_t* json, size_t size, const std::string& what, const std::string& elements) {
    const auto corrupt = [&](const std::string& why) { return Result(Status::CorruptData, what + " " + why); };
    if (!json || size == 0) return corrupt("is empty");
    if (nesting(json, size, kMaxJsonDepth) > kMaxJsonDepth) {
        return corrupt("is nested deeper than " + std::to_string(kMaxJsonDepth) + " levels");
    }
    Json doc = Json::parse(json, json + size, nullptr, /*allow_exceptions=*/false);
    if (doc.is_discarded()) return corrupt("is not valid JSON");
    if (!doc.is_array()) return corrupt("is not a JSON array of " + elements + " (DICOM JSON)");
    return doc;
}

} // namespace

Result forEachJsonObject(const uint8_t* json, size_t size, const std::string& what,
                         const std::function<Result(size_t index, const Attributes& object)>& each) {
    auto doc = parseArray(json, size, what, "objects");
    if (!doc.ok()) return doc.error();
    for (size_t i = 0; i < doc->size(); ++i) {
        if (!(*doc)[i].is_object()) {
            return Result(Status::CorruptData,
                          what + " element " + std::to_string(i + 1) + " is not a DICOM JSON object");
        }
        if (Result r = each(i, JsonAttributes((*doc)[i])); !r.ok()) return r;
    }
    return {};
}

bool isUid(const std::string& uid) {
    if (uid.empty() || uid.size() > 64) return false;
    for (char c : uid)
        if (!(c == '.' || (c >= '0' && c <= '9'))) return false;
    return true;
}

Expected<JsonSeries> describeJsonSeries(const uint8_t* json, size_t size, const std::string& seriesUid,
                                        const std::string& seriesName) {
    const auto corrupt = [&](const std::string& why) {
        return Result(Status::CorruptData, "Cannot open " + seriesName + ": its metadata " + why);
    };
    auto parsed = parseArray(json, size, "Cannot open " + seriesName + ": its metadata", "instances");
    if (!parsed.ok()) return parsed.error();
    const Json& doc = *parsed;
    JsonSeries out;
    std::vector<size_t> element; // the JSON element of each instance
    std::set<std::string> seen;
    for (size_t i = 0; i < doc.size(); ++i) {
        if (!doc[i].is_object()) return corrupt("element " + std::to_string(i + 1) + " is not a DICOM JSON object");
        const JsonAttributes attributes(doc[i]);
        const Attributes& a = attributes; // the base class has the default arguments
        if (a.text(tag(0x0008, 0x0016)).value_or("") != kWsiSopClass) {
            ++out.otherInstances;
            continue;
        }
        const std::string sop = a.text(tag(0x0008, 0x0018)).value_or("");
        if (!isUid(sop)) {
            return corrupt("element " + std::to_string(i + 1) + " has no usable SOP Instance UID ('" +
                           sop.substr(0, 80) + "')");
        }
        if (!seen.insert(sop).second) continue; // listed twice
        auto in = describeInstance(a, "DICOMweb instance " + sop);
        if (!in.ok()) return in.error();
        if (in->seriesUid != seriesUid) {
            return corrupt("lists instance " + sop + " of series '" + in->seriesUid.substr(0, 80) +
                           "', not of the series asked for");
        }
        out.instances.push_back(std::move(*in));
        element.push_back(i);
    }
    if (out.instances.empty()) {
        return Result(Status::UnsupportedFormat, "Cannot open " + seriesName + ": none of its " +
                                                     std::to_string(doc.size()) +
                                                     " instances is a VL Whole Slide Microscopy Image");
    }
    if (Result r = layoutSeries(out.instances, seriesName, &out.layout); !r.ok()) return r;
    out.metadata = describeMetadata(JsonAttributes(doc[element[out.layout.base]]));
    return out;
}

} // namespace iris::dicom
