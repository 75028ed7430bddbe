// QuPath GeoJSON: read with nlohmann-json's SAX parser, one feature at a time (a 100 MB file
// never becomes one DOM), and written feature by feature. docs/ANNOTATIONS.md has the mapping.
//
// Errors: a syntax error names the line and column (nlohmann reports the byte offset); a
// feature that parses but does not make sense names the feature's index and its line.
#include <nlohmann/json.hpp>

#include <cmath>
#include <iterator>
#include <map>

#include "annotations/format_support.h"

namespace iris {

using namespace ann;
using ojson = nlohmann::ordered_json; // keeps properties and measurements in file order

namespace {

// A const char* that tells the reader how far the parser has come (for progress and for the
// line of each feature): nlohmann reads input through iterators, one character at a time.
struct TrackingIter {
    using iterator_category = std::forward_iterator_tag;
    using value_type = char;
    using difference_type = std::ptrdiff_t;
    using pointer = const char*;
    using reference = const char&;
    const char* p = nullptr;
    const char** pos = nullptr;
    reference operator*() const { return *p; }
    TrackingIter& operator++() {
        *pos = ++p;
        return *this;
    }
    TrackingIter operator++(int) {
        TrackingIter t = *this;
        ++*this;
        return t;
    }
    bool operator==(const TrackingIter& o) const { return p == o.p; }
};

// Builds a DOM from SAX events (the part of the file it is given), without recursion.
class DomBuilder {
public:
    ojson root;
    bool done() const { return started_ && stack_.empty(); }
    void value(ojson v) {
        started_ = true;
        if (stack_.empty()) root = std::move(v);
        else if (stack_.back()->is_array()) stack_.back()->push_back(std::move(v));
        else (*stack_.back())[key_] = std::move(v);
    }
    void open(ojson container) {
        started_ = true;
        ojson* at;
        if (stack_.empty()) {
            root = std::move(container);
            at = &root;
        } else if (stack_.back()->is_array()) {
            stack_.back()->push_back(std::move(container));
            at = &stack_.back()->back();
        } else {
            at = &((*stack_.back())[key_] = std::move(container));
        }
        stack_.push_back(at);
    }
    void close() { stack_.pop_back(); }
    void key(std::string k) { key_ = std::move(k); }
    void reset() {
        root = nullptr;
        stack_.clear();
        started_ = false;
    }

private:
    std::vector<ojson*> stack_;
    std::string key_;
    bool started_ = false;
};

std::string typeName(const ojson& j) { return j.type_name(); }

// One feature's DOM to objects; errors without the "feature N" prefix.
class FeatureReader {
public:
    explicit FeatureReader(AnnotationDocument& doc) : doc_(doc) {}

    Result read(const ojson& f) {
        if (!f.is_object()) return fail("is a JSON " + typeName(f) + ", not an object");
        if (auto t = f.find("type"); t == f.end() || *t != "Feature")
            return fail(t == f.end() ? "has no \"type\": \"Feature\"" : "has type " + t->dump() + ", expected \"Feature\"");
        AnnotationObject o;
        const ojson* props = nullptr;
        if (auto p = f.find("properties"); p != f.end() && !p->is_null()) {
            if (!p->is_object()) return fail("\"properties\" is a " + typeName(*p) + ", not an object");
            props = &*p;
        }
        if (auto id = f.find("id"); id != f.end()) {
            if (id->is_number_unsigned() && id->get<uint64_t>() > 0) o.id = id->get<uint64_t>();
            else if (id->is_string()) o.properties.emplace_back("geojson:id", id->get<std::string>());
            else if (!id->is_null()) o.properties.emplace_back("geojson:id", id->dump());
        }
        const ojson* iris = props ? find(*props, "iris") : nullptr;
        auto g = f.find("geometry");
        if (g == f.end() || g->is_null()) return fail("has no geometry");
        if (Result r = geometry(*g, o, iris); !r.ok()) return r;
        if (props) {
            if (Result r = properties(*props, o); !r.ok()) return r;
        }
        if (std::string p = annotationProblem(o); !p.empty()) return fail(p);
        doc_.objects.push_back(std::move(o));
        return {};
    }

private:
    static Result fail(std::string what) { return Result(Status::CorruptData, std::move(what)); }
    static const ojson* find(const ojson& obj, const char* key) {
        auto it = obj.find(key);
        return it == obj.end() ? nullptr : &*it;
    }

    Result point(const ojson& c, Point2& out, const std::string& where) {
        if (!c.is_array() || c.size() < 2 || c.size() > 3)
            return fail(where + ": a position must be an array of 2 or 3 numbers, not " + c.dump().substr(0, 40));
        for (size_t i = 0; i < c.size(); ++i)
            if (!c[i].is_number()) return fail(where + ": a position holds " + typeName(c[i]) + " " + c[i].dump().substr(0, 40));
        out = {c[0].get<double>(), c[1].get<double>()};
        if (!std::isfinite(out.x) || !std::isfinite(out.y)) return fail(where + ": a coordinate is not finite");
        return {};
    }
    Result line(const ojson& c, std::vector<Point2>& out, const std::string& where, bool ring) {
        if (!c.is_array()) return fail(where + " must be an array of positions, not " + typeName(c));
        if (c.size() > kMaxVerticesPerObject)
            return fail(where + " has " + std::to_string(c.size()) + " positions, more than the " +
                        std::to_string(kMaxVerticesPerObject) + " allowed");
        out.resize(c.size());
        for (size_t i = 0; i < c.size(); ++i)
            if (Result r = point(c[i], out[i], where); !r.ok()) return r;
        if (ring) {
            if (out.size() >= 2 && out.front() == out.back()) out.pop_back(); // stored open
            if (out.size() < 3) return fail(where + " has fewer than 3 distinct positions");
        }
        return {};
    }
    Result polygon(const ojson& c, PolygonPart& part, const std::string& where) {
        if (!c.is_array() || c.empty()) return fail(where + " must be a non-empty array of rings");
        if (Result r = line(c[0], part.outer, where + " outer ring", true); !r.ok()) return r;
        for (size_t i = 1; i < c.size(); ++i) {
            part.holes.emplace_back();
            if (Result r = line(c[i], part.holes.back(), where + " hole " + std::to_string(i - 1), true); !r.ok()) return r;
        }
        return {};
    }

    Result geometry(const ojson& g, AnnotationObject& o, const ojson* iris) {
        if (!g.is_object()) return fail("\"geometry\" is a " + typeName(g) + ", not an object");
        const ojson* type = find(g, "type");
        const ojson* coords = find(g, "coordinates");
        if (!type || !type->is_string()) return fail("geometry has no \"type\"");
        const std::string t = type->get<std::string>();
        if (!coords) return fail(t + " geometry has no \"coordinates\"");
        if (t == "Point") {
            o.kind = AnnotationKind::Point;
            o.points.resize(1);
            return point(*coords, o.points[0], "Point");
        }
        if (t == "MultiPoint") {
            o.kind = AnnotationKind::Point;
            if (Result r = line(*coords, o.points, "MultiPoint", false); !r.ok()) return r;
            if (o.points.empty()) return fail("MultiPoint has no positions");
            return {};
        }
        if (t == "LineString") {
            o.kind = AnnotationKind::Polyline;
            if (Result r = line(*coords, o.points, "LineString", false); !r.ok()) return r;
            if (o.points.size() < 2) return fail("LineString has fewer than 2 positions");
            return {};
        }
        if (t == "Polygon" || t == "MultiPolygon") {
            o.kind = AnnotationKind::Polygon;
            if (t == "Polygon") {
                o.polygons.resize(1);
                if (Result r = polygon(*coords, o.polygons[0], "Polygon"); !r.ok()) return r;
            } else {
                if (!coords->is_array() || coords->empty()) return fail("MultiPolygon must be a non-empty array of polygons");
                o.polygons.resize(coords->size());
                for (size_t i = 0; i < coords->size(); ++i)
                    if (Result r = polygon((*coords)[i], o.polygons[i], "MultiPolygon polygon " + std::to_string(i)); !r.ok())
                        return r;
            }
            if (vertexCount(o) > kMaxVerticesPerObject)
                return fail(t + " has " + std::to_string(vertexCount(o)) + " vertices, more than the " +
                            std::to_string(kMaxVerticesPerObject) + " allowed");
            // Our rectangles and ellipses travel as polygons; "iris" says which, and the box.
            if (iris && iris->is_object()) {
                const ojson* shape = find(*iris, "shape");
                if (shape && (*shape == "rectangle" || *shape == "ellipse")) {
                    const ojson* box = find(*iris, "box");
                    Box2 b = annotationBounds(o);
                    if (box && box->is_array() && box->size() == 4 && std::all_of(box->begin(), box->end(), [](auto& v) { return v.is_number(); }))
                        b = {(*box)[0].get<double>(), (*box)[1].get<double>(), (*box)[2].get<double>(), (*box)[3].get<double>()};
                    o.kind = *shape == "rectangle" ? AnnotationKind::Rectangle : AnnotationKind::Ellipse;
                    o.box = b;
                    o.polygons.clear();
                }
            }
            return {};
        }
        return fail("geometry type \"" + t + "\" is not supported (Point, MultiPoint, LineString, Polygon, MultiPolygon are)");
    }

    // [r,g,b], [r,g,b,a] or QuPath's packed integer (0xAARRGGBB as a signed int, or 0xRRGGBB).
    static std::optional<Rgba8> color(const ojson& c) {
        if (c.is_array() && (c.size() == 3 || c.size() == 4)) {
            uint8_t v[4] = {0, 0, 0, 255};
            for (size_t i = 0; i < c.size(); ++i) {
                if (!c[i].is_number_integer() || c[i].get<int64_t>() < 0 || c[i].get<int64_t>() > 255) return std::nullopt;
                v[i] = uint8_t(c[i].get<int64_t>());
            }
            return Rgba8{v[0], v[1], v[2], v[3]};
        }
        if (c.is_number_integer()) {
            const uint32_t p = uint32_t(c.get<int64_t>());
            return Rgba8{uint8_t(p >> 16), uint8_t(p >> 8), uint8_t(p), 255};
        }
        return std::nullopt;
    }

    Result properties(const ojson& p, AnnotationObject& o) {
        for (auto it = p.begin(); it != p.end(); ++it) {
            const std::string& k = it.key();
            const ojson& v = it.value();
            if (k == "objectType") {
                if (!v.is_string()) return fail("\"objectType\" is a " + typeName(v) + ", not a string");
                const std::string t = v.get<std::string>();
                if (t == "annotation") o.type = AnnotationType::Annotation;
                else if (t == "detection") o.type = AnnotationType::Detection;
                else {
                    // QuPath's cell, tile, tma_core…: detections kept with their own name.
                    o.type = t == "cell" || t == "tile" ? AnnotationType::Detection : AnnotationType::Annotation;
                    o.properties.emplace_back("objectType", t);
                }
            } else if (k == "classification") {
                if (v.is_null()) continue;
                if (!v.is_object()) return fail("\"classification\" is a " + typeName(v) + ", not an object");
                const ojson* name = find(v, "name");
                if (!name || !name->is_string()) return fail("\"classification\" has no string \"name\"");
                o.className = name->get<std::string>();
                const ojson* c = find(v, "color");
                if (!c) c = find(v, "colorRGB");
                // Every class named joins the table, with its colour or the default one.
                Rgba8 col = defaultClassColor(o.className);
                if (c) {
                    auto given = color(*c);
                    if (!given) return fail("classification color " + c->dump().substr(0, 40) + " is neither [r,g,b] nor a packed integer");
                    col = *given;
                }
                classColor(o.className, col);
            } else if (k == "color") {
                auto col = color(v);
                if (!col) return fail("color " + v.dump().substr(0, 40) + " is neither [r,g,b] nor a packed integer");
                o.color = *col;
            } else if (k == "name") {
                if (!v.is_string()) return fail("\"name\" is a " + typeName(v) + ", not a string");
                o.name = v.get<std::string>();
            } else if (k == "isLocked") {
                if (!v.is_boolean()) return fail("\"isLocked\" is a " + typeName(v) + ", not a boolean");
                o.locked = v.get<bool>();
            } else if (k == "measurements") {
                if (Result r = measurements(v, o); !r.ok()) return r;
            } else if (k == "iris") {
                if (Result r = irisFields(v, o); !r.ok()) return r;
            } else {
                o.properties.emplace_back(k, v.is_string() ? v.get<std::string>() : v.dump());
            }
        }
        return {};
    }

    static Result measurements(const ojson& v, AnnotationObject& o) {
        auto number = [](const ojson& x) -> std::optional<double> {
            if (x.is_number()) return x.get<double>();
            if (x.is_null()) return NAN; // QuPath writes NaN as null (JSON has no NaN)
            return std::nullopt;
        };
        if (v.is_object()) {
            for (auto it = v.begin(); it != v.end(); ++it) {
                auto n = number(it.value());
                if (!n) return fail("measurement \"" + it.key() + "\" is a " + typeName(it.value()) + ", not a number");
                o.measurements.emplace_back(it.key(), *n);
            }
            return {};
        }
        if (v.is_array()) { // QuPath ≤ 0.3: [{"name": …, "value": …}]
            for (size_t i = 0; i < v.size(); ++i) {
                const ojson& m = v[i];
                const ojson* name = m.is_object() ? find(m, "name") : nullptr;
                const ojson* value = m.is_object() ? find(m, "value") : nullptr;
                if (!name || !name->is_string() || !value)
                    return fail("measurement " + std::to_string(i) + " is not {\"name\": string, \"value\": number}");
                auto n = number(*value);
                if (!n) return fail("measurement \"" + name->get<std::string>() + "\" is a " + typeName(*value) + ", not a number");
                o.measurements.emplace_back(name->get<std::string>(), *n);
            }
            return {};
        }
        return fail("\"measurements\" is a " + typeName(v) + ", neither an object nor an array");
    }

    static Result irisFields(const ojson& v, AnnotationObject& o) {
        if (!v.is_object()) return fail("\"iris\" is a " + typeName(v) + ", not an object");
        for (auto it = v.begin(); it != v.end(); ++it) {
            const std::string& k = it.key();
            const ojson& x = it.value();
            auto need = [&](bool ok, const char* what) { return ok ? Result() : fail("iris." + k + " is not " + what); };
            if (k == "lineWidth") {
                if (Result r = need(x.is_number(), "a number"); !r.ok()) return r;
                o.lineWidth = toFloat(x.get<double>());
            } else if (k == "fill") {
                if (Result r = need(x.is_boolean(), "a boolean"); !r.ok()) return r;
                o.fill = x.get<bool>();
            } else if (k == "fillOpacity") {
                if (Result r = need(x.is_number(), "a number"); !r.ok()) return r;
                o.fillOpacity = toFloat(x.get<double>());
            } else if (k == "visible") {
                if (Result r = need(x.is_boolean(), "a boolean"); !r.ok()) return r;
                o.visible = x.get<bool>();
            } // "shape" and "box" are the geometry's (read there); unknown keys are ignored
        }
        return {};
    }

    void classColor(const std::string& name, Rgba8 c) {
        auto [it, fresh] = seen_.emplace(name, doc_.classes.size());
        if (fresh) doc_.classes.push_back({name, c, true});
    }

    AnnotationDocument& doc_;
    std::map<std::string, size_t> seen_;

public:
    void declareClass(AnnotationClass c) {
        auto [it, fresh] = seen_.emplace(c.name, doc_.classes.size());
        if (fresh) doc_.classes.push_back(std::move(c));
        else doc_.classes[it->second] = std::move(c);
    }
};

// The SAX handler: routes events of each element of "features" (or of a top-level array) to a
// DomBuilder and converts the feature when it closes; everything else to the root's builder.
class Handler : public nlohmann::json_sax<ojson> {
public:
    Handler(std::string_view text, const char** pos, AnnotationDocument& doc, const ReadControl& control)
        : text_(text), pos_(pos), lines_(text), reader_(doc), control_(control) {}

    Result error;
    size_t features = 0;
    ojson rootMembers() const { return root_.root; }

    bool null() override { return scalar(nullptr); }
    bool boolean(bool v) override { return scalar(v); }
    bool number_integer(number_integer_t v) override { return scalar(v); }
    bool number_unsigned(number_unsigned_t v) override { return scalar(v); }
    bool number_float(number_float_t v, const string_t&) override { return scalar(v); }
    bool string(string_t& v) override { return scalar(std::move(v)); }
    bool binary(binary_t&) override { return scalar(nullptr); }
    bool start_object(std::size_t) override { return open(ojson::object()); }
    bool start_array(std::size_t) override { return open(ojson::array()); }
    bool end_object() override { return close(); }
    bool end_array() override { return close(); }
    bool key(string_t& k) override {
        if (depth_ == 1 && !inFeature() && !featuresOpen_ && k == "features" && rootIsObject_) {
            featuresKey_ = true; // its array is not built: its elements are, one at a time
            return true;
        }
        (inFeature() ? feature_ : root_).key(std::move(k));
        return true;
    }
    bool parse_error(std::size_t position, const std::string&, const nlohmann::detail::exception& ex) override {
        std::string what = ex.what();
        // nlohmann's text: "[json.exception.parse_error.101] parse error at line 1, column 5: …"
        // or, for a number out of range, "[json.exception.out_of_range.406] number overflow …".
        if (auto c = what.find(": "); c != std::string::npos) what = what.substr(c + 2);
        else if (auto b = what.find("] "); what.starts_with("[json.exception") && b != std::string::npos) what = what.substr(b + 2);
        const size_t at = position > 0 ? position - 1 : 0;
        error = Result(Status::CorruptData, "GeoJSON line " + std::to_string(lines_.line(at)) + ", column " +
                                                std::to_string(lines_.column(at)) + ": " + what);
        return false;
    }

private:
    bool inFeature() const { return featureDepth_ >= 0; }
    size_t offset() const { return size_t(*pos_ - text_.data()); }

    bool begin() {
        // A value starting directly inside the features array: a new feature.
        if (featuresOpen_ && !inFeature() && depth_ == featuresDepth_) {
            featureDepth_ = depth_;
            featureStart_ = offset();
            feature_.reset();
        }
        return true;
    }
    bool scalar(ojson v) {
        if (featuresKey_) return fail("\"features\" is a " + typeName(v) + ", not an array");
        begin();
        (inFeature() ? feature_ : root_).value(std::move(v));
        if (inFeature() && depth_ == featureDepth_) return finishFeature();
        return true;
    }
    bool open(ojson container) {
        if (featuresKey_) {
            featuresKey_ = false;
            if (!container.is_array()) return fail("\"features\" is an object, not an array");
            ++depth_;
            featuresOpen_ = true;
            featuresDepth_ = depth_;
            return true;
        }
        if (depth_ == 0) {
            rootIsObject_ = container.is_object();
            if (!rootIsObject_) { // a bare array of features
                ++depth_;
                featuresOpen_ = true;
                featuresDepth_ = depth_;
                rootIsArray_ = true;
                return true;
            }
        }
        begin();
        if (++depth_ > kMaxJsonDepth) return fail("nesting deeper than " + std::to_string(kMaxJsonDepth) + " levels");
        (inFeature() ? feature_ : root_).open(std::move(container));
        return true;
    }
    bool close() {
        --depth_;
        if (featuresOpen_ && depth_ + 1 == featuresDepth_) { // the features array itself closes
            featuresOpen_ = false;
            return true;
        }
        (inFeature() ? feature_ : root_).close();
        if (inFeature() && depth_ == featureDepth_) return finishFeature();
        return true;
    }
    bool finishFeature() {
        featureDepth_ = -1;
        Result r = reader_.read(feature_.root);
        if (!r.ok()) {
            const ojson* name = feature_.root.is_object() && feature_.root.contains("properties") &&
                                        feature_.root["properties"].is_object() && feature_.root["properties"].contains("name")
                                    ? &feature_.root["properties"]["name"]
                                    : nullptr;
            error = Result(r.status(), "GeoJSON feature " + std::to_string(features) + " (line " +
                                           std::to_string(lines_.line(featureStart_ > 0 ? featureStart_ - 1 : 0)) + ")" +
                                           (name && name->is_string() ? " \"" + name->get<std::string>() + "\"" : "") +
                                           ": " + r.message());
            return false;
        }
        feature_.reset();
        ++features;
        if (features % 1024 == 0) {
            if (cancelled(control_)) {
                error = Result(Status::Cancelled, "reading GeoJSON was cancelled");
                return false;
            }
            if (control_.progress) control_.progress(offset(), text_.size());
        }
        return true;
    }
    bool fail(std::string what) {
        const size_t at = offset() > 0 ? offset() - 1 : 0;
        error = Result(Status::CorruptData, "GeoJSON line " + std::to_string(lines_.line(at)) + ": " + what);
        return false;
    }

    std::string_view text_;
    const char** pos_;
    LineIndex lines_;
    FeatureReader reader_;
    const ReadControl& control_;
    DomBuilder root_, feature_;
    int depth_ = 0;
    int featuresDepth_ = -1;
    int featureDepth_ = -1;
    size_t featureStart_ = 0;
    bool featuresKey_ = false, featuresOpen_ = false, rootIsObject_ = false, rootIsArray_ = false;

public:
    bool rootWasArray() const { return rootIsArray_; }
    FeatureReader& reader() { return reader_; }
};

bool isReserved(const std::string& k) {
    return k == "objectType" || k == "name" || k == "classification" || k == "color" || k == "isLocked" ||
           k == "measurements" || k == "iris";
}

ojson colorJson(Rgba8 c) {
    ojson a = ojson::array({c.r, c.g, c.b});
    if (c.a != 255) a.push_back(c.a);
    return a;
}

ojson ringJson(const std::vector<Point2>& ring) {
    ojson a = ojson::array();
    for (Point2 p : ring) a.push_back(ojson::array({p.x, p.y}));
    if (!ring.empty()) a.push_back(ojson::array({ring.front().x, ring.front().y})); // GeoJSON closes rings
    return a;
}

ojson partJson(const PolygonPart& part) {
    ojson rings = ojson::array({ringJson(part.outer)});
    for (const auto& h : part.holes) rings.push_back(ringJson(h));
    return rings;
}

} // namespace

std::optional<AnnotationFormat> detectAnnotationFormat(std::string_view text) noexcept {
    size_t i = 0;
    if (text.substr(0, 3) == "\xEF\xBB\xBF") i = 3; // UTF-8 byte-order mark
    while (i < text.size() && (text[i] == ' ' || text[i] == '\t' || text[i] == '\r' || text[i] == '\n')) ++i;
    if (i == text.size()) return std::nullopt;
    if (text[i] == '{' || text[i] == '[') return AnnotationFormat::GeoJson;
    if (text[i] == '<') return AnnotationFormat::AsapXml;
    return std::nullopt;
}

Expected<AnnotationDocument> readGeoJson(std::string_view text, const ReadControl& control) {
    AnnotationDocument doc;
    const char* pos = text.data();
    Handler h(text, &pos, doc, control);
    TrackingIter first{text.data(), &pos}, last{text.data() + text.size(), &pos};
    const bool ok = ojson::sax_parse(first, last, &h, nlohmann::detail::input_format_t::json, true);
    if (!ok) {
        if (!h.error.ok()) return h.error;
        return Result(Status::CorruptData, "GeoJSON: the parser stopped without saying why");
    }
    if (!h.rootWasArray()) {
        const ojson root = h.rootMembers();
        const ojson* type = root.is_object() && root.contains("type") ? &root["type"] : nullptr;
        if (type && *type == "Feature") { // a single feature
            if (Result r = h.reader().read(root); !r.ok()) return Result(r.status(), "GeoJSON feature 0 (line 1): " + r.message());
        } else if (!type || *type != "FeatureCollection") {
            return Result(Status::UnsupportedFormat, std::string("GeoJSON: the top level is ") +
                                                         (!root.is_object() ? "a JSON " + typeName(root)
                                                          : type            ? "of type " + type->dump()
                                                                            : "an object without \"type\"") +
                                                         ", not a FeatureCollection, a Feature or an array of features");
        }
        // Our class table (classes without objects, class visibility): optional, QuPath ignores it.
        if (root.is_object() && root.contains("iris:classes") && root["iris:classes"].is_array()) {
            for (const auto& c : root["iris:classes"]) {
                if (!c.is_object() || !c.contains("name") || !c["name"].is_string()) continue;
                AnnotationClass k{c["name"].get<std::string>(), defaultClassColor(c["name"].get<std::string>()), true};
                if (c.contains("color") && c["color"].is_array() && (c["color"].size() == 3 || c["color"].size() == 4)) {
                    uint8_t v[4] = {0, 0, 0, 255};
                    for (size_t i = 0; i < c["color"].size(); ++i)
                        if (c["color"][i].is_number_integer()) v[i] = uint8_t(std::clamp<int64_t>(c["color"][i].get<int64_t>(), 0, 255));
                    k.color = {v[0], v[1], v[2], v[3]};
                }
                if (c.contains("visible") && c["visible"].is_boolean()) k.visible = c["visible"].get<bool>();
                h.reader().declareClass(std::move(k));
            }
        }
    }
    // Classes by name: the order features happened to name them in is no property of the file.
    std::sort(doc.classes.begin(), doc.classes.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
    if (control.progress) control.progress(text.size(), text.size());
    return doc;
}

std::string writeGeoJson(const AnnotationDocument& doc) {
    std::map<std::string, AnnotationClass, std::less<>> classes;
    for (const auto& c : doc.classes) classes[c.name] = c;
    std::string out = "{\"type\":\"FeatureCollection\",";
    if (!doc.classes.empty()) {
        ojson cl = ojson::array();
        for (const auto& [name, c] : classes) cl.push_back({{"name", c.name}, {"color", colorJson(c.color)}, {"visible", c.visible}});
        out += "\"iris:classes\":" + cl.dump(-1, ' ', false, ojson::error_handler_t::replace) + ",";
    }
    out += "\"features\":[";
    bool first = true;
    for (const AnnotationObject& o : doc.objects) {
        ojson f;
        f["type"] = "Feature";
        // Our id when the object has one; else the file's own (QuPath's UUID), which the reader
        // kept as the property "geojson:id" (the first such property: it is not written again).
        const std::pair<std::string, std::string>* fileId = nullptr;
        if (o.id) f["id"] = o.id;
        else
            for (const auto& kv : o.properties)
                if (kv.first == "geojson:id") {
                    f["id"] = kv.second;
                    fileId = &kv;
                    break;
                }
        ojson g;
        switch (o.kind) {
        case AnnotationKind::Point:
            if (o.points.size() == 1) g = {{"type", "Point"}, {"coordinates", {o.points[0].x, o.points[0].y}}};
            else {
                ojson c = ojson::array();
                for (Point2 p : o.points) c.push_back(ojson::array({p.x, p.y}));
                g = {{"type", "MultiPoint"}, {"coordinates", c}};
            }
            break;
        case AnnotationKind::Polyline: {
            ojson c = ojson::array();
            for (Point2 p : o.points) c.push_back(ojson::array({p.x, p.y}));
            g = {{"type", "LineString"}, {"coordinates", c}};
            break;
        }
        case AnnotationKind::Polygon:
            if (o.polygons.size() == 1) g = {{"type", "Polygon"}, {"coordinates", partJson(o.polygons[0])}};
            else {
                ojson c = ojson::array();
                for (const auto& part : o.polygons) c.push_back(partJson(part));
                g = {{"type", "MultiPolygon"}, {"coordinates", c}};
            }
            break;
        case AnnotationKind::Rectangle:
        case AnnotationKind::Ellipse: {
            // QuPath stores these as polygons too; the ellipse at a vertex count fine enough
            // for a 4000-pixel radius at 1:1, the box kept exactly in "iris".
            const Box2& b = o.box;
            PolygonPart part;
            part.outer = o.kind == AnnotationKind::Rectangle
                             ? std::vector<Point2>{{b.minX, b.minY}, {b.maxX, b.minY}, {b.maxX, b.maxY}, {b.minX, b.maxY}}
                             : flattenEllipse(b, std::min(256, ellipseVertexCount(b.width() / 2, b.height() / 2, 1)));
            g = {{"type", "Polygon"}, {"coordinates", partJson(part)}};
            break;
        }
        }
        f["geometry"] = std::move(g);
        ojson p = ojson::object();
        bool typeWritten = false;
        for (const auto& [k, v] : o.properties)
            if (k == "objectType") p["objectType"] = v, typeWritten = true;
        if (!typeWritten) p["objectType"] = o.type == AnnotationType::Detection ? "detection" : "annotation";
        if (!o.name.empty()) p["name"] = o.name;
        if (!o.className.empty()) {
            auto it = classes.find(o.className);
            const Rgba8 c = it != classes.end() ? it->second.color : defaultClassColor(o.className);
            p["classification"] = {{"name", o.className}, {"color", colorJson(c)}};
        }
        if (o.color) p["color"] = colorJson(*o.color);
        if (o.locked) p["isLocked"] = true;
        if (!o.measurements.empty()) {
            ojson m = ojson::object();
            for (const auto& [k, v] : o.measurements) m[k] = std::isfinite(v) ? ojson(v) : ojson(nullptr);
            p["measurements"] = std::move(m);
        }
        // Free-form properties, except those whose names the format itself uses (a host's
        // property called "name" would replace the object's name on the way back in).
        for (const auto& kv : o.properties)
            if (&kv != fileId && !isReserved(kv.first)) p[kv.first] = kv.second;
        // Our drawing fields, only where they differ from the defaults (a million detections
        // should not carry them a million times).
        const AnnotationObject defaults;
        ojson iris = ojson::object();
        if (o.lineWidth != defaults.lineWidth) iris["lineWidth"] = o.lineWidth;
        if (o.fill != defaults.fill) iris["fill"] = o.fill;
        if (o.fillOpacity != defaults.fillOpacity) iris["fillOpacity"] = o.fillOpacity;
        if (o.visible != defaults.visible) iris["visible"] = o.visible;
        if (o.kind == AnnotationKind::Rectangle || o.kind == AnnotationKind::Ellipse) {
            iris["shape"] = o.kind == AnnotationKind::Rectangle ? "rectangle" : "ellipse";
            iris["box"] = {o.box.minX, o.box.minY, o.box.maxX, o.box.maxY};
        }
        if (!iris.empty()) p["iris"] = std::move(iris);
        f["properties"] = std::move(p);
        if (!first) out += ',';
        first = false;
        out += '\n';
        out += f.dump(-1, ' ', false, ojson::error_handler_t::replace); // invalid UTF-8 → U+FFFD
    }
    out += "\n]}\n";
    return out;
}

} // namespace iris
