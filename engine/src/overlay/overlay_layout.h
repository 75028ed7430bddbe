// Overlay layout: pure functions from (slide, viewport, overlay settings, text metrics) to
// where each overlay goes and what it is made of, in target pixels. The render thread runs
// it every frame; tests run it directly.
//
// Sizes are defined in logical pixels and scaled by the device pixel ratio, so overlays look
// the same on any screen; every box edge lies on a whole logical pixel, so that at an
// integer ratio r the whole layout is exactly r times the layout at ratio 1. The thumbnail
// and the bar's length are computed in device pixels (they measure the slide).
#pragma once

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "iris/types.h"
#include "overlay/legend.h"
#include "overlay/overlay_settings.h"
#include "view/view_model.h"

namespace iris::overlay {

// Layout constants, logical pixels.
struct Metrics {
    static constexpr int kMargin = 10;        // from the target's edge to the first overlay
    static constexpr int kGap = 6;            // between overlays stacked in one corner
    static constexpr int kPad = 6;            // plate around its content
    static constexpr int kTextSize = 13;      // label pixel size at ratio 1
    static constexpr int kBarHeight = 4;
    static constexpr int kBarLabelGap = 3;
    static constexpr double kBarMin = 80;     // the scale bar's length range
    static constexpr double kBarMax = 200;
    static constexpr double kOverviewMax = 180; // thumbnail's longer side at most …
    static constexpr double kOverviewFraction = 0.35; // … and at most this share of the target
    static constexpr double kOverviewMinSide = 24;    // smaller than this: not shown
    static constexpr int kOverviewPad = 3;
    static constexpr int kFieldLine = 2;      // the field outline's width
    static constexpr int kFieldMin = 4;       // the outline is at least this big
    static constexpr int kCrosshairArm = 12;  // the cross-hair's arms, from its centre
    static constexpr int kLegendBarWidth = 160; // the legend's colour bar, at least
    static constexpr int kLegendBarHeight = 10;
    static constexpr int kLegendNumberGap = 12; // between its low and high numbers, at least
    static constexpr int kLegendSwatch = 12;    // a label legend's class swatch (square)
    static constexpr int kLegendSwatchGap = 6;  // between a swatch and its class's name
    static constexpr int kLegendRowGap = 3;     // between class rows
};

// Colours, straight alpha.
inline constexpr std::array<float, 4> kPlateColour{0.0f, 0.0f, 0.0f, 0.6f};
inline constexpr std::array<float, 4> kTextColour{1.0f, 1.0f, 1.0f, 1.0f};
inline constexpr std::array<float, 4> kBarColour{1.0f, 1.0f, 1.0f, 1.0f};
inline constexpr std::array<float, 4> kFieldColour{0.0f, 1.0f, 1.0f, 1.0f};
inline constexpr std::array<float, 4> kCrosshairColour{1.0f, 1.0f, 0.0f, 1.0f};
inline constexpr std::array<float, 4> kCrosshairOutline{0.0f, 0.0f, 0.0f, 0.8f};

// The scale bar's length: the largest 1, 2 or 5 × 10^n µm that is at most maxPixels long at
// `micronsPerPixel`; the 1-2-5 steps are at most 2.5 apart, so it is at least maxPixels / 2.5.
// 0 when micronsPerPixel is not a positive number.
double niceScaleMicrons(double micronsPerPixel, double maxPixels);
std::string scaleLabel(double microns);        // "100 µm", "0.5 µm", "1 mm", "20 mm"
std::string magnificationLabel(double magnification); // "20.0×", "0.50×"
std::u32string decodeUtf8(const std::string& s);

// A label's extent as the font sets it, in logical pixels. ok = false: no font.
struct TextMetrics {
    bool ok = false;
    double width = 0;   // advance width
    double ascent = 0;  // above the baseline (the font's ascender, not this text's ink)
    double descent = 0; // below it, positive
};
using MeasureText = std::function<TextMetrics(const std::string& utf8)>;

struct Quad {
    double x0, y0, x1, y1; // target pixels
    std::array<float, 4> colour;
};
struct Label {
    std::string text;
    int x = 0;        // pen start, target pixels
    int baseline = 0;
};

// One overlay's drawing, clipped to `rect`: plate and backgrounds, then the thumbnail's
// tiles (overview), then bars and outlines, then labels.
struct OverlayDraw {
    Overlay which = Overlay::ScaleBar;
    PixelRect rect;
    std::vector<Quad> under;
    bool thumbnail = false;
    PixelRect thumbnailRect;  // where the thumbnail's tiles go (clip)
    Viewport thumbnailView;   // the slide seen at the thumbnail's downsample; its (0, 0) is
                              // thumbnailRect's top-left corner
    std::vector<Quad> over;
    std::vector<Label> labels;
    PixelRect legendBar;      // the legend's colour bar (a Scalar layer's legend only)
    std::vector<PixelRect> legendSwatches; // a Label layer's legend: one per class row
};

struct OverlayPlan {
    OverlayLayout layout;
    std::vector<OverlayDraw> draws;
};

// Lays out the visible overlays for a slide (null: none) shown in viewport. `measure` is
// called for the labels; `background` colours the thumbnail's area outside the slide;
// `legend` is what the legend shows (null: no layer qualifies, no legend).
OverlayPlan layoutOverlays(const SlideInfo* slide, const Viewport& viewport, const OverlaySettings& settings,
                           const MeasureText& measure, const std::array<float, 3>& background,
                           const LegendContent* legend = nullptr);

} // namespace iris::overlay
