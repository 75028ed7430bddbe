// tst_novulkan: IrisSlideView where Vulkan cannot start.
//
// Run on Qt's offscreen platform, which offers no Vulkan surfaces, so the shared
// QVulkanInstance cannot be created: the view must show a clear message in its place,
// report slideError() when asked to open a slide, take every call and input event
// harmlessly, and never crash.

#include <QtTest/QSignalSpy>
#include <QtTest/QTest>
#include <QtWidgets/QApplication>
#include <QtWidgets/QLabel>

#include <iris/IrisSlideView.h>

#include "enginehost_p.h"

class TstNoVulkan : public QObject {
    Q_OBJECT
private Q_SLOTS:
    void showsWhyInsteadOfCrashing();
};

void TstNoVulkan::showsWhyInsteadOfCrashing()
{
    QCOMPARE(QGuiApplication::platformName(), QStringLiteral("offscreen"));
    IrisSlideView view;
    view.resize(320, 240);
    view.show();
    QVERIFY(QTest::qWaitForWindowExposed(&view));

    QVERIFY(!view.isRendererAvailable());
    QVERIFY(!view.rendererError().isEmpty());
    QVERIFY(view.rendererError().contains(QLatin1String("Vulkan")));
    QCOMPARE(view.surfaceWindow(), nullptr);
    auto *message = view.findChild<QLabel *>(QStringLiteral("irisRendererMessage"));
    QVERIFY(message);
    QVERIFY(message->isVisible());
    QVERIFY(message->text().contains(view.rendererError()));

    QSignalSpy errors(&view, &IrisSlideView::slideError);
    QSignalSpy opened(&view, &IrisSlideView::slideOpened);
    QVERIFY(!view.openSlide(qEnvironmentVariable("IRIS_TEST_SAMPLE")));
    QCOMPARE(errors.count(), 1);
    QVERIFY(errors.first().first().toString().contains(view.rendererError()));
    QCOMPARE(opened.count(), 0);
    QVERIFY(!view.hasSlide());
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 0);

    // Every call and input is harmless.
    view.fitToWindow();
    view.zoomBy(2);
    view.panBy(QPointF(10, 10));
    view.setMagnification(20);
    view.setCentre(QPointF(5, 5));
    view.closeSlide();
    QCOMPARE(view.magnification(), 0.0);
    QCOMPARE(view.centre(), QPointF());
    QVERIFY(view.associatedImage(QStringLiteral("label")).isNull());
    QCOMPARE(view.validationMessageCount(), quint64(0));
    QTest::keyClick(&view, Qt::Key_Right);
    QTest::keyClick(&view, Qt::Key_Plus);
    QTest::mousePress(&view, Qt::LeftButton, {}, QPoint(50, 50));
    QTest::mouseMove(&view, QPoint(80, 90));
    QTest::mouseRelease(&view, Qt::LeftButton, {}, QPoint(80, 90));
    QTest::mouseDClick(&view, Qt::LeftButton, {}, QPoint(80, 90));
    view.resize(200, 100);
    // And so is whatever those calls queued (the resize's events, anything posted to the view).
    QCoreApplication::sendPostedEvents();
    QCoreApplication::processEvents();
    QCOMPARE(view.centre(), QPointF());
    QVERIFY(!view.hasSlide());
}

QTEST_MAIN(TstNoVulkan)
#include "tst_novulkan.moc"
