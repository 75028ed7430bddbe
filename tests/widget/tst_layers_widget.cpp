// tst_layers_widget: IrisSlideView's raster layers (heat maps, label maps; issue 19) on an X
// display (Xvfb in CI) with lavapipe and the validation layers on. The engine's layer pass is
// not what is tested here (no pixels of a layer are checked): the widget's API is, against the
// engine's own stack (Engine::layers(), reached through IrisWidget::engineOf):
//   * layers added from files the test writes (grey PNG, float32 .npy, a PNG as class ids) and
//     from host maps; every setter reaches the engine's style, bad values change nothing;
//   * order (moveLayer) and removal in the engine's stack as in the view's;
//   * a user LUT file, and one that cannot be read;
//   * a new engine (a budget change, applied at the next open) gets the layers back, ids kept;
//   * another slide, or closing, removes them (they belong to their slide); layers added with no
//     slide open wait for the next one;
//   * hostile files: slideError(), no layer, the view still renders.

#include <cmath>
#include <limits>
#include <memory>

#include <QtCore/QDir>
#include <QtCore/QFileInfo>
#include <QtCore/QTemporaryDir>
#include <QtTest/QSignalSpy>
#include <QtTest/QTest>
#include <QtWidgets/QApplication>
#include <QtWidgets/QVBoxLayout>

#include <iris/IrisSlideView.h>
#include <iris/layers.h>

#include "enginehost_p.h"
#include "irisslideview_p.h"
#include "layer_files.h"
#include "widget_test_support.h"

using namespace iriswidgettest;

namespace {

constexpr QSize kViewSize(480, 360);

struct ViewWindow {
    std::unique_ptr<QWidget> window = std::make_unique<QWidget>();
    IrisSlideView *view = new IrisSlideView;
    std::unique_ptr<FrameWatcher> frames = std::make_unique<FrameWatcher>(view);

    ViewWindow()
    {
        auto *layout = new QVBoxLayout(window.get());
        layout->setContentsMargins(0, 0, 0, 0);
        layout->addWidget(view);
        window->resize(kViewSize);
    }
    ~ViewWindow() { frames.reset(); }
};

iris::Engine *engineOf(IrisSlideView *view)
{
    return IrisWidget::engineOf(view);
}

// The engine's entry showing the view's layer `id` (matched by its map, which is shared).
std::optional<iris::Engine::LayerEntry> engineLayer(IrisSlideView *view, quint64 id)
{
    const std::shared_ptr<const iris::RasterMap> map = view->layerMap(id);
    for (const iris::Engine::LayerEntry &e : engineOf(view)->layers()) {
        if (e.map == map)
            return e;
    }
    return std::nullopt;
}

// The engine's stack as the view's ids, bottom first (0 for an entry the view does not have).
QList<quint64> engineOrder(IrisSlideView *view)
{
    QList<quint64> ids;
    for (const iris::Engine::LayerEntry &e : engineOf(view)->layers()) {
        quint64 found = 0;
        for (quint64 id : view->layerIds()) {
            if (view->layerMap(id) == e.map)
                found = id;
        }
        ids.append(found);
    }
    return ids;
}

std::shared_ptr<const iris::RasterMap> scalarMap(int width, int height, float scale)
{
    std::vector<float> values(size_t(width) * size_t(height));
    for (size_t i = 0; i < values.size(); ++i)
        values[i] = float(i) * scale;
    auto map = iris::fromHostMemory(values, width, height, "host map");
    return map ? std::make_shared<const iris::RasterMap>(std::move(map).value()) : nullptr;
}

} // namespace

class TstLayersWidget : public QObject {
    Q_OBJECT
private Q_SLOTS:
    void initTestCase();
    void init();
    void cleanup();
    void cleanupTestCase();

    void fromFilesWithTheirKinds();
    void settersReachTheEngine();
    void badValuesChangeNothing();
    void orderAndRemoval();
    void userColorMapFile();
    void newEngineGetsTheLayersBack();
    void layersBelongToTheirSlide();
    void hostileFilesLeaveTheViewUsable();
    void unusableHostMaps();

private:
    QString path(const QString &name) const { return m_dir.filePath(name); }

    QString m_sample;
    QString m_sampleB;
    QTemporaryDir m_dir;
    std::unique_ptr<ViewWindow> m_w;
};

void TstLayersWidget::initTestCase()
{
    QCOMPARE(QGuiApplication::platformName(), QStringLiteral("xcb"));
    IrisSlideView::setVulkanValidation(true);
    m_sample = sampleSlide();
    m_sampleB = secondSampleSlide();
    QVERIFY2(QFileInfo::exists(m_sample), qPrintable(m_sample));
    QVERIFY2(QFileInfo::exists(m_sampleB), qPrintable(m_sampleB));
    QVERIFY(m_dir.isValid());
    QVERIFY(layerfiles::writeGreyPng(path(QStringLiteral("heat.png")), 60, 40, [](int x, int y) { return (x + y) * 2; }));
    // Class ids 0..3 in bands.
    QVERIFY(layerfiles::writeGreyPng(path(QStringLiteral("labels.png")), 32, 16, [](int x, int) { return x / 8; }));
    std::vector<float> values(30 * 20);
    for (size_t i = 0; i < values.size(); ++i)
        values[i] = float(i) / float(values.size() - 1);
    values[5] = std::numeric_limits<float>::quiet_NaN(); // no data
    QVERIFY(layerfiles::writeNpy(path(QStringLiteral("prob.npy")), 30, 20, values));
    QVERIFY(layerfiles::writeTextLut(path(QStringLiteral("lut.txt"))));
}

void TstLayersWidget::init()
{
    m_w = std::make_unique<ViewWindow>();
    m_w->window->show();
    QVERIFY(QTest::qWaitForWindowExposed(m_w->window.get()));
    QVERIFY(m_w->view->isRendererAvailable());
    QVERIFY2(m_w->view->openSlide(m_sample), qPrintable(m_sample));
    QVERIFY(m_w->frames->waitForCompleteFrame());
}

void TstLayersWidget::cleanup()
{
    if (m_w) {
        QVERIFY(m_w->frames->waitForCompleteFrame());
        QCOMPARE(m_w->view->validationMessageCount(), quint64(0));
    }
    m_w.reset();
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 0);
}

void TstLayersWidget::cleanupTestCase()
{
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 0);
}

void TstLayersWidget::fromFilesWithTheirKinds()
{
    IrisSlideView *view = m_w->view;
    QSignalSpy changed(view, &IrisSlideView::layersChanged);
    QSignalSpy errors(view, &IrisSlideView::slideError);

    const quint64 heat = view->addLayer(path(QStringLiteral("heat.png")));
    QVERIFY(heat != 0);
    QCOMPARE(changed.count(), 1);
    IrisLayerInfo info = view->layer(heat);
    QVERIFY(info.isValid());
    QCOMPARE(info.title, QStringLiteral("heat.png"));
    QCOMPARE(info.kind, IrisLayerInfo::Scalar);
    QCOMPARE(info.kindName(), QStringLiteral("scalar"));
    QCOMPARE(info.size, QSize(60, 40));
    QCOMPARE(info.minValue, 0.0);
    QCOMPARE(info.maxValue, double((59 + 39) * 2));
    QCOMPARE(info.colorMap, QStringLiteral("viridis"));
    QVERIFY(std::isnan(info.low) && std::isnan(info.high));

    const quint64 prob = view->addLayer(path(QStringLiteral("prob.npy")));
    QVERIFY(prob != 0 && prob != heat);
    info = view->layer(prob);
    QCOMPARE(info.kind, IrisLayerInfo::Scalar);
    QCOMPARE(info.size, QSize(30, 20));
    QCOMPARE(info.minValue, 0.0);
    QCOMPARE(info.maxValue, 1.0);

    const quint64 labels = view->addLayer(path(QStringLiteral("labels.png")), true);
    QVERIFY(labels != 0);
    info = view->layer(labels);
    QCOMPARE(info.kind, IrisLayerInfo::Label);
    QCOMPARE(info.maxValue, 3.0);
    QCOMPARE(info.classes.size(), 4); // one per id 0..3, background hidden
    QVERIFY(!info.classes[0].visible);
    QVERIFY(info.classes[1].visible);
    QCOMPARE(changed.count(), 3);
    QCOMPARE(errors.count(), 0);

    // The engine shows the same maps, in the same order, spanning the slide.
    QCOMPARE(view->layerIds(), (QList<quint64>{heat, prob, labels}));
    QCOMPARE(engineOrder(view), view->layerIds());
    for (quint64 id : view->layerIds()) {
        const auto entry = engineLayer(view, id);
        QVERIFY(entry);
        QVERIFY(!entry->placement);
    }
    QCOMPARE(engineLayer(view, labels)->style.classes.size(), size_t(4));
    QVERIFY(!view->layer(12345).isValid());
    QVERIFY(!view->layerMap(12345));
    // The frame goes on rendering with three layers in the stack.
    view->panBy(QPointF(20, 10));
    QVERIFY(m_w->frames->waitForCompleteFrame());
}

void TstLayersWidget::settersReachTheEngine()
{
    IrisSlideView *view = m_w->view;
    const quint64 heat = view->addLayer(path(QStringLiteral("heat.png")));
    const quint64 labels = view->addLayer(path(QStringLiteral("labels.png")), true);
    QVERIFY(heat && labels);
    QSignalSpy changed(view, &IrisSlideView::layersChanged);

    QVERIFY(view->setLayerOpacity(heat, 0.3));
    QVERIFY(view->setLayerColorMap(heat, QStringLiteral("magma")));
    QVERIFY(view->setLayerWindow(heat, 10, 150));
    QVERIFY(view->setLayerThreshold(heat, 20));
    QVERIFY(view->setLayerSampling(heat, IrisLayerInfo::Nearest));
    QVERIFY(view->setLayerVisible(heat, false));
    QVERIFY(view->setLayerOpacity(labels, 7)); // clamped
    QVERIFY(view->setLayerClassColor(labels, 2, QColor(10, 20, 30, 128)));
    QVERIFY(view->setLayerClassVisible(labels, 1, false));
    QCOMPARE(changed.count(), 9);

    const iris::LayerStyle s = engineLayer(view, heat)->style;
    QCOMPARE(s.opacity, 0.3);
    QCOMPARE(s.colorMap.name, std::string("magma"));
    QVERIFY(s.colorMap.entries == iris::ColorMap::magma().entries);
    QCOMPARE(s.low, 10.0);
    QCOMPARE(s.high, 150.0);
    QCOMPARE(s.threshold, 20.0);
    QCOMPARE(s.sampling, iris::LayerSampling::Nearest);
    QVERIFY(!s.visible);
    const iris::LayerStyle l = engineLayer(view, labels)->style;
    QCOMPARE(l.opacity, 1.0);
    QVERIFY((l.classes[2].color == iris::Rgba8{10, 20, 30, 128}));
    QVERIFY(!l.classes[1].visible);
    QVERIFY(l.classes[3].visible);

    // The view reports what it gave the engine.
    const IrisLayerInfo info = view->layer(heat);
    QCOMPARE(info.opacity, 0.3);
    QCOMPARE(info.colorMap, QStringLiteral("magma"));
    QCOMPARE(info.low, 10.0);
    QCOMPARE(info.threshold, 20.0);
    QCOMPARE(info.sampling, IrisLayerInfo::Nearest);
    QVERIFY(!info.visible);
    QCOMPARE(view->layer(labels).classes[2].color, QColor(10, 20, 30, 128));

    // Back to the map's own range and no threshold; a placement, and back to spanning.
    QVERIFY(view->setLayerWindow(heat, qQNaN(), qQNaN()));
    QVERIFY(view->setLayerThreshold(heat, -std::numeric_limits<double>::infinity()));
    QVERIFY(std::isnan(engineLayer(view, heat)->style.low));
    QVERIFY(std::isinf(engineLayer(view, heat)->style.threshold));
    QVERIFY(view->setLayerPlacement(heat, iris::Placement::scaleRotateOffset(10, 10, 0, 100, 200)));
    QVERIFY(engineLayer(view, heat)->placement);
    QCOMPARE(engineLayer(view, heat)->placement->m[2], 100.0);
    QVERIFY(view->resetLayerPlacement(heat));
    QVERIFY(!engineLayer(view, heat)->placement);

    // A whole style at once, and a streamed map replacing the file's.
    iris::LayerStyle whole;
    whole.opacity = 0.9;
    whole.colorMap = iris::ColorMap::jet();
    QVERIFY(view->setLayerStyle(heat, whole));
    QCOMPARE(engineLayer(view, heat)->style.colorMap.name, std::string("jet"));
    const auto streamed = scalarMap(8, 8, 0.5f);
    QVERIFY(view->setLayerMap(heat, streamed));
    QCOMPARE(view->layerMap(heat), streamed);
    QVERIFY(engineLayer(view, heat));
    QCOMPARE(engineLayer(view, heat)->style.opacity, 0.9);
}

void TstLayersWidget::badValuesChangeNothing()
{
    IrisSlideView *view = m_w->view;
    const quint64 heat = view->addLayer(path(QStringLiteral("heat.png")));
    const quint64 labels = view->addLayer(path(QStringLiteral("labels.png")), true);
    QVERIFY(heat && labels);
    const iris::LayerStyle before = engineLayer(view, heat)->style;
    QSignalSpy changed(view, &IrisSlideView::layersChanged);

    QVERIFY(!view->setLayerOpacity(heat, qQNaN()));
    QVERIFY(!view->setLayerColorMap(heat, QStringLiteral("rainbow")));
    QVERIFY(!view->setLayerWindow(heat, 0, std::numeric_limits<double>::infinity()));
    QVERIFY(!view->setLayerThreshold(heat, qQNaN()));
    QVERIFY(!view->setLayerClassColor(labels, 4, Qt::red)); // ids 0..3 only
    QVERIFY(!view->setLayerClassVisible(labels, -1, true));
    QVERIFY(!view->setLayerClassColor(heat, 0, Qt::red)); // a scalar map has no classes
    // Ids the view does not have.
    QVERIFY(!view->setLayerOpacity(999, 0.5));
    QVERIFY(!view->setLayerVisible(0, true));
    QVERIFY(!view->moveLayer(999, 0));
    QVERIFY(!view->setLayerMap(999, scalarMap(4, 4, 1)));
    view->removeLayer(999);
    QCOMPARE(changed.count(), 0);
    const iris::LayerStyle after = engineLayer(view, heat)->style;
    QCOMPARE(after.opacity, before.opacity);
    QCOMPARE(after.colorMap.name, before.colorMap.name);
    QCOMPARE(view->layerIds().size(), 2);
}

void TstLayersWidget::orderAndRemoval()
{
    IrisSlideView *view = m_w->view;
    const quint64 a = view->addLayer(scalarMap(8, 8, 1));
    const quint64 b = view->addLayer(scalarMap(9, 9, 1));
    const quint64 c = view->addLayer(scalarMap(10, 10, 1));
    QVERIFY(a && b && c);
    QCOMPARE(view->layer(a).title, QStringLiteral("host map"));
    QSignalSpy changed(view, &IrisSlideView::layersChanged);

    QVERIFY(view->moveLayer(c, 0)); // to the bottom
    QCOMPARE(view->layerIds(), (QList<quint64>{c, a, b}));
    QCOMPARE(engineOrder(view), view->layerIds());
    QVERIFY(view->moveLayer(c, 99)); // past the end: the top
    QCOMPARE(view->layerIds(), (QList<quint64>{a, b, c}));
    QCOMPARE(engineOrder(view), view->layerIds());
    QVERIFY(view->moveLayer(a, 1));
    QCOMPARE(view->layerIds(), (QList<quint64>{b, a, c}));
    QCOMPARE(engineOrder(view), view->layerIds());

    view->removeLayer(a);
    QCOMPARE(view->layerIds(), (QList<quint64>{b, c}));
    QCOMPARE(engineOrder(view), view->layerIds());
    const quint64 d = view->addLayer(scalarMap(4, 4, 1));
    QVERIFY(d > c); // ids are never reused
    view->clearLayers();
    QVERIFY(view->layerIds().isEmpty());
    QVERIFY(engineOf(view)->layers().empty());
    QCOMPARE(changed.count(), 6); // three moves, a removal, an addition, the clearing
    view->clearLayers(); // nothing to clear: no signal
    QCOMPARE(changed.count(), 6);
}

void TstLayersWidget::userColorMapFile()
{
    IrisSlideView *view = m_w->view;
    const quint64 heat = view->addLayer(path(QStringLiteral("heat.png")));
    QVERIFY(heat);
    QSignalSpy errors(view, &IrisSlideView::slideError);
    QVERIFY(view->loadLayerColorMap(heat, path(QStringLiteral("lut.txt"))));
    const iris::LayerStyle s = engineLayer(view, heat)->style;
    QCOMPARE(s.colorMap.name, std::string("lut.txt"));
    QVERIFY((s.colorMap.entries[10] == iris::Rgba8{10, 245, 7, 255}));
    QCOMPARE(view->layer(heat).colorMap, QStringLiteral("lut.txt"));
    QCOMPARE(errors.count(), 0);

    // 255 entries: refused, named, and the LUT in use stays.
    QByteArray shortLut;
    for (int i = 0; i < 255; ++i)
        shortLut += "1 2 3\n";
    QVERIFY(layerfiles::writeBytes(path(QStringLiteral("short.lut")), shortLut));
    QVERIFY(!view->loadLayerColorMap(heat, path(QStringLiteral("short.lut"))));
    QVERIFY(!view->loadLayerColorMap(heat, path(QStringLiteral("missing.lut"))));
    QCOMPARE(errors.count(), 2);
    QVERIFY2(errors.first().first().toString().contains(QStringLiteral("short.lut")),
             qPrintable(errors.first().first().toString()));
    QCOMPARE(engineLayer(view, heat)->style.colorMap.name, std::string("lut.txt"));
}

void TstLayersWidget::newEngineGetsTheLayersBack()
{
    IrisSlideView *view = m_w->view;
    const quint64 heat = view->addLayer(path(QStringLiteral("heat.png")));
    const quint64 labels = view->addLayer(path(QStringLiteral("labels.png")), true);
    QVERIFY(view->setLayerOpacity(heat, 0.25));
    QVERIFY(view->setLayerClassVisible(labels, 2, false));
    QVERIFY(view->setLayerPlacement(labels, iris::Placement::scaleRotateOffset(50, 50, 30, 10, 10)));
    QVERIFY(view->moveLayer(labels, 0));

    // A budget change takes effect at the next open: a new engine, the same slide.
    const iris::Engine *before = engineOf(view);
    view->setRamBudgetMB(view->ramBudgetMB() + 64);
    QSignalSpy changed(view, &IrisSlideView::layersChanged);
    QVERIFY(view->openSlide(m_sample));
    QVERIFY(engineOf(view) != before);
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 1);
    QCOMPARE(changed.count(), 0); // the same slide: the layers stay
    QCOMPARE(view->layerIds(), (QList<quint64>{labels, heat}));
    QCOMPARE(engineOrder(view), view->layerIds());
    QCOMPARE(engineLayer(view, heat)->style.opacity, 0.25);
    QVERIFY(!engineLayer(view, labels)->style.classes[2].visible);
    QVERIFY(engineLayer(view, labels)->placement);
    QVERIFY(m_w->frames->waitForCompleteFrame());

    // And the new engine takes further edits.
    QVERIFY(view->setLayerOpacity(heat, 0.75));
    QCOMPARE(engineLayer(view, heat)->style.opacity, 0.75);
    view->removeLayer(labels);
    QCOMPARE(engineOf(view)->layers().size(), size_t(1));
}

void TstLayersWidget::layersBelongToTheirSlide()
{
    IrisSlideView *view = m_w->view;
    QVERIFY(view->addLayer(path(QStringLiteral("heat.png"))));
    QSignalSpy changed(view, &IrisSlideView::layersChanged);

    // Another slide: the first one's layers go.
    QVERIFY(view->openSlide(m_sampleB));
    QCOMPARE(changed.count(), 1);
    QVERIFY(view->layerIds().isEmpty());
    QVERIFY(engineOf(view)->layers().empty());

    // Layers of this slide; closing it removes them.
    QVERIFY(view->addLayer(path(QStringLiteral("prob.npy"))));
    view->closeSlide();
    QCOMPARE(changed.count(), 3);
    QVERIFY(view->layerIds().isEmpty());
    QVERIFY(engineOf(view)->layers().empty());

    // Added with no slide open: kept for the next slide opened.
    const quint64 waiting = view->addLayer(path(QStringLiteral("heat.png")));
    QVERIFY(waiting);
    QVERIFY(view->openSlide(m_sample));
    QCOMPARE(view->layerIds(), QList<quint64>{waiting});
    QCOMPARE(engineOf(view)->layers().size(), size_t(1));
    QVERIFY(m_w->frames->waitForCompleteFrame());

    // An open that fails closes the slide shown, and its layers with it.
    changed.clear();
    QVERIFY(!view->openSlide(path(QStringLiteral("no-such-slide.svs"))));
    QCOMPARE(changed.count(), 1);
    QVERIFY(view->layerIds().isEmpty());
    QVERIFY(view->openSlide(m_sample));
}

void TstLayersWidget::hostileFilesLeaveTheViewUsable()
{
    IrisSlideView *view = m_w->view;
    const quint64 kept = view->addLayer(path(QStringLiteral("heat.png")));
    QVERIFY(kept);
    QVERIFY(view->setLayerOpacity(kept, 0.4));

    // A PNG cut short in its header chunk, a .npy header that claims more than it holds, a .npy of 3 dimensions,
    // noise, an empty file, a folder, a missing file.
    QFile heat(path(QStringLiteral("heat.png")));
    QVERIFY(heat.open(QIODevice::ReadOnly));
    QVERIFY(layerfiles::writeBytes(path(QStringLiteral("cut.png")), heat.readAll().left(40)));
    std::vector<float> few(10, 0.5f);
    QVERIFY(layerfiles::writeNpy(path(QStringLiteral("short.npy")), 100, 100, few));
    QByteArray cube = "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 2, 2), }";
    while ((10 + cube.size() + 1) % 64 != 0)
        cube += ' ';
    cube += '\n';
    QVERIFY(layerfiles::writeBytes(path(QStringLiteral("cube.npy")),
                                   QByteArray("\x93NUMPY\x01\x00", 8) + char(cube.size()) + char(0) + cube
                                       + QByteArray(32, '\0')));
    QByteArray noise(4096, '\0');
    for (int i = 0; i < noise.size(); ++i)
        noise[i] = char((i * 7919) ^ (i >> 3));
    QVERIFY(layerfiles::writeBytes(path(QStringLiteral("noise.tif")), noise));
    QVERIFY(layerfiles::writeBytes(path(QStringLiteral("empty.png")), QByteArray()));
    QVERIFY(QDir(m_dir.path()).mkpath(QStringLiteral("folder.png")));

    const QStringList hostile{QStringLiteral("cut.png"),   QStringLiteral("short.npy"), QStringLiteral("cube.npy"),
                              QStringLiteral("noise.tif"), QStringLiteral("empty.png"), QStringLiteral("folder.png"),
                              QStringLiteral("missing.png")};
    QSignalSpy errors(view, &IrisSlideView::slideError);
    QSignalSpy changed(view, &IrisSlideView::layersChanged);
    for (const QString &name : hostile) {
        errors.clear();
        QCOMPARE(view->addLayer(path(name)), quint64(0));
        QCOMPARE(errors.count(), 1);
        const QString message = errors.first().first().toString();
        QVERIFY2(message.contains(name), qPrintable(name + QStringLiteral(": ") + message));
        QCOMPARE(view->addLayer(path(name), true), quint64(0));
    }
    QCOMPARE(changed.count(), 0);
    QCOMPARE(view->layerIds(), QList<quint64>{kept});
    QCOMPARE(engineOf(view)->layers().size(), size_t(1));
    QCOMPARE(engineLayer(view, kept)->style.opacity, 0.4);

    // The view is as it was: it moves, renders, and takes a good layer.
    QVERIFY(view->hasSlide());
    view->panBy(QPointF(-30, 15));
    QVERIFY(m_w->frames->waitForCompleteFrame());
    QVERIFY(view->addLayer(path(QStringLiteral("prob.npy"))));
    QCOMPARE(engineOf(view)->layers().size(), size_t(2));
}

void TstLayersWidget::unusableHostMaps()
{
    IrisSlideView *view = m_w->view;
    QSignalSpy errors(view, &IrisSlideView::slideError);
    QCOMPARE(view->addLayer(std::shared_ptr<const iris::RasterMap>()), quint64(0));
    auto empty = std::make_shared<iris::RasterMap>(); // no level
    QCOMPARE(view->addLayer(empty), quint64(0));
    auto inconsistent = std::make_shared<iris::RasterMap>();
    inconsistent->levels.push_back(iris::RasterLevel{4, 4, std::vector<float>(3), {}, {}}); // 3 values for 16
    QCOMPARE(view->addLayer(inconsistent), quint64(0));
    QCOMPARE(errors.count(), 3);
    QVERIFY(view->layerIds().isEmpty());

    const quint64 good = view->addLayer(scalarMap(4, 4, 1));
    QVERIFY(good);
    QVERIFY(!view->setLayerMap(good, inconsistent));
    QCOMPARE(errors.count(), 4);
    QCOMPARE(view->layer(good).size, QSize(4, 4));
}

IRIS_WIDGET_TEST_MAIN(TstLayersWidget)
#include "tst_layers_widget.moc"
