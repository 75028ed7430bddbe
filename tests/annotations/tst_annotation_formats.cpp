// QuPath GeoJSON and ASAP XML (iris/annotations.h): round trips that lose nothing (holes,
// several parts, ellipses, classes, colours, properties, measurements), files written by hand
// from each format's documentation, malformed inputs each with the error text it must give,
// and AnnotationLoader's progress, cancel and all-or-nothing publication.
#include <QtTest>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>

#include "iris/annotations.h"

using namespace iris;

namespace {

std::vector<AnnotationClass> sortedClasses(std::vector<AnnotationClass> c) {
    std::sort(c.begin(), c.end(), [](auto& a, auto& b) { return a.name < b.name; });
    return c;
}

// Every kind and the awkward cases: holes, several parts, a hole-less multipolygon part,
// coordinates that do not survive a careless decimal round trip, an ellipse whose box is not
// representable as centre ± radius, properties with quotes, newlines, XML and JSON syntax.
AnnotationDocument sampleDocument() {
    AnnotationDocument d;
    d.classes = {{"Tumor", {200, 0, 0, 255}, true}, {"Stroma", {10, 150, 20, 128}, false}, {"Unused", {1, 2, 3, 255}, true}};
    AnnotationObject poly;
    poly.id = 7;
    poly.kind = AnnotationKind::Polygon;
    poly.className = "Tumor";
    poly.name = "outline \"A\" <&>";
    poly.polygons = {{{{0.1, 0.2}, {1000.3, 0.2}, {1000.3, 800.7}, {0.1, 800.7}},
                      {{{100, 100}, {200, 100}, {150, 180.125}}, {{500, 500}, {600, 500}, {600, 600}, {500, 600}}}},
                     {{{2000, 2000}, {2100, 2000}, {2050, 2100}}, {}}};
    poly.fill = true;
    poly.fillOpacity = 0.4f;
    poly.lineWidth = 3.5f;
    poly.locked = true;
    poly.properties = {{"note", "line1\nline2 \"quoted\" {json} <xml/> & ünïcode"}, {"score", "0.93"}};
    poly.measurements = {{"Area µm^2", 123456.789}, {"Perimeter", 1e-7}, {"Count", 3}};
    AnnotationObject det;
    det.id = 8;
    det.type = AnnotationType::Detection;
    det.kind = AnnotationKind::Polygon;
    det.className = "Stroma";
    det.color = Rgba8{1, 2, 3, 255};
    det.polygons = {{{{10, 10}, {20, 10}, {20, 20}, {10, 20}, {5, 15}}, {}}};
    AnnotationObject dot;
    dot.id = 9;
    dot.kind = AnnotationKind::Point;
    dot.points = {{123.456789012345, 987.654321098765}};
    dot.visible = false;
    AnnotationObject set = dot;
    set.id = 10;
    set.visible = true;
    set.points = {{1, 2}, {3, 4}, {5, 6}};
    set.className = "Tumor";
    AnnotationObject line;
    line.id = 11;
    line.kind = AnnotationKind::Polyline;
    line.points = {{0, 0}, {10, 10}, {20, 0}};
    AnnotationObject ruler = line;
    ruler.id = 12;
    ruler.points = {{0, 0}, {3, 4}};
    ruler.measurements = {{"Length", 5}};
    AnnotationObject rect;
    rect.id = 13;
    rect.kind = AnnotationKind::Rectangle;
    rect.box = {10.5, 20.25, 30.75, 40};
    AnnotationObject ell;
    ell.id = 14;
    ell.kind = AnnotationKind::Ellipse;
    ell.box = {0.1, 0.2, 0.7, 1e6 + 0.3};
    ell.color = Rgba8{0, 0, 255, 255};
    ell.fill = true;
    d.objects = {poly, det, dot, set, line, ruler, rect, ell};
    return d;
}

std::string describe(const AnnotationObject& o) {
    return std::string(annotationKindName(o.kind)) + " " + std::to_string(o.id) + " '" + o.name + "'";
}

// Compares two documents object by object, field by field, naming the first difference.
QString difference(const AnnotationDocument& a, const AnnotationDocument& b) {
    if (a.objects.size() != b.objects.size())
        return QString("%1 objects vs %2").arg(a.objects.size()).arg(b.objects.size());
    for (size_t i = 0; i < a.objects.size(); ++i) {
        const auto &x = a.objects[i], &y = b.objects[i];
        const QString w = QString::fromStdString(describe(x));
        if (x.id != y.id) return w + ": id";
        if (x.kind != y.kind) return w + ": kind " + annotationKindName(y.kind);
        if (x.type != y.type) return w + ": type";
        if (x.name != y.name) return w + ": name '" + QString::fromStdString(y.name) + "'";
        if (x.className != y.className) return w + ": class";
        if (x.color != y.color) return w + ": colour";
        if (x.lineWidth != y.lineWidth || x.fill != y.fill || x.fillOpacity != y.fillOpacity) return w + ": line/fill";
        if (x.visible != y.visible || x.locked != y.locked) return w + ": flags";
        if (x.points != y.points) return w + ": points";
        if (x.polygons != y.polygons) return w + ": polygons";
        if (x.box != y.box) return w + ": box";
        if (x.properties != y.properties) {
            QString s = w + ": properties:";
            for (auto& [k, v] : y.properties) s += " " + QString::fromStdString(k) + "=" + QString::fromStdString(v);
            return s;
        }
        if (x.measurements != y.measurements) return w + ": measurements";
    }
    if (sortedClasses(a.classes) != sortedClasses(b.classes)) return "classes";
    return {};
}

QString tempPath(const char* name) {
    const QByteArray out = qgetenv("IRIS_TEST_OUT");
    return (out.isEmpty() ? QDir::tempPath() : QString::fromLocal8Bit(out)) + "/" + name;
}
void writeFile(const QString& path, const std::string& text) {
    std::ofstream f(path.toStdString(), std::ios::binary);
    f << text;
}

// A GeoJSON of n detections of `vertices` vertices each (the load-time test's shape).
std::string generatedGeoJson(size_t n, int vertices, uint64_t seed) {
    std::mt19937_64 rng(seed);
    AnnotationDocument d;
    d.classes = {{"Tumor", {200, 0, 0, 255}, true}};
    d.objects.reserve(n);
    for (size_t i = 0; i < n; ++i) {
        AnnotationObject o;
        o.kind = AnnotationKind::Polygon;
        o.type = AnnotationType::Detection;
        o.className = "Tumor";
        const double cx = double(rng() % 100000), cy = double(rng() % 80000);
        PolygonPart p;
        for (int k = 0; k < vertices; ++k) {
            const double a = 2 * M_PI * k / vertices;
            p.outer.push_back({std::round((cx + 8 * std::cos(a)) * 100) / 100, std::round((cy + 6 * std::sin(a)) * 100) / 100});
        }
        o.polygons.push_back(std::move(p));
        o.measurements = {{"Nucleus: Area", double(rng() % 1000) / 10}};
        d.objects.push_back(std::move(o));
    }
    return writeGeoJson(d);
}

} // namespace

class TestAnnotationFormats : public QObject {
    Q_OBJECT
private slots:
    void detectsFormat();
    void geoJsonRoundTrip();
    void asapRoundTrip();
    void storeRoundTrip();
    void qupathFileByHand();
    void asapFileByHand();
    void asapRingClosedTwice();
    void malformedGeoJson_data();
    void malformedGeoJson();
    void malformedAsap_data();
    void malformedAsap();
    void tooManyVertices();
    void loaderPublishesOnceWithProgress();
    void failedLoadLeavesStoreUnchanged();
    void loaderCancels();
};

void TestAnnotationFormats::detectsFormat() {
    QCOMPARE(detectAnnotationFormat("  \n{\"type\":1}"), std::optional(AnnotationFormat::GeoJson));
    QCOMPARE(detectAnnotationFormat("\xEF\xBB\xBF[]"), std::optional(AnnotationFormat::GeoJson));
    QCOMPARE(detectAnnotationFormat("<?xml version=\"1.0\"?>"), std::optional(AnnotationFormat::AsapXml));
    QVERIFY(!detectAnnotationFormat("hello"));
    QVERIFY(!detectAnnotationFormat("   "));
}

void TestAnnotationFormats::geoJsonRoundTrip() {
    const AnnotationDocument d = sampleDocument();
    const std::string text = writeGeoJson(d);
    auto back = readGeoJson(text);
    QVERIFY2(back.ok(), back.ok() ? "" : back.error().message().c_str());
    const QString diff = difference(d, *back);
    QVERIFY2(diff.isEmpty(), qPrintable(diff));
    QCOMPARE(writeGeoJson(*back), text); // and it is stable
    // A free-form property named like one of the format's own fields is not written: it would
    // replace the field on the way back in.
    AnnotationDocument r;
    r.objects.push_back(d.objects[2]);
    r.objects[0].name = "real";
    r.objects[0].properties = {{"name", "impostor"}, {"iris", "x"}, {"kept", "1"}};
    auto rb = readGeoJson(writeGeoJson(r));
    QVERIFY(rb.ok());
    QCOMPARE(rb->objects[0].name, std::string("real"));
    QCOMPARE(rb->objects[0].properties, (std::vector<std::pair<std::string, std::string>>{{"kept", "1"}}));
    // NaN measurements travel as null (JSON has no NaN).
    AnnotationDocument n;
    n.objects.push_back(d.objects[2]);
    n.objects[0].measurements = {{"missing", NAN}};
    auto nb = readGeoJson(writeGeoJson(n));
    QVERIFY(nb.ok() && std::isnan(nb->objects[0].measurements[0].second));
}

void TestAnnotationFormats::asapRoundTrip() {
    const AnnotationDocument d = sampleDocument();
    const std::string text = writeAsapXml(d);
    auto back = readAsapXml(text);
    QVERIFY2(back.ok(), back.ok() ? "" : back.error().message().c_str());
    const QString diff = difference(d, *back);
    QVERIFY2(diff.isEmpty(), qPrintable(diff));
    QCOMPARE(writeAsapXml(*back), text);
    // The outline ASAP itself reads: the first <Coordinates> of the polygon is its outer ring.
    const size_t first = text.find("<Annotation ");
    QVERIFY2(text.find("<Annotation Name=\"outline &quot;A&quot; &lt;&amp;>\" Type=\"Polygon\" PartOfGroup=\"Tumor\" Color=\"#C80000\"") ==
                 first,
             text.substr(first, 120).c_str());
    // Across formats: GeoJSON → ASAP → GeoJSON keeps everything too.
    auto viaAsap = readAsapXml(writeAsapXml(*readGeoJson(writeGeoJson(d))));
    QVERIFY(viaAsap.ok());
    QVERIFY2(difference(d, *viaAsap).isEmpty(), qPrintable(difference(d, *viaAsap)));
}

void TestAnnotationFormats::storeRoundTrip() {
    AnnotationStore store;
    const AnnotationDocument d = sampleDocument();
    QVERIFY(store.replaceAll(d.objects, d.classes).ok());
    auto s = store.snapshot();
    QCOMPARE(s->size(), d.objects.size());
    QCOMPARE(sortedClasses(s->classes()), sortedClasses(d.classes));
    QCOMPARE(s->find(8)->object.color, (std::optional<Rgba8>(Rgba8{1, 2, 3, 255})));
    QVERIFY(!s->drawn(s->find(8)->object)); // Stroma is hidden
    auto back = readGeoJson(writeGeoJson(documentOf(*s)));
    QVERIFY(back.ok());
    std::sort(back->objects.begin(), back->objects.end(), [](auto& a, auto& b) { return a.id < b.id; });
    QVERIFY2(difference(d, *back).isEmpty(), qPrintable(difference(d, *back)));
    // New ids continue above the loaded ones.
    AnnotationObject fresh = d.objects[2];
    fresh.id = 0;
    QVERIFY(*store.add(fresh) > 14);
}

void TestAnnotationFormats::qupathFileByHand() {
    // As QuPath 0.4 exports (Export objects as GeoJSON, FeatureCollection), with the older
    // measurement list and packed colour of 0.2/0.3 in the second feature.
    const std::string text = R"({
  "type": "FeatureCollection",
  "features": [
    {
      "type": "Feature",
      "id": "6d4b5d7e-2a3f-4b8e-9c1a-2f2f7a0e8b11",
      "geometry": {
        "type": "Polygon",
        "coordinates": [[[1000, 1000], [3000, 1000], [3000, 2500], [1000, 2500], [1000, 1000]],
                        [[1500, 1500], [2000, 1500], [2000, 2000], [1500, 1500]]]
      },
      "properties": {
        "objectType": "annotation",
        "name": "Region 1",
        "classification": { "name": "Tumor", "color": [200, 0, 0] },
        "isLocked": true,
        "measurements": { "Area µm^2": 725000.5, "Num Detections": 12 },
        "metadata": { "source": "pathologist" }
      }
    },
    {
      "type": "Feature",
      "geometry": { "type": "MultiPolygon", "coordinates": [[[[0,0],[10,0],[10,10],[0,0]]], [[[20,20],[30,20],[30,30],[20,20]]]] },
      "properties": {
        "objectType": "cell",
        "classification": { "name": "Lymphocyte", "colorRGB": -16776961 },
        "measurements": [ { "name": "Nucleus: Area", "value": 31.5 }, { "name": "Missing", "value": null } ]
      }
    },
    { "type": "Feature", "geometry": { "type": "Point", "coordinates": [5.5, 6.5, 0] }, "properties": { "objectType": "detection" } },
    { "type": "Feature", "geometry": { "type": "LineString", "coordinates": [[0, 0], [100, 50]] }, "properties": { "color": [0, 255, 0] } }
  ]
})";
    auto doc = readGeoJson(text);
    QVERIFY2(doc.ok(), doc.ok() ? "" : doc.error().message().c_str());
    QCOMPARE(doc->objects.size(), size_t(4));
    const auto& a = doc->objects[0];
    QCOMPARE(a.kind, AnnotationKind::Polygon);
    QCOMPARE(a.type, AnnotationType::Annotation);
    QCOMPARE(a.name, std::string("Region 1"));
    QCOMPARE(a.className, std::string("Tumor"));
    QVERIFY(a.locked && !a.color);
    QCOMPARE(a.polygons[0].outer.size(), size_t(4)); // the closing position is dropped
    QCOMPARE(a.polygons[0].holes.size(), size_t(1));
    QCOMPARE(a.polygons[0].holes[0].size(), size_t(3));
    QCOMPARE(a.measurements.size(), size_t(2));
    QCOMPARE(a.measurements[0].first, std::string("Area µm^2"));
    QCOMPARE(a.measurements[1].second, 12.0);
    // A string id and a non-string property are kept as strings.
    QCOMPARE(a.properties, (std::vector<std::pair<std::string, std::string>>{
                               {"geojson:id", "6d4b5d7e-2a3f-4b8e-9c1a-2f2f7a0e8b11"}, {"metadata", R"({"source":"pathologist"})"}}));
    const auto& b = doc->objects[1];
    QCOMPARE(b.type, AnnotationType::Detection);
    QCOMPARE(b.polygons.size(), size_t(2));
    QCOMPARE(b.properties, (std::vector<std::pair<std::string, std::string>>{{"objectType", "cell"}}));
    QVERIFY(std::isnan(b.measurements[1].second));
    QCOMPARE(doc->objects[2].kind, AnnotationKind::Point);
    QCOMPARE(doc->objects[2].points[0], (Point2{5.5, 6.5}));
    QCOMPARE(doc->objects[3].kind, AnnotationKind::Polyline);
    QCOMPARE(doc->objects[3].color, std::optional(Rgba8{0, 255, 0, 255}));
    const auto classes = sortedClasses(doc->classes);
    QCOMPARE(classes.size(), size_t(2));
    QCOMPARE(classes[0], (AnnotationClass{"Lymphocyte", {0, 0, 255, 255}, true})); // 0xFF0000FF packed
    QCOMPARE(classes[1], (AnnotationClass{"Tumor", {200, 0, 0, 255}, true}));
    // Written back: QuPath's objectType "cell" and the UUID come back as they were.
    const std::string out = writeGeoJson(*doc);
    QVERIFY(out.find(R"("id":"6d4b5d7e-2a3f-4b8e-9c1a-2f2f7a0e8b11")") != std::string::npos);
    QVERIFY(out.find(R"("objectType":"cell")") != std::string::npos);
    auto again = readGeoJson(out);
    QVERIFY(again.ok());
    QCOMPARE(again->objects[0].properties, a.properties);
    // A bare array of features and a single Feature are accepted too.
    auto arr = readGeoJson(R"([{"type":"Feature","geometry":{"type":"Point","coordinates":[1,2]},"properties":{}}])");
    QVERIFY(arr.ok() && arr->objects.size() == 1);
    auto one = readGeoJson(R"({"type":"Feature","geometry":{"type":"Point","coordinates":[1,2]}})");
    QVERIFY(one.ok() && one->objects.size() == 1);
    auto empty = readGeoJson(R"({"type":"FeatureCollection","features":[]})");
    QVERIFY(empty.ok() && empty->objects.empty());
}

void TestAnnotationFormats::asapFileByHand() {
    // As ASAP 1.9 saves (and the CAMELYON16/17 annotations are): coordinates possibly out of
    // Order, groups with colours, and one coordinate written under a comma-decimal locale.
    const std::string text = R"(<?xml version="1.0"?>
<ASAP_Annotations>
	<Annotations>
		<Annotation Name="Annotation 0" Type="Polygon" PartOfGroup="_0" Color="#F4FA58">
			<Coordinates>
				<Coordinate Order="2" X="30" Y="40" />
				<Coordinate Order="0" X="10.5" Y="20" />
				<Coordinate Order="1" X="50" Y="20,25" />
			</Coordinates>
		</Annotation>
		<Annotation Name="Annotation 1" Type="Spline" PartOfGroup="_2" Color="#64FE2E">
			<Coordinates>
				<Coordinate Order="0" X="0" Y="0" /><Coordinate Order="1" X="5" Y="0" /><Coordinate Order="2" X="5" Y="5" />
			</Coordinates>
		</Annotation>
		<Annotation Name="Dot 1" Type="Dot" PartOfGroup="None" Color="#F4FA58">
			<Coordinates><Coordinate Order="0" X="7" Y="8" /></Coordinates>
		</Annotation>
		<Annotation Name="Set" Type="PointSet" PartOfGroup="_0" Color="#F4FA58">
			<Coordinates><Coordinate Order="0" X="1" Y="1" /><Coordinate Order="1" X="2" Y="2" /></Coordinates>
		</Annotation>
		<Annotation Name="Box" Type="Rectangle" PartOfGroup="_0" Color="#F4FA58">
			<Coordinates><Coordinate Order="0" X="1" Y="2" /><Coordinate Order="1" X="11" Y="2" /><Coordinate Order="2" X="11" Y="12" /><Coordinate Order="3" X="1" Y="12" /></Coordinates>
		</Annotation>
		<Annotation Name="Ruler" Type="Measurement" PartOfGroup="None" Color="#F4FA58">
			<Coordinates><Coordinate Order="0" X="0" Y="0" /><Coordinate Order="1" X="30" Y="40" /></Coordinates>
		</Annotation>
	</Annotations>
	<AnnotationGroups>
		<Group Name="_0" PartOfGroup="None" Color="#F4FA58"><Attributes /></Group>
		<Group Name="_2" PartOfGroup="None" Color="#FF0000"><Attributes /></Group>
	</AnnotationGroups>
</ASAP_Annotations>
)";
    auto doc = readAsapXml(text);
    QVERIFY2(doc.ok(), doc.ok() ? "" : doc.error().message().c_str());
    QCOMPARE(doc->objects.size(), size_t(6));
    const auto& p = doc->objects[0];
    QCOMPARE(p.kind, AnnotationKind::Polygon);
    QCOMPARE(p.className, std::string("_0"));
    QVERIFY(!p.color); // its group's colour
    QCOMPARE(p.polygons[0].outer, (std::vector<Point2>{{10.5, 20}, {50, 20.25}, {30, 40}}));
    const auto& s = doc->objects[1];
    QCOMPARE(s.color, std::optional(Rgba8{0x64, 0xFE, 0x2E, 255})); // differs from _2's #FF0000
    QCOMPARE(s.properties, (std::vector<std::pair<std::string, std::string>>{{"asap:Type", "Spline"}}));
    QCOMPARE(doc->objects[2].kind, AnnotationKind::Point);
    QCOMPARE(doc->objects[2].className, std::string());
    QCOMPARE(doc->objects[3].points.size(), size_t(2));
    QCOMPARE(doc->objects[4].kind, AnnotationKind::Rectangle);
    QCOMPARE(doc->objects[4].box, (Box2{1, 2, 11, 12}));
    QCOMPARE(doc->objects[5].kind, AnnotationKind::Polyline);
    QCOMPARE(sortedClasses(doc->classes),
             (std::vector<AnnotationClass>{{"_0", {0xF4, 0xFA, 0x58, 255}, true}, {"_2", {255, 0, 0, 255}, true}}));
    // Written back, a Spline stays a Spline and ASAP's own attributes come first.
    const std::string out = writeAsapXml(*doc);
    QVERIFY(out.find(R"(<Annotation Name="Annotation 1" Type="Spline" PartOfGroup="_2" Color="#64FE2E")") != std::string::npos);
    auto again = readAsapXml(out);
    QVERIFY(again.ok());
    QVERIFY2(difference(*doc, *again).isEmpty(), qPrintable(difference(*doc, *again)));
}

void TestAnnotationFormats::malformedGeoJson_data() {
    QTest::addColumn<QString>("text");
    QTest::addColumn<QString>("error");
    const QString pt = R"({"type":"Feature","geometry":{"type":"Point","coordinates":[1,2]}})";
    QTest::newRow("syntax") << "{\"type\":\"FeatureCollection\",\n\"features\":[\n{\"type\":\"Feature\",]}"
                            << "GeoJSON line 3, column 19: syntax error while parsing object key - unexpected ']'; expected string literal";
    QTest::newRow("truncated") << "{\"type\":\"FeatureCollection\",\"features\":[" + pt
                               << "GeoJSON line 1, column 107: syntax error while parsing array - unexpected end of input; expected ']'";
    QTest::newRow("huge number") << "{\"type\":\"FeatureCollection\",\"features\":[\n{\"type\":\"Feature\",\"geometry\":{\"type\":\"Point\",\"coordinates\":[1e999,2]}}]}"
                                 << "GeoJSON line 2, column 65: number overflow parsing '1e999'";
    QTest::newRow("geometry type") << "{\"type\":\"FeatureCollection\",\"features\":[" + pt + ",\n" +
                                          R"({"type":"Feature","geometry":{"type":"Circle","coordinates":[1,2]}}]})"
                                   << "GeoJSON feature 1 (line 2): geometry type \"Circle\" is not supported (Point, MultiPoint, LineString, Polygon, MultiPolygon are)";
    QTest::newRow("huge coordinate") << R"([{"type":"Feature","geometry":{"type":"Point","coordinates":[1e300,2]}}])"
                                     << "GeoJSON feature 0 (line 1): a coordinate is outside ±1e12";
    QTest::newRow("reversed box") << R"([{"type":"Feature","geometry":{"type":"Polygon","coordinates":[[[0,0],[1,0],[1,1],[0,0]]]},"properties":{"iris":{"shape":"ellipse","box":[5,5,1,1]}}}])"
                                  << "GeoJSON feature 0 (line 1): the box's minimum exceeds its maximum";
    QTest::newRow("not a feature") << R"({"type":"FeatureCollection","features":[{"type":"Polygon","coordinates":[]}]})"
                                   << "GeoJSON feature 0 (line 1): has type \"Polygon\", expected \"Feature\"";
    QTest::newRow("two positions") << R"({"type":"FeatureCollection","features":[{"type":"Feature","properties":{"name":"bad one"},"geometry":{"type":"Polygon","coordinates":[[[0,0],[1,1],[0,0]]]}}]})"
                                   << "GeoJSON feature 0 (line 1) \"bad one\": Polygon outer ring has fewer than 3 distinct positions";
    QTest::newRow("string coordinate") << R"([{"type":"Feature","geometry":{"type":"LineString","coordinates":[[0,0],["1",1]]}}])"
                                       << "GeoJSON feature 0 (line 1): LineString: a position holds string \"1\"";
    QTest::newRow("no geometry") << R"([{"type":"Feature","geometry":null}])" << "GeoJSON feature 0 (line 1): has no geometry";
    QTest::newRow("features object") << R"({"type":"FeatureCollection","features":{}})"
                                     << "GeoJSON line 1: \"features\" is an object, not an array";
    QTest::newRow("features string") << R"({"type":"FeatureCollection","features":"x"})"
                                     << "GeoJSON line 1: \"features\" is a string, not an array";
    QTest::newRow("top level") << R"({"type":"Polygon","coordinates":[]})"
                               << "GeoJSON: the top level is of type \"Polygon\", not a FeatureCollection, a Feature or an array of features";
    QTest::newRow("top number") << "42" << "GeoJSON: the top level is a JSON number, not a FeatureCollection, a Feature or an array of features";
    QTest::newRow("class without name") << R"([{"type":"Feature","geometry":{"type":"Point","coordinates":[1,2]},"properties":{"classification":{"color":[1,2,3]}}}])"
                                        << "GeoJSON feature 0 (line 1): \"classification\" has no string \"name\"";
    QTest::newRow("bad colour") << R"([{"type":"Feature","geometry":{"type":"Point","coordinates":[1,2]},"properties":{"classification":{"name":"x","color":[1,2,300]}}}])"
                                << "GeoJSON feature 0 (line 1): classification color [1,2,300] is neither [r,g,b] nor a packed integer";
    QTest::newRow("measurement") << R"([{"type":"Feature","geometry":{"type":"Point","coordinates":[1,2]},"properties":{"measurements":{"Area":"big"}}}])"
                                 << "GeoJSON feature 0 (line 1): measurement \"Area\" is a string, not a number";
    QTest::newRow("locked") << R"([{"type":"Feature","geometry":{"type":"Point","coordinates":[1,2]},"properties":{"isLocked":"yes"}}])"
                            << "GeoJSON feature 0 (line 1): \"isLocked\" is a string, not a boolean";
    QString deep = "[{\"type\":\"Feature\",\"geometry\":{\"type\":\"Point\",\"coordinates\":[1,2]},\"properties\":{\"x\":";
    for (int i = 0; i < 100; ++i) deep += "[";
    QTest::newRow("deep nesting") << deep << "GeoJSON line 1: nesting deeper than 64 levels";
    QTest::newRow("empty") << "" << "GeoJSON line 1, column 1: syntax error while parsing value - unexpected end of input; expected '[', '{', or a literal";
}

void TestAnnotationFormats::malformedGeoJson() {
    QFETCH(QString, text);
    QFETCH(QString, error);
    auto r = readGeoJson(text.toStdString());
    QVERIFY(!r.ok());
    QCOMPARE(QString::fromStdString(r.error().message()), error);
    QVERIFY(r.error().status() == Status::CorruptData || r.error().status() == Status::UnsupportedFormat);
}

void TestAnnotationFormats::asapRingClosedTwice() {
    // Rings are stored open and written as stored, so every copy of the first point at a ring's
    // end is dropped, not only the last: otherwise [a b c a a] was kept as [a b c a] and lost
    // the closing vertex only when Iris read its own file again (fuzz_asap_xml).
    const std::string text = R"(<ASAP_Annotations><Annotations>
<Annotation Name="p" Type="Polygon" PartOfGroup="None"><Coordinates>
<Coordinate Order="0" X="0" Y="0"/><Coordinate Order="1" X="10" Y="0"/><Coordinate Order="2" X="10" Y="10"/>
<Coordinate Order="3" X="0" Y="0"/><Coordinate Order="4" X="0" Y="0"/></Coordinates>
<Coordinates IrisRole="hole"><Coordinate X="1" Y="1"/><Coordinate X="2" Y="1"/><Coordinate X="2" Y="2"/><Coordinate X="1" Y="1"/><Coordinate X="1" Y="1"/></Coordinates>
</Annotation></Annotations></ASAP_Annotations>)";
    auto doc = readAsapXml(text);
    QVERIFY2(doc.ok(), doc.ok() ? "" : doc.error().message().c_str());
    QCOMPARE(doc->objects.at(0).polygons.at(0).outer.size(), size_t(3));
    QCOMPARE(doc->objects.at(0).polygons.at(0).holes.at(0).size(), size_t(3));
    const std::string once = writeAsapXml(*doc);
    auto again = readAsapXml(once);
    QVERIFY2(again.ok(), again.ok() ? "" : again.error().message().c_str());
    QCOMPARE(again->objects.at(0).polygons, doc->objects.at(0).polygons);
    QCOMPARE(writeAsapXml(*again), once);
}

void TestAnnotationFormats::malformedAsap_data() {
    QTest::addColumn<QString>("text");
    QTest::addColumn<QString>("error");
    const QString head = "<?xml version=\"1.0\"?>\n<ASAP_Annotations>\n<Annotations>\n";
    const QString tail = "</Annotations>\n</ASAP_Annotations>\n";
    QTest::newRow("mismatched tag") << head + "<Annotation Name=\"a\" Type=\"Dot\">\n<Coordinates></Coordinate>\n</Annotation>\n" + tail
                                    << "ASAP XML line 5, column 16: Start-end tags mismatch";
    QTest::newRow("root") << "<Annotations/>" << "ASAP XML line 1: the root element is <Annotations>, not <ASAP_Annotations>";
    QTest::newRow("bad X") << head + "<Annotation Name=\"a\" Type=\"Dot\">\n<Coordinates>\n<Coordinate Order=\"0\" X=\"abc\" Y=\"1\"/>\n</Coordinates></Annotation>\n" + tail
                           << "ASAP XML line 6: Coordinate X \"abc\" is not a number";
    QTest::newRow("no Y") << head + "<Annotation Name=\"a\" Type=\"Dot\">\n<Coordinates>\n<Coordinate Order=\"0\" X=\"1\"/>\n</Coordinates></Annotation>\n" + tail
                          << "ASAP XML line 6: <Coordinate> without X or Y";
    QTest::newRow("type") << head + "<Annotation Name=\"c\" Type=\"Circle\"><Coordinates/></Annotation>\n" + tail
                          << "ASAP XML line 4: annotation \"c\" has Type \"Circle\" (Polygon, Spline, Rectangle, Dot, PointSet, Measurement are known)";
    QTest::newRow("two coordinates") << head + "<Annotation Name=\"p\" Type=\"Polygon\">\n<Coordinates><Coordinate Order=\"0\" X=\"1\" Y=\"1\"/><Coordinate Order=\"1\" X=\"2\" Y=\"2\"/></Coordinates></Annotation>\n" + tail
                                     << "ASAP XML line 5: annotation \"p\" (Polygon) has fewer than 3 coordinates";
    QTest::newRow("closed twice, two left") << head + "<Annotation Name=\"p\" Type=\"Polygon\">\n<Coordinates><Coordinate X=\"1\" Y=\"1\"/><Coordinate X=\"2\" Y=\"2\"/><Coordinate X=\"1\" Y=\"1\"/><Coordinate X=\"1\" Y=\"1\"/></Coordinates></Annotation>\n" + tail
                                           << "ASAP XML line 5: annotation \"p\" (Polygon) has fewer than 3 coordinates";
    QTest::newRow("colour") << head + "<Annotation Name=\"p\" Type=\"Dot\" Color=\"red\"><Coordinates><Coordinate X=\"1\" Y=\"1\"/></Coordinates></Annotation>\n" + tail
                            << "ASAP XML line 4: annotation \"p\" has Color \"red\", not #RRGGBB";
    QTest::newRow("no coordinates") << head + "<Annotation Name=\"p\" Type=\"Dot\"/>\n" + tail
                                    << "ASAP XML line 4: annotation \"p\" has no <Coordinates>";
    QTest::newRow("infinite") << head + "<Annotation Name=\"p\" Type=\"Dot\"><Coordinates>\n<Coordinate X=\"1e999\" Y=\"1\"/></Coordinates></Annotation>\n" + tail
                              << "ASAP XML line 5: Coordinate X \"1e999\" is not a number";
    QTest::newRow("order") << head + "<Annotation Name=\"p\" Type=\"Dot\"><Coordinates>\n<Coordinate Order=\"0.5\" X=\"1\" Y=\"1\"/></Coordinates></Annotation>\n" + tail
                           << "ASAP XML line 5: Coordinate Order \"0.5\" is not an integer";
    QTest::newRow("empty") << "" << "ASAP XML line 1, column 1: No document element found";
}

void TestAnnotationFormats::malformedAsap() {
    QFETCH(QString, text);
    QFETCH(QString, error);
    auto r = readAsapXml(text.toStdString());
    QVERIFY(!r.ok());
    QCOMPARE(QString::fromStdString(r.error().message()), error);
}

void TestAnnotationFormats::tooManyVertices() {
    // One polygon past the per-object limit (2·10^6 vertices): refused with its count.
    std::string text = R"([{"type":"Feature","geometry":{"type":"Polygon","coordinates":[[)";
    text.reserve(2'000'001 * 8 + 200);
    for (int i = 0; i < 2'000'001; ++i) text += i ? ",[1,2]" : "[1,2]";
    text += "]]}}]";
    auto r = readGeoJson(text);
    QVERIFY(!r.ok());
    QCOMPARE(QString::fromStdString(r.error().message()),
             QString("GeoJSON feature 0 (line 1): Polygon outer ring has 2000001 positions, more than the 2000000 allowed"));
}

void TestAnnotationFormats::loaderPublishesOnceWithProgress() {
    const QString path = tempPath("ann-loader.geojson");
    writeFile(path, generatedGeoJson(20000, 12, 1));
    AnnotationStore store;
    (void)store.add(AnnotationObject{.kind = AnnotationKind::Point, .points = {{1, 1}}});
    const uint64_t gen = store.snapshot()->generation();
    std::vector<std::pair<uint64_t, uint64_t>> progress;
    std::atomic<int> finishedCalls{0};
    size_t reported = 0;
    AnnotationLoader loader(store, path.toStdString(),
                            {.progress = [&](uint64_t d, uint64_t t) { progress.emplace_back(d, t); },
                             .finished =
                                 [&](const Result& r, size_t n) {
                                     ++finishedCalls;
                                     reported = r.ok() ? n : 0;
                                 }});
    const Result r = loader.wait();
    QVERIFY2(r.ok(), r.message().c_str());
    QCOMPARE(finishedCalls.load(), 1);
    QCOMPARE(reported, size_t(20000));
    auto s = store.snapshot();
    QCOMPARE(s->generation(), gen + 1); // replaced in one publication
    QCOMPARE(s->size(), size_t(20000));
    QVERIFY(progress.size() >= 3);
    for (size_t i = 1; i < progress.size(); ++i) QVERIFY(progress[i].first >= progress[i - 1].first);
    QCOMPARE(progress.back().first, progress.back().second);
    QCOMPARE(progress.back().second, uint64_t(2 * QFileInfo(path).size()));
    // Append keeps what is there and gives the file's objects fresh ids.
    AnnotationLoader again(store, path.toStdString(), {}, AnnotationLoader::Mode::Append);
    QVERIFY(again.wait().ok());
    QCOMPARE(store.snapshot()->size(), size_t(40000));
}

void TestAnnotationFormats::failedLoadLeavesStoreUnchanged() {
    AnnotationStore store;
    const AnnotationDocument d = sampleDocument();
    QVERIFY(store.replaceAll(d.objects, d.classes).ok());
    const uint64_t gen = store.snapshot()->generation();
    // A good start, a bad feature in the middle.
    std::string text = generatedGeoJson(3000, 6, 2);
    text.insert(text.rfind("\n]}"), ",\n{\"type\":\"Feature\",\"geometry\":{\"type\":\"Polygon\",\"coordinates\":[[[0,0],[1,0],[0,0]]]}}");
    const QString path = tempPath("ann-bad.geojson");
    writeFile(path, text);
    Result seen;
    AnnotationLoader loader(store, path.toStdString(), {.finished = [&](const Result& r, size_t) { seen = r; }});
    const Result r = loader.wait();
    QVERIFY(!r.ok());
    QCOMPARE(QString::fromStdString(r.message()),
             path + ": GeoJSON feature 3000 (line 3002): Polygon outer ring has fewer than 3 distinct positions");
    QCOMPARE(seen.message(), r.message());
    QCOMPARE(store.snapshot()->generation(), gen);
    QCOMPARE(store.snapshot()->size(), d.objects.size());
    AnnotationLoader missing(store, "/nonexistent/annotations.json", {});
    QCOMPARE(missing.wait().status(), Status::NotFound);
    const QString junk = tempPath("ann-junk.txt");
    writeFile(junk, "hello");
    AnnotationLoader notAnnotations(store, junk.toStdString(), {});
    const Result j = notAnnotations.wait();
    QCOMPARE(QString::fromStdString(j.message()), junk + ": neither GeoJSON nor XML (by its first character)");
    QCOMPARE(store.snapshot()->generation(), gen);
}

void TestAnnotationFormats::loaderCancels() {
    const QString path = tempPath("ann-cancel.geojson");
    writeFile(path, generatedGeoJson(60000, 12, 3));
    AnnotationStore store;
    const uint64_t gen = store.snapshot()->generation();
    // Cancelled from its own progress callback once parsing has begun (past the read pass).
    const uint64_t size = uint64_t(QFileInfo(path).size());
    std::atomic<AnnotationLoader*> self{nullptr};
    std::atomic<bool> cancelledMidParse{false};
    AnnotationLoader loader(store, path.toStdString(), {.progress = [&](uint64_t d, uint64_t) {
                                if (d > size && !cancelledMidParse) {
                                    while (!self.load()) std::this_thread::yield();
                                    self.load()->cancel();
                                    cancelledMidParse = true;
                                }
                            }});
    self = &loader;
    const Result r = loader.wait();
    QVERIFY(cancelledMidParse.load());
    QCOMPARE(r.status(), Status::Cancelled);
    QCOMPARE(QString::fromStdString(r.message()), path + ": reading GeoJSON was cancelled");
    QCOMPARE(store.snapshot()->generation(), gen);
    QCOMPARE(store.snapshot()->size(), size_t(0));
    // Cancelled at once (the destructor too cancels and joins).
    {
        AnnotationLoader early(store, path.toStdString(), {});
        early.cancel();
        QCOMPARE(early.wait().status(), Status::Cancelled);
    }
    QCOMPARE(store.snapshot()->generation(), gen);
}

QTEST_APPLESS_MAIN(TestAnnotationFormats)
#include "tst_annotation_formats.moc"
