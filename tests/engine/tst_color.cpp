// Colour management on the GPU (docs/COLOR.md): the tile shader's colour step against
// LittleCMS applied on the CPU to the same source pixels.
//
//   * For slides with an embedded profile (the TCGA SVS and the generic TIFF of the shared test
//     data when they carry one, and a generated slide with a profile of strong curves, as TIFF
//     and encoded as .iris), a 1:1
//     integer-aligned frame with colour management on is compared pixel by pixel with the same
//     frame off (the slide's stored bytes, which the pixel-exact suites check against
//     OpenSlide) passed through LittleCMS: CIEDE2000, as the display shows both colours, at
//     most 1.0 at the 99th percentile and 2.0 at the maximum; and with the CPU model of the
//     table's trilinear lookup (tests/support/color_reference.h), within one 8-bit step.
//   * Shrunk, shifted and magnified views (mip levels, filtering between texels): the colour
//     step follows the filter, so against LittleCMS applied to the same view drawn without the
//     transform (whose filtered colours are rounded to 8 bits, which the comparison allows for),
//     the same ΔE2000 limits.
//   * Both intents and a display profile that is not sRGB.
//   * A slide without a profile, colour management on: frames byte-identical to it off.
//   * A broken profile: a status error and a warning, the slide drawn untransformed (frames
//     byte-identical to colour off), nothing else affected.
//   * Switching at runtime changes the next frame, and back.
#include <QtTest>

#include <algorithm>
#include <filesystem>
#include <tiffio.h>

#include <iris/encoder.h>

#include "color_reference.h"
#include "test_support.h"

using namespace iristest;
using namespace std::chrono_literals;
namespace ref = iristest::color;

namespace {

constexpr uint32_t kW = 512, kH = 384;

struct Stats {
    double p99 = 0, max = 0;
    int maxLutStep = 0; // largest difference from the CPU model of the table, in 8-bit steps
    size_t offModel = 0; // pixels that differ from it at all
    size_t pixels = 0;
};

} // namespace

class TestColor : public QObject {
    Q_OBJECT
private slots:
    void initTestCase();
    void cleanupTestCase();
    void init() { engine_.beginTest(); }
    void cleanup() {
        const std::string problems = engine_.endTest();
        QVERIFY2(problems.empty(), problems.c_str());
    }

    void profiledSlidesMatchLittleCms_data();
    void profiledSlidesMatchLittleCms();
    void shrunkAndShiftedViewsMatchLittleCms_data();
    void shrunkAndShiftedViewsMatchLittleCms();
    void slideWithoutProfileIsUnchanged();
    void brokenProfileFallsBackToNoTransform();
    void switchingAtRuntime();
    void associatedImagesForDisplay();

private:
    // A frame of `path` at level 0, top-left corner (x0, y0), with `settings`.
    std::optional<iris::Frame> frameOf(const QString& path, double x0, double y0, const iris::ColorSettings& settings,
                                       double downsample = 1.0);
    // Over the frame's pixels that show the slide (x < w, y < h: the rest is the background,
    // which is not slide colour and is never transformed).
    // rounded: the frame drawn off holds filtered colours rounded to 8 bits, while the colour
    // step transforms the filtered colour itself (between two codes): a pixel over 1.0 is then
    // compared with the nearest of LittleCMS's results for the off pixel's channels moved by
    // −½ … +1 code (rounding to nearest or toward zero, which Vulkan both allows), so that only
    // the outliers that rounding explains are forgiven (where the transform is steep).
    Stats compare(const iris::Frame& off, const iris::Frame& on, uint32_t w, uint32_t h,
                  const std::vector<uint8_t>& profile, const iris::ColorSettings& settings,
                  const iris::color::Lut3D* lut, bool rounded = false);

    TestEngine engine_;
    fs::path dir_;
};

void TestColor::initTestCase() {
    // Each comparison draws a view with colour management off (the source pixels LittleCMS is
    // applied to) and on: both must be drawn the same way. On a CPU device the resolve on the
    // host (render/host_resolve.h) serves the first and never the second (no colour step
    // there), and rounds differently from the quads; engine.host_resolve compares the two.
    // (Elsewhere the default draws both alike: per pixel on a GPU's offscreen targets.)
    engine_ = createTestEngine();
    if (engine_ && engine_->device().tileUpload == "host") { // where the host resolve is
        QVERIFY(engine_.finish().empty());
        iris::EngineConfig quads;
        quads.tuning.tileResolve = iris::EngineTuning::TileResolve::Quads;
        engine_ = createTestEngine(quads);
    }
    QVERIFY2(engine_, describe(engine_.error).c_str());
    QVERIFY(engine_->bindOffscreen(kW, kH).ok());
    dir_ = testOutDir() / "color";
    fs::create_directories(dir_);
    std::string error;
    QVERIFY2(writeOneLevelTiff(dir_ / "strong-curves.tiff", 2048, 1536, {}, &error, ref::strongCurvesProfile()),
             error.c_str());
    QVERIFY2(writeOneLevelTiff(dir_ / "no-profile.tiff", 2048, 1536, {}, &error), error.c_str());
    // The same slide as .iris: the profile goes through the encoder's ICC_PROFILE block and the
    // .iris reader (the reference encoders' fixtures in the shared test data carry none).
    const auto encoded =
        iris::encodeIris((dir_ / "strong-curves.tiff").string(), (dir_ / "strong-curves.iris").string());
    QVERIFY2(encoded.ok(), describe(encoded.error()).c_str());
    std::vector<uint8_t> truncated = ref::strongCurvesProfile();
    truncated.resize(truncated.size() / 2);
    QVERIFY2(writeOneLevelTiff(dir_ / "broken-profile.tiff", 2048, 1536, {}, &error, truncated), error.c_str());
}

void TestColor::cleanupTestCase() {
    const std::string problems = engine_.finish();
    QVERIFY2(problems.empty(), problems.c_str());
}

std::optional<iris::Frame> TestColor::frameOf(const QString& path, double x0, double y0,
                                              const iris::ColorSettings& settings, double downsample) {
    iris::Engine& e = *engine_.engine;
    e.setColorSettings(settings);
    if (const iris::Result r = e.open(path.toStdString()); !r.ok()) {
        qWarning("%s", describe(r).c_str());
        return std::nullopt;
    }
    std::string why;
    auto f = renderView(e, viewWithOrigin(x0, y0, downsample, kW, kH), kW, kH, 60s, &why);
    if (!f) qWarning("%s", why.c_str());
    return f;
}

Stats TestColor::compare(const iris::Frame& off, const iris::Frame& on, uint32_t w, uint32_t h,
                         const std::vector<uint8_t>& profile, const iris::ColorSettings& settings,
                         const iris::color::Lut3D* lut, bool rounded) {
    Stats s;
    std::string error;
    const auto intent = settings.intent == iris::RenderingIntent::RelativeColorimetric
                            ? ref::Intent::RelativeColorimetric
                            : ref::Intent::Perceptual;
    const auto transform = ref::Transform::create(profile, settings.displayProfile, intent, &error);
    const auto lab = ref::LabConverter::create(settings.displayProfile, &error);
    if (!transform || !lab) {
        qWarning("LittleCMS: %s", error.c_str());
        s.p99 = s.max = 1e9;
        return s;
    }
    std::vector<double> de;
    de.reserve(size_t(kW) * kH);
    for (size_t i = 0; i < size_t(kW) * kH; ++i) {
        if (i % kW >= w || i / kW >= h) continue;
        const uint8_t* src = &off.image.rgba[i * 4];
        const uint8_t* got = &on.image.rgba[i * 4];
        const std::array<uint8_t, 3> want = transform->apply8(src[0], src[1], src[2]);
        const std::array<uint8_t, 3> shown{got[0], got[1], got[2]};
        const ref::Lab shownLab = lab->toLab(shown);
        double d = ref::deltaE2000(shownLab, lab->toLab(want));
        if (rounded && d > 1.0) { // an outlier: the nearest within the off pixel's rounding
            constexpr float kSteps[] = {-0.5f, 0.0f, 0.5f, 1.0f};
            for (float dr : kSteps)
                for (float dg : kSteps)
                    for (float db : kSteps) {
                        const float in[3] = {std::clamp((float(src[0]) + dr) / 255.0f, 0.0f, 1.0f),
                                             std::clamp((float(src[1]) + dg) / 255.0f, 0.0f, 1.0f),
                                             std::clamp((float(src[2]) + db) / 255.0f, 0.0f, 1.0f)};
                        float out[3];
                        transform->apply(in, out, 1);
                        std::array<uint8_t, 3> alt;
                        for (int c = 0; c < 3; ++c) alt[c] = uint8_t(std::lround(std::clamp(out[c], 0.0f, 1.0f) * 255.0f));
                        d = std::min(d, ref::deltaE2000(shownLab, lab->toLab(alt)));
                    }
        }
        de.push_back(d);
        if (lut) {
            const std::array<uint8_t, 3> model = ref::applyLut(*lut, src[0], src[1], src[2]);
            int step = 0;
            for (int c = 0; c < 3; ++c) step = std::max(step, std::abs(int(model[c]) - int(got[c])));
            s.maxLutStep = std::max(s.maxLutStep, step);
            if (step > 0) ++s.offModel;
        }
    }
    s.pixels = de.size();
    if (de.empty()) return s;
    std::sort(de.begin(), de.end());
    s.p99 = de[size_t(double(de.size() - 1) * 0.99)];
    s.max = de.back();
    return s;
}

void TestColor::profiledSlidesMatchLittleCms_data() {
    QTest::addColumn<QString>("slide");
    QTest::addColumn<double>("x0");
    QTest::addColumn<double>("y0");
    QTest::addColumn<int>("intent");
    QTest::addColumn<bool>("wideDisplay");
    const QString strong = QString::fromStdString((dir_ / "strong-curves.tiff").string());
    QTest::newRow("strong curves, perceptual, sRGB") << strong << 512.0 << 256.0 << 0 << false;
    QTest::newRow("strong curves, relative, sRGB") << strong << 512.0 << 256.0 << 1 << false;
    QTest::newRow("strong curves, perceptual, wide gamut display") << strong << 512.0 << 256.0 << 0 << true;
    const QString strongIris = QString::fromStdString((dir_ / "strong-curves.iris").string());
    QTest::newRow("strong curves as .iris, perceptual, sRGB") << strongIris << 512.0 << 256.0 << 0 << false;
    if (auto slides = slidesDir()) {
        for (const char* f :
             {"aperio/tcga-cr-7395-01a-01-ts1.svs", "aperio/CMU-1-Small-Region.svs", "generic-tiff/boxes.tiff"}) {
            const fs::path p = *slides / f;
            if (!fs::exists(p) || tiffIccProfile(p).empty()) continue;
            const double origin = std::string(f).find("boxes") != std::string::npos ? 0.0 : 256.0; // a small slide
            QTest::newRow((std::string(f) + ", perceptual, sRGB").c_str())
                << QString::fromStdString(p.string()) << origin << origin << 0 << false;
            QTest::newRow((std::string(f) + ", relative, wide gamut display").c_str())
                << QString::fromStdString(p.string()) << origin << origin << 1 << true;
        }
    }
}

void TestColor::profiledSlidesMatchLittleCms() {
    QFETCH(QString, slide);
    QFETCH(double, x0);
    QFETCH(double, y0);
    QFETCH(int, intent);
    QFETCH(bool, wideDisplay);
    iris::ColorSettings settings;
    settings.intent = intent ? iris::RenderingIntent::RelativeColorimetric : iris::RenderingIntent::Perceptual;
    if (wideDisplay) settings.displayProfile = ref::wideGamma18Profile();
    iris::ColorSettings off = settings;
    off.managed = false;

    const auto a = frameOf(slide, x0, y0, off);
    QVERIFY(a);
    QVERIFY(!engine_->colorStatus().applied);
    const auto b = frameOf(slide, x0, y0, settings);
    QVERIFY(b);
    const iris::ColorStatus status = engine_->colorStatus();
    QVERIFY2(status.applied, describe(status.error).c_str());
    QVERIFY(!status.slideProfile.empty());
    // The strong curves change every colour; a scanner's sRGB-like profile shown on an sRGB
    // display may change none (the table then reproduces the stored bytes exactly).
    if (slide.contains(QLatin1String("strong-curves"))) {
        QVERIFY(a->image.rgba != b->image.rgba);
        QCOMPARE(status.slideProfile, std::string("Iris test: strong curves"));
    }

    const std::vector<uint8_t> profile = engine_->slideInfo()->iccProfile;
    const auto intentRef = intent ? iris::color::Intent::RelativeColorimetric : iris::color::Intent::Perceptual;
    const auto lut = iris::color::bakeLut(profile, settings.displayProfile, intentRef);
    QVERIFY2(lut.ok(), describe(lut.error()).c_str());
    const iris::SlideInfo info = *engine_->slideInfo();
    const uint32_t w = uint32_t(std::clamp<int64_t>(info.width - int64_t(x0), 0, kW));
    const uint32_t h = uint32_t(std::clamp<int64_t>(info.height - int64_t(y0), 0, kH));
    const Stats s = compare(*a, *b, w, h, profile, settings, &lut.value());
    QVERIFY2(s.pixels >= 10000, "the frame shows too little of the slide");
    qInfo("%s: %zu pixels, ΔE2000 p99 %.3f, max %.3f; largest difference from the CPU model of the table: %d (%zu "
          "pixels differ)",
          qPrintable(slide), s.pixels, s.p99, s.max, s.maxLutStep, s.offModel);
    QVERIFY2(s.p99 <= 1.0, "ΔE2000 over 1.0 at the 99th percentile");
    QVERIFY2(s.max <= 2.0, "ΔE2000 over 2.0");
    QVERIFY2(s.maxLutStep <= 1, "the GPU's lookup differs from the CPU model by more than one 8-bit step");
}

void TestColor::shrunkAndShiftedViewsMatchLittleCms_data() {
    QTest::addColumn<double>("x0");
    QTest::addColumn<double>("y0");
    QTest::addColumn<double>("downsample");
    QTest::addColumn<bool>("wideDisplay");
    QTest::newRow("mip 1 texel centres") << 0.0 << 0.0 << 2.0 << false;
    QTest::newRow("mip 2, wide gamut display") << 0.0 << 0.0 << 4.0 << true;
    QTest::newRow("1.37, shifted") << 311.3 << 207.6 << 1.37 << false;
    QTest::newRow("2.9, shifted, wide gamut display") << 17.5 << 40.25 << 2.9 << true;
    QTest::newRow("0.6 (magnified), shifted") << 700.4 << 500.7 << 0.6 << false;
}

void TestColor::shrunkAndShiftedViewsMatchLittleCms() {
    QFETCH(double, x0);
    QFETCH(double, y0);
    QFETCH(double, downsample);
    QFETCH(bool, wideDisplay);
    const QString slide = QString::fromStdString((dir_ / "strong-curves.tiff").string());
    iris::ColorSettings settings;
    if (wideDisplay) settings.displayProfile = ref::wideGamma18Profile();
    iris::ColorSettings off = settings;
    off.managed = false;
    const auto a = frameOf(slide, x0, y0, off, downsample);
    QVERIFY(a);
    const auto b = frameOf(slide, x0, y0, settings, downsample);
    QVERIFY(b);
    QVERIFY(engine_->colorStatus().applied);
    QVERIFY(a->image.rgba != b->image.rgba);
    const iris::SlideInfo info = *engine_->slideInfo();
    // The target pixels that show the slide; the last one at the slide's edge mixes it with
    // the background (not slide colour), so it is left out.
    const auto shown = [&](int64_t extent, double origin) {
        return uint32_t(std::clamp<int64_t>(int64_t(std::floor((double(extent) - origin) / downsample)) - 1, 0, kW));
    };
    const uint32_t w = std::min(shown(info.width, x0), kW), h = std::min(shown(info.height, y0), kH);
    const Stats s = compare(*a, *b, w, h, info.iccProfile, settings, nullptr, /*rounded=*/true);
    QVERIFY2(s.pixels >= 10000, "the frame shows too little of the slide");
    qInfo("downsample %.2f at (%.2f, %.2f): %zu pixels, ΔE2000 p99 %.3f, max %.3f", downsample, x0, y0, s.pixels, s.p99,
          s.max);
    QVERIFY2(s.p99 <= 1.0, "ΔE2000 over 1.0 at the 99th percentile");
    QVERIFY2(s.max <= 2.0, "ΔE2000 over 2.0");
}

void TestColor::slideWithoutProfileIsUnchanged() {
    const QString path = QString::fromStdString((dir_ / "no-profile.tiff").string());
    iris::ColorSettings off;
    off.managed = false;
    const auto a = frameOf(path, 300, 200, off);
    QVERIFY(a);
    const auto b = frameOf(path, 300, 200, iris::ColorSettings{});
    QVERIFY(b);
    QVERIFY(!engine_->colorStatus().applied);
    QVERIFY(engine_->colorStatus().slideProfile.empty());
    QVERIFY(a->image.rgba == b->image.rgba);
}

void TestColor::brokenProfileFallsBackToNoTransform() {
    const QString path = QString::fromStdString((dir_ / "broken-profile.tiff").string());
    iris::ColorSettings off;
    off.managed = false;
    const auto a = frameOf(path, 300, 200, off);
    QVERIFY(a);
    const auto b = frameOf(path, 300, 200, iris::ColorSettings{});
    QVERIFY(b);
    const iris::ColorStatus status = engine_->colorStatus();
    QVERIFY(!status.applied);
    QVERIFY2(!status.error.ok(), "a truncated profile was not reported");
    qInfo("broken profile: %s", describe(status.error).c_str());
    QVERIFY(a->image.rgba == b->image.rgba);
    QVERIFY(engine_->error().ok()); // the slide itself is fine
}

void TestColor::switchingAtRuntime() {
    const QString path = QString::fromStdString((dir_ / "strong-curves.tiff").string());
    iris::ColorSettings off;
    off.managed = false;
    const auto a = frameOf(path, 700, 500, off);
    QVERIFY(a);
    iris::Engine& e = *engine_.engine;
    const iris::View v = viewWithOrigin(700, 500, 1.0, kW, kH);
    // A settings change is published like a view change: waitForFrame waits for a complete
    // frame drawn with it.
    e.setColorSettings(iris::ColorSettings{});
    QVERIFY(e.waitForFrame(10s).ok());
    const auto on = e.readFrame();
    QVERIFY(on.ok());
    QVERIFY(on.value().image.rgba != a->image.rgba);
    QCOMPARE(on.value().view.centerX, v.centerX);
    e.setColorSettings(off);
    QVERIFY(e.waitForFrame(10s).ok());
    const auto back = e.readFrame();
    QVERIFY(back.ok());
    QVERIFY(back.value().image.rgba == a->image.rgba);
}

// Engine::readAssociatedImage(…, ForDisplay): the same transform as the tiles (LittleCMS on
// the stored pixels, within one 8-bit step), the stored pixels when colour management is off
// or the slide has no profile. Needs a slide with a profile and associated images: the TCGA SVS.
void TestColor::associatedImagesForDisplay() {
    const auto slides = slidesDir();
    const fs::path tcga = slides ? *slides / "aperio/tcga-cr-7395-01a-01-ts1.svs" : fs::path();
    if (!slides || !fs::exists(tcga)) QSKIP("the shared test slide aperio/tcga-cr-7395-01a-01-ts1.svs is not here");
    const std::vector<uint8_t> profile = tiffIccProfile(tcga);
    QVERIFY(!profile.empty());
    iris::Engine& e = *engine_.engine;
    iris::ColorSettings settings;
    settings.displayProfile = ref::wideGamma18Profile(); // sRGB → sRGB would change little
    e.setColorSettings(settings);
    QVERIFY(e.open(tcga.string()).ok());
    QVERIFY(e.colorStatus().applied);
    const auto names = e.slideInfo()->associatedImages;
    QVERIFY(!names.empty());
    std::string error;
    const auto xf = ref::Transform::create(profile, settings.displayProfile, settings.intent, &error);
    QVERIFY2(xf, error.c_str());
    for (const std::string& name : names) {
        const auto stored = e.readAssociatedImage(name);
        const auto shown = e.readAssociatedImage(name, iris::ImageColors::ForDisplay);
        QVERIFY2(stored.ok() && shown.ok(), name.c_str());
        QCOMPARE(shown->width, stored->width);
        QCOMPARE(shown->height, stored->height);
        int worst = 0;
        for (size_t i = 0; i < stored->rgba.size(); i += 4) {
            QCOMPARE(stored->rgba[i + 3], uint8_t(255)); // scanners' associated images are opaque
            const auto want = xf->apply8(stored->rgba[i], stored->rgba[i + 1], stored->rgba[i + 2]);
            for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(int(shown->rgba[i + c]) - int(want[c])));
        }
        qInfo("%s: %ux%u, largest difference from LittleCMS %d", name.c_str(), stored->width, stored->height, worst);
        QVERIFY2(worst <= 1, name.c_str());
        QVERIFY(shown->rgba != stored->rgba);
    }
    iris::ColorSettings off = settings;
    off.managed = false;
    e.setColorSettings(off);
    const auto stored = e.readAssociatedImage(names.front());
    const auto shown = e.readAssociatedImage(names.front(), iris::ImageColors::ForDisplay);
    QVERIFY(stored.ok() && shown.ok());
    QVERIFY(shown->rgba == stored->rgba);
    e.setColorSettings(iris::ColorSettings{});
    e.close();
}

QTEST_GUILESS_MAIN(TestColor)
#include "tst_color.moc"
