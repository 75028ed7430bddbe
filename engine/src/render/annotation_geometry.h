// What the annotation pass draws for a view (docs/ANNOTATIONS.md, "Drawing"): a pure function
// from (annotation snapshot, viewport, selection) to fill triangles and strokes in target
// pixels, with no Vulkan in it, tested against brute force and a CPU rasteriser like
// render/draw_list is. The render thread calls it in the pass's prepare().
//
//   1. The view's footprint (the target grown by a margin for outlines and handles, turned with
//      the view) in level-0 pixels. When the snapshot holds more objects than the budget, the
//      fit-view aggregate (AnnotationSnapshot::overview) counts more than the budget in the
//      footprint and its cells are at most a few pixels apart on screen, the cells are drawn as
//      dots and nothing else: bounded work at fit view whatever the count.
//   2. Otherwise the drawn objects the footprint touches (the R-tree query), each at its level
//      of detail (annotationLod): a dot, an outline, or an outline over its fill. Points are
//      dots of a fixed size. Outlines are capsules of the object's line width in screen pixels
//      (constant at every zoom), with vertices closer than half a pixel to the last one kept
//      merged and segments wholly off the target left out.
//   3. The selected object again on top: a contrasting outline and a square handle at each
//      vertex.
//
// Fills of polygons not yet triangulated (GEOS, tens of microseconds each, then cached) are
// made within a time budget per frame; those left over are drawn next frame (`complete` false).
#pragma once

#include <cstdint>
#include <vector>

#include "gpu/annotation_vertex.h"
#include "iris/annotations.h"
#include "view/view_model.h"

namespace iris::render {

struct AnnotationBudget {
    // More drawn objects than maxObjects in the footprint, and the fit-view aggregate's cells no
    // more than aggregateCellPixels apart on screen: the cells are drawn instead of the objects
    // (a dot each). Where cells would be further apart the objects are drawn, so that the
    // aggregate does not show visibly coarser than the data — up to hardMaxObjects, beyond
    // which the cells are drawn whatever their spacing (a frame's work stays bounded: 10^5 dots
    // cost the render thread ~30 ms to build on the H200).
    size_t maxObjects = 20000;
    double aggregateCellPixels = 8.0;
    size_t hardMaxObjects = 100000;
    double triangulateMs = 4.0;   // new fill triangulations a frame, wall time
    size_t maxHandles = 20000;    // vertex handles of the selected object
};

// Sizes in target pixels.
inline constexpr float kAnnotationDotRadius = 1.5f;   // an object drawn as a dot (LOD)
inline constexpr float kAnnotationPointRadius = 4.0f; // a Point object's points
inline constexpr float kAnnotationHandleHalf = 4.0f;  // vertex handles: a dark square, a light one 1.5 px inside
inline constexpr float kAnnotationMarginPx = 16.0f;   // the footprint's growth for outlines near the edge
inline constexpr uint32_t kAnnotationSelectedRgba = 0xFF00FFFFu; // yellow (R, G = 255), opaque

struct AnnotationGeometry {
    std::vector<gpu::AnnotationFillVertex> fills; // triangle list
    std::vector<gpu::AnnotationStroke> strokes;   // drawn after the fills, in order
    uint32_t objects = 0;       // objects drawn (cells when `overview`)
    uint32_t dots = 0;          // of them, drawn as dots
    bool overview = false;      // the fit-view aggregate was drawn instead of the objects
    bool complete = true;       // every fill that should show is in `fills`
    std::vector<std::string> errors; // fills that could not be made (a zero-area polygon)
    void clear();
};

// RGBA8 with R in the low byte (the shaders' R8G8B8A8_UNORM attribute).
inline uint32_t packRgba(Rgba8 c) {
    return uint32_t(c.r) | uint32_t(c.g) << 8 | uint32_t(c.b) << 16 | uint32_t(c.a) << 24;
}

void buildAnnotationGeometry(const AnnotationSnapshot& snap, const Viewport& vp, uint64_t selected,
                             const AnnotationBudget& budget, AnnotationGeometry& out);

} // namespace iris::render
