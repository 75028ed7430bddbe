// Iris View widget — not API. The editing tools' geometry as pure functions (the view model's
// style: no widget, no store, testable alone): boxes from a drag, moving an object or one of its
// vertex handles, thinning a freehand path, the brush's outline (GEOS) and the readouts.
// Coordinates are level-0 pixels.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <iris/annotations.h>

#include "autotest_p.h"

namespace IrisWidget {

// The box with corners a and b; with `square`, the side is the larger of the two extents and
// the box grows from a towards b.
IRIS_WIDGET_AUTOTEST_EXPORT iris::Box2 boxFromDrag(iris::Point2 a, iris::Point2 b, bool square);

// The object moved by (dx, dy).
IRIS_WIDGET_AUTOTEST_EXPORT iris::AnnotationObject translated(iris::AnnotationObject o, double dx, double dy);

// A vertex handle of an object, where the engine draws one for the selection: every vertex of
// points, polylines and polygon rings, a rectangle's four corners (0 top-left, 1 top-right,
// 2 bottom-right, 3 bottom-left) and an ellipse's four extremes (0 right, 1 bottom, 2 left, 3 top).
struct VertexHandle
{
    iris::Point2 position;
    int polygon = -1; // Polygon: the part
    int ring = -1; // Polygon: 0 outer, 1.. holes
    int vertex = -1; // the vertex (or corner / extreme)
};
IRIS_WIDGET_AUTOTEST_EXPORT std::vector<VertexHandle> vertexHandles(const iris::AnnotationObject &o);
// The object with that handle moved to `to`. A rectangle keeps the opposite corner, an ellipse
// the opposite side; a box dragged over its opposite side is turned the right way round.
IRIS_WIDGET_AUTOTEST_EXPORT iris::AnnotationObject withHandleMoved(
    iris::AnnotationObject o, const VertexHandle &handle, iris::Point2 to);

// Appends p unless it lies within minDistance of the last point kept (freehand, brush paths).
IRIS_WIDGET_AUTOTEST_EXPORT void appendThinned(std::vector<iris::Point2> &path, iris::Point2 p, double minDistance);
// Consecutive points closer than minDistance merged (a double click's two presses), and the
// last dropped when it meets the first (a ring is stored open).
IRIS_WIDGET_AUTOTEST_EXPORT std::vector<iris::Point2> withoutRepeats(
    const std::vector<iris::Point2> &ring, double minDistance);

// The area a disc of `radius` covers when dragged along `path`: the union of the discs stamped
// at every point of it (GEOS's buffer of the path, 8 segments a quarter circle). Empty parts
// when GEOS fails (*error says why).
IRIS_WIDGET_AUTOTEST_EXPORT std::vector<iris::PolygonPart> brushOutline(
    const std::vector<iris::Point2> &path, double radius, std::string *error);

// Readouts. mppX/mppY: µm per level-0 pixel, 0 when the slide does not say (then pixels).
struct Measurement
{
    double length = 0; // polyline length, or perimeter of a closed shape (every ring)
    double area = 0; // closed shapes: outer rings less holes
    bool closed = false;
    bool physical = false; // µm and µm² (else pixels)
    int points = 0; // Point objects: how many
};
IRIS_WIDGET_AUTOTEST_EXPORT Measurement measure(const iris::AnnotationObject &o, double mppX, double mppY);
// "perimeter 740 µm, area 0.0300 mm²", "length 1.23 mm", "3 points"; µm below 1 mm and µm²
// below 1 mm², mm and mm² from there up; px and px² without mpp.
IRIS_WIDGET_AUTOTEST_EXPORT std::string measurementText(const iris::AnnotationObject &o, double mppX, double mppY);

} // namespace IrisWidget
