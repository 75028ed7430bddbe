// iris-viewer: the Iris View demo viewer.
//
//   iris-viewer [SLIDE] [--exit-after-ms N] [--screenshot FILE]
//
// With no SLIDE it opens the built-in sample slide (generated once into the cache folder).

#include <cstdio>

#include <QtCore/QCommandLineParser>
#include <QtCore/QTimer>
#include <QtGui/QScreen>
#include <QtWidgets/QApplication>

#include <iris/IrisSlideView.h>

#include "mainwindow.h"

int main(int argc, char *argv[])
{
    QApplication app(argc, argv);
    QApplication::setOrganizationName(QStringLiteral("IrisView"));
    QApplication::setApplicationName(QStringLiteral("iris-viewer"));
    QApplication::setApplicationDisplayName(QStringLiteral("Iris View"));
    QApplication::setApplicationVersion(QStringLiteral(IRIS_VIEW_VERSION));

    QCommandLineParser parser;
    parser.setApplicationDescription(QStringLiteral("Whole-slide image viewer (Iris View)."));
    parser.addHelpOption();
    parser.addVersionOption();
    parser.addPositionalArgument(QStringLiteral("slide"),
                                 QStringLiteral("Slide to open (default: the built-in sample slide)."),
                                 QStringLiteral("[slide]"));
    const QCommandLineOption exitAfter(QStringLiteral("exit-after-ms"),
                                       QStringLiteral("Quit after <ms> milliseconds (for scripts)."),
                                       QStringLiteral("ms"));
    const QCommandLineOption screenshot(QStringLiteral("screenshot"),
                                        QStringLiteral("Save the window as <file> just before quitting "
                                                       "(with --exit-after-ms)."),
                                        QStringLiteral("file"));
    parser.addOptions({exitAfter, screenshot});
    parser.process(app);

    MainWindow window;
    window.show();

    int status = 0;
    QObject::connect(window.view(), &IrisSlideView::slideError, &app, [&status](const QString &message) {
        std::fprintf(stderr, "iris-viewer: %s\n", qPrintable(message));
        status = 1;
    });

    const QStringList slides = parser.positionalArguments();
    QTimer::singleShot(0, &window, [&window, slides] {
        if (slides.isEmpty())
            window.openSample();
        else
            window.openSlide(slides.first(), false);
    });

    if (parser.isSet(exitAfter)) {
        bool ok = false;
        const int ms = parser.value(exitAfter).toInt(&ok);
        if (!ok || ms < 0) {
            std::fprintf(stderr, "iris-viewer: --exit-after-ms needs a number of milliseconds\n");
            return 2;
        }
        const QString shotPath = parser.value(screenshot);
        QTimer::singleShot(ms, &window, [&window, &status, shotPath] {
            if (!shotPath.isEmpty()) {
                const QPixmap shot = window.screen()->grabWindow(window.winId());
                if (shot.isNull() || !shot.save(shotPath)) {
                    std::fprintf(stderr, "iris-viewer: cannot save the screenshot to %s\n", qPrintable(shotPath));
                    status = 1;
                }
            }
            QApplication::quit();
        });
    }

    const int code = QApplication::exec();
    return code != 0 ? code : status;
}
