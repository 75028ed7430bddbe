#include "irisslideviewplugin.h"

#include <algorithm>
#include <cmath>

#include <QtGui/QColor>
#include <QtGui/QIcon>
#include <QtGui/QPainter>
#include <QtGui/QPixmap>

#include <iris/IrisSlideView.h>
#include <iris/engine.h>

namespace {

// A small glass-slide icon, drawn so that no image file needs to ship with the plugin.
QIcon slideIcon()
{
    QPixmap pixmap(32, 32);
    pixmap.fill(Qt::transparent);
    QPainter p(&pixmap);
    p.setRenderHint(QPainter::Antialiasing);
    p.setPen(QColor(90, 110, 140));
    p.setBrush(QColor(225, 235, 245));
    p.drawRoundedRect(QRectF(2.5, 9.5, 27, 13), 2, 2);
    p.setPen(Qt::NoPen);
    p.setBrush(QColor(200, 90, 160));
    p.drawEllipse(QRectF(12, 11.5, 9, 9));
    p.setBrush(QColor(240, 240, 240));
    p.drawRect(QRectF(4, 11, 5, 10));
    return QIcon(pixmap);
}

} // namespace

IrisSlideViewPlugin::IrisSlideViewPlugin(QObject *parent)
    : QObject(parent)
{
}

QString IrisSlideViewPlugin::name() const
{
    return QStringLiteral("IrisSlideView");
}

QString IrisSlideViewPlugin::group() const
{
    return QStringLiteral("Iris View");
}

QString IrisSlideViewPlugin::toolTip() const
{
    return QStringLiteral("Whole-slide image view (Iris View)");
}

QString IrisSlideViewPlugin::whatsThis() const
{
    return QStringLiteral(
        "Shows a digital pathology whole-slide image (any format OpenSlide reads, or .iris) "
        "rendered with Vulkan: drag to pan, wheel or pinch to zoom, arrow keys move one field, "
        "0 fits the slide, 1-4 jump to 5x, 10x, 20x and 40x. A scale bar, the magnification, "
        "an overview map (click it to go there) and a heat map's legend are drawn over the "
        "slide; each can be "
        "switched off or moved to another corner.");
}

QString IrisSlideViewPlugin::includeFile() const
{
    return QStringLiteral("iris/IrisSlideView.h");
}

QIcon IrisSlideViewPlugin::icon() const
{
    return slideIcon();
}

bool IrisSlideViewPlugin::isContainer() const
{
    return false;
}

QWidget *IrisSlideViewPlugin::createWidget(QWidget *parent)
{
    return new IrisSlideView(parent);
}

bool IrisSlideViewPlugin::isInitialized() const
{
    return m_initialized;
}

void IrisSlideViewPlugin::initialize(QDesignerFormEditorInterface *)
{
    m_initialized = true;
}

QString IrisSlideViewPlugin::domXml() const
{
    // The defaults a new IrisSlideView gets when dropped on a form: the engine's own
    // (EngineConfig) for the background, the budgets and colour management. The slide path stays empty: a form
    // usually opens its slide at run time.
    const iris::EngineConfig engine;
    const auto byte = [](float v) { return QString::number(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f)); };
    return QStringLiteral(R"(<ui language="c++">
  <widget class="IrisSlideView" name="slideView">
    <property name="geometry">
      <rect><x>0</x><y>0</y><width>640</width><height>480</height></rect>
    </property>
    <property name="minimumSize">
      <size><width>64</width><height>64</height></size>
    </property>
    <property name="focusPolicy">
      <enum>Qt::StrongFocus</enum>
    </property>
    <property name="backgroundColor">
      <color><red>%1</red><green>%2</green><blue>%3</blue></color>
    </property>
    <property name="enhance">
      <bool>true</bool>
    </property>
    <property name="kineticPanning">
      <bool>true</bool>
    </property>
    <property name="ramBudgetMB">
      <number>%4</number>
    </property>
    <property name="vramBudgetMB">
      <number>%5</number>
    </property>
    <property name="scaleBarVisible">
      <bool>true</bool>
    </property>
    <property name="scaleBarCorner">
      <enum>IrisSlideView::BottomLeft</enum>
    </property>
    <property name="magnificationLabelVisible">
      <bool>true</bool>
    </property>
    <property name="magnificationLabelCorner">
      <enum>IrisSlideView::TopLeft</enum>
    </property>
    <property name="overviewVisible">
      <bool>true</bool>
    </property>
    <property name="overviewCorner">
      <enum>IrisSlideView::TopRight</enum>
    </property>
    <property name="legendVisible">
      <bool>true</bool>
    </property>
    <property name="legendCorner">
      <enum>IrisSlideView::BottomRight</enum>
    </property>
    <property name="colorManaged">
      <bool>%6</bool>
    </property>
    <property name="renderingIntent">
      <enum>IrisSlideView::%7</enum>
    </property>
    <property name="annotationToolsEnabled">
      <bool>true</bool>
    </property>
    <property name="annotationTool">
      <enum>IrisSlideView::Navigate</enum>
    </property>
  </widget>
  <customwidgets>
    <customwidget>
      <class>IrisSlideView</class>
      <extends>QWidget</extends>
      <header>iris/IrisSlideView.h</header>
    </customwidget>
  </customwidgets>
</ui>
)")
        .arg(byte(engine.background[0]), byte(engine.background[1]), byte(engine.background[2]),
            QString::number(engine.ramBudgetBytes >> 20), QString::number(engine.vramBudgetBytes >> 20),
            engine.color.managed ? QStringLiteral("true") : QStringLiteral("false"),
            engine.color.intent == iris::RenderingIntent::RelativeColorimetric ? QStringLiteral("RelativeColorimetric")
                                                                               : QStringLiteral("Perceptual"));
}
