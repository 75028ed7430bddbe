#include "irisslideview_p.h"

#include <algorithm>
#include <cmath>

#include <QtCore/QFile>
#include <QtCore/QTimer>
#include <QtGui/QScreen>
#include <QtGui/QVulkanInstance>
#include <QtWidgets/QLabel>
#include <QtWidgets/QStackedLayout>

#include "displayprofile_p.h"
#include "eventforwarding_p.h"
#include "logging_p.h"
#include "magnification_p.h"
#include "slideinfo_p.h"
#include "vulkaninstance_p.h"

using namespace IrisWidget;

namespace {
QString fromStd(const std::string &s)
{
    return QString::fromUtf8(s.data(), qsizetype(s.size()));
}
} // namespace

IrisSlideViewPrivate::IrisSlideViewPrivate(IrisSlideView *q)
    : q_ptr(q)
    , navigator(this)
    , tools(q)
{
    const auto &[r, g, b] = settings.background; // the engine's default
    background = QColor::fromRgbF(r, g, b);
}

IrisSlideViewPrivate::~IrisSlideViewPrivate() = default;

namespace IrisWidget {
iris::Engine *engineOf(IrisSlideView *view)
{
    return view ? IrisSlideViewPrivate::dOf(view)->engine() : nullptr;
}

int surfaceReplacementsOf(IrisSlideView *view)
{
    return view ? IrisSlideViewPrivate::dOf(view)->surfaceReplacements : 0;
}
} // namespace IrisWidget

void IrisSlideViewPrivate::init()
{
    Q_Q(IrisSlideView);
    stack = new QStackedLayout(q);
    stack->setContentsMargins(0, 0, 0, 0);
    q->setFocusPolicy(Qt::StrongFocus);
    q->setMouseTracking(true);
    q->setAttribute(Qt::WA_OpaquePaintEvent);

    QObject::connect(&host, &EngineHost::frameRendered, &host,
                     [this](const iris::FrameStats &stats) { onFrameRendered(stats); });
    QObject::connect(&navigator, &ViewNavigator::draggingChanged, &navigator, [this](bool dragging) {
        if (window)
            window->setCursor(dragging ? Qt::ClosedHandCursor : Qt::OpenHandCursor);
    });

    QObject::connect(&host, &EngineHost::engineFault, &host,
                     [this](iris::Status status, const QString &message) { onEngineFault(status, message); });

    vulkan = acquireVulkanInstance(&rendererError);
    if (!vulkan) {
        showMessage(rendererError);
        return;
    }
    createSurfaceWindow();
}

// The native window the engine presents into, embedded in the widget, and its connections.
void IrisSlideViewPrivate::createSurfaceWindow()
{
    Q_Q(IrisSlideView);
    window = new SurfaceWindow;
    window->setVulkanInstance(vulkan.get());
    window->inputHandler = [this](QEvent *event) {
        Q_Q(IrisSlideView);
        // Qt gives click and wheel focus only for spontaneous events to widgets; input on
        // the embedded window must do it here, or a click would not focus the view.
        const Qt::FocusPolicy policy = q->focusPolicy();
        if ((event->type() == QEvent::MouseButtonPress && (policy & Qt::ClickFocus))
            || (event->type() == QEvent::Wheel && (policy & Qt::WheelFocus) == Qt::WheelFocus)) {
            if (!q->hasFocus())
                q->setFocus(event->type() == QEvent::Wheel ? Qt::OtherFocusReason : Qt::MouseFocusReason);
        }
        return forwardInputEvent(event, container, q);
    };
    QObject::connect(window, &SurfaceWindow::exposedChanged, &host,
                     [this](bool exposed) { onExposedChanged(exposed); });
    QObject::connect(window, &SurfaceWindow::contentsLost, &host, [this] {
        if (host.isBound())
            engine()->redraw();
    });
    QObject::connect(window, &SurfaceWindow::targetSizeChanged, &host,
                     [this](QSize size) { onTargetSizeChanged(size); });
    QObject::connect(window, &SurfaceWindow::surfaceAboutToBeDestroyed, &host,
                     [this] { onSurfaceAboutToBeDestroyed(); });
    // The display profile follows the screen the view is on (a child window's screen follows
    // its top-level's) and the platform's changes to it.
    QObject::connect(window, &QWindow::screenChanged, &host, [this] { updateColor(false); });
    if (DisplayProfileWatcher *watcher = DisplayProfileWatcher::instance())
        QObject::connect(watcher, &DisplayProfileWatcher::changed, &host, [this] { updateColor(false); });
    updateColor(false);

    container = QWidget::createWindowContainer(window, q);
    container->setObjectName(QStringLiteral("irisSurfaceContainer"));
    container->setFocusPolicy(Qt::StrongFocus);
    container->setMouseTracking(true);
    q->setFocusProxy(container);
    stack->addWidget(container);
    stack->setCurrentWidget(container);
}

// The window system took the surface away (VK_ERROR_SURFACE_LOST_KHR): the engine draws
// nothing until it is given a new one. A new native window brings a new VkSurfaceKHR; the
// engine, its slide and view stay, and the next expose binds it (bindIfReady).
void IrisSlideViewPrivate::replaceSurfaceWindow()
{
    Q_Q(IrisSlideView);
    const bool hadFocus = container && container->hasFocus();
    host.unbindSurface();
    if (container) {
        q->setFocusProxy(nullptr);
        delete container; // the window and its lost VkSurfaceKHR go with it
        container = nullptr;
        window = nullptr;
    }
    createSurfaceWindow();
    if (q->isVisible())
        container->show();
    if (hadFocus)
        container->setFocus(Qt::OtherFocusReason);
    surfaceReplacements++;
}

void IrisSlideViewPrivate::onEngineFault(iris::Status status, const QString &message)
{
    Q_Q(IrisSlideView);
    switch (status) {
    case iris::Status::SurfaceLost:
        qCWarning(lcIrisWidget).noquote() << "surface lost:" << message << "- making a new one";
        if (engine())
            engine()->clearError(); // handled here: checkEngineError() must not report it again
        replaceSurfaceWindow();
        break;
    case iris::Status::DeviceLost:
        // The engine recreates its device and draws the view again by itself.
        qCWarning(lcIrisWidget).noquote() << "device lost:" << message;
        if (engine())
            engine()->clearError();
        Q_EMIT q->slideError(IrisSlideView::tr("The graphics device was lost; the view is being restored."));
        break;
    case iris::Status::Ok:
        qCInfo(lcIrisWidget).noquote() << message;
        break;
    default:
        qCWarning(lcIrisWidget).noquote() << "engine fault:" << message;
        break;
    }
}

void IrisSlideViewPrivate::teardown()
{
    navigator.stopMotion();
    host.destroy(); // releases the swapchain, then joins the engine's threads
    if (container) {
        Q_Q(IrisSlideView);
        q->setFocusProxy(nullptr);
        delete container; // the window and its VkSurfaceKHR go with it
        container = nullptr;
        window = nullptr;
    }
}

void IrisSlideViewPrivate::showMessage(const QString &text)
{
    Q_Q(IrisSlideView);
    if (!message) {
        message = new QLabel(q);
        message->setObjectName(QStringLiteral("irisRendererMessage"));
        message->setAlignment(Qt::AlignCenter);
        message->setWordWrap(true);
        message->setMargin(24);
        message->setTextInteractionFlags(Qt::TextSelectableByMouse);
        stack->addWidget(message);
    }
    message->setText(IrisSlideView::tr("The slide view cannot be shown.\n\n%1").arg(text));
    stack->setCurrentWidget(message);
    if (container)
        container->hide();
}

void IrisSlideViewPrivate::updateColor(bool settingChanged)
{
    Q_Q(IrisSlideView);
    const QScreen *screen = window ? window->screen() : q->screen();
    const QByteArray profile = hostDisplayProfile ? *hostDisplayProfile : screenIccProfile(screen);
    const bool profileChanged = profile != settings.displayProfile;
    if (profileChanged) {
        qCInfo(lcIrisWidget).noquote() << "display profile:"
                                       << (profile.isEmpty() ? QStringLiteral("sRGB")
                                                             : QStringLiteral("%1 bytes").arg(profile.size()))
                                       << (hostDisplayProfile ? "(the host's)" : "(the screen's)");
        settings.displayProfile = profile;
    }
    host.applyColor(settings);
    if (settingChanged || profileChanged)
        Q_EMIT q->colorManagementChanged();
}

// --- engine and surface ----------------------------------------------------------------

bool IrisSlideViewPrivate::ensureEngine()
{
    if (engine())
        return true;
    if (!vulkan)
        return false;
    QString error;
    // The engine counts validation messages when the shared instance has the layer (it was
    // made with it when IrisSlideView::setVulkanValidation(true) came first).
    settings.validation = vulkan->layers().contains(QByteArrayLiteral("VK_LAYER_KHRONOS_validation"));
    if (!host.create(vulkan.get(), settings, &error)) {
        Q_Q(IrisSlideView);
        rendererError = error;
        showMessage(error);
        Q_EMIT q->slideError(IrisSlideView::tr("The renderer could not start: %1").arg(error));
        return false;
    }
    bindIfReady();
    return true;
}

bool IrisSlideViewPrivate::recreateEngine()
{
    qCInfo(lcIrisWidget) << "recreating the engine";
    host.destroy();
    return ensureEngine();
}

void IrisSlideViewPrivate::bindIfReady()
{
    if (!engine() || host.isBound() || !window || !window->isExposed())
        return;
    const QSize size = window->targetSize();
    if (size.isEmpty())
        return;
    QString error;
    if (!host.bindSurface(window, size, &error)) {
        Q_Q(IrisSlideView);
        Q_EMIT q->slideError(IrisSlideView::tr("The view cannot present: %1").arg(error));
        return;
    }
    boundDevicePixelRatio = window->devicePixelRatio();
    engine()->setDevicePixelRatio(boundDevicePixelRatio); // overlays: text at device resolution
    engine()->setVisible(true);
    if (fitPending && slide) {
        fitPending = false;
        engine()->setView(engine()->fitView());
    }
    notifyViewChanged();
}

void IrisSlideViewPrivate::onExposedChanged(bool exposed)
{
    if (exposed) {
        if (!ensureEngine())
            return;
        bindIfReady();
    }
    if (host.isBound())
        engine()->setVisible(exposed);
}

void IrisSlideViewPrivate::onTargetSizeChanged(QSize deviceSize)
{
    if (!host.isBound())
        return;
    const double ratio = window->devicePixelRatio();
    const iris::View before = engine()->view();
    engine()->resize(uint32_t(deviceSize.width()), uint32_t(deviceSize.height()));
    engine()->setDevicePixelRatio(ratio);
    if (slide && boundDevicePixelRatio > 0 && ratio != boundDevicePixelRatio) {
        // Another screen: keep the same field in the same logical area, so the glass looks
        // as it did; the device-pixel downsample follows the new ratio.
        iris::View view = before;
        view.downsample = before.downsample * boundDevicePixelRatio / ratio;
        engine()->setView(view);
    }
    boundDevicePixelRatio = ratio;
    notifyViewChanged();
}

void IrisSlideViewPrivate::onSurfaceAboutToBeDestroyed()
{
    navigator.stopMotion();
    host.unbindSurface();
}

void IrisSlideViewPrivate::onFrameRendered(const iris::FrameStats &stats)
{
    Q_Q(IrisSlideView);
    IrisFrameMetrics metrics;
    metrics.serial = stats.serial;
    metrics.intervalMs = stats.intervalMs;
    metrics.cpuMs = stats.cpuMs;
    metrics.tilesDrawn = stats.tilesDrawn;
    metrics.fps = fps.add(stats.intervalMs);
    metrics.complete = stats.complete;
    metrics.centre = QPointF(stats.view.centerX, stats.view.centerY);
    metrics.downsample = stats.view.downsample;
    Q_EMIT q->framePresented(metrics);
    notifyViewChanged();
    checkEngineError();
}

void IrisSlideViewPrivate::checkEngineError()
{
    if (!engine())
        return;
    const iris::Result error = engine()->error();
    if (error.ok())
        return;
    engine()->clearError();
    Q_Q(IrisSlideView);
    const QString text = fromStd(error.message());
    qCWarning(lcIrisWidget).noquote() << "engine error:" << iris::statusName(error.status()) << text;
    // A lost device or surface is dealt with by onEngineFault (the engine told it first).
    if (error.status() == iris::Status::DeviceLost || error.status() == iris::Status::SurfaceLost)
        return;
    Q_EMIT q->slideError(text);
}

// --- slide and view --------------------------------------------------------------------

bool IrisSlideViewPrivate::open(const QString &newPath)
{
    Q_Q(IrisSlideView);
    navigator.stopMotion();
    if (newPath.isEmpty()) {
        q->closeSlide();
        return false;
    }
    // Budgets changed since the engine was made: this is the moment to apply them.
    const EngineSettings &current = host.settings();
    if (engine() && (current.ramBudgetBytes != settings.ramBudgetBytes
                     || current.vramBudgetBytes != settings.vramBudgetBytes)) {
        recreateEngine();
    }
    if (!ensureEngine()) {
        const bool had = slide.has_value();
        forgetSlide();
        if (had) {
            Q_EMIT q->slidePathChanged(path);
            Q_EMIT q->slideClosed();
            Q_EMIT q->colorManagementChanged();
        }
        if (!vulkan) // ensureEngine() reported any other reason itself
            Q_EMIT q->slideError(IrisSlideView::tr("The renderer could not start: %1").arg(rendererError));
        return false;
    }

    const iris::Result opened = engine()->open(QFile::encodeName(newPath).toStdString());
    if (!opened) {
        engine()->clearError(); // reported here; checkEngineError() must not repeat it
        const bool had = slide.has_value();
        forgetSlide();
        const QString text = fromStd(opened.message());
        qCWarning(lcIrisWidget).noquote() << "cannot open" << newPath << ":" << text;
        if (had) {
            Q_EMIT q->slidePathChanged(path);
            Q_EMIT q->slideClosed();
            Q_EMIT q->colorManagementChanged();
        }
        Q_EMIT q->slideError(text);
        notifyViewChanged();
        return false;
    }
    slide = engine()->slideInfo();
    if (!slide) { // closed by another thread in between; nothing sensible to show
        forgetSlide();
        return false;
    }
    info = toSlideInfo(*slide);
    path = newPath;
    layersFollowSlide(newPath);
    fitPending = !host.isBound();
    qCInfo(lcIrisWidget).noquote() << "opened" << newPath << info.vendor << info.width << "x" << info.height
                                   << "levels" << info.levels.size();
    Q_EMIT q->slidePathChanged(path);
    Q_EMIT q->slideOpened(info);
    Q_EMIT q->colorManagementChanged();
    notifyViewChanged();
    return true;
}

void IrisSlideViewPrivate::forgetSlide()
{
    slide.reset();
    info = {};
    path.clear();
    fitPending = false;
    layersFollowSlide(QString());
}

void IrisSlideViewPrivate::setView(iris::View view)
{
    if (!engine() || !slide || !std::isfinite(view.centerX) || !std::isfinite(view.centerY)
        || !(view.downsample > 0)) {
        return;
    }
    view.downsample = clampDownsample(view.downsample);
    engine()->setView(view);
    notifyViewChanged();
}

void IrisSlideViewPrivate::notifyViewChanged()
{
    Q_Q(IrisSlideView);
    std::optional<iris::View> now;
    if (engine() && slide)
        now = engine()->view();
    const auto same = [](const std::optional<iris::View> &a, const std::optional<iris::View> &b) {
        if (a.has_value() != b.has_value())
            return false;
        return !a || *a == *b;
    };
    if (same(now, notifiedView))
        return;
    notifiedView = now;
    Q_EMIT q->viewChanged();
}

double IrisSlideViewPrivate::devicePixelRatio() const
{
    Q_Q(const IrisSlideView);
    return window ? window->devicePixelRatio() : q->devicePixelRatioF();
}

QPointF IrisSlideViewPrivate::toTarget(QPointF widgetPos) const
{
    Q_Q(const IrisSlideView);
    const QPointF local = container ? container->mapFrom(q, widgetPos) : widgetPos;
    return local * devicePixelRatio();
}

QPointF IrisSlideViewPrivate::fromTarget(QPointF targetPos) const
{
    Q_Q(const IrisSlideView);
    const QPointF local = targetPos / devicePixelRatio();
    return container ? container->mapTo(q, local) : local;
}

double IrisSlideViewPrivate::clampDownsample(double downsample) const
{
    if (!engine() || !slide)
        return downsample;
    return zoomLimitsFor(*slide, engine()->fitView().downsample).clamp(downsample);
}

bool IrisSlideViewPrivate::moveToOverview(QPointF widgetPos, bool clamp)
{
    if (!engine() || !slide)
        return false;
    QPointF t = toTarget(widgetPos);
    if (clamp) {
        const iris::PixelRect img = engine()->overlayLayout().overviewImage;
        if (img.empty())
            return false;
        t.setX(std::clamp(t.x(), double(img.x), img.x + img.width - 0.5));
        t.setY(std::clamp(t.y(), double(img.y), img.y + img.height - 0.5));
    }
    iris::View view;
    if (!engine()->overviewHit(t.x(), t.y(), &view))
        return false;
    navigator.stopMotion();
    setView(view);
    return true;
}

void IrisSlideViewPrivate::updateCursor(QPointF widgetPos)
{
    if (!window || navigator.isDragging())
        return;
    const QPointF t = toTarget(widgetPos);
    const bool overview = engine() && slide && engine()->overviewHit(t.x(), t.y());
    if (overview)
        window->setCursor(Qt::PointingHandCursor);
    else
        window->setCursor(tools.active() ? tools.cursor() : Qt::OpenHandCursor);
}

// --- NavigationTarget ------------------------------------------------------------------

bool IrisSlideViewPrivate::canNavigate() const
{
    return engine() && slide;
}

void IrisSlideViewPrivate::pan(QPointF logicalDelta)
{
    if (!canNavigate())
        return;
    const QPointF delta = logicalDelta * devicePixelRatio();
    engine()->translate(delta.x(), delta.y());
    notifyViewChanged();
}

void IrisSlideViewPrivate::panFields(int fieldsX, int fieldsY)
{
    if (!canNavigate())
        return;
    const auto [width, height] = engine()->targetSize();
    // translate() moves the image with the pointer: to see the field to the right, the
    // image moves left by exactly one target width.
    engine()->translate(-double(fieldsX) * width, -double(fieldsY) * height);
    notifyViewChanged();
}

void IrisSlideViewPrivate::zoom(double factor, QPointF logicalAnchor)
{
    if (!canNavigate() || !(factor > 0) || !std::isfinite(factor))
        return;
    const double downsample = engine()->view().downsample;
    const double clamped = clampDownsample(downsample / factor);
    const double effective = downsample / clamped;
    if (std::abs(effective - 1) < 1e-12)
        return;
    const QPointF anchor = toTarget(logicalAnchor);
    engine()->zoom(effective, anchor.x(), anchor.y());
    notifyViewChanged();
}

void IrisSlideViewPrivate::rotate(double degrees, QPointF logicalAnchor)
{
    if (!canNavigate() || !std::isfinite(degrees) || degrees == 0)
        return;
    const QPointF anchor = toTarget(logicalAnchor);
    engine()->rotate(degrees, anchor.x(), anchor.y());
    notifyViewChanged();
}

void IrisSlideViewPrivate::flip()
{
    if (!canNavigate())
        return;
    // The image mirrored left-right on screen, whatever its rotation: mirroring the slide
    // before a turn by r equals mirroring the screen after a turn by -r.
    iris::View view = engine()->view();
    view.flipH = !view.flipH;
    view.rotation = -view.rotation;
    setView(view);
}

void IrisSlideViewPrivate::resetOrientation()
{
    if (!canNavigate())
        return;
    iris::View view = engine()->view();
    view.rotation = 0;
    view.flipH = view.flipV = false;
    setView(view);
}

QPointF IrisSlideViewPrivate::viewportCentre() const
{
    if (!engine())
        return {};
    const auto [width, height] = engine()->targetSize();
    return fromTarget(QPointF(width / 2.0, height / 2.0));
}

void IrisSlideViewPrivate::fit()
{
    Q_Q(IrisSlideView);
    q->fitToWindow();
}

void IrisSlideViewPrivate::showMagnificationPreset(int index)
{
    if (index < 0 || index >= int(kMagnificationPresets.size()))
        return;
    Q_Q(IrisSlideView);
    q->setMagnification(kMagnificationPresets[size_t(index)]);
}
