// Iris View widget — not API. Converts the engine's slide description to IrisSlideInfo.
#pragma once

#include <iris/types.h>

#include "iris/IrisSlideInfo.h"

namespace IrisWidget {
IrisSlideInfo toSlideInfo(const iris::SlideInfo &info);
}
