// Iris View widget — not API. Objective magnification ↔ downsample, and zoom limits.
#pragma once

#include <array>

#include <iris/types.h>

#include "autotest_p.h"

namespace IrisWidget {

// The magnifications keys 1–4 (and the demo's View menu) jump to.
inline constexpr std::array<double, 4> kMagnificationPresets{5.0, 10.0, 20.0, 40.0};

// (The objective itself: iris::SlideInfo::effectiveObjectivePower, the engine's rule.)

// objective × level-0 downsample / downsample; 0 when the objective is unknown.
double magnificationFor(const iris::SlideInfo &info, double downsample);
// The downsample that shows the slide at magnification; 0 when that is impossible.
double downsampleFor(const iris::SlideInfo &info, double magnification);

// `view` with its centre moved by under half a target pixel on each axis onto the pixel grid
// of the level whose downsample it is at (when it is at one, turned by a multiple of 90°), so
// that every target pixel's centre falls on a level pixel's centre: the level is then shown as
// it is, one slide pixel to one device pixel, with no interpolation blurring it by half a pixel
// (and the engine draws it by its cheapest path, render::drawsExact). Any other view is returned
// unchanged. width and height: the target's, device pixels. Panning by whole device pixels
// keeps the alignment.
IRIS_WIDGET_AUTOTEST_EXPORT iris::View alignedToLevelPixels(const iris::SlideInfo &info, iris::View view,
                                                            int width, int height);

// How far in and out the view may zoom: from 8 device pixels per level-0 pixel up to a
// quarter of the fitted size (never less than fitDownsample itself).
struct ZoomLimits {
    double minDownsample = 0.125;
    double maxDownsample = 1;
    double clamp(double downsample) const;
};
ZoomLimits zoomLimitsFor(const iris::SlideInfo &info, double fitDownsample);

} // namespace IrisWidget
