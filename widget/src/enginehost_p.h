// Iris View widget — not API. Owns one iris::Engine for a widget and carries its
// render-thread callbacks over to the GUI thread.
//
// Lifecycle (GUI thread): create() → bindSurface() … unbindSurface() → destroy(). The
// engine's frame callback runs on the engine's render thread; it only posts a queued call
// to this object, through a relay that the destructor disconnects under a lock, so nothing
// reaches a destroyed host. Posting is bounded: when the GUI thread falls more than a few
// frames behind, the newest frame's figures replace the last ones waiting, so that the last
// frame rendered is always delivered (a complete frame that ends a burst of loading included).
#pragma once

#include <array>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include <QtCore/QByteArray>
#include <QtCore/QObject>
#include <QtCore/QPointF>
#include <QtCore/QSize>
#include <QtCore/QString>

#include <iris/engine.h>

#include "autotest_p.h"

QT_BEGIN_NAMESPACE
class QColor;
class QVulkanInstance;
class QWindow;
QT_END_NAMESPACE

namespace IrisWidget {

// A raster layer of the view (IrisSlideView::addLayer): the view's own id, which outlives
// engines (each engine numbers its layers itself), and what the engine is given.
struct LayerSettings {
    quint64 id = 0;
    std::shared_ptr<const iris::RasterMap> map;
    iris::LayerStyle style;
    std::optional<iris::Placement> placement; // none: spanning the open slide's level 0
};

struct EngineSettings {
    // The engine's defaults (EngineConfig), which the widget's properties start from.
    quint64 ramBudgetBytes = iris::EngineConfig{}.ramBudgetBytes;
    quint64 vramBudgetBytes = iris::EngineConfig{}.vramBudgetBytes;
    bool validation = false;
    std::array<float, 3> background = iris::EngineConfig{}.background;
    bool enhance = true;
    // The widget shows every overlay by default (the engine's own default is none).
    // (The legend shows only while a heat map is: on, it appears with the first one.)
    std::array<bool, iris::kOverlayCount> overlayVisible{true, true, true, true};
    std::array<iris::Corner, iris::kOverlayCount> overlayCorner{iris::Corner::BottomLeft, iris::Corner::TopLeft,
                                                                iris::Corner::TopRight, iris::Corner::BottomRight};
    QString overlayFont; // empty: the engine's default
    std::optional<QPointF> crosshair; // level-0 position; none: hidden
    // Colour management; displayProfile is the one in use (the host's or the screen's).
    bool colorManaged = iris::EngineConfig{}.color.managed;
    iris::RenderingIntent intent = iris::EngineConfig{}.color.intent;
    QByteArray displayProfile;
    // DICOMweb credentials and TLS (IrisSlideView::setNetworkCredentials); memory only, never logged.
    iris::NetworkOptions network;
    // Annotations (IrisSlideView::setAnnotations): the host's store, shown, selected object.
    std::shared_ptr<iris::AnnotationStore> annotations;
    bool annotationsVisible = true;
    quint64 selectedAnnotation = 0;
    // Raster layers, bottom first (IrisSlideView::addLayer and its setters).
    std::vector<LayerSettings> layers;
};

// The layer of that id in `layers`; null when there is none.
const LayerSettings *findLayer(const std::vector<LayerSettings> &layers, quint64 id);

// The engine's colour settings for `settings`.
iris::ColorSettings toEngineColor(const EngineSettings &settings);

// A QColor as the engine's background components. The engine's targets are UNORM (bytes
// in, bytes out, no sRGB encode on write), so QColor's display-encoded components are
// passed through as they are.
std::array<float, 3> toEngineRgb(const QColor &color);

class IRIS_WIDGET_AUTOTEST_EXPORT EngineHost : public QObject {
    Q_OBJECT
public:
    explicit EngineHost(QObject *parent = nullptr);
    ~EngineHost() override;

    // Creates the engine on vulkan's VkInstance. On failure returns false and sets *error.
    bool create(QVulkanInstance *vulkan, const EngineSettings &settings, QString *error);
    // Releases the swapchain if bound, then destroys the engine (joining its threads).
    void destroy();
    iris::Engine *engine() const { return m_engine.get(); }
    const EngineSettings &settings() const { return m_settings; }
    // Shows, places and re-fonts the overlays as `settings` say (only what changed).
    void applyOverlays(const EngineSettings &settings);
    void applyAnnotations(const EngineSettings &settings);
    // Brings the engine's layer stack to settings.layers: adds, removes, re-styles and re-orders
    // only what differs from the stack last applied (a new engine gets them all).
    void applyLayers(const EngineSettings &settings);
    // Gives the engine the colour settings of `settings` when they differ from its own (a new
    // transform is baked on this thread: milliseconds).
    void applyColor(const EngineSettings &settings);

    // Makes the engine present into window's surface at deviceSize.
    bool bindSurface(QWindow *window, QSize deviceSize, QString *error);
    // Waits until the render thread has released the swapchain; the surface may die next.
    void unbindSurface();
    bool isBound() const { return m_bound; }

    // Engines alive in this process (tests check that closing widgets frees them).
    static int liveEngineCount();

Q_SIGNALS:
    // A frame was rendered and presented (delivered on the GUI thread).
    void frameRendered(const iris::FrameStats &stats);
    // The engine lost its device (it recovers by itself), recovered it (status Ok), or lost
    // the bound surface (Engine::setFaultCallback; delivered on the GUI thread).
    void engineFault(iris::Status status, const QString &message);

private:
    struct Relay;
    // Emits frameRendered for every frame waiting in relay (GUI thread).
    void deliverFrames(Relay &relay);
    std::shared_ptr<Relay> m_relay;
    QVulkanInstance *m_vulkan = nullptr;
    std::unique_ptr<iris::Engine> m_engine;
    EngineSettings m_settings;
    std::map<quint64, uint64_t> m_layerIds; // the view's layer id → this engine's
    bool m_bound = false;
};

} // namespace IrisWidget
