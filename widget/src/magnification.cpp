#include "magnification_p.h"

#include <algorithm>
#include <cmath>

namespace IrisWidget {

static double levelZeroDownsample(const iris::SlideInfo &info)
{
    return info.levels.empty() ? 1.0 : info.levels.front().downsample;
}

double magnificationFor(const iris::SlideInfo &info, double downsample)
{
    const double objective = info.effectiveObjectivePower();
    if (objective <= 0 || !(downsample > 0))
        return 0;
    return objective * levelZeroDownsample(info) / downsample;
}

double downsampleFor(const iris::SlideInfo &info, double magnification)
{
    const double objective = info.effectiveObjectivePower();
    if (objective <= 0 || !(magnification > 0) || !std::isfinite(magnification))
        return 0;
    return objective * levelZeroDownsample(info) / magnification;
}

iris::View alignedToLevelPixels(const iris::SlideInfo &info, iris::View view, int width, int height)
{
    if (width <= 0 || height <= 0 || !std::isfinite(view.centerX) || !std::isfinite(view.centerY))
        return view;
    const auto level = std::find_if(info.levels.begin(), info.levels.end(),
                                    [&](const iris::LevelInfo &l) { return l.downsample == view.downsample; });
    if (level == info.levels.end())
        return view;
    const iris::ViewTransform t = iris::ViewTransform::of(view, width, height);
    if (!t.axisAligned())
        return view;
    // The first target pixel's centre lies at slide position centre + offset, offset being a
    // multiple of half the downsample (M's entries are 0 and ±1, the target's centre a multiple
    // of a half). Putting it on the centre of the level's pixel k, k + 1/2 level pixels from the
    // origin, puts every pixel centre on one. Computed from k rather than by nudging the
    // centre, so that the new centre is exact where the downsample is (a power of two, a whole
    // number), as the engine's placement then is.
    const double ds = view.downsample, lds = level->downsample;
    const double dx = 0.5 - t.targetCX, dy = 0.5 - t.targetCY;
    const double offsetX = (t.m[0] * dx + t.m[2] * dy) * ds, offsetY = (t.m[1] * dx + t.m[3] * dy) * ds;
    const double kx = std::floor((view.centerX + offsetX) / lds), ky = std::floor((view.centerY + offsetY) / lds);
    const double cx = (kx + 0.5) * lds - offsetX, cy = (ky + 0.5) * lds - offsetY;
    if (!std::isfinite(cx) || !std::isfinite(cy))
        return view;
    view.centerX = cx;
    view.centerY = cy;
    return view;
}

double ZoomLimits::clamp(double downsample) const
{
    return std::clamp(downsample, minDownsample, maxDownsample);
}

ZoomLimits zoomLimitsFor(const iris::SlideInfo &info, double fitDownsample)
{
    ZoomLimits limits;
    limits.minDownsample = 0.125 * levelZeroDownsample(info);
    const double coarsest = info.levels.empty() ? 1.0 : info.levels.back().downsample;
    limits.maxDownsample = std::max({fitDownsample * 4, coarsest, limits.minDownsample});
    return limits;
}

} // namespace IrisWidget
