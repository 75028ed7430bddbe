// Shared helpers of the widget suites (tests/widget/tst_*.cpp).
//
//   * where the slides are: the sample slides the CTest fixtures generate ($IRIS_TEST_SAMPLE,
//     $IRIS_TEST_SAMPLE_B) and the shared test data ($IRIS_TESTDATA or $IRIS_TESTDATA_DEFAULT);
//   * FrameWatcher: the last frame an IrisSlideView presented, and waiting for a complete
//     frame of the view the widget currently shows;
//   * grabbing the presented frame from the X server (QScreen::grabWindow of the Vulkan
//     surface window: under Xvfb that is exactly what the swapchain presented);
//   * rendering the same view headless (a second Engine on an offscreen target), and
//     comparing two images with a stated tolerance;
//   * the suites' main(): the widget suites need an X display (xvfb-run in CI); without one
//     they exit with code 77, which CTest reports as skipped (SKIP_RETURN_CODE).
#pragma once

#include <optional>

#include <QtCore/QObject>
#include <QtCore/QPointer>
#include <QtCore/QString>
#include <QtGui/QImage>

#include <iris/IrisSlideView.h>

namespace iriswidgettest {

QString sampleSlide();       // $IRIS_TEST_SAMPLE (6000 × 4000)
QString secondSampleSlide(); // $IRIS_TEST_SAMPLE_B (3000 × 2000, another seed)
// <test data>/slides/<relative>, or an empty string when the test data is not there.
QString testDataSlide(const QString &relative);

// Exit code a suite returns when the environment cannot run it at all (no X display).
inline constexpr int kSkipExitCode = 77;
// Empty when the suite can run; otherwise why not.
QString missingDisplayReason();

class FrameWatcher : public QObject {
    Q_OBJECT
public:
    explicit FrameWatcher(IrisSlideView *view);

    int frames() const { return m_frames; }
    std::optional<IrisFrameMetrics> last() const { return m_last; }
    // True once a complete frame of the view's current centre and downsample was presented.
    bool hasCompleteFrameOfCurrentView() const;
    // Waits (processing events) for such a frame.
    bool waitForCompleteFrame(int timeoutMs = 20000);

private:
    QPointer<IrisSlideView> m_view;
    std::optional<IrisFrameMetrics> m_last;
    int m_frames = 0;
};

// Whether the view stays where it is (no viewChanged) for kStillMs. A negative check, for "no
// glide follows this release": nothing announces that a glide will not start, so it waits the
// shortest time in which one would show. KineticPanner moves the view on every tick of its
// 16 ms timer, and Qt fires due timers in order, so a glide started before the call moves the
// view within the first tick, well inside the three ticks waited here.
inline constexpr int kStillMs = 50;
bool viewStaysStill(IrisSlideView *view);

// The view's presented pixels in device pixels (RGBA8888), read back from the X server.
QImage grabPresented(IrisSlideView *view);
// Whether the presented pixel at `at` (device pixels) is `expected` within ±tolerance per
// channel; *seen gets the colour found (invalid when the grab failed or had the wrong size).
// A frame reaches the X server a moment after it was submitted: call it in QTRY_VERIFY.
bool presentedPixelIs(IrisSlideView *view, QPoint at, const QColor &expected, int tolerance, QColor *seen);

// Renders path headless at the given view into a targetSize offscreen target and returns it
// (RGBA8888); on failure returns a null image and sets *error. With overlaysOf, the engine
// draws the overlays that view shows, where it shows them, at its device pixel ratio (and
// the frame must have every one of them), and turns and mirrors the slide as it does;
// without, no overlays and no turn.
QImage renderHeadless(const QString &path, QSize targetSize, QPointF centre, double downsample,
                      const QColor &background, QString *error, const IrisSlideView *overlaysOf = nullptr);

struct ImageDifference {
    double meanAbs = 0;          // mean |a − b| over every channel of every pixel (0…255)
    double fractionOver = 0;     // fraction of pixels with some channel differing by > threshold
    int maxAbs = 0;
    QString describe() const;
};
// Compares RGB (alpha ignored) of two images of the same size.
ImageDifference compareImages(const QImage &a, const QImage &b, int threshold);

// Saves an image under $IRIS_TEST_OUT/failures/<name>.png (for a failing comparison).
void saveArtefact(const QImage &image, const QString &name);

} // namespace iriswidgettest

// main() for a widget suite: skips without a display, then runs the Qt Test class.
#define IRIS_WIDGET_TEST_MAIN(TestClass)                                                      \
    int main(int argc, char *argv[])                                                          \
    {                                                                                         \
        const QString reason = iriswidgettest::missingDisplayReason();                        \
        if (!reason.isEmpty()) {                                                              \
            fprintf(stderr, "SKIP: %s\n", qPrintable(reason));                               \
            return iriswidgettest::kSkipExitCode;                                             \
        }                                                                                     \
        QApplication app(argc, argv);                                                         \
        TestClass test;                                                                       \
        QTEST_SET_MAIN_SOURCE_PATH                                                            \
        return QTest::qExec(&test, argc, argv);                                               \
    }
