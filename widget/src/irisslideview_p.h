// Iris View widget — not API. IrisSlideView's private implementation.
//
// Ownership and order: the shared QVulkanInstance outlives the engine, which outlives the
// surface window's VkSurfaceKHR binding. ~IrisSlideView therefore (1) stops motion, (2)
// destroys the engine (which first releases the swapchain), (3) deletes the window
// container (the window and its VkSurfaceKHR), and only then lets this object — and with
// it the instance reference — go. When the platform destroys the surface on its own
// (re-parenting), SurfaceAboutToBeDestroyed unbinds first and the next expose rebinds.
#pragma once

#include <memory>
#include <optional>

#include <QtGui/QColor>

#include <iris/engine.h>

#include "annotationtools_p.h"
#include "autotest_p.h"
#include "enginehost_p.h"
#include "fpsmeter_p.h"
#include "iris/IrisSlideView.h"
#include "navigator_p.h"
#include "surfacewindow_p.h"

QT_BEGIN_NAMESPACE
class QLabel;
class QStackedLayout;
class QVulkanInstance;
QT_END_NAMESPACE

class IrisSlideViewPrivate final : public IrisWidget::NavigationTarget {
    Q_DECLARE_PUBLIC(IrisSlideView)
public:
    explicit IrisSlideViewPrivate(IrisSlideView *q);
    ~IrisSlideViewPrivate() override;
    static IrisSlideViewPrivate *dOf(IrisSlideView *view) { return view->d_func(); }

    void init();
    void teardown();

    // --- engine and surface ----------------------------------------------------------
    iris::Engine *engine() const { return host.engine(); }
    bool ensureEngine();
    bool recreateEngine();
    void bindIfReady();
    void onExposedChanged(bool exposed);
    void onTargetSizeChanged(QSize deviceSize);
    void onSurfaceAboutToBeDestroyed();
    void onFrameRendered(const iris::FrameStats &stats);
    void checkEngineError();
    void createSurfaceWindow();
    void replaceSurfaceWindow();
    void onEngineFault(iris::Status status, const QString &message);
    void showMessage(const QString &text);
    // Takes the display profile from the host's setting or the view's screen and gives the
    // engine the colour settings when they changed; emits colorManagementChanged() when the
    // caller changed a setting or the profile changed.
    void updateColor(bool settingChanged);

    // --- slide and view --------------------------------------------------------------
    bool open(const QString &path);
    void forgetSlide();
    // Raster layers belong to the slide they are shown over: called with the path now shown
    // ("" when none), it removes them when that is not the slide they were shown over.
    void layersFollowSlide(const QString &shownPath);
    void setView(iris::View view);
    void notifyViewChanged();
    double devicePixelRatio() const;
    QPointF toTarget(QPointF widgetPos) const;   // logical widget → device target pixels
    QPointF fromTarget(QPointF targetPos) const; // and back
    double clampDownsample(double downsample) const;
    // Centres the view on the slide point under widgetPos when it lies on the overview map's
    // thumbnail (clamp: a point beside it counts as its nearest edge, for drags); false otherwise.
    bool moveToOverview(QPointF widgetPos, bool clamp);
    // The pointer's shape over the view: a pointing hand over the overview map, else an open hand.
    void updateCursor(QPointF widgetPos);

    // --- NavigationTarget ------------------------------------------------------------
    bool canNavigate() const override;
    void pan(QPointF logicalDelta) override;
    void panFields(int fieldsX, int fieldsY) override;
    void zoom(double factor, QPointF logicalAnchor) override;
    void rotate(double degrees, QPointF logicalAnchor) override;
    void flip() override;
    void resetOrientation() override;
    QPointF viewportCentre() const override;
    void fit() override;
    void showMagnificationPreset(int index) override;

    IrisSlideView *q_ptr;
    std::shared_ptr<QVulkanInstance> vulkan;
    QString rendererError;                   // why there is no renderer; empty while fine
    QStackedLayout *stack = nullptr;
    QWidget *container = nullptr;            // owns window
    IrisWidget::SurfaceWindow *window = nullptr;
    QLabel *message = nullptr;
    IrisWidget::EngineHost host;
    IrisWidget::ViewNavigator navigator;
    IrisWidget::AnnotationTools tools; // takes input first while a tool is in effect
    Qt::MouseButton toolPanButton = Qt::NoButton; // a right or middle drag panning under a tool
    IrisWidget::EngineSettings settings;     // for the next engine
    IrisWidget::FpsMeter fps;
    QColor background;

    std::optional<iris::SlideInfo> slide;
    IrisSlideInfo info;
    QString path;
    bool fitPending = false;                 // opened before a target was bound
    int surfaceReplacements = 0;             // lost surfaces replaced (tests)
    double boundDevicePixelRatio = 0;        // at the last bind or resize
    std::optional<iris::View> notifiedView;  // last view viewChanged() announced
    bool overviewDragging = false;           // a press on the overview map: moves follow it
    std::optional<QByteArray> hostDisplayProfile; // setDisplayProfile(); none: the screen's
    quint64 lastLayerId = 0;                 // the view's layer ids count up from 1
    QString layersSlide;                     // the slide the layers are shown over; "": none yet
};

namespace IrisWidget {
// For the widget's own tests (fault injection, the engine's layer stack): free functions rather
// than access through IrisSlideViewPrivate, whose typeinfo is not exported (UBSan's vptr check in
// the asan build needs it for any member access through a pointer to it).
IRIS_WIDGET_AUTOTEST_EXPORT iris::Engine *engineOf(IrisSlideView *view);
IRIS_WIDGET_AUTOTEST_EXPORT int surfaceReplacementsOf(IrisSlideView *view);
} // namespace IrisWidget
