// Shows an IrisSlideView in a window, opens a slide, and checks on screen that a complete
// frame was presented: the 400×400 window fits the landscape slide with bands of the
// background colour above and below it, and the band must show exactly that colour.
//   widget_consumer SLIDE       (needs a display: xvfb-run)
#include <cstdio>

#include <QtCore/QElapsedTimer>
#include <QtCore/QTimer>
#include <QtGui/QScreen>
#include <QtGui/QWindow>
#include <QtWidgets/QApplication>

#include <iris/IrisSlideView.h>

int main(int argc, char** argv)
{
    QApplication app(argc, argv);
    if (argc != 2) {
        std::fprintf(stderr, "usage: widget_consumer SLIDE\n");
        return 2;
    }
    const QColor background(255, 0, 255);
    IrisSlideView view;
    view.setBackgroundColor(background);
    view.resize(400, 400);
    view.show();

    int status = 1;
    bool complete = false;
    QObject::connect(&view, &IrisSlideView::slideError, &app, [](const QString& message) {
        std::fprintf(stderr, "widget_consumer: %s\n", qPrintable(message));
        QApplication::exit(1);
    });
    QObject::connect(&view, &IrisSlideView::framePresented, &app,
                     [&](const IrisFrameMetrics& metrics) { complete = complete || metrics.complete; });
    // Presentation may reach the X server a little after the frame: look until the band shows.
    QElapsedTimer clock;
    clock.start();
    QTimer poll;
    QObject::connect(&poll, &QTimer::timeout, &app, [&] {
        if (clock.elapsed() > 60000) {
            std::fprintf(stderr, "widget_consumer: no complete frame with the background band in 60 s\n");
            QApplication::exit(1);
            return;
        }
        if (!complete)
            return;
        const QImage shot = view.screen()->grabWindow(view.winId()).toImage();
        const QColor band = shot.pixelColor(shot.width() / 2, 3);
        const QColor centre = shot.pixelColor(shot.width() / 2, shot.height() / 2);
        if (band == background && centre != background) {
            std::printf("widget_consumer: presented: band %s, slide %s\n", qPrintable(band.name()),
                        qPrintable(centre.name()));
            status = 0;
            QApplication::exit(0);
        }
    });
    poll.start(50);
    if (!view.openSlide(QString::fromLocal8Bit(argv[1])))
        return 1;
    return QApplication::exec() == 0 ? status : 1;
}
