#include "enginehost_p.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <vector>

#include <QtCore/QFile>
#include <QtCore/QPointer>
#include <QtGui/QColor>
#include <QtGui/QVulkanInstance>
#include <QtGui/QWindow>

#include "logging_p.h"

namespace IrisWidget {

namespace {

constexpr size_t kMaxPendingFrames = 4;
std::atomic<int> g_liveEngines{0};

QString fromStd(const std::string &s)
{
    return QString::fromUtf8(s.data(), qsizetype(s.size()));
}

bool sameNumber(double a, double b)
{
    return a == b || (std::isnan(a) && std::isnan(b));
}

bool sameStyle(const iris::LayerStyle &a, const iris::LayerStyle &b)
{
    const auto sameClass = [](const iris::LabelClass &x, const iris::LabelClass &y) {
        return x.name == y.name && x.color == y.color && x.visible == y.visible;
    };
    return a.visible == b.visible && sameNumber(a.opacity, b.opacity) && a.colorMap.name == b.colorMap.name
        && a.colorMap.entries == b.colorMap.entries && sameNumber(a.low, b.low) && sameNumber(a.high, b.high)
        && sameNumber(a.threshold, b.threshold) && a.sampling == b.sampling
        && std::equal(a.classes.begin(), a.classes.end(), b.classes.begin(), b.classes.end(), sameClass);
}

bool samePlacement(const std::optional<iris::Placement> &a, const std::optional<iris::Placement> &b)
{
    return a.has_value() == b.has_value() && (!a || a->m == b->m);
}

void warnLayer(const char *what, quint64 id, const iris::Result &r)
{
    if (!r)
        qCWarning(lcIrisWidget).noquote() << what << "layer" << id << ":" << fromStd(r.message());
}

} // namespace

const LayerSettings *findLayer(const std::vector<LayerSettings> &layers, quint64 id)
{
    const auto it = std::find_if(layers.begin(), layers.end(), [id](const LayerSettings &l) { return l.id == id; });
    return it == layers.end() ? nullptr : &*it;
}

std::array<float, 3> toEngineRgb(const QColor &color)
{
    const QColor rgb = color.toRgb();
    return {rgb.redF(), rgb.greenF(), rgb.blueF()};
}

iris::ColorSettings toEngineColor(const EngineSettings &settings)
{
    iris::ColorSettings color;
    color.managed = settings.colorManaged;
    color.intent = settings.intent;
    color.displayProfile.assign(settings.displayProfile.begin(), settings.displayProfile.end());
    return color;
}

// Shared by the host (GUI thread) and the engine's frame callback (render thread).
struct EngineHost::Relay {
    std::mutex mutex;
    EngineHost *host = nullptr; // guarded by mutex; null once the host is going away
    // Frames rendered but not yet delivered, oldest first (guarded by mutex); a queued call
    // to deliver them is outstanding while it is not empty. At most kMaxPendingFrames: a
    // frame that finds it full takes the last place, so that the frame delivered last is the
    // last one rendered.
    // (Dropping the newest instead lost the complete frame that ends a burst of loading, and
    // a host waiting for it waited for ever: the engine draws nothing more until the view
    // changes. tst_view_churn found it with eight views opening at once.)
    std::vector<iris::FrameStats> pending;
};

EngineHost::EngineHost(QObject *parent)
    : QObject(parent)
    , m_relay(std::make_shared<Relay>())
{
    m_relay->host = this;
}

EngineHost::~EngineHost()
{
    {
        std::lock_guard lock(m_relay->mutex);
        m_relay->host = nullptr;
    }
    destroy();
}

namespace {
// An engine callback's way to its host, from an engine thread: f(relay) runs under the relay's
// mutex, and only while the relay and its host are both alive.
template <class Relay, class F>
void withLiveHost(const std::weak_ptr<Relay> &weakRelay, F &&f)
{
    const std::shared_ptr<Relay> relay = weakRelay.lock();
    if (!relay)
        return;
    std::lock_guard lock(relay->mutex);
    if (relay->host)
        f(relay);
}
} // namespace

bool EngineHost::create(QVulkanInstance *vulkan, const EngineSettings &settings, QString *error)
{
    destroy();
    iris::EngineConfig config;
    config.ramBudgetBytes = settings.ramBudgetBytes;
    config.vramBudgetBytes = settings.vramBudgetBytes;
    config.validation = settings.validation;
    config.background = settings.background;
    config.instance = vulkan->vkInstance();
    config.log = &logEngineMessage;
    config.color = toEngineColor(settings);
    config.network = settings.network;

    auto created = iris::Engine::create(config);
    if (!created) {
        *error = fromStd(created.error().message());
        qCWarning(lcIrisWidget).noquote() << "cannot create the engine:" << *error;
        return false;
    }
    m_engine = std::move(created).value();
    m_vulkan = vulkan;
    m_settings = settings;
    m_engine->setEnhance(settings.enhance);
    m_settings.overlayFont.clear(); // a new engine has no font of the host's yet
    applyOverlays(settings);
    applyAnnotations(settings);
    m_layerIds.clear(); // a new engine has none of them yet
    applyLayers(settings);
    g_liveEngines.fetch_add(1, std::memory_order_relaxed); // a counter for tests; orders nothing

    std::weak_ptr<Relay> weakRelay = m_relay;
    m_engine->setFrameCallback([weakRelay](const iris::FrameStats &stats) {
        withLiveHost(weakRelay, [&](const std::shared_ptr<Relay> &relay) {
            const bool queued = !relay->pending.empty();
            if (relay->pending.size() < kMaxPendingFrames)
                relay->pending.push_back(stats);
            else
                relay->pending.back() = stats;
            if (queued)
                return;
            EngineHost *host = relay->host;
            // The queued call belongs to host: if host is deleted first, Qt discards it.
            QMetaObject::invokeMethod(
                host, [host, relay] { host->deliverFrames(*relay); }, Qt::QueuedConnection);
        });
    });

    m_engine->setFaultCallback([weakRelay](const iris::Result &fault) {
        withLiveHost(weakRelay, [&](const std::shared_ptr<Relay> &relay) {
            EngineHost *host = relay->host;
            const iris::Status status = fault.status();
            const QString message = fromStd(fault.message());
            QMetaObject::invokeMethod(host, [host, status, message] {
                Q_EMIT host->engineFault(status, message);
            }, Qt::QueuedConnection);
        });
    });

    const iris::DeviceInfo device = m_engine->device();
    qCInfo(lcIrisWidget).noquote() << "engine ready on" << fromStd(device.name) << "with"
                                   << device.atlasSlots << "tile slots";
    return true;
}

void EngineHost::deliverFrames(Relay &relay)
{
    // One at a time from the queue itself, not a copy of it: a receiver that runs a nested
    // event loop delivers the next frames there, and this loop then goes on after them, in order.
    const QPointer<EngineHost> alive(this);
    for (;;) {
        iris::FrameStats stats;
        {
            std::lock_guard lock(relay.mutex);
            if (relay.pending.empty())
                return; // a frame rendered from now on queues another call
            stats = relay.pending.front();
            relay.pending.erase(relay.pending.begin());
        }
        Q_EMIT frameRendered(stats);
        if (!alive) // a receiver deleted the view
            return;
    }
}

void EngineHost::applyOverlays(const EngineSettings &settings)
{
    if (!m_engine)
        return;
    m_settings.overlayVisible = settings.overlayVisible;
    m_settings.overlayCorner = settings.overlayCorner;
    for (int i = 0; i < iris::kOverlayCount; ++i)
        m_engine->setOverlayCorner(iris::Overlay(i), settings.overlayCorner[size_t(i)]);
    // The font first: turning a labelled overlay on would otherwise look up the default one.
    // (An empty path goes back to the engine's default font.)
    if (settings.overlayFont != m_settings.overlayFont) {
        const iris::Result r = m_engine->setOverlayFont(QFile::encodeName(settings.overlayFont).toStdString());
        if (!r)
            qCWarning(lcIrisWidget).noquote() << "overlay font:" << fromStd(r.message());
    }
    m_settings.overlayFont = settings.overlayFont;
    for (int i = 0; i < iris::kOverlayCount; ++i)
        m_engine->setOverlayVisible(iris::Overlay(i), settings.overlayVisible[size_t(i)]);
    m_settings.crosshair = settings.crosshair;
    m_engine->setCrosshair(settings.crosshair ? std::optional(std::array<double, 2>{settings.crosshair->x(),
                                                                                   settings.crosshair->y()})
                                              : std::nullopt);
}

void EngineHost::applyAnnotations(const EngineSettings &settings)
{
    if (!m_engine)
        return;
    m_settings.annotations = settings.annotations;
    m_settings.annotationsVisible = settings.annotationsVisible;
    m_settings.selectedAnnotation = settings.selectedAnnotation;
    m_engine->setAnnotations(settings.annotations);
    m_engine->setAnnotationsVisible(settings.annotationsVisible);
    m_engine->setSelectedAnnotation(settings.selectedAnnotation);
}

void EngineHost::applyLayers(const EngineSettings &settings)
{
    if (!m_engine)
        return;
    for (auto it = m_layerIds.begin(); it != m_layerIds.end();) {
        if (findLayer(settings.layers, it->first)) {
            ++it;
            continue;
        }
        m_engine->removeLayer(it->second);
        it = m_layerIds.erase(it);
    }
    std::vector<uint64_t> order; // engine ids, bottom first
    for (const LayerSettings &layer : settings.layers) {
        const auto shown = m_layerIds.find(layer.id);
        const LayerSettings *was = findLayer(m_settings.layers, layer.id);
        if (shown == m_layerIds.end() || !was) {
            const iris::Expected<uint64_t> added = m_engine->addLayer(layer.map, layer.style, layer.placement);
            if (!added) { // the view checks maps first: not expected
                warnLayer("cannot add", layer.id, added.error());
                continue;
            }
            m_layerIds[layer.id] = *added;
            order.push_back(*added);
            continue;
        }
        order.push_back(shown->second);
        if (was->map != layer.map)
            warnLayer("cannot replace the map of", layer.id, m_engine->setLayerMap(shown->second, layer.map));
        if (!sameStyle(was->style, layer.style))
            warnLayer("cannot style", layer.id, m_engine->setLayerStyle(shown->second, layer.style));
        if (!samePlacement(was->placement, layer.placement))
            warnLayer("cannot place", layer.id, m_engine->setLayerPlacement(shown->second, layer.placement));
    }
    std::vector<uint64_t> stack;
    for (const iris::Engine::LayerEntry &entry : m_engine->layers())
        stack.push_back(entry.id);
    if (stack != order) {
        for (size_t i = 0; i < order.size(); ++i)
            warnLayer("cannot move", order[i], m_engine->moveLayer(order[i], i));
    }
    m_settings.layers = settings.layers;
}

void EngineHost::applyColor(const EngineSettings &settings)
{
    if (!m_engine)
        return;
    if (settings.colorManaged == m_settings.colorManaged && settings.intent == m_settings.intent
        && settings.displayProfile == m_settings.displayProfile)
        return;
    m_settings.colorManaged = settings.colorManaged;
    m_settings.intent = settings.intent;
    m_settings.displayProfile = settings.displayProfile;
    m_engine->setColorSettings(toEngineColor(settings));
}

void EngineHost::destroy()
{
    if (!m_engine)
        return;
    unbindSurface();
    m_engine->setFrameCallback({});
    m_engine->setFaultCallback({});
    m_engine.reset(); // joins the engine's threads: no callback runs after this
    m_layerIds.clear();
    m_vulkan = nullptr;
    g_liveEngines.fetch_sub(1, std::memory_order_relaxed);
}

bool EngineHost::bindSurface(QWindow *window, QSize deviceSize, QString *error)
{
    if (!m_engine || m_bound)
        return m_bound;
    const VkSurfaceKHR surface = QVulkanInstance::surfaceForWindow(window);
    if (surface == VK_NULL_HANDLE) {
        *error = QStringLiteral("The window has no Vulkan surface.");
        return false;
    }
    const iris::Result bound = m_engine->bindSurface(m_vulkan->vkInstance(), surface,
                                                     uint32_t(deviceSize.width()), uint32_t(deviceSize.height()));
    if (!bound) {
        *error = fromStd(bound.message());
        qCWarning(lcIrisWidget).noquote() << "cannot bind the surface:" << *error;
        return false;
    }
    qCDebug(lcIrisWidget) << "surface bound at" << deviceSize << "device pixels";
    m_bound = true;
    return true;
}

void EngineHost::unbindSurface()
{
    if (!m_engine || !m_bound)
        return;
    m_engine->unbindSurface();
    m_bound = false;
    qCDebug(lcIrisWidget) << "surface released";
}

int EngineHost::liveEngineCount()
{
    return g_liveEngines.load(std::memory_order_relaxed);
}

} // namespace IrisWidget
