// tst_designerplugin: the Qt Designer plugin for IrisSlideView, and a uic-compiled form.
//
//   * the plugin (built in <build>/plugins/designer/) loads with QPluginLoader and offers
//     IrisSlideView through QDesignerCustomWidgetInterface;
//   * its domXml() parses, names the class, and every property it sets exists on the widget
//     and accepts the value's type;
//   * slideform.ui (an IrisSlideView inside a form, with properties set in Designer) went
//     through uic at build time; the form is built here, its properties arrive, and the
//     view in it shows a slide.

#include <QtCore/QFileInfo>
#include <QtCore/QPluginLoader>
#include <QtCore/QXmlStreamReader>
#include <QtGui/QWindow>
#include <QtTest/QTest>
#include <QtUiPlugin/QDesignerCustomWidgetInterface>
#include <QtWidgets/QApplication>

#include <iris/IrisSlideView.h>

#include "ui_slideform.h"
#include "widget_test_support.h"

using namespace iriswidgettest;

class TstDesignerPlugin : public QObject {
    Q_OBJECT

private Q_SLOTS:
    void initTestCase();
    void cleanupTestCase();
    void describesTheWidget();
    void createsTheWidget();
    void domXmlParsesAndMatchesTheWidget();
    void uicFormBuildsAndShowsASlide();

private:
    QPluginLoader m_loader;
    QDesignerCustomWidgetInterface *m_plugin = nullptr;
};

void TstDesignerPlugin::initTestCase()
{
    IrisSlideView::setVulkanValidation(true); // before any view exists
    const QString path = qEnvironmentVariable("IRIS_DESIGNER_PLUGIN_PATH"); // set by CTest
    QVERIFY2(!path.isEmpty(), "IRIS_DESIGNER_PLUGIN_PATH is not set (run the suite through ctest)");
    QVERIFY2(QFileInfo::exists(path), qPrintable(path));
    m_loader.setFileName(path);
    QVERIFY2(m_loader.load(), qPrintable(m_loader.errorString()));
    QObject *instance = m_loader.instance();
    QVERIFY(instance);
    m_plugin = qobject_cast<QDesignerCustomWidgetInterface *>(instance);
    QVERIFY2(m_plugin, "the plugin does not implement QDesignerCustomWidgetInterface");
    QCOMPARE(m_loader.metaData().value(QStringLiteral("IID")).toString(),
             QStringLiteral("org.qt-project.Qt.QDesignerCustomWidgetInterface"));
}

void TstDesignerPlugin::cleanupTestCase()
{
    // The plugin stays loaded: Qt keeps plugin libraries until exit anyway.
}

void TstDesignerPlugin::describesTheWidget()
{
    QCOMPARE(m_plugin->name(), QStringLiteral("IrisSlideView"));
    QCOMPARE(m_plugin->group(), QStringLiteral("Iris View"));
    QCOMPARE(m_plugin->includeFile(), QStringLiteral("iris/IrisSlideView.h"));
    QVERIFY(!m_plugin->isContainer());
    QVERIFY(!m_plugin->toolTip().isEmpty());
    QVERIFY(!m_plugin->whatsThis().isEmpty());
    QVERIFY(!m_plugin->icon().isNull());
    QVERIFY(!m_plugin->isInitialized());
    m_plugin->initialize(nullptr);
    QVERIFY(m_plugin->isInitialized());
}

void TstDesignerPlugin::createsTheWidget()
{
    QWidget parent;
    QWidget *widget = m_plugin->createWidget(&parent);
    QVERIFY(widget);
    QCOMPARE(widget->parentWidget(), &parent);
    auto *view = qobject_cast<IrisSlideView *>(widget);
    QVERIFY2(view, widget->metaObject()->className());
    QCOMPARE(view->metaObject()->className(), m_plugin->name().toLatin1());
    QVERIFY(view->slidePath().isEmpty());
    QCOMPARE(view->focusPolicy(), Qt::StrongFocus);
}

void TstDesignerPlugin::domXmlParsesAndMatchesTheWidget()
{
    QXmlStreamReader xml(m_plugin->domXml());
    QString widgetClass;
    QString widgetName;
    QString customClass;
    QString header;
    QStringList properties;
    QString property;
    int depthInProperty = 0;
    QStringList path;
    while (!xml.atEnd()) {
        xml.readNext();
        if (xml.isStartElement()) {
            path << xml.name().toString();
            if (xml.name() == QLatin1String("widget") && widgetClass.isEmpty()) {
                widgetClass = xml.attributes().value(QLatin1String("class")).toString();
                widgetName = xml.attributes().value(QLatin1String("name")).toString();
            } else if (xml.name() == QLatin1String("property") && path.size() == 3) {
                property = xml.attributes().value(QLatin1String("name")).toString();
                properties << property;
                depthInProperty = 1;
            } else if (xml.name() == QLatin1String("class") && path.contains(QLatin1String("customwidget"))) {
                customClass = xml.readElementText();
                path.removeLast();
            } else if (xml.name() == QLatin1String("header")) {
                header = xml.readElementText();
                path.removeLast();
            } else if (depthInProperty > 0) {
                ++depthInProperty;
            }
        } else if (xml.isEndElement()) {
            path.removeLast();
            if (depthInProperty > 0)
                --depthInProperty;
        }
    }
    QVERIFY2(!xml.hasError(), qPrintable(xml.errorString()));
    QCOMPARE(widgetClass, QStringLiteral("IrisSlideView"));
    QVERIFY(!widgetName.isEmpty());
    QCOMPARE(customClass, QStringLiteral("IrisSlideView"));
    QCOMPARE(header, m_plugin->includeFile());

    // Every default the plugin sets is a writable property of the widget.
    IrisSlideView view;
    for (const QString &name : std::as_const(properties)) {
        const int index = view.metaObject()->indexOfProperty(name.toLatin1().constData());
        QVERIFY2(index >= 0, qPrintable(QStringLiteral("domXml sets unknown property '%1'").arg(name)));
        QVERIFY2(view.metaObject()->property(index).isWritable(), qPrintable(name));
        QVERIFY2(view.metaObject()->property(index).isDesignable(), qPrintable(name));
    }
    for (const char* expected : {"backgroundColor", "enhance", "ramBudgetMB", "vramBudgetMB", "scaleBarVisible",
                                 "scaleBarCorner", "magnificationLabelVisible", "magnificationLabelCorner",
                                 "overviewVisible", "overviewCorner", "legendVisible", "legendCorner", "colorManaged",
                                 "renderingIntent"})
        QVERIFY2(properties.contains(QLatin1String(expected)), expected);
}

void TstDesignerPlugin::uicFormBuildsAndShowsASlide()
{
    QWidget form;
    Ui::SlideForm ui;
    ui.setupUi(&form);
    IrisSlideView *view = ui.slideView;
    QVERIFY(view);
    QCOMPARE(view->objectName(), QStringLiteral("slideView"));
    QCOMPARE(view->backgroundColor(), QColor(32, 48, 64));
    QVERIFY(!view->enhance());
    QVERIFY(!view->kineticPanning());
    QCOMPARE(view->ramBudgetMB(), 256);
    QCOMPARE(view->vramBudgetMB(), 128);
    QVERIFY(!view->isOverviewVisible());
    QCOMPARE(view->scaleBarCorner(), IrisSlideView::TopRight);
    QVERIFY(view->isMagnificationLabelVisible()); // not set in the form: the widget's default
    QVERIFY(!view->colorManaged());
    QCOMPARE(view->renderingIntent(), IrisSlideView::RelativeColorimetric);

    const QString slide = sampleSlide();
    QVERIFY2(QFileInfo::exists(slide), qPrintable(slide));
    FrameWatcher frames(view);
    form.show();
    QVERIFY(QTest::qWaitForWindowExposed(&form));
    QVERIFY(view->openSlide(slide));
    QVERIFY(frames.waitForCompleteFrame());
    // The form's background colour reached the engine: the fitted 3:2 slide in this view
    // leaves a band of it above or beside the slide. The complete frame was submitted; its
    // presentation reaches the X server a moment later, so the grab is retried until then.
    QColor corner;
    QTRY_VERIFY2_WITH_TIMEOUT(presentedPixelIs(view, QPoint(1, 1), QColor(32, 48, 64), 2, &corner),
                              qPrintable(corner.name()), 5000);
    QCOMPARE(view->validationMessageCount(), quint64(0));
}

IRIS_WIDGET_TEST_MAIN(TstDesignerPlugin)
#include "tst_designerplugin.moc"
