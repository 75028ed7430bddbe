// The annotation pass's vertex data, without Vulkan (render/annotation_geometry builds them and
// is tested without a device).
#pragma once

#include <cstdint>

namespace iris::gpu {

// One stroke instance; the layout matches shaders/annotation_stroke.vert.
struct AnnotationStroke {
    float p0[2], p1[2]; // target pixels; p0 == p1: a dot
    float halfWidth;    // pixels; negative: a square of that half side centred on p0 (a handle)
    uint32_t colour;    // RGBA8 (R in the low byte), straight alpha
};
static_assert(sizeof(AnnotationStroke) == 24);

// One fill vertex (triangle lists); the layout matches shaders/annotation_fill.vert.
struct AnnotationFillVertex {
    float p[2];      // target pixels
    uint32_t colour; // RGBA8 (R in the low byte), straight alpha, the fill opacity included
};
static_assert(sizeof(AnnotationFillVertex) == 12);

} // namespace iris::gpu
