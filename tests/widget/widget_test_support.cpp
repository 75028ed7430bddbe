#include "widget_test_support.h"

#include <cmath>
#include <cstdlib>

#include <QtCore/QDeadlineTimer>
#include <QtCore/QDir>
#include <QtCore/QEventLoop>
#include <QtCore/QFile>
#include <QtCore/QFileInfo>
#include <QtCore/QTimer>
#include <QtGui/QGuiApplication>
#include <QtGui/QScreen>
#include <QtGui/QWindow>
#include <QtTest/QSignalSpy>

#include <iris/engine.h>

namespace iriswidgettest {

QString sampleSlide()
{
    return qEnvironmentVariable("IRIS_TEST_SAMPLE");
}

QString secondSampleSlide()
{
    return qEnvironmentVariable("IRIS_TEST_SAMPLE_B");
}

QString testDataSlide(const QString &relative)
{
    for (const char *variable : {"IRIS_TESTDATA", "IRIS_TESTDATA_DEFAULT"}) {
        const QString dir = qEnvironmentVariable(variable);
        if (dir.isEmpty())
            continue;
        const QString path = QDir(dir).filePath(QStringLiteral("slides/") + relative);
        if (QFileInfo::exists(path))
            return path;
    }
    return {};
}

QString missingDisplayReason()
{
    const QByteArray platform = qgetenv("QT_QPA_PLATFORM");
    if ((platform.isEmpty() || platform.startsWith("xcb")) && qEnvironmentVariableIsEmpty("DISPLAY"))
        return QStringLiteral("no X display (the widget suites run under xvfb-run with QT_QPA_PLATFORM=xcb)");
    return {};
}

// --- FrameWatcher --------------------------------------------------------------------------

FrameWatcher::FrameWatcher(IrisSlideView *view)
    : m_view(view)
{
    connect(view, &IrisSlideView::framePresented, this, [this](const IrisFrameMetrics &metrics) {
        m_last = metrics;
        ++m_frames;
    });
}

static bool near(double a, double b)
{
    return std::abs(a - b) <= 1e-9 * std::max({1.0, std::abs(a), std::abs(b)});
}

bool FrameWatcher::hasCompleteFrameOfCurrentView() const
{
    if (!m_view || !m_last || !m_last->complete)
        return false;
    const QPointF centre = m_view->centre();
    return near(m_last->centre.x(), centre.x()) && near(m_last->centre.y(), centre.y())
        && near(m_last->downsample, m_view->downsample());
}

bool FrameWatcher::waitForCompleteFrame(int timeoutMs)
{
    if (!m_view)
        return false;
    // Only a frame presented or a change of the view can make the answer change: test again
    // after each (this object's own connection, made first, has recorded the frame by then).
    QDeadlineTimer deadline(timeoutMs);
    QEventLoop loop;
    QTimer expiry;
    expiry.setSingleShot(true);
    connect(&expiry, &QTimer::timeout, &loop, &QEventLoop::quit);
    connect(m_view, &IrisSlideView::framePresented, &loop, &QEventLoop::quit);
    connect(m_view, &IrisSlideView::viewChanged, &loop, &QEventLoop::quit);
    connect(m_view, &QObject::destroyed, &loop, &QEventLoop::quit);
    while (!hasCompleteFrameOfCurrentView()) {
        if (!m_view || deadline.hasExpired())
            return false;
        expiry.start(std::chrono::milliseconds(deadline.remainingTime()));
        loop.exec();
    }
    return true;
}

bool viewStaysStill(IrisSlideView *view)
{
    QSignalSpy moved(view, &IrisSlideView::viewChanged);
    return !moved.wait(kStillMs);
}

// --- images --------------------------------------------------------------------------------

QImage grabPresented(IrisSlideView *view)
{
    QWindow *window = view->surfaceWindow();
    if (!window || !window->screen())
        return {};
    const QPixmap pixmap = window->screen()->grabWindow(window->winId());
    return pixmap.toImage().convertToFormat(QImage::Format_RGBA8888);
}

bool presentedPixelIs(IrisSlideView *view, QPoint at, const QColor &expected, int tolerance, QColor *seen)
{
    const QImage presented = grabPresented(view);
    *seen = QColor();
    if (presented.size() != view->targetSize() || !presented.rect().contains(at))
        return false;
    *seen = presented.pixelColor(at);
    return std::abs(seen->red() - expected.red()) <= tolerance && std::abs(seen->green() - expected.green()) <= tolerance
        && std::abs(seen->blue() - expected.blue()) <= tolerance;
}

QImage renderHeadless(const QString &path, QSize targetSize, QPointF centre, double downsample,
                      const QColor &background, QString *error, const IrisSlideView *overlaysOf)
{
    iris::EngineConfig config;
    config.validation = true;
    config.loaderThreads = 2;
    config.background = {float(background.redF()), float(background.greenF()), float(background.blueF())};
    auto created = iris::Engine::create(config);
    if (!created) {
        *error = QString::fromStdString(created.error().message());
        return {};
    }
    iris::Engine &engine = **created;
    if (auto r = engine.bindOffscreen(uint32_t(targetSize.width()), uint32_t(targetSize.height())); !r) {
        *error = QString::fromStdString(r.message());
        return {};
    }
    if (auto r = engine.open(QFile::encodeName(path).toStdString()); !r) {
        *error = QString::fromStdString(r.message());
        return {};
    }
    if (overlaysOf) {
        if (!overlaysOf->overlayFont().isEmpty()) {
            if (auto r = engine.setOverlayFont(QFile::encodeName(overlaysOf->overlayFont()).toStdString()); !r) {
                *error = QString::fromStdString(r.message());
                return {};
            }
        }
        if (QWindow *window = overlaysOf->surfaceWindow())
            engine.setDevicePixelRatio(window->devicePixelRatio());
        for (auto o : {IrisSlideView::ScaleBar, IrisSlideView::MagnificationLabel, IrisSlideView::Overview}) {
            engine.setOverlayCorner(iris::Overlay(int(o)), iris::Corner(int(overlaysOf->overlayCorner(o))));
            engine.setOverlayVisible(iris::Overlay(int(o)), overlaysOf->isOverlayVisible(o));
        }
    }
    iris::View view{centre.x(), centre.y(), downsample};
    if (overlaysOf) {
        view.rotation = overlaysOf->rotation();
        view.flipH = overlaysOf->isFlippedHorizontally();
        view.flipV = overlaysOf->isFlippedVertically();
    }
    engine.setView(view);
    if (auto r = engine.waitForFrame(std::chrono::seconds(30)); !r) {
        *error = QStringLiteral("waitForFrame: ") + QString::fromStdString(r.message());
        return {};
    }
    auto frame = engine.readFrame();
    if (!frame) {
        *error = QString::fromStdString(frame.error().message());
        return {};
    }
    if (engine.validationMessageCount() != 0) {
        *error = QStringLiteral("the headless engine reported %1 validation messages")
                     .arg(engine.validationMessageCount());
        return {};
    }
    const iris::Image &image = frame->image;
    QImage out(int(image.width), int(image.height), QImage::Format_RGBA8888);
    for (int y = 0; y < out.height(); ++y)
        memcpy(out.scanLine(y), image.rgba.data() + size_t(y) * image.width * 4, size_t(image.width) * 4);
    return out;
}

QString ImageDifference::describe() const
{
    return QStringLiteral("mean |Δ| %1, max |Δ| %2, %3% of pixels over the threshold")
        .arg(meanAbs, 0, 'f', 3)
        .arg(maxAbs)
        .arg(fractionOver * 100, 0, 'f', 3);
}

ImageDifference compareImages(const QImage &a, const QImage &b, int threshold)
{
    ImageDifference d;
    if (a.size() != b.size() || a.isNull()) {
        d.meanAbs = 255;
        d.fractionOver = 1;
        d.maxAbs = 255;
        return d;
    }
    const QImage x = a.convertToFormat(QImage::Format_RGBA8888);
    const QImage y = b.convertToFormat(QImage::Format_RGBA8888);
    quint64 sum = 0;
    quint64 over = 0;
    for (int row = 0; row < x.height(); ++row) {
        const uchar *p = x.constScanLine(row);
        const uchar *q = y.constScanLine(row);
        for (int col = 0; col < x.width(); ++col) {
            int worst = 0;
            for (int c = 0; c < 3; ++c) {
                const int delta = std::abs(int(p[col * 4 + c]) - int(q[col * 4 + c]));
                sum += quint64(delta);
                worst = std::max(worst, delta);
            }
            d.maxAbs = std::max(d.maxAbs, worst);
            if (worst > threshold)
                ++over;
        }
    }
    const double pixels = double(x.width()) * x.height();
    d.meanAbs = double(sum) / (pixels * 3);
    d.fractionOver = double(over) / pixels;
    return d;
}

void saveArtefact(const QImage &image, const QString &name)
{
    QString dir = qEnvironmentVariable("IRIS_TEST_OUT");
    if (dir.isEmpty())
        dir = QDir::tempPath();
    QDir(dir).mkpath(QStringLiteral("failures"));
    const QString path = QDir(dir).filePath(QStringLiteral("failures/%1.png").arg(name));
    if (image.save(path))
        qInfo("saved %s", qPrintable(path));
}

} // namespace iriswidgettest
