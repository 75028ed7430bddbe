// iris-viewer: the Iris View demo viewer.
//
//   iris-viewer [SLIDE] [--exit-after-ms N] [--screenshot FILE] [--validation]
//
// With no SLIDE it opens the built-in sample slide (generated once into the cache folder).
// The command line is read before QApplication exists, so --help, --version and bad arguments
// need no display (help2man and the package test run them on headless machines).

#include <cstdio>

#include <QtCore/QCommandLineParser>
#include <QtCore/QCoreApplication>
#include <QtCore/QTimer>
#include <QtGui/QScreen>
#include <QtWidgets/QApplication>

#include <iris/IrisSlideView.h>
#include <iris/version.h>

#include "mainwindow.h"

namespace {

// A usage error: one line naming the option and a pointer to --help; exit status 2.
int usageError(const QString &message)
{
    std::fprintf(stderr, "iris-viewer: error: %s\nRun with --help for more information.\n", qPrintable(message));
    return 2;
}

// Qt's own command-line options (QGuiApplication's, X11's and QApplication's), which the
// QApplication constructor takes out of argv: accepted by the early parse, listed by --help-all.
const char *const kQtOptionsWithValue[] = {"platform", "platformpluginpath", "platformtheme", "plugin",
                                           "qmljsdebugger", "qwindowgeometry", "qwindowicon", "qwindowtitle",
                                           "session", "display", "geometry", "title", "icon", "name",
                                           "style", "stylesheet"};
const char *const kQtFlags[] = {"reverse", "widgetcount", "nograb", "dograb", "sync"};

void addQtOptions(QCommandLineParser &parser)
{
    // They are single-dash words ("-platform offscreen", "-style=fusion"), so "-abc" is one
    // option, not -a -b -c.
    parser.setSingleDashWordOptionMode(QCommandLineParser::ParseAsLongOptions);
    for (const char *name : kQtOptionsWithValue) {
        QCommandLineOption option(QString::fromLatin1(name), QString(), QStringLiteral("value"));
        option.setFlags(QCommandLineOption::HiddenFromHelp);
        parser.addOption(option);
    }
    for (const char *name : kQtFlags) {
        QCommandLineOption option(QString::fromLatin1(name));
        option.setFlags(QCommandLineOption::HiddenFromHelp);
        parser.addOption(option);
    }
}

} // namespace

int main(int argc, char *argv[])
{
    QCommandLineParser parser;
    parser.setApplicationDescription(QStringLiteral("Whole-slide image viewer (Iris View)."));
    const QCommandLineOption help = parser.addHelpOption();
    const QCommandLineOption version = parser.addVersionOption();
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
    const QCommandLineOption validation(QStringLiteral("validation"),
                                        QStringLiteral("Check every Vulkan call with the Khronos validation layer "
                                                       "(for development; also IRIS_VALIDATION=1)."));
    parser.addOptions({exitAfter, screenshot, validation});
    addQtOptions(parser);

    QStringList arguments;
    for (int i = 0; i < argc; ++i)
        arguments << QString::fromLocal8Bit(argv[i]);
    if (!parser.parse(arguments))
        return usageError(parser.errorText());
    if (parser.isSet(help) || parser.isSet(QStringLiteral("help-all"))) {
        // helpText() names the program from QCoreApplication::arguments(): a QCoreApplication
        // needs no display.
        QCoreApplication core(argc, argv);
        std::fputs(qPrintable(parser.helpText()), stdout);
        if (parser.isSet(QStringLiteral("help-all"))) {
            // (Qt's own descriptions of them come only from a QApplication, which needs a display.)
            QStringList names;
            for (const char *name : kQtOptionsWithValue)
                names << QStringLiteral("-%1 <value>").arg(QLatin1String(name));
            for (const char *name : kQtFlags)
                names << QStringLiteral("-%1").arg(QLatin1String(name));
            QString text = QStringLiteral("\nQt options (see the QGuiApplication and QApplication documentation):\n");
            QString line;
            for (const QString &name : names) {
                if (line.size() + 1 + name.size() > 78) {
                    text += line + QLatin1Char('\n');
                    line.clear();
                }
                line += (line.isEmpty() ? QStringLiteral("  ") : QStringLiteral(" ")) + name;
            }
            std::fputs(qPrintable(text + line + QLatin1Char('\n')), stdout);
        }
        return 0;
    }
    if (parser.isSet(version)) {
        std::printf("iris-viewer (Iris View) %s\n", IRIS_VIEW_VERSION_STRING);
        return 0;
    }
    int exitAfterMs = -1;
    if (parser.isSet(exitAfter)) {
        bool ok = false;
        exitAfterMs = parser.value(exitAfter).toInt(&ok);
        if (!ok || exitAfterMs < 0)
            return usageError(QStringLiteral("--exit-after-ms needs a number of milliseconds"));
    }

    QApplication app(argc, argv);
    QApplication::setOrganizationName(QStringLiteral("IrisView"));
    QApplication::setApplicationName(QStringLiteral("iris-viewer"));
    QApplication::setApplicationDisplayName(QStringLiteral("Iris View"));
    QApplication::setApplicationVersion(QStringLiteral(IRIS_VIEW_VERSION_STRING));

    // The widget never reads the environment; the application maps its own switches.
    IrisSlideView::setVulkanValidation(parser.isSet(validation) || qEnvironmentVariableIntValue("IRIS_VALIDATION") == 1);

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

    if (exitAfterMs >= 0) {
        const QString shotPath = parser.value(screenshot);
        QTimer::singleShot(exitAfterMs, &window, [&window, &status, shotPath] {
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
