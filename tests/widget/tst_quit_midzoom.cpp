// tst_quit_midzoom: the application quits while a view is zooming and loading tiles.
//
// A plain program (CTest checks its exit status; LeakSanitizer checks for leaks under the
// asan preset): a main window with an IrisSlideView opens the sample slide, starts an
// animated wheel zoom far in, and quits the event loop mid-animation; the window is then
// destroyed by main()'s stack unwinding, as in any Qt application. Exit status 0 means the
// engine went away cleanly with no validation message; 1 is a failure; 77 means no display.

#include <cstdio>

#include <QtCore/QTimer>
#include <QtGui/QWheelEvent>
#include <QtGui/QWindow>
#include <QtWidgets/QApplication>
#include <QtWidgets/QMainWindow>

#include <iris/IrisSlideView.h>

#include "enginehost_p.h"
#include "widget_test_support.h"

namespace {

int fail(const char *message)
{
    std::fprintf(stderr, "FAIL: %s\n", message);
    return 1;
}

} // namespace

int main(int argc, char *argv[])
{
    const QString reason = iriswidgettest::missingDisplayReason();
    if (!reason.isEmpty()) {
        std::fprintf(stderr, "SKIP: %s\n", qPrintable(reason));
        return iriswidgettest::kSkipExitCode;
    }
    const QString slide = iriswidgettest::sampleSlide();
    IrisSlideView::setVulkanValidation(true);
    int status = 0;
    quint64 validation = 0;
    bool zooming = false;
    {
        QApplication app(argc, argv);
        QMainWindow window;
        auto *view = new IrisSlideView;
        window.setCentralWidget(view);
        window.resize(640, 480);
        window.show();

        QObject::connect(view, &IrisSlideView::viewChanged, view, [&zooming] { zooming = true; });
        QTimer::singleShot(0, view, [view, slide, &status] {
            if (!view->openSlide(slide)) {
                status = fail("cannot open the sample slide");
                QApplication::exit(1);
            }
        });
        // Once frames flow: zoom in by 8 notches about a point, then quit 40 ms into the
        // 150 ms animation.
        QObject::connect(view, &IrisSlideView::framePresented, view, [view] {
            static bool started = false;
            if (started || !view->surfaceWindow())
                return;
            started = true;
            const QPointF p(200, 150);
            QWheelEvent wheel(p, view->surfaceWindow()->mapToGlobal(p), QPoint(), QPoint(0, 960),
                              Qt::NoButton, Qt::NoModifier, Qt::NoScrollPhase, false);
            QCoreApplication::sendEvent(view->surfaceWindow(), &wheel);
            QTimer::singleShot(40, qApp, [] { QApplication::quit(); });
        });
        QTimer::singleShot(30000, qApp, [&status] {
            status = fail("no frame within 30 s");
            QApplication::exit(1);
        });
        const int code = QApplication::exec();
        if (code != 0 && status == 0)
            status = fail("the event loop failed");
        validation = view->validationMessageCount();
    } // window, view, engine and QApplication go here, in that order
    if (status != 0)
        return status;
    if (!zooming)
        return fail("the view never changed");
    if (validation != 0)
        return fail("the Vulkan validation layers reported messages");
    if (IrisWidget::EngineHost::liveEngineCount() != 0)
        return fail("an engine outlived its view");
    std::puts("PASS: quit mid-zoom");
    return 0;
}
