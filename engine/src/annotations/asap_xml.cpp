// ASAP XML (the CAMELYON annotation format) with pugixml. docs/ANNOTATIONS.md has the mapping.
//
//   <ASAP_Annotations>
//     <Annotations>
//       <Annotation Name="Annotation 0" Type="Polygon" PartOfGroup="Tumor" Color="#F4FA58">
//         <Coordinates><Coordinate Order="0" X="1.5" Y="2"/>…</Coordinates>
//       </Annotation>
//     </Annotations>
//     <AnnotationGroups><Group Name="Tumor" PartOfGroup="None" Color="#64FE2E"/></AnnotationGroups>
//   </ASAP_Annotations>
//
// What ASAP cannot say (holes, several polygon parts, ellipses, detections, properties,
// measurements, fill, line width) travels in attributes and elements whose names start with
// "Iris", which ASAP ignores: the first <Coordinates> is always the outline ASAP draws.
#include <pugixml.hpp>

#include <algorithm>
#include <map>
#include <sstream>

#include "annotations/format_support.h"

namespace iris {

using namespace ann;

namespace {

class Reader {
public:
    Reader(std::string_view text, const ReadControl& control) : text_(text), lines_(text), control_(control) {}

    Expected<AnnotationDocument> read() {
        pugi::xml_document xml;
        const pugi::xml_parse_result parsed =
            xml.load_buffer(text_.data(), text_.size(), pugi::parse_default | pugi::parse_ws_pcdata_single);
        if (!parsed) {
            const size_t at = size_t(std::max<ptrdiff_t>(0, parsed.offset));
            return Result(Status::CorruptData, "ASAP XML line " + std::to_string(lines_.line(at)) + ", column " +
                                                   std::to_string(lines_.column(at)) + ": " + parsed.description());
        }
        const pugi::xml_node root = xml.document_element();
        if (std::string_view(root.name()) != "ASAP_Annotations")
            return Result(Status::UnsupportedFormat, "ASAP XML line " + line(root) + ": the root element is <" +
                                                         root.name() + ">, not <ASAP_Annotations>");
        AnnotationDocument doc;
        std::map<std::string, Rgba8, std::less<>> groupColor;
        for (pugi::xml_node g : root.child("AnnotationGroups").children("Group")) {
            const std::string name = g.attribute("Name").value();
            if (name.empty()) return fail(g, "<Group> has no Name");
            AnnotationClass c{name, defaultClassColor(name), true};
            if (auto a = g.attribute("Color")) {
                auto col = parseHexColor(a.value());
                if (!col) return fail(g, "group \"" + name + "\" has Color \"" + a.value() + "\", not #RRGGBB");
                c.color = *col;
            }
            c.visible = !g.attribute("IrisVisible") || g.attribute("IrisVisible").as_bool();
            groupColor[name] = c.color;
            doc.classes.push_back(std::move(c));
        }
        size_t index = 0;
        for (pugi::xml_node a : root.child("Annotations").children("Annotation")) {
            if (index % 256 == 0) {
                if (cancelled(control_)) return Result(Status::Cancelled, "reading ASAP XML was cancelled");
                if (control_.progress) control_.progress(size_t(a.offset_debug()), text_.size());
            }
            AnnotationObject o;
            if (Result r = annotation(a, o, groupColor); !r.ok()) return r;
            doc.objects.push_back(std::move(o));
            ++index;
        }
        if (control_.progress) control_.progress(text_.size(), text_.size());
        return doc;
    }

private:
    std::string line(pugi::xml_node n) const {
        const ptrdiff_t off = n.offset_debug();
        return off < 0 ? "?" : std::to_string(lines_.line(size_t(off)));
    }
    Result fail(pugi::xml_node n, const std::string& what) const {
        return Result(Status::CorruptData, "ASAP XML line " + line(n) + ": " + what);
    }

    Result coordinates(pugi::xml_node list, std::vector<Point2>& out) const {
        std::vector<std::pair<long long, Point2>> ordered;
        for (pugi::xml_node c : list.children("Coordinate")) {
            const auto x = parseDouble(c.attribute("X").value()), y = parseDouble(c.attribute("Y").value());
            if (!c.attribute("X") || !c.attribute("Y")) return fail(c, "<Coordinate> without X or Y");
            if (!x) return fail(c, std::string("Coordinate X \"") + c.attribute("X").value() + "\" is not a number");
            if (!y) return fail(c, std::string("Coordinate Y \"") + c.attribute("Y").value() + "\" is not a number");
            if (!std::isfinite(*x) || !std::isfinite(*y)) return fail(c, "a coordinate is not finite");
            long long order = (long long)ordered.size();
            if (auto o = c.attribute("Order")) {
                const std::string_view v = o.value();
                auto r = std::from_chars(v.data(), v.data() + v.size(), order);
                if (v.empty() || r.ec != std::errc() || r.ptr != v.data() + v.size())
                    return fail(c, std::string("Coordinate Order \"") + o.value() + "\" is not an integer");
            }
            ordered.push_back({order, {*x, *y}});
            if (ordered.size() > kMaxVerticesPerObject)
                return fail(list, "more than " + std::to_string(kMaxVerticesPerObject) + " coordinates in one annotation");
        }
        std::stable_sort(ordered.begin(), ordered.end(), [](auto& a, auto& b) { return a.first < b.first; });
        out.clear();
        for (auto& [k, p] : ordered) out.push_back(p);
        return {};
    }

    // A ring is stored open (the writer writes it as stored), so every copy of the first point
    // at its end goes, not only the last: a ring closed twice, [a b c a a], kept [a b c a],
    // written so, lost another vertex when read again (or fell under 3 coordinates and the
    // file Iris had written was refused).
    static void dropClosingRepeats(std::vector<Point2>& ring) {
        while (ring.size() >= 2 && ring.front() == ring.back()) ring.pop_back();
    }

    Result annotation(pugi::xml_node a, AnnotationObject& o, const std::map<std::string, Rgba8, std::less<>>& groups) const {
        const std::string type = a.attribute("Type").value();
        o.name = a.attribute("Name").value();
        const std::string group = a.attribute("PartOfGroup").value();
        o.className = group == "None" ? "" : group;
        if (auto c = a.attribute("Color")) {
            auto col = parseHexColor(c.value());
            if (!col) return fail(a, "annotation \"" + o.name + "\" has Color \"" + c.value() + "\", not #RRGGBB");
            // Its class's colour is no colour of its own (ASAP writes a colour on every annotation).
            auto g = groups.find(o.className);
            const Rgba8 classColor = g != groups.end() ? g->second : defaultClassColor(o.className);
            if (!(*col == classColor)) o.color = *col;
        }
        if (auto v = a.attribute("IrisId")) o.id = v.as_ullong();
        if (std::string_view(a.attribute("IrisObjectType").value()) == "detection") o.type = AnnotationType::Detection;
        if (auto v = a.attribute("IrisLocked")) o.locked = v.as_bool();
        if (auto v = a.attribute("IrisVisible")) o.visible = v.as_bool();
        if (auto v = a.attribute("IrisFill")) o.fill = v.as_bool();
        if (auto v = a.attribute("IrisFillOpacity")) o.fillOpacity = toFloat(parseDouble(v.value()).value_or(o.fillOpacity));
        if (auto v = a.attribute("IrisLineWidth")) o.lineWidth = toFloat(parseDouble(v.value()).value_or(o.lineWidth));
        for (pugi::xml_node p : a.child("IrisProperties").children("Property"))
            if (std::string_view(p.attribute("Name").value()) != "asap:Type") // the Type attribute's, below
                o.properties.emplace_back(p.attribute("Name").value(), p.attribute("Value").value());
        for (pugi::xml_node m : a.child("IrisMeasurements").children("Measurement")) {
            const std::string_view v = m.attribute("Value").value();
            const auto n = v == "NaN" ? std::optional<double>(NAN) : parseDouble(v);
            if (!n) return fail(m, "measurement \"" + std::string(m.attribute("Name").value()) + "\" is \"" + std::string(v) + "\", not a number");
            o.measurements.emplace_back(m.attribute("Name").value(), *n);
        }

        // The outline (first <Coordinates>), then ours: holes and further parts.
        std::vector<Point2> outline;
        pugi::xml_node first = a.child("Coordinates");
        if (!first) return fail(a, "annotation \"" + o.name + "\" has no <Coordinates>");
        if (Result r = coordinates(first, outline); !r.ok()) return r;
        const std::string_view shape = a.attribute("IrisShape").value();
        const std::string where = "annotation \"" + o.name + "\" (" + type + ")";
        // A Rectangle is ours when it is one ring of 4 corners of its bounds (a closing repeat
        // dropped); otherwise (rotated, more corners) it is read as a polygon that remembers its Type.
        bool rectangle = false;
        if (type == "Rectangle") {
            dropClosingRepeats(outline);
            Box2 b;
            for (Point2 p : outline) b.expand(p);
            rectangle = outline.size() == 4 && !first.next_sibling("Coordinates") &&
                        std::all_of(outline.begin(), outline.end(), [&](Point2 p) {
                            return (p.x == b.minX || p.x == b.maxX) && (p.y == b.minY || p.y == b.maxY);
                        });
            if (rectangle) {
                o.kind = AnnotationKind::Rectangle;
                o.box = b;
            }
        }
        if (rectangle) {
            // kind and box set above
        } else if (type == "Polygon" || type == "Spline" || type == "Rectangle") {
            if (shape == "ellipse" && type == "Polygon") {
                o.kind = AnnotationKind::Ellipse;
                Box2 b;
                for (Point2 p : outline) b.expand(p);
                std::istringstream in(a.attribute("IrisBox").value());
                std::string t[4];
                if (in >> t[0] >> t[1] >> t[2] >> t[3]) {
                    auto v0 = parseDouble(t[0]), v1 = parseDouble(t[1]), v2 = parseDouble(t[2]), v3 = parseDouble(t[3]);
                    if (v0 && v1 && v2 && v3) b = {*v0, *v1, *v2, *v3};
                }
                o.box = b;
            } else {
                o.kind = AnnotationKind::Polygon;
                dropClosingRepeats(outline);
                if (outline.size() < 3) return fail(first, where + " has fewer than 3 coordinates");
                o.polygons.push_back({std::move(outline), {}});
                for (pugi::xml_node c = first.next_sibling("Coordinates"); c; c = c.next_sibling("Coordinates")) {
                    std::vector<Point2> ring;
                    if (Result r = coordinates(c, ring); !r.ok()) return r;
                    dropClosingRepeats(ring);
                    if (ring.size() < 3) return fail(c, where + ": a ring has fewer than 3 coordinates");
                    const std::string_view role = c.attribute("IrisRole").value();
                    if (role == "hole") o.polygons.back().holes.push_back(std::move(ring));
                    else o.polygons.push_back({std::move(ring), {}}); // "part" (or unmarked)
                }
                if (type == "Spline") o.properties.emplace_back("asap:Type", "Spline");
                if (type == "Rectangle") o.properties.emplace_back("asap:Type", "Rectangle");
            }
        } else if (type == "Dot" || type == "PointSet") {
            o.kind = AnnotationKind::Point;
            o.points = std::move(outline);
            if (o.points.empty()) return fail(first, where + " has no coordinates");
            if ((type == "Dot") != (o.points.size() == 1)) o.properties.emplace_back("asap:Type", type);
        } else if (type == "Measurement" || type == "Polyline" || type == "PolyLine") {
            o.kind = AnnotationKind::Polyline;
            o.points = std::move(outline);
            if (o.points.size() < 2) return fail(first, where + " has fewer than 2 coordinates");
            if (type == "PolyLine" || (type == "Measurement") != (o.points.size() == 2)) o.properties.emplace_back("asap:Type", type);
        } else {
            return fail(a, "annotation \"" + o.name + "\" has Type \"" + type +
                               "\" (Polygon, Spline, Rectangle, Dot, PointSet, Measurement are known)");
        }
        if (std::string p = annotationProblem(o); !p.empty()) return fail(a, where + ": " + p);
        return {};
    }

    std::string_view text_;
    LineIndex lines_;
    const ReadControl& control_;
};

void addCoordinates(pugi::xml_node parent, const std::vector<Point2>& pts, const char* role) {
    pugi::xml_node list = parent.append_child("Coordinates");
    if (role) list.append_attribute("IrisRole") = role;
    for (size_t i = 0; i < pts.size(); ++i) {
        pugi::xml_node c = list.append_child("Coordinate");
        c.append_attribute("Order") = (unsigned long long)i;
        c.append_attribute("X") = formatDouble(pts[i].x).c_str();
        c.append_attribute("Y") = formatDouble(pts[i].y).c_str();
    }
}

} // namespace

Expected<AnnotationDocument> readAsapXml(std::string_view text, const ReadControl& control) {
    return Reader(text, control).read();
}

std::string writeAsapXml(const AnnotationDocument& doc) {
    std::map<std::string, Rgba8, std::less<>> classColor;
    for (const auto& c : doc.classes) classColor[c.name] = c.color;
    pugi::xml_document xml;
    pugi::xml_node root = xml.append_child("ASAP_Annotations");
    pugi::xml_node list = root.append_child("Annotations");
    for (const AnnotationObject& o : doc.objects) {
        pugi::xml_node a = list.append_child("Annotation");
        // The Type the reader kept ("asap:Type"), where it fits the kind: a Spline or a rotated
        // Rectangle is a polygon, a one-point PointSet a point, and so on.
        std::string asapType;
        for (const auto& [k, v] : o.properties) {
            if (k != "asap:Type") continue;
            if ((o.kind == AnnotationKind::Polygon && (v == "Spline" || v == "Rectangle")) ||
                (o.kind == AnnotationKind::Point && (v == "Dot" || v == "PointSet")) ||
                (o.kind == AnnotationKind::Polyline && (v == "Measurement" || v == "Polyline" || v == "PolyLine")))
                asapType = v;
        }
        std::string type;
        switch (o.kind) {
        case AnnotationKind::Point: type = o.points.size() == 1 ? "Dot" : "PointSet"; break;
        case AnnotationKind::Polyline: type = o.points.size() == 2 ? "Measurement" : "Polyline"; break;
        case AnnotationKind::Polygon:
        case AnnotationKind::Ellipse: type = "Polygon"; break;
        case AnnotationKind::Rectangle: type = "Rectangle"; break;
        }
        if (!asapType.empty()) type = asapType;
        a.append_attribute("Name") = o.name.c_str();
        a.append_attribute("Type") = type.c_str();
        a.append_attribute("PartOfGroup") = o.className.empty() ? "None" : o.className.c_str();
        auto cc = classColor.find(o.className);
        const Rgba8 color = o.color ? *o.color : cc != classColor.end() ? cc->second : defaultClassColor(o.className);
        a.append_attribute("Color") = hexColor(color).c_str();
        if (o.id) a.append_attribute("IrisId") = (unsigned long long)o.id;
        if (o.type == AnnotationType::Detection) a.append_attribute("IrisObjectType") = "detection";
        if (o.locked) a.append_attribute("IrisLocked") = true;
        if (!o.visible) a.append_attribute("IrisVisible") = false;
        if (o.fill) a.append_attribute("IrisFill") = true;
        a.append_attribute("IrisFillOpacity") = formatDouble(o.fillOpacity).c_str();
        a.append_attribute("IrisLineWidth") = formatDouble(o.lineWidth).c_str();
        switch (o.kind) {
        case AnnotationKind::Point:
        case AnnotationKind::Polyline: addCoordinates(a, o.points, nullptr); break;
        case AnnotationKind::Polygon:
            for (size_t k = 0; k < o.polygons.size(); ++k) {
                addCoordinates(a, o.polygons[k].outer, k == 0 ? nullptr : "part");
                for (const auto& h : o.polygons[k].holes) addCoordinates(a, h, "hole");
            }
            break;
        case AnnotationKind::Rectangle: {
            const Box2& b = o.box;
            addCoordinates(a, {{b.minX, b.minY}, {b.maxX, b.minY}, {b.maxX, b.maxY}, {b.minX, b.maxY}}, nullptr);
            break;
        }
        case AnnotationKind::Ellipse: {
            const Box2& b = o.box;
            a.append_attribute("IrisShape") = "ellipse";
            a.append_attribute("IrisBox") = (formatDouble(b.minX) + " " + formatDouble(b.minY) + " " + formatDouble(b.maxX) +
                                             " " + formatDouble(b.maxY))
                                                .c_str();
            addCoordinates(a, flattenEllipse(b, std::min(256, ellipseVertexCount(b.width() / 2, b.height() / 2, 1))), nullptr);
            break;
        }
        }
        bool anyProperty = false;
        for (const auto& [k, v] : o.properties) anyProperty = anyProperty || k != "asap:Type";
        if (anyProperty) {
            pugi::xml_node props = a.append_child("IrisProperties");
            for (const auto& [k, v] : o.properties) {
                if (k == "asap:Type") continue;
                pugi::xml_node p = props.append_child("Property");
                p.append_attribute("Name") = k.c_str();
                p.append_attribute("Value") = v.c_str();
            }
        }
        if (!o.measurements.empty()) {
            pugi::xml_node ms = a.append_child("IrisMeasurements");
            for (const auto& [k, v] : o.measurements) {
                pugi::xml_node m = ms.append_child("Measurement");
                m.append_attribute("Name") = k.c_str();
                m.append_attribute("Value") = std::isnan(v) ? "NaN" : formatDouble(v).c_str();
            }
        }
    }
    pugi::xml_node groups = root.append_child("AnnotationGroups");
    for (const auto& c : doc.classes) {
        pugi::xml_node g = groups.append_child("Group");
        g.append_attribute("Name") = c.name.c_str();
        g.append_attribute("PartOfGroup") = "None";
        g.append_attribute("Color") = hexColor(c.color).c_str();
        if (!c.visible) g.append_attribute("IrisVisible") = false;
        g.append_child("Attributes");
    }
    std::ostringstream out;
    xml.save(out, "\t", pugi::format_default, pugi::encoding_utf8);
    return out.str();
}

} // namespace iris
