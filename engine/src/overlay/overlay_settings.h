// What the API publishes about overlays (a member of the Snapshot every engine thread
// copies): which are on, where, the host's device pixel ratio and the loaded font.
#pragma once

#include <algorithm>
#include <array>
#include <memory>
#include <optional>

#include "iris/types.h"
#include "overlay/font.h"

namespace iris::overlay {

struct OverlaySettings {
    std::array<bool, kOverlayCount> visible{};
    std::array<Corner, kOverlayCount> corner{Corner::BottomLeft, Corner::TopLeft, Corner::TopRight,
                                                 Corner::BottomRight};
    double devicePixelRatio = 1;
    std::shared_ptr<const FontData> font; // null: no usable font, labels are not drawn
    // A cross-hair at this level-0 slide position (Engine::setCrosshair); none: not drawn.
    std::optional<std::array<double, 2>> crosshair;

    bool visibleAny() const {
        return std::find(visible.begin(), visible.end(), true) != visible.end() || crosshair.has_value();
    }
};

} // namespace iris::overlay
