// Iris View widget — IrisSlideView's raster layers (heat maps, label maps): the view's own list
// in EngineSettings::layers, handed to the engine by EngineHost::applyLayers.
#include <algorithm>
#include <cmath>
#include <functional>

#include <QtCore/QFile>
#include <QtCore/QFileInfo>

#include <iris/layers.h>

#include "iris/IrisSlideView.h"
#include "irisslideview_p.h"
#include "logging_p.h"

using IrisWidget::LayerSettings;

namespace {

QString fromStd(const std::string &s)
{
    return QString::fromUtf8(s.data(), qsizetype(s.size()));
}

using IrisWidget::findLayer;

std::vector<LayerSettings>::iterator layerAt(std::vector<LayerSettings> &layers, quint64 id)
{
    const LayerSettings *found = findLayer(layers, id);
    return found ? layers.begin() + (found - layers.data()) : layers.end();
}

QColor toQColor(iris::Rgba8 c)
{
    return QColor(c.r, c.g, c.b, c.a);
}

iris::Rgba8 toRgba8(const QColor &color)
{
    const QColor rgb = color.toRgb();
    return {uint8_t(rgb.red()), uint8_t(rgb.green()), uint8_t(rgb.blue()), uint8_t(rgb.alpha())};
}

IrisLayerInfo toLayerInfo(const LayerSettings &layer)
{
    IrisLayerInfo info;
    const iris::RasterMap &map = *layer.map;
    const iris::LayerStyle &style = layer.style;
    info.id = layer.id;
    info.title = fromStd(map.title);
    info.kind = map.kind == iris::RasterKind::Label ? IrisLayerInfo::Label
        : map.kind == iris::RasterKind::Rgba        ? IrisLayerInfo::Rgba
                                                    : IrisLayerInfo::Scalar;
    info.size = QSize(map.width(), map.height());
    info.levels = int(map.levels.size());
    info.minValue = map.minValue;
    info.maxValue = map.maxValue;
    info.visible = style.visible;
    info.opacity = style.opacity;
    info.colorMap = fromStd(style.colorMap.name);
    info.low = style.low;
    info.high = style.high;
    info.threshold = style.threshold;
    info.sampling = style.sampling == iris::LayerSampling::Nearest ? IrisLayerInfo::Nearest : IrisLayerInfo::Bilinear;
    for (const iris::LabelClass &c : style.classes)
        info.classes.append(IrisLayerClass{fromStd(c.name), toQColor(c.color), c.visible});
    return info;
}

// The style a layer starts with: a label map without a class table gets one for its ids.
iris::LayerStyle initialStyle(const iris::RasterMap &map, iris::LayerStyle style)
{
    if (map.kind == iris::RasterKind::Label && style.classes.empty() && std::isfinite(map.maxValue))
        style.classes = iris::defaultLabelClasses(int(map.maxValue) + 1);
    return style;
}

// Applies `edit` to layer `id` (false from it: nothing changes), then gives the engine the
// list and tells the host.
bool editLayer(IrisSlideView *q, IrisSlideViewPrivate *d, quint64 id, const std::function<bool(LayerSettings &)> &edit)
{
    const auto it = layerAt(d->settings.layers, id);
    if (it == d->settings.layers.end()) {
        qCDebug(lcIrisWidget) << "no layer" << id;
        return false;
    }
    LayerSettings changed = *it;
    if (!edit(changed))
        return false;
    *it = std::move(changed);
    d->host.applyLayers(d->settings);
    Q_EMIT q->layersChanged();
    return true;
}

bool editStyle(IrisSlideView *q, IrisSlideViewPrivate *d, quint64 id, const std::function<bool(iris::LayerStyle &)> &edit)
{
    return editLayer(q, d, id, [&](LayerSettings &layer) { return edit(layer.style); });
}

} // namespace

void IrisSlideViewPrivate::layersFollowSlide(const QString &shownPath)
{
    Q_Q(IrisSlideView);
    const bool another = !layersSlide.isEmpty() && layersSlide != shownPath;
    layersSlide = shownPath;
    if (!another || settings.layers.empty())
        return;
    qCInfo(lcIrisWidget) << "the slide's" << settings.layers.size() << "layers are removed with it";
    settings.layers.clear();
    host.applyLayers(settings);
    Q_EMIT q->layersChanged();
}

quint64 IrisSlideView::addLayer(const QString &path, bool asLabels)
{
    iris::RasterLoadOptions options;
    options.asLabels = asLabels;
    options.title = QFileInfo(path).fileName().toStdString();
    iris::Expected<iris::RasterMap> loaded = iris::loadRasterMap(QFile::encodeName(path).toStdString(), options);
    if (!loaded) {
        const QString text = fromStd(loaded.error().message());
        qCWarning(lcIrisWidget).noquote() << "cannot add the layer" << path << ":" << text;
        Q_EMIT slideError(text);
        return 0;
    }
    return addLayer(std::make_shared<const iris::RasterMap>(std::move(loaded).value()));
}

quint64 IrisSlideView::addLayer(std::shared_ptr<const iris::RasterMap> map)
{
    return addLayer(std::move(map), iris::LayerStyle{});
}

quint64 IrisSlideView::addLayer(std::shared_ptr<const iris::RasterMap> map, const iris::LayerStyle &style)
{
    Q_D(IrisSlideView);
    const std::string problem = map ? iris::rasterMapProblem(*map) : std::string("no map given");
    if (!problem.empty()) {
        const QString text = tr("The layer cannot be shown: %1").arg(fromStd(problem));
        qCWarning(lcIrisWidget).noquote() << text;
        Q_EMIT slideError(text);
        return 0;
    }
    LayerSettings layer;
    layer.id = ++d->lastLayerId;
    layer.style = initialStyle(*map, style);
    layer.map = std::move(map);
    d->settings.layers.push_back(std::move(layer));
    d->host.applyLayers(d->settings);
    Q_EMIT layersChanged();
    return d->lastLayerId;
}

QList<quint64> IrisSlideView::layerIds() const
{
    Q_D(const IrisSlideView);
    QList<quint64> ids;
    for (const LayerSettings &layer : d->settings.layers)
        ids.append(layer.id);
    return ids;
}

IrisLayerInfo IrisSlideView::layer(quint64 id) const
{
    Q_D(const IrisSlideView);
    const LayerSettings *layer = findLayer(d->settings.layers, id);
    return layer ? toLayerInfo(*layer) : IrisLayerInfo();
}

QList<IrisLayerInfo> IrisSlideView::layers() const
{
    Q_D(const IrisSlideView);
    QList<IrisLayerInfo> all;
    for (const LayerSettings &layer : d->settings.layers)
        all.append(toLayerInfo(layer));
    return all;
}

std::shared_ptr<const iris::RasterMap> IrisSlideView::layerMap(quint64 id) const
{
    Q_D(const IrisSlideView);
    const LayerSettings *layer = findLayer(d->settings.layers, id);
    return layer ? layer->map : nullptr;
}

iris::LayerStyle IrisSlideView::layerStyle(quint64 id) const
{
    Q_D(const IrisSlideView);
    const LayerSettings *layer = findLayer(d->settings.layers, id);
    return layer ? layer->style : iris::LayerStyle{};
}

bool IrisSlideView::setLayerMap(quint64 id, std::shared_ptr<const iris::RasterMap> map)
{
    Q_D(IrisSlideView);
    if (!findLayer(d->settings.layers, id))
        return false;
    const std::string problem = map ? iris::rasterMapProblem(*map) : std::string("no map given");
    if (!problem.empty()) {
        Q_EMIT slideError(tr("The layer cannot be shown: %1").arg(fromStd(problem)));
        return false;
    }
    return editLayer(this, d, id, [&](LayerSettings &layer) {
        layer.style = initialStyle(*map, layer.style);
        layer.map = std::move(map);
        return true;
    });
}

bool IrisSlideView::setLayerStyle(quint64 id, const iris::LayerStyle &style)
{
    Q_D(IrisSlideView);
    return editStyle(this, d, id, [&](iris::LayerStyle &s) {
        s = style;
        return true;
    });
}

bool IrisSlideView::setLayerPlacement(quint64 id, const iris::Placement &placement)
{
    Q_D(IrisSlideView);
    return editLayer(this, d, id, [&](LayerSettings &layer) {
        layer.placement = placement;
        return true;
    });
}

bool IrisSlideView::resetLayerPlacement(quint64 id)
{
    Q_D(IrisSlideView);
    return editLayer(this, d, id, [](LayerSettings &layer) {
        layer.placement.reset();
        return true;
    });
}

bool IrisSlideView::setLayerVisible(quint64 id, bool visible)
{
    Q_D(IrisSlideView);
    return editStyle(this, d, id, [&](iris::LayerStyle &s) {
        s.visible = visible;
        return true;
    });
}

bool IrisSlideView::setLayerOpacity(quint64 id, double opacity)
{
    Q_D(IrisSlideView);
    return editStyle(this, d, id, [&](iris::LayerStyle &s) {
        if (!std::isfinite(opacity))
            return false;
        s.opacity = std::clamp(opacity, 0.0, 1.0);
        return true;
    });
}

bool IrisSlideView::setLayerColorMap(quint64 id, const QString &name)
{
    Q_D(IrisSlideView);
    return editStyle(this, d, id, [&](iris::LayerStyle &s) {
        std::optional<iris::ColorMap> map = iris::ColorMap::builtin(name.toStdString());
        if (!map)
            return false;
        s.colorMap = std::move(*map);
        return true;
    });
}

bool IrisSlideView::loadLayerColorMap(quint64 id, const QString &path)
{
    Q_D(IrisSlideView);
    return editStyle(this, d, id, [&](iris::LayerStyle &s) {
        iris::Expected<iris::ColorMap> map = iris::ColorMap::fromFile(QFile::encodeName(path).toStdString());
        if (!map) {
            const QString text = fromStd(map.error().message());
            qCWarning(lcIrisWidget).noquote() << "cannot use the colour map" << path << ":" << text;
            Q_EMIT slideError(text);
            return false;
        }
        s.colorMap = std::move(map).value();
        s.colorMap.name = QFileInfo(path).fileName().toStdString();
        return true;
    });
}

bool IrisSlideView::setLayerWindow(quint64 id, double low, double high)
{
    Q_D(IrisSlideView);
    return editStyle(this, d, id, [&](iris::LayerStyle &s) {
        if (std::isinf(low) || std::isinf(high))
            return false;
        s.low = low;
        s.high = high;
        return true;
    });
}

bool IrisSlideView::setLayerThreshold(quint64 id, double threshold)
{
    Q_D(IrisSlideView);
    return editStyle(this, d, id, [&](iris::LayerStyle &s) {
        if (std::isnan(threshold))
            return false;
        s.threshold = threshold;
        return true;
    });
}

bool IrisSlideView::setLayerSampling(quint64 id, IrisLayerInfo::Sampling sampling)
{
    Q_D(IrisSlideView);
    return editStyle(this, d, id, [&](iris::LayerStyle &s) {
        s.sampling = sampling == IrisLayerInfo::Nearest ? iris::LayerSampling::Nearest : iris::LayerSampling::Bilinear;
        return true;
    });
}

bool IrisSlideView::setLayerClassColor(quint64 id, int classId, const QColor &color)
{
    Q_D(IrisSlideView);
    return editStyle(this, d, id, [&](iris::LayerStyle &s) {
        if (classId < 0 || size_t(classId) >= s.classes.size() || !color.isValid())
            return false;
        s.classes[size_t(classId)].color = toRgba8(color);
        return true;
    });
}

bool IrisSlideView::setLayerClassVisible(quint64 id, int classId, bool visible)
{
    Q_D(IrisSlideView);
    return editStyle(this, d, id, [&](iris::LayerStyle &s) {
        if (classId < 0 || size_t(classId) >= s.classes.size())
            return false;
        s.classes[size_t(classId)].visible = visible;
        return true;
    });
}

bool IrisSlideView::moveLayer(quint64 id, int index)
{
    Q_D(IrisSlideView);
    auto &layers = d->settings.layers;
    const auto it = layerAt(layers, id);
    if (it == layers.end())
        return false;
    LayerSettings moving = std::move(*it);
    layers.erase(it);
    const size_t to = std::min(size_t(std::max(index, 0)), layers.size());
    layers.insert(layers.begin() + std::ptrdiff_t(to), std::move(moving));
    d->host.applyLayers(d->settings);
    Q_EMIT layersChanged();
    return true;
}

void IrisSlideView::removeLayer(quint64 id)
{
    Q_D(IrisSlideView);
    const auto it = layerAt(d->settings.layers, id);
    if (it == d->settings.layers.end())
        return;
    d->settings.layers.erase(it);
    d->host.applyLayers(d->settings);
    Q_EMIT layersChanged();
}

void IrisSlideView::clearLayers()
{
    Q_D(IrisSlideView);
    if (d->settings.layers.empty())
        return;
    d->settings.layers.clear();
    d->host.applyLayers(d->settings);
    Q_EMIT layersChanged();
}
