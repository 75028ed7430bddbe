// tst_view_churn: eight IrisSlideViews in one window, each on a slide of its own, opened and
// closed many times (issue #14, "Load and soak"), on a real X display (Xvfb in CI) with lavapipe
// and the Vulkan validation layers on.
//
// One top-level window holds a 4 × 2 grid of views. Every cycle opens a different slide in each
// view, waits until every view has presented a complete frame of it (tiles drawn, the view it
// shows now), zooms every view in and pans every other one, waits for complete frames of the
// new views, and then closes. Odd cycles close the slides and keep the window, its views and
// their engines; even cycles destroy the window with its eight views (their engines, surfaces
// and swapchains, and the shared Vulkan instance when the last view goes) and build a new one.
//
// Per cycle: every view reported its own slide opened and presented such frames, no view
// reported slideError, every engine's validation message count is zero, and the number of live
// engines is eight while the window lives and zero once it is gone. At the end: the heap in use,
// resident memory (/proc/self/statm), open file descriptors (/proc/self/fd) and threads
// (/proc/self/task), taken with no window alive, may exceed those after cycle 10 by at most
// kHeapSlackMiB, kRssSlackMiB, kFdSlack and kThreadSlack, so that something leaked once per
// cycle (an engine, a surface, a descriptor, a thread) fails even where LeakSanitizer sees no
// leak (memory still referenced, a descriptor, a thread): the asan preset adds LeakSanitizer at
// exit. The figures are printed every 10 cycles.
//
// Cycles: 200, or $IRIS_CHURN_CYCLES (tests/widget/CMakeLists.txt sets fewer for CI).
//
// lastFrameReachesABusyGuiThread, first, is the regression test of what the churn found: the
// engine host's frame relay (widget/src/enginehost.cpp) dropped the newest frames while the GUI
// thread was behind, so the complete frame that ends a burst of loading could be lost and a
// host waiting for it (here, for one of eight views opened at once) waited for ever.
//
// Frames from before a close can still be delivered after the next open (the render thread
// posts them to the GUI thread). None can pass for a frame of the new cycle: a frame counts
// only when it shows the view's current centre and downsample with tiles drawn, the first wait
// is for the fitted view (a view about to be closed was zoomed in from it, so its frames show
// another downsample), and the zoom factor changes from one cycle to the next.

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <memory>
#include <optional>

#include <unistd.h>

#if defined(__SANITIZE_ADDRESS__)
#define IRIS_CHURN_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define IRIS_CHURN_ASAN 1
#endif
#endif
#ifdef IRIS_CHURN_ASAN
// From the sanitizers' allocator_interface.h, which GCC does not install (libasan has them).
extern "C" size_t __sanitizer_get_current_allocated_bytes();
extern "C" void __sanitizer_purge_allocator();
#else
#include <malloc.h>
#endif

#include <QtCore/QDeadlineTimer>
#include <QtCore/QDir>
#include <QtCore/QElapsedTimer>
#include <QtCore/QEventLoop>
#include <QtCore/QFile>
#include <QtCore/QFileInfo>
#include <QtCore/QLoggingCategory>
#include <QtCore/QThread>
#include <QtCore/QTimer>
#include <QtCore/QVersionNumber>
#include <QtGui/QVulkanInstance>
#include <QtTest/QTest>
#include <QtWidgets/QApplication>
#include <QtWidgets/QGridLayout>

#include <iris/IrisSlideView.h>

#include "enginehost_p.h"
#include "widget_test_support.h"

using namespace iriswidgettest;

namespace {

constexpr int kViews = 8;
constexpr int kColumns = 4;
constexpr QSize kWindowSize(1200, 600); // 300 × 300 logical pixels a view
constexpr int kDefaultCycles = 200;
// The cycle after which the process's resources are first measured (everything warmed up:
// the loader's, Qt's and the driver's one-time allocations made).
constexpr int kBaselineCycle = 10;
// What the last measurement may exceed the baseline by. The heap in use is the exact figure
// (glibc's mallinfo2, or AddressSanitizer's own count): it grows by well under 1 KiB a cycle
// (Qt's and the drivers' caches), while one leaked view, engine or window a cycle would add tens
// of KiB to MiB each. Resident memory also holds what the Vulkan driver maps itself (lavapipe's
// JIT code, device memory), hence its looser bound. One descriptor or one thread a cycle
// exceeds theirs within a few cycles.
constexpr double kHeapSlackMiB = 4;
constexpr double kRssSlackMiB = 64;
#ifdef IRIS_CHURN_ASAN
// AddressSanitizer's own mappings grow by about 1 MiB a cycle (measured: 64 and 128 KiB
// regions of its internal allocator, outside the heap, which stays flat): its stack depot
// keeps every distinct allocation stack for good, and lavapipe's JIT code, in many of those
// stacks, lands at new addresses with every device. Resident memory may grow by that much more.
constexpr double kAsanRssPerCycleMiB = 1.5;
#endif
constexpr int kFdSlack = 4;
constexpr int kThreadSlack = 2;
// Budgets for each view's engine: small, since only the fitted and one zoomed field are shown.
constexpr int kRamBudgetMB = 64;
constexpr int kVramBudgetMB = 64;
// How long eight views may take to present complete frames (lavapipe, ASan, a loaded runner).
constexpr int kFrameTimeoutMs = 60000;

struct ProcessResources
{
    double heapMiB = 0; // bytes the program has allocated and not freed
    double rssMiB = 0;
    int fds = 0;
    int threads = 0;

    QString describe() const
    {
        return QStringLiteral("heap in use %1 MiB, RSS %2 MiB, %3 fds, %4 threads")
            .arg(heapMiB, 0, 'f', 2)
            .arg(rssMiB, 0, 'f', 1)
            .arg(fds)
            .arg(threads);
    }
};

int countEntries(const char *dir)
{
    return int(QDir(QString::fromLatin1(dir)).entryList(QDir::AllEntries | QDir::System | QDir::NoDotAndDotDot).size());
}

// The allocator first gives back what it keeps of freed memory, so that resident memory counts
// what is in use (and what the drivers map): glibc keeps free pages in its arenas (see
// initTestCase for the rest), AddressSanitizer freed blocks in its quarantine.
ProcessResources measure()
{
    ProcessResources r;
    constexpr double kMiB = 1024.0 * 1024.0;
#ifdef IRIS_CHURN_ASAN
    __sanitizer_purge_allocator();
    r.heapMiB = double(__sanitizer_get_current_allocated_bytes()) / kMiB;
#else
    malloc_trim(0);
    const struct mallinfo2 heap = mallinfo2();
    r.heapMiB = double(heap.uordblks + heap.hblkhd) / kMiB; // arenas' blocks in use, and mmapped ones
#endif
    QFile statm(QStringLiteral("/proc/self/statm"));
    if (statm.open(QIODevice::ReadOnly)) {
        const QList<QByteArray> fields = statm.readAll().simplified().split(' ');
        if (fields.size() >= 2)
            r.rssMiB = fields[1].toDouble() * double(sysconf(_SC_PAGESIZE)) / kMiB;
    }
    // Listing /proc/self/fd opens one descriptor itself, in every measurement alike.
    r.fds = countEntries("/proc/self/fd");
    r.threads = countEntries("/proc/self/task");
    return r;
}

bool near(double a, double b)
{
    return std::abs(a - b) <= 1e-9 * std::max({1.0, std::abs(a), std::abs(b)});
}

// A slide that may be missing: the shared test data's, else a stand-in.
QString sharedOr(const QString &relative, const QString &standIn)
{
    const QString path = testDataSlide(relative);
    return path.isEmpty() ? standIn : path;
}

} // namespace

class TstViewChurn : public QObject
{
    Q_OBJECT

private Q_SLOTS:
    void initTestCase();
    void lastFrameReachesABusyGuiThread();
    void churn();
    void cleanupTestCase();

private:
    // The window and its views, and what each view reported this cycle.
    struct Grid
    {
        std::unique_ptr<QWidget> window = std::make_unique<QWidget>();
        std::array<IrisSlideView *, kViews> views{};
    };
    struct Reported
    {
        std::optional<IrisFrameMetrics> lastFrame;
        QString opened; // the path slideOpened() named
        int openedCount = 0;
        int closedCount = 0;
    };

    std::unique_ptr<Grid> makeGrid();
    // Whether view i's latest frame is complete, has tiles and shows the view's current view.
    bool presentsCurrentView(int i) const;
    // Waits (on the views' signals) until every view presents its current view, a view reports
    // an error, or the time runs out; on failure *why says which view and what it last showed.
    bool waitForCompleteFrames(QString *why);
    // Runs posted events, deferred deletions included.
    static void drainEvents();

    QStringList m_slides;
    std::unique_ptr<Grid> m_grid;
    std::array<Reported, kViews> m_reported;
    QStringList m_errors; // "view i: message" for every slideError
};

void TstViewChurn::initTestCase()
{
    QCOMPARE(QGuiApplication::platformName(), QStringLiteral("xcb"));
    IrisSlideView::setVulkanValidation(true);
    // The "opened …" and "engine ready" lines of eight views a cycle would bury what matters;
    // warnings (the validation layers', the engine's errors) still print. QT_LOGGING_RULES
    // overrides this.
    QLoggingCategory::setFilterRules(QStringLiteral("iris.widget.info=false"));

    const QString sample = sampleSlide();
    // Each view's own slide: the fixtures' samples (generic TIFF of four seeds and sizes), two
    // procedural ones (one stored with a single level, so the engine makes its synthetic
    // levels), and the shared test data's Aperio, .iris and Deflate TIFF files when present.
    m_slides = {sample, secondSampleSlide(), qEnvironmentVariable("IRIS_TEST_CHURN_C"),
        qEnvironmentVariable("IRIS_TEST_CHURN_D"), QStringLiteral("synthetic:9000x7000"),
        sharedOr(QStringLiteral("aperio/CMU-1-Small-Region.svs"), QStringLiteral("synthetic:4096x3072:1")),
        sharedOr(QStringLiteral("iris/CMU-1-Small-Region.v1.1.iris"), QStringLiteral("synthetic:5000x3000")),
        sharedOr(QStringLiteral("generic-tiff/boxes.tiff"), QStringLiteral("synthetic:2000x6000"))};
    for (const QString &slide : std::as_const(m_slides)) {
        QVERIFY2(slide.startsWith(QLatin1String("synthetic:")) || QFileInfo::exists(slide),
            qPrintable(QStringLiteral("no slide at '%1' (the sample_slide, widget_second_sample and "
                                      "widget_churn_slides fixtures make them)")
                           .arg(slide)));
    }
    QCOMPARE(QSet<QString>(m_slides.begin(), m_slides.end()).size(), kViews);
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 0);
#ifndef IRIS_CHURN_ASAN
    // glibc gives a per-thread arena's free top back only above the trim threshold, which
    // grows with the mmap threshold (up to 64 MiB) as large blocks are freed, and
    // malloc_trim() leaves those tops alone: with eight engines' threads coming and going,
    // resident memory would wander by ±100 MiB with no byte more in use. Fixed thresholds
    // keep it to what is in use and what the drivers map.
    mallopt(M_MMAP_THRESHOLD, 256 * 1024);
    mallopt(M_TRIM_THRESHOLD, 256 * 1024);
#endif
}

void TstViewChurn::cleanupTestCase()
{
    m_grid.reset();
    drainEvents();
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 0);
}

void TstViewChurn::lastFrameReachesABusyGuiThread()
{
    // An engine host on an instance of its own (as the views' shared one: validation on when
    // installed), rendering offscreen.
    QVulkanInstance vulkan;
    vulkan.setApiVersion(QVersionNumber(1, 3));
    vulkan.setFlags(QVulkanInstance::NoDebugOutputRedirect);
    IrisWidget::EngineSettings settings;
    settings.validation = vulkan.supportedLayers().contains(QByteArrayLiteral("VK_LAYER_KHRONOS_validation"));
    if (settings.validation) {
        vulkan.setLayers({QByteArrayLiteral("VK_LAYER_KHRONOS_validation")});
        if (vulkan.supportedExtensions().contains(QByteArrayLiteral("VK_EXT_debug_utils")))
            vulkan.setExtensions({QByteArrayLiteral("VK_EXT_debug_utils")});
    }
    QVERIFY(vulkan.create());
    IrisWidget::EngineHost host;
    QString error;
    QVERIFY2(host.create(&vulkan, settings, &error), qPrintable(error));
    iris::Engine *engine = host.engine();
    QVERIFY(engine->bindOffscreen(256, 256, false).ok());
    std::optional<iris::FrameStats> last;
    connect(
        &host, &IrisWidget::EngineHost::frameRendered, &host, [&last](const iris::FrameStats &stats) { last = stats; });
    QVERIFY(engine->open(QFile::encodeName(sampleSlide()).toStdString()).ok());

    // The GUI thread runs no events while the engine renders eight views to the end, one after
    // another: more frames than the relay keeps. Nothing changes after the last, so no frame
    // follows it.
    for (int step = 0; step < 8; ++step) {
        engine->zoom(1.25, 128, 128);
        const iris::Result settled = engine->waitForSettled(std::chrono::seconds(60));
        QVERIFY2(settled.ok(), settled.message().c_str());
    }
    // The render thread hands the last frame to the host just after waitForSettled returns:
    // the GUI thread stays busy a moment longer, past that (this models its being busy, it
    // waits for nothing).
    QThread::msleep(200);
    const iris::View view = engine->view();
    // The frame delivered last is the complete frame of that view.
    QTRY_VERIFY_WITH_TIMEOUT(last && last->complete && near(last->view.centerX, view.centerX)
            && near(last->view.centerY, view.centerY) && near(last->view.downsample, view.downsample),
        10000);
    QCOMPARE(engine->validationMessageCount(), uint64_t(0));
}

std::unique_ptr<TstViewChurn::Grid> TstViewChurn::makeGrid()
{
    auto grid = std::make_unique<Grid>();
    grid->window->setWindowTitle(QStringLiteral("tst_view_churn"));
    auto *layout = new QGridLayout(grid->window.get());
    layout->setContentsMargins(0, 0, 0, 0);
    layout->setSpacing(0);
    for (int i = 0; i < kViews; ++i) {
        auto *view = new IrisSlideView;
        view->setRamBudgetMB(kRamBudgetMB);
        view->setVramBudgetMB(kVramBudgetMB);
        layout->addWidget(view, i / kColumns, i % kColumns);
        grid->views[size_t(i)] = view;
        // Connected before any wait's own connections, so a wait sees the frame recorded.
        connect(view, &IrisSlideView::framePresented, view,
            [this, i](const IrisFrameMetrics &metrics) { m_reported[size_t(i)].lastFrame = metrics; });
        connect(view, &IrisSlideView::slideOpened, view, [this, i](const IrisSlideInfo &info) {
            m_reported[size_t(i)].opened = info.path;
            ++m_reported[size_t(i)].openedCount;
        });
        connect(view, &IrisSlideView::slideClosed, view, [this, i] { ++m_reported[size_t(i)].closedCount; });
        connect(view, &IrisSlideView::slideError, view,
            [this, i](const QString &message) { m_errors << QStringLiteral("view %1: %2").arg(i).arg(message); });
    }
    grid->window->resize(kWindowSize);
    grid->window->show();
    return grid;
}

bool TstViewChurn::presentsCurrentView(int i) const
{
    const IrisSlideView *view = m_grid->views[size_t(i)];
    const std::optional<IrisFrameMetrics> &frame = m_reported[size_t(i)].lastFrame;
    if (!frame || !frame->complete || frame->tilesDrawn == 0)
        return false;
    return near(frame->centre.x(), view->centre().x()) && near(frame->centre.y(), view->centre().y())
        && near(frame->downsample, view->downsample());
}

bool TstViewChurn::waitForCompleteFrames(QString *why)
{
    QDeadlineTimer deadline(kFrameTimeoutMs);
    QEventLoop loop;
    QTimer expiry;
    expiry.setSingleShot(true);
    connect(&expiry, &QTimer::timeout, &loop, &QEventLoop::quit);
    for (IrisSlideView *view : m_grid->views) {
        connect(view, &IrisSlideView::framePresented, &loop, &QEventLoop::quit);
        connect(view, &IrisSlideView::viewChanged, &loop, &QEventLoop::quit);
        connect(view, &IrisSlideView::slideError, &loop, &QEventLoop::quit);
    }
    for (;;) {
        int waiting = -1;
        for (int i = 0; i < kViews && waiting < 0; ++i) {
            if (!presentsCurrentView(i))
                waiting = i;
        }
        if (waiting < 0)
            return true;
        if (!m_errors.isEmpty() || deadline.hasExpired()) {
            const std::optional<IrisFrameMetrics> &frame = m_reported[size_t(waiting)].lastFrame;
            const IrisSlideView *view = m_grid->views[size_t(waiting)];
            *why = QStringLiteral("view %1 (%2) has no complete frame of its view (centre %3, %4; downsample %5); "
                                  "its last frame: %6. Errors: %7")
                       .arg(waiting)
                       .arg(view->slidePath())
                       .arg(view->centre().x())
                       .arg(view->centre().y())
                       .arg(view->downsample())
                       .arg(frame ? QStringLiteral("serial %1, complete %2, %3 tiles, centre %4, %5, downsample %6")
                                        .arg(frame->serial)
                                        .arg(frame->complete)
                                        .arg(frame->tilesDrawn)
                                        .arg(frame->centre.x())
                                        .arg(frame->centre.y())
                                        .arg(frame->downsample)
                                  : QStringLiteral("none"))
                       .arg(m_errors.isEmpty() ? QStringLiteral("none") : m_errors.join(QLatin1String("; ")));
            return false;
        }
        expiry.start(std::chrono::milliseconds(deadline.remainingTime()));
        loop.exec();
    }
}

void TstViewChurn::drainEvents()
{
    QCoreApplication::sendPostedEvents(nullptr, QEvent::DeferredDelete);
    QCoreApplication::processEvents();
}

void TstViewChurn::churn()
{
    bool numeric = true;
    const int requested = qEnvironmentVariableIntValue("IRIS_CHURN_CYCLES", &numeric);
    const int cycles = qEnvironmentVariableIsSet("IRIS_CHURN_CYCLES") ? requested : kDefaultCycles;
    QVERIFY2(numeric || !qEnvironmentVariableIsSet("IRIS_CHURN_CYCLES"), "IRIS_CHURN_CYCLES is not a number");
    QVERIFY2(cycles >= 1, "IRIS_CHURN_CYCLES must be at least 1");

    std::optional<ProcessResources> baseline;
    QElapsedTimer clock;
    clock.start();
    for (int cycle = 1; cycle <= cycles; ++cycle) {
        const QString at = QStringLiteral("cycle %1: ").arg(cycle);
        if (!m_grid)
            m_grid = makeGrid();
        for (Reported &r : m_reported)
            r = Reported{};

        for (int i = 0; i < kViews; ++i) {
            IrisSlideView *view = m_grid->views[size_t(i)];
            const QString &slide = m_slides[i];
            QVERIFY2(view->openSlide(slide),
                qPrintable(at
                    + QStringLiteral("view %1 cannot open %2: %3")
                          .arg(i)
                          .arg(slide, m_errors.join(QLatin1String("; ")))));
            QVERIFY2(m_reported[size_t(i)].openedCount == 1 && m_reported[size_t(i)].opened == slide,
                qPrintable(at
                    + QStringLiteral("view %1 reported opening '%2' %3 times, not %4 once")
                          .arg(i)
                          .arg(m_reported[size_t(i)].opened)
                          .arg(m_reported[size_t(i)].openedCount)
                          .arg(slide)));
        }
        QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), kViews);
        QString why;
        QVERIFY2(waitForCompleteFrames(&why), qPrintable(at + QStringLiteral("after opening: ") + why));

        // A little interaction: every view zooms in about its centre (by a factor that differs
        // from the previous cycle's), every other one pans as well.
        const double factor = 1.25 + 0.25 * (cycle % 3);
        for (int i = 0; i < kViews; ++i) {
            IrisSlideView *view = m_grid->views[size_t(i)];
            const double fitted = view->downsample();
            view->zoomBy(factor);
            // (A zoom clamped away would let a frame of the fitted view pass for this one.)
            QVERIFY2(!near(view->downsample(), fitted),
                qPrintable(at
                    + QStringLiteral("view %1 (%2) did not zoom in from downsample %3")
                          .arg(i)
                          .arg(view->slidePath())
                          .arg(fitted)));
            if (i % 2)
                view->panBy(QPointF(7 * (i + 1), -5 * (i + 1)));
        }
        QVERIFY2(waitForCompleteFrames(&why), qPrintable(at + QStringLiteral("after zooming: ") + why));

        for (int i = 0; i < kViews; ++i) {
            const IrisSlideView *view = m_grid->views[size_t(i)];
            QVERIFY2(view->validationMessageCount() == 0,
                qPrintable(at
                    + QStringLiteral("view %1 (%2): %3 Vulkan validation messages (see the log)")
                          .arg(i)
                          .arg(view->slidePath())
                          .arg(view->validationMessageCount())));
        }
        QVERIFY2(m_errors.isEmpty(), qPrintable(at + m_errors.join(QLatin1String("; "))));

        if (cycle % 2) {
            for (int i = 0; i < kViews; ++i) {
                IrisSlideView *view = m_grid->views[size_t(i)];
                view->closeSlide();
                QVERIFY2(!view->hasSlide() && m_reported[size_t(i)].closedCount == 1,
                    qPrintable(at + QStringLiteral("view %1 did not close its slide").arg(i)));
            }
            drainEvents();
            QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), kViews);
        } else {
            m_grid.reset();
            drainEvents();
            QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 0);
        }
        QVERIFY2(m_errors.isEmpty(), qPrintable(at + m_errors.join(QLatin1String("; "))));

        if (cycle == kBaselineCycle)
            baseline = measure();
        if (cycle % kBaselineCycle == 0) {
            qInfo().noquote() << "after cycle" << cycle << ":" << measure().describe() << "," << clock.elapsed()
                              << "ms";
        }
    }
    // The last measurement, like the baseline's, with no window alive.
    m_grid.reset();
    drainEvents();
    const ProcessResources last = measure();
    qInfo().noquote() << "after cycle" << cycles << ":" << last.describe() << "," << clock.elapsed() << "ms,"
                      << double(clock.elapsed()) / cycles << "ms a cycle";
    if (!baseline) {
        qInfo() << "fewer than" << kBaselineCycle << "cycles: no growth to check";
        return;
    }
#ifdef IRIS_CHURN_ASAN
    const double rssSlackMiB = kRssSlackMiB + kAsanRssPerCycleMiB * (cycles - kBaselineCycle);
#else
    const double rssSlackMiB = kRssSlackMiB;
#endif
    struct Growth
    {
        const char *what;
        double before, after, bound;
        int decimals;
    };
    const Growth growths[] = {{"the heap in use (MiB)", baseline->heapMiB, last.heapMiB, kHeapSlackMiB, 2},
        {"resident memory (MiB)", baseline->rssMiB, last.rssMiB, rssSlackMiB, 1},
        {"open file descriptors", double(baseline->fds), double(last.fds), double(kFdSlack), 0},
        {"threads", double(baseline->threads), double(last.threads), double(kThreadSlack), 0}};
    for (const Growth &g : growths) {
        QVERIFY2(g.after <= g.before + g.bound,
            qPrintable(QStringLiteral("%1 grew from %2 to %3 between cycles %4 and %5 (bound: +%6)")
                           .arg(QLatin1String(g.what))
                           .arg(g.before, 0, 'f', g.decimals)
                           .arg(g.after, 0, 'f', g.decimals)
                           .arg(kBaselineCycle)
                           .arg(cycles)
                           .arg(g.bound)));
    }
}

IRIS_WIDGET_TEST_MAIN(TstViewChurn)

#include "tst_view_churn.moc"
