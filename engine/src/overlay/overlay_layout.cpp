#include "overlay/overlay_layout.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

namespace iris::overlay {

namespace {

// d × 10^n, exact for negative n too (1/10 is not 0.1 × 1 in binary, but d / 10^-n rounds right).
double decimal(int d, int n) { return n >= 0 ? d * std::pow(10.0, n) : d / std::pow(10.0, -n); }

std::string shortest(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.10g", v);
    return buf;
}

void shift(OverlayDraw& d, int dx, int dy) {
    d.rect.x += dx;
    d.rect.y += dy;
    d.thumbnailRect.x += dx;
    d.thumbnailRect.y += dy;
    d.legendBar.x += dx;
    d.legendBar.y += dy;
    for (PixelRect& r : d.legendSwatches) {
        r.x += dx;
        r.y += dy;
    }
    for (auto* quads : {&d.under, &d.over}) {
        for (Quad& q : *quads) {
            q.x0 += dx;
            q.x1 += dx;
            q.y0 += dy;
            q.y1 += dy;
        }
    }
    for (Label& l : d.labels) {
        l.x += dx;
        l.baseline += dy;
    }
}

Quad quad(const PixelRect& r, const std::array<float, 4>& colour) {
    return {double(r.x), double(r.y), double(r.x + r.width), double(r.y + r.height), colour};
}

} // namespace

double niceScaleMicrons(double micronsPerPixel, double maxPixels) {
    if (!(micronsPerPixel > 0) || !std::isfinite(micronsPerPixel) || !(maxPixels > 0)) return 0;
    const double maxMicrons = micronsPerPixel * maxPixels;
    const int n = int(std::floor(std::log10(maxMicrons)));
    // log10 may land a hair off a power of ten: look one decade either side.
    for (int k = n + 1; k >= n - 1; --k) {
        for (int d : {5, 2, 1}) {
            const double v = decimal(d, k);
            if (v <= maxMicrons * (1 + 1e-12)) return v;
        }
    }
    return decimal(5, n - 2);
}

std::string scaleLabel(double microns) {
    if (microns >= 1000) return shortest(microns / 1000) + " mm";
    return shortest(microns) + " \u00B5m"; // MICRO SIGN
}

std::string magnificationLabel(double m) {
    const char* format = m >= 1000 ? "%.0f" : m >= 1 ? "%.1f" : m >= 0.1 ? "%.2f" : "%.3f";
    char buf[32];
    std::snprintf(buf, sizeof buf, format, m);
    return std::string(buf) + "\u00D7"; // MULTIPLICATION SIGN
}

std::u32string decodeUtf8(const std::string& s) {
    std::u32string out;
    for (size_t i = 0; i < s.size();) {
        const unsigned char c = static_cast<unsigned char>(s[i]);
        int extra = c < 0x80 ? 0 : (c >> 5) == 0x6 ? 1 : (c >> 4) == 0xE ? 2 : (c >> 3) == 0x1E ? 3 : -1;
        if (extra < 0 || i + size_t(extra) >= s.size()) {
            out.push_back(U'\uFFFD');
            ++i;
            continue;
        }
        char32_t cp = extra == 0 ? c : extra == 1 ? (c & 0x1F) : extra == 2 ? (c & 0x0F) : (c & 0x07);
        bool valid = true;
        for (int k = 1; k <= extra; ++k) {
            const unsigned char cc = static_cast<unsigned char>(s[i + size_t(k)]);
            if ((cc >> 6) != 0x2) valid = false;
            cp = (cp << 6) | (cc & 0x3F);
        }
        out.push_back(valid ? cp : U'\uFFFD');
        i += valid ? size_t(extra) + 1 : 1;
    }
    return out;
}

OverlayPlan layoutOverlays(const SlideInfo* slide, const Viewport& vp, const OverlaySettings& s,
                           const MeasureText& measure, const std::array<float, 3>& background,
                           const LegendContent* legend) {
    OverlayPlan plan;
    const View& v = vp.view;
    if (!slide || !s.visibleAny() || vp.width == 0 || vp.height == 0 || slide->width <= 0 || slide->height <= 0 ||
        !(v.downsample > 0) || !std::isfinite(v.downsample) || !std::isfinite(v.centerX) || !std::isfinite(v.centerY))
        return plan;
    const double r = s.devicePixelRatio > 0 && std::isfinite(s.devicePixelRatio) ? s.devicePixelRatio : 1.0;
    const auto px = [r](double logical) { return int32_t(std::lround(logical * r)); };
    OverlayLayout& out = plan.layout;
    std::array<std::optional<OverlayDraw>, kOverlayCount> items;

    // Scale bar: label above a bar of a round length, both centred on the plate.
    if (s.visible[size_t(Overlay::ScaleBar)] && slide->mppX > 0 && std::isfinite(slide->mppX)) {
        const double micronsPerPixel = slide->mppX * v.downsample; // per target (device) pixel
        const double microns = niceScaleMicrons(micronsPerPixel * r, Metrics::kBarMax);
        if (microns > 0) {
            const double barPixels = microns / micronsPerPixel;
            const double barLogical = barPixels / r;
            const std::string label = scaleLabel(microns);
            const TextMetrics tm = measure(label);
            const int textW = tm.ok ? int(std::ceil(tm.width)) : 0;
            const int ascent = tm.ok ? int(std::ceil(tm.ascent)) : 0;
            const int lineH = tm.ok ? ascent + int(std::ceil(tm.descent)) + Metrics::kBarLabelGap : 0;
            const int contentW = std::max(int(std::ceil(barLogical - 1e-9)), textW);
            const int w = contentW + 2 * Metrics::kPad, h = lineH + Metrics::kBarHeight + 2 * Metrics::kPad;
            OverlayDraw d;
            d.which = Overlay::ScaleBar;
            d.rect = {0, 0, px(w), px(h)};
            d.under.push_back(quad(d.rect, kPlateColour));
            const double barX = px(Metrics::kPad + std::floor((contentW - barLogical) / 2));
            d.over.push_back(Quad{barX, double(px(Metrics::kPad + lineH)), barX + barPixels,
                                  double(px(Metrics::kPad + lineH + Metrics::kBarHeight)), kBarColour});
            if (tm.ok) d.labels.push_back(Label{label, px(Metrics::kPad + (contentW - textW) / 2), px(Metrics::kPad + ascent)});
            out.scaleBarMicrons = microns;
            out.scaleBarPixels = barPixels;
            out.scaleBarLabel = label;
            items[size_t(Overlay::ScaleBar)] = std::move(d);
        }
    }

    // Magnification readout: a label on a plate; nothing to show without a font.
    const double objective = slide->effectiveObjectivePower();
    if (s.visible[size_t(Overlay::Magnification)] && objective > 0) {
        const double level0 = slide->levels.empty() ? 1.0 : slide->levels.front().downsample;
        const double m = objective * level0 / v.downsample;
        const std::string label = magnificationLabel(m);
        const TextMetrics tm = measure(label);
        if (tm.ok) {
            const int ascent = int(std::ceil(tm.ascent));
            const int w = int(std::ceil(tm.width)) + 2 * Metrics::kPad;
            const int h = ascent + int(std::ceil(tm.descent)) + 2 * Metrics::kPad;
            OverlayDraw d;
            d.which = Overlay::Magnification;
            d.rect = {0, 0, px(w), px(h)};
            d.under.push_back(quad(d.rect, kPlateColour));
            d.labels.push_back(Label{label, px(Metrics::kPad), px(Metrics::kPad + ascent)});
            out.magnification = m;
            out.magnificationLabel = label;
            items[size_t(Overlay::Magnification)] = std::move(d);
        }
    }

    // Overview: the whole slide at one downsample (its longer side fills the box), on the
    // background colour, inside a plate. The outline is added once the box is placed.
    double thumbDownsample = 0;
    if (s.visible[size_t(Overlay::Overview)]) {
        const double boxW = std::min(Metrics::kOverviewMax, Metrics::kOverviewFraction * vp.width / r);
        const double boxH = std::min(Metrics::kOverviewMax, Metrics::kOverviewFraction * vp.height / r);
        if (boxW >= Metrics::kOverviewMinSide && boxH >= Metrics::kOverviewMinSide) {
            const double maxW = std::floor(boxW * r), maxH = std::floor(boxH * r);
            const double W = double(slide->width), H = double(slide->height);
            thumbDownsample = std::max(W / maxW, H / maxH);
            const int imgW = std::max(1, int(std::ceil(W / thumbDownsample - 1e-6)));
            const int imgH = std::max(1, int(std::ceil(H / thumbDownsample - 1e-6)));
            const int pad = px(Metrics::kOverviewPad);
            OverlayDraw d;
            d.which = Overlay::Overview;
            d.rect = {0, 0, imgW + 2 * pad, imgH + 2 * pad};
            d.thumbnail = true;
            d.thumbnailRect = {pad, pad, imgW, imgH};
            d.thumbnailView.view = View{imgW * thumbDownsample / 2, imgH * thumbDownsample / 2, thumbDownsample};
            d.thumbnailView.width = uint32_t(imgW);
            d.thumbnailView.height = uint32_t(imgH);
            d.under.push_back(quad(d.rect, kPlateColour));
            d.under.push_back(quad(d.thumbnailRect, {background[0], background[1], background[2], 1.0f}));
            items[size_t(Overlay::Overview)] = std::move(d);
        }
    }

    // Legend: the title above a colour bar, the window's low and high numbers under its ends.
    // The bar is drawn one device-pixel column at a time, each the colour map at its centre's
    // t (opaque: the layer's opacity and the map's alpha are not shown), so it is the ramp the
    // layer pass uses; the text lines are left out without a font.
    if (s.visible[size_t(Overlay::Legend)] && legend && legend->kind == RasterKind::Label) {
        // A label map's legend: the title, then a row per class drawn: an opaque swatch of the
        // class's colour (the layer's opacity and the class's alpha are not shown, as the bar
        // does not show them), its name to the right, then "+N more" for classes left out.
        // Without a font only the swatches are drawn, one under the other.
        const auto lineHeight = [](const TextMetrics& tm) {
            return tm.ok ? int(std::ceil(tm.ascent)) + int(std::ceil(tm.descent)) : 0;
        };
        const auto textWidth = [](const TextMetrics& tm) { return tm.ok ? int(std::ceil(tm.width)) : 0; };
        const TextMetrics title = legend->title.empty() ? TextMetrics{} : measure(legend->title);
        const std::string moreLabel = legend->moreClasses > 0 ? legendMoreLabel(legend->moreClasses) : std::string();
        const TextMetrics more = moreLabel.empty() ? TextMetrics{} : measure(moreLabel);
        std::vector<TextMetrics> names;
        int nameW = 0, rowH = Metrics::kLegendSwatch;
        for (const LegendClass& c : legend->classes) {
            names.push_back(measure(c.name));
            nameW = std::max(nameW, textWidth(names.back()));
            rowH = std::max(rowH, lineHeight(names.back()));
        }
        const int titleH = title.ok ? lineHeight(title) + Metrics::kBarLabelGap : 0;
        const int moreH = more.ok ? lineHeight(more) + Metrics::kLegendRowGap : 0;
        const int rows = int(legend->classes.size());
        const int contentW = std::max({Metrics::kLegendSwatch + (nameW > 0 ? Metrics::kLegendSwatchGap + nameW : 0),
                                       textWidth(title), textWidth(more)});
        const int w = contentW + 2 * Metrics::kPad;
        const int h = titleH + rows * rowH + (rows - 1) * Metrics::kLegendRowGap + moreH + 2 * Metrics::kPad;
        OverlayDraw d;
        d.which = Overlay::Legend;
        d.rect = {0, 0, px(w), px(h)};
        d.under.push_back(quad(d.rect, kPlateColour));
        if (title.ok) d.labels.push_back(Label{legend->title, px(Metrics::kPad), px(Metrics::kPad + int(std::ceil(title.ascent)))});
        for (int i = 0; i < rows; ++i) {
            const int top = Metrics::kPad + titleH + i * (rowH + Metrics::kLegendRowGap);
            const int swatchTop = top + (rowH - Metrics::kLegendSwatch) / 2;
            const PixelRect swatch{px(Metrics::kPad), px(swatchTop), px(Metrics::kPad + Metrics::kLegendSwatch) - px(Metrics::kPad),
                                   px(swatchTop + Metrics::kLegendSwatch) - px(swatchTop)};
            const Rgba8 c = legend->classes[size_t(i)].color;
            d.over.push_back(quad(swatch, {c.r / 255.0f, c.g / 255.0f, c.b / 255.0f, 1.0f}));
            d.legendSwatches.push_back(swatch);
            const TextMetrics& tm = names[size_t(i)];
            if (tm.ok) {
                const int baseline = top + (rowH - lineHeight(tm)) / 2 + int(std::ceil(tm.ascent));
                d.labels.push_back(Label{legend->classes[size_t(i)].name,
                                         px(Metrics::kPad + Metrics::kLegendSwatch + Metrics::kLegendSwatchGap), px(baseline)});
            }
        }
        if (more.ok) {
            const int top = Metrics::kPad + titleH + rows * rowH + (rows - 1) * Metrics::kLegendRowGap + Metrics::kLegendRowGap;
            d.labels.push_back(Label{moreLabel, px(Metrics::kPad), px(top + int(std::ceil(more.ascent)))});
        }
        items[size_t(Overlay::Legend)] = std::move(d);
    } else if (s.visible[size_t(Overlay::Legend)] && legend) {
        const std::string lowLabel = legendNumber(legend->low), highLabel = legendNumber(legend->high);
        const TextMetrics title = legend->title.empty() ? TextMetrics{} : measure(legend->title);
        const TextMetrics lo = measure(lowLabel), hi = measure(highLabel);
        const auto lineHeight = [](const TextMetrics& tm) {
            return tm.ok ? int(std::ceil(tm.ascent)) + int(std::ceil(tm.descent)) + Metrics::kBarLabelGap : 0;
        };
        const auto textWidth = [](const TextMetrics& tm) { return tm.ok ? int(std::ceil(tm.width)) : 0; };
        const bool numbers = lo.ok && hi.ok;
        const int titleH = lineHeight(title), numbersH = numbers ? lineHeight(lo) : 0;
        const int contentW = std::max({Metrics::kLegendBarWidth, textWidth(title),
                                       numbers ? textWidth(lo) + Metrics::kLegendNumberGap + textWidth(hi) : 0});
        const int w = contentW + 2 * Metrics::kPad;
        const int h = titleH + Metrics::kLegendBarHeight + numbersH + 2 * Metrics::kPad;
        OverlayDraw d;
        d.which = Overlay::Legend;
        d.rect = {0, 0, px(w), px(h)};
        d.under.push_back(quad(d.rect, kPlateColour));
        const PixelRect bar{px(Metrics::kPad), px(Metrics::kPad + titleH), px(Metrics::kPad + contentW) - px(Metrics::kPad),
                            px(Metrics::kPad + titleH + Metrics::kLegendBarHeight) - px(Metrics::kPad + titleH)};
        for (int32_t i = 0; i < bar.width; ++i) {
            const std::array<double, 4> c = legend->colorMap.at((i + 0.5) / bar.width);
            d.over.push_back(quad({bar.x + i, bar.y, 1, bar.height},
                                  {float(c[0] / 255), float(c[1] / 255), float(c[2] / 255), 1.0f}));
        }
        if (title.ok) d.labels.push_back(Label{legend->title, px(Metrics::kPad), px(Metrics::kPad + int(std::ceil(title.ascent)))});
        if (numbers) {
            const int baseline = Metrics::kPad + titleH + Metrics::kLegendBarHeight + Metrics::kBarLabelGap +
                                 int(std::ceil(lo.ascent));
            d.labels.push_back(Label{lowLabel, px(Metrics::kPad), px(baseline)});
            d.labels.push_back(Label{highLabel, px(Metrics::kPad + contentW - textWidth(hi)), px(baseline)});
        }
        d.legendBar = bar;
        items[size_t(Overlay::Legend)] = std::move(d);
    }

    // Placement: per corner, in the order of Overlay, from the corner inwards (downwards from
    // a top corner, upwards from a bottom one). An overlay that does not fit is left out.
    const int32_t margin = px(Metrics::kMargin), gap = px(Metrics::kGap);
    const int32_t W = int32_t(vp.width), H = int32_t(vp.height);
    std::array<int32_t, 4> offset{margin, margin, margin, margin};
    for (size_t i = 0; i < items.size(); ++i) {
        if (!items[i]) continue;
        OverlayDraw& d = *items[i];
        const Corner c = s.corner[i];
        const bool left = c == Corner::TopLeft || c == Corner::BottomLeft;
        const bool top = c == Corner::TopLeft || c == Corner::TopRight;
        int32_t& o = offset[size_t(c)];
        const int32_t x = left ? margin : W - margin - d.rect.width;
        const int32_t y = top ? o : H - o - d.rect.height;
        if (x < 0 || y < 0 || x + d.rect.width > W || y + d.rect.height > H) continue;
        o += d.rect.height + gap;
        shift(d, x, y);
        out.rects[i] = d.rect;
        if (!d.labels.empty()) out.text = true;
        if (d.which == Overlay::Legend) {
            out.legendLayer = legend->layer;
            out.legendTitle = legend->title;
            if (legend->kind == RasterKind::Label) {
                out.legendSwatches = d.legendSwatches;
                for (const LegendClass& c : legend->classes) {
                    out.legendClassIds.push_back(c.id);
                    out.legendClassNames.push_back(c.name);
                }
                out.legendMoreClasses = legend->moreClasses;
            } else {
                out.legendBar = d.legendBar;
                out.legendLowLabel = legendNumber(legend->low);
                out.legendHighLabel = legendNumber(legend->high);
            }
        }
        if (d.which == Overlay::Overview) {
            const PixelRect& img = d.thumbnailRect;
            out.overviewImage = img;
            out.overviewDownsample = thumbDownsample;
            // The view's field in target pixels, then the part of it on the slide, outlined.
            const ViewTransform vt = ViewTransform::of(v, vp.width, vp.height);
            const double W0 = vp.width, H0 = vp.height;
            const std::array<std::array<double, 2>, 4> targetCorners{{{0, 0}, {W0, 0}, {W0, H0}, {0, H0}}};
            std::array<std::array<double, 2>, 4> corner{};
            for (size_t k = 0; k < 4; ++k) {
                const auto sp = vt.toSlide(targetCorners[k][0], targetCorners[k][1]);
                corner[k] = {img.x + sp[0] / thumbDownsample, img.y + sp[1] / thumbDownsample};
                out.overviewFieldCorners[2 * k] = corner[k][0];
                out.overviewFieldCorners[2 * k + 1] = corner[k][1];
            }
            const auto [bx0, by0, bx1, by1] = fieldBounds(vp);
            const double fx0 = img.x + bx0 / thumbDownsample, fy0 = img.y + by0 / thumbDownsample;
            const double fx1 = img.x + bx1 / thumbDownsample, fy1 = img.y + by1 / thumbDownsample;
            out.overviewField = {fx0, fy0, fx1, fy1};
            const double sx1 = img.x + double(slide->width) / thumbDownsample;
            const double sy1 = img.y + double(slide->height) / thumbDownsample;
            const double cx0 = std::max(fx0, double(img.x)), cx1 = std::min(fx1, sx1);
            const double cy0 = std::max(fy0, double(img.y)), cy1 = std::min(fy1, sy1);
            if (!vt.axisAligned()) {
                // A turned field: its four sides stroked as runs of t×t squares, one per pixel
                // step along each side (the overlay pipeline draws axis-aligned quads only),
                // within the thumbnail.
                const int32_t t = std::max(1, px(Metrics::kFieldLine));
                const double clipX1 = std::min(sx1, double(img.x + img.width));
                const double clipY1 = std::min(sy1, double(img.y + img.height));
                for (size_t k = 0; k < 4; ++k) {
                    const auto& a = corner[k];
                    const auto& b = corner[(k + 1) % 4];
                    const double len = std::max(std::abs(b[0] - a[0]), std::abs(b[1] - a[1]));
                    const int steps = int(std::min(4096.0, std::ceil(len)));
                    for (int i = 0; i <= steps; ++i) {
                        const double f = steps > 0 ? double(i) / steps : 0.0;
                        const int32_t x = int32_t(std::lround(a[0] + (b[0] - a[0]) * f - t / 2.0));
                        const int32_t y = int32_t(std::lround(a[1] + (b[1] - a[1]) * f - t / 2.0));
                        if (x < img.x || y < img.y || x + t > clipX1 || y + t > clipY1) continue;
                        d.over.push_back(quad({x, y, t, t}, kFieldColour));
                    }
                }
            } else             if (cx0 < cx1 && cy0 < cy1) {
                const int32_t minSide = std::min({px(Metrics::kFieldMin), img.width, img.height});
                const auto span = [minSide](double a, double b, int32_t lo, int32_t hi) {
                    int32_t i0 = int32_t(std::lround(a)), i1 = int32_t(std::lround(b));
                    if (i1 - i0 < minSide) {
                        i0 = int32_t(std::lround((a + b) / 2 - minSide / 2.0));
                        i1 = i0 + minSide;
                    }
                    if (i0 < lo) i1 += lo - i0, i0 = lo;
                    if (i1 > hi) i0 -= i1 - hi, i1 = hi;
                    return std::pair{i0, i1};
                };
                const auto [x0, x1] = span(cx0, cx1, img.x, img.x + img.width);
                const auto [y0, y1] = span(cy0, cy1, img.y, img.y + img.height);
                const int32_t t = std::max(1, std::min({px(Metrics::kFieldLine), (x1 - x0) / 2, (y1 - y0) / 2}));
                d.over.push_back(quad({x0, y0, x1 - x0, t}, kFieldColour));
                d.over.push_back(quad({x0, y1 - t, x1 - x0, t}, kFieldColour));
                d.over.push_back(quad({x0, y0 + t, t, y1 - y0 - 2 * t}, kFieldColour));
                d.over.push_back(quad({x1 - t, y0 + t, t, y1 - y0 - 2 * t}, kFieldColour));
            }
        }
        plan.draws.push_back(std::move(d));
    }

    // The cross-hair: a plus of light arms on a dark outline, centred on the slide point's
    // pixel, over everything else; left out when its centre is off the target.
    if (s.crosshair) {
        const auto p = ViewTransform::of(v, vp.width, vp.height).toTarget((*s.crosshair)[0], (*s.crosshair)[1]);
        if (std::isfinite(p[0]) && std::isfinite(p[1]) && p[0] >= 0 && p[1] >= 0 && p[0] < vp.width &&
            p[1] < vp.height) {
            const int32_t cx = int32_t(std::floor(p[0])), cy = int32_t(std::floor(p[1]));
            const int32_t arm = px(Metrics::kCrosshairArm), line = std::max(1, px(1));
            OverlayDraw d;
            d.rect = {cx - arm - line, cy - arm - line, 2 * (arm + line) + line, 2 * (arm + line) + line};
            d.over.push_back(quad({cx - arm - line, cy - line, 2 * (arm + line) + line, 3 * line}, kCrosshairOutline));
            d.over.push_back(quad({cx - line, cy - arm - line, 3 * line, 2 * (arm + line) + line}, kCrosshairOutline));
            d.over.push_back(quad({cx - arm, cy, 2 * arm + line, line}, kCrosshairColour));
            d.over.push_back(quad({cx, cy - arm, line, 2 * arm + line}, kCrosshairColour));
            plan.draws.push_back(std::move(d));
        }
    }
    return plan;
}

} // namespace iris::overlay
