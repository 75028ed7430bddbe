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
