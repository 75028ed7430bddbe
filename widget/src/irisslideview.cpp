#include "iris/IrisSlideView.h"

#include "iris/annotations.h"

#include <algorithm>
#include <cstring>

#include <QtCore/QFile>
#include <QtGui/QKeyEvent>
#include <QtGui/QUndoStack>
#include <QtGui/QMouseEvent>
#include <QtGui/QWheelEvent>

#include "irisslideview_p.h"
#include "logging_p.h"
#include "magnification_p.h"
#include "vulkaninstance_p.h"

using namespace IrisWidget;

namespace {
constexpr quint64 kMiB = 1024 * 1024;
}

IrisSlideView::IrisSlideView(QWidget *parent)
    : QWidget(parent)
    , d_ptr(new IrisSlideViewPrivate(this))
{
    Q_D(IrisSlideView);
    d->init();
}

IrisSlideView::~IrisSlideView()
{
    Q_D(IrisSlideView);
    d->tools.watchStore(nullptr); // no more calls from the store's writers
    d->tools.cancel(); // a preview leaves the host's store
    d->teardown();
}

// --- slide -----------------------------------------------------------------------------

QString IrisSlideView::slidePath() const
{
    Q_D(const IrisSlideView);
    return d->path;
}

bool IrisSlideView::hasSlide() const
{
    Q_D(const IrisSlideView);
    return d->slide.has_value();
}

IrisSlideInfo IrisSlideView::slideInfo() const
{
    Q_D(const IrisSlideView);
    return d->info;
}

double IrisSlideView::objectivePower() const
{
    Q_D(const IrisSlideView);
    return d->slide ? d->slide->effectiveObjectivePower() : 0;
}

QImage IrisSlideView::associatedImage(const QString &name) const
{
    Q_D(const IrisSlideView);
    if (!d->engine() || !d->slide)
        return {};
    auto image = d->engine()->readAssociatedImage(name.toStdString(), iris::ImageColors::ForDisplay);
    if (!image) {
        qCWarning(lcIrisWidget).noquote() << "cannot read the associated image" << name << ":"
                                          << QString::fromStdString(image.error().message());
        return {};
    }
    const iris::Image &rgba = *image;
    QImage out(int(rgba.width), int(rgba.height), QImage::Format_RGBA8888);
    if (out.isNull() || rgba.rgba.size() < size_t(rgba.width) * rgba.height * 4)
        return {};
    for (int y = 0; y < out.height(); ++y)
        memcpy(out.scanLine(y), rgba.rgba.data() + size_t(y) * rgba.width * 4, size_t(rgba.width) * 4);
    return out;
}

void IrisSlideView::setNetworkCredentials(const NetworkCredentials &credentials)
{
    Q_D(IrisSlideView);
    // Only the credentials change: the timeouts and connection counts stay the engine's defaults.
    iris::NetworkOptions o;
    const std::string secret = credentials.secret.toStdString();
    if (credentials.kind == NetworkCredentials::Basic) {
        o.username = credentials.user.toStdString();
        o.password = secret;
    } else if (credentials.kind == NetworkCredentials::Bearer) {
        o.bearerToken = secret;
    }
    o.caFile = QFile::encodeName(credentials.caFile).toStdString();
    o.verifyTls = credentials.verifyTls;
    o.frameCacheDirectory = d->settings.network.frameCacheDirectory; // not a credential: kept
    o.frameCacheBytes = d->settings.network.frameCacheBytes;
    d->settings.network = o; // for an engine made later (the first slide, a budget change)
    if (d->engine())
        d->engine()->setNetworkOptions(o);
}

void IrisSlideView::setFrameCacheDirectory(const QString &directory, qint64 maxBytes)
{
    Q_D(IrisSlideView);
    d->settings.network.frameCacheDirectory = QFile::encodeName(directory).toStdString();
    d->settings.network.frameCacheBytes = uint64_t(std::max<qint64>(maxBytes, 0));
    if (d->engine())
        d->engine()->setNetworkOptions(d->settings.network);
}

QString IrisSlideView::frameCacheDirectory() const
{
    Q_D(const IrisSlideView);
    return QFile::decodeName(d->settings.network.frameCacheDirectory.c_str());
}

bool IrisSlideView::hasNetworkCredentials() const
{
    Q_D(const IrisSlideView);
    return !d->settings.network.username.empty() || !d->settings.network.bearerToken.empty();
}

bool IrisSlideView::openSlide(const QString &path)
{
    Q_D(IrisSlideView);
    d->tools.cancel();
    return d->open(path);
}

void IrisSlideView::setSlidePath(const QString &path)
{
    Q_D(IrisSlideView);
    if (path != d->path)
        d->open(path);
}

void IrisSlideView::closeSlide()
{
    Q_D(IrisSlideView);
    d->navigator.stopMotion();
    d->tools.cancel();
    if (!d->slide)
        return;
    if (d->engine())
        d->engine()->close();
    d->forgetSlide();
    Q_EMIT slidePathChanged(QString());
    Q_EMIT slideClosed();
    Q_EMIT colorManagementChanged();
    d->notifyViewChanged();
}

// --- view ------------------------------------------------------------------------------

double IrisSlideView::magnification() const
{
    Q_D(const IrisSlideView);
    if (!d->engine() || !d->slide)
        return 0;
    return magnificationFor(*d->slide, d->engine()->view().downsample);
}

void IrisSlideView::setMagnification(double magnification)
{
    Q_D(IrisSlideView);
    if (!d->engine() || !d->slide)
        return;
    const double downsample = downsampleFor(*d->slide, magnification);
    if (downsample <= 0) {
        qCInfo(lcIrisWidget) << "magnification" << magnification
                             << "is not available: the slide states neither objective power nor mpp";
        return;
    }
    d->navigator.stopMotion();
    iris::View view = d->engine()->view();
    view.downsample = downsample;
    // At a level's own scale (20× on a 20× scan), on the level's pixel grid: sharp, each slide
    // pixel on one device pixel. The centre moves by under half a device pixel.
    const auto [width, height] = d->engine()->targetSize();
    d->setView(alignedToLevelPixels(*d->slide, view, int(width), int(height)));
}

QPointF IrisSlideView::centre() const
{
    Q_D(const IrisSlideView);
    if (!d->engine() || !d->slide)
        return {};
    const iris::View view = d->engine()->view();
    return {view.centerX, view.centerY};
}

void IrisSlideView::setCentre(const QPointF &slidePos)
{
    Q_D(IrisSlideView);
    if (!d->engine() || !d->slide)
        return;
    d->navigator.stopMotion();
    iris::View view = d->engine()->view();
    view.centerX = slidePos.x();
    view.centerY = slidePos.y();
    d->setView(view);
}

double IrisSlideView::downsample() const
{
    Q_D(const IrisSlideView);
    if (!d->engine() || !d->slide)
        return 0;
    return d->engine()->view().downsample;
}

void IrisSlideView::setDownsample(double downsample)
{
    Q_D(IrisSlideView);
    if (!d->engine() || !d->slide)
        return;
    d->navigator.stopMotion();
    iris::View view = d->engine()->view();
    view.downsample = downsample;
    // At a level's own scale (20× on a 20× scan), on the level's pixel grid: sharp, each slide
    // pixel on one device pixel. The centre moves by under half a device pixel.
    const auto [width, height] = d->engine()->targetSize();
    d->setView(alignedToLevelPixels(*d->slide, view, int(width), int(height)));
}

double IrisSlideView::rotation() const
{
    Q_D(const IrisSlideView);
    if (!d->engine() || !d->slide)
        return 0;
    return d->engine()->view().rotation;
}

bool IrisSlideView::isFlippedHorizontally() const
{
    Q_D(const IrisSlideView);
    return d->engine() && d->slide && d->engine()->view().flipH;
}

bool IrisSlideView::isFlippedVertically() const
{
    Q_D(const IrisSlideView);
    return d->engine() && d->slide && d->engine()->view().flipV;
}

void IrisSlideView::setRotation(double degrees)
{
    Q_D(IrisSlideView);
    if (!d->engine() || !d->slide || !std::isfinite(degrees))
        return;
    d->navigator.stopMotion();
    iris::View view = d->engine()->view();
    view.rotation = degrees;
    d->setView(view);
}

void IrisSlideView::rotateBy(double degrees)
{
    Q_D(IrisSlideView);
    d->navigator.stopMotion();
    d->rotate(degrees, d->viewportCentre());
}

void IrisSlideView::rotateBy(double degrees, const QPointF &widgetAnchor)
{
    Q_D(IrisSlideView);
    d->navigator.stopMotion();
    d->rotate(degrees, widgetAnchor);
}

void IrisSlideView::setFlipped(bool horizontally, bool vertically)
{
    Q_D(IrisSlideView);
    if (!d->engine() || !d->slide)
        return;
    d->navigator.stopMotion();
    iris::View view = d->engine()->view();
    view.flipH = horizontally;
    view.flipV = vertically;
    d->setView(view);
}

void IrisSlideView::setFlippedHorizontally(bool on)
{
    setFlipped(on, isFlippedVertically());
}

void IrisSlideView::setFlippedVertically(bool on)
{
    setFlipped(isFlippedHorizontally(), on);
}

void IrisSlideView::resetOrientation()
{
    Q_D(IrisSlideView);
    d->navigator.stopMotion();
    d->resetOrientation();
}

void IrisSlideView::setView(const QPointF &centre, double downsample, double rotation)
{
    setView(centre, downsample, rotation, isFlippedHorizontally(), isFlippedVertically());
}

void IrisSlideView::setView(const QPointF &centre, double downsample, double rotation, bool flippedHorizontally,
                            bool flippedVertically)
{
    Q_D(IrisSlideView);
    if (!d->engine() || !d->slide || !std::isfinite(rotation))
        return;
    d->navigator.stopMotion();
    iris::View view = d->engine()->view();
    view.centerX = centre.x();
    view.centerY = centre.y();
    view.downsample = downsample;
    view.rotation = rotation;
    view.flipH = flippedHorizontally;
    view.flipV = flippedVertically;
    d->setView(view);
}

void IrisSlideView::stopMotion()
{
    Q_D(IrisSlideView);
    d->navigator.stopMotion();
}

QPointF IrisSlideView::mapToSlide(const QPointF &widgetPos) const
{
    Q_D(const IrisSlideView);
    if (!d->engine() || !d->slide)
        return {};
    const auto [width, height] = d->engine()->targetSize();
    const QPointF t = d->toTarget(widgetPos);
    const auto s = iris::ViewTransform::of(d->engine()->view(), width, height).toSlide(t.x(), t.y());
    return {s[0], s[1]};
}

QPointF IrisSlideView::mapFromSlide(const QPointF &slidePos) const
{
    Q_D(const IrisSlideView);
    if (!d->engine() || !d->slide)
        return {};
    const auto [width, height] = d->engine()->targetSize();
    const auto t = iris::ViewTransform::of(d->engine()->view(), width, height).toTarget(slidePos.x(), slidePos.y());
    return d->fromTarget(QPointF(t[0], t[1]));
}

void IrisSlideView::setCrosshair(const QPointF &slidePos)
{
    Q_D(IrisSlideView);
    if (!std::isfinite(slidePos.x()) || !std::isfinite(slidePos.y()))
        return;
    d->settings.crosshair = slidePos;
    d->host.applyOverlays(d->settings);
}

void IrisSlideView::clearCrosshair()
{
    Q_D(IrisSlideView);
    d->settings.crosshair.reset();
    d->host.applyOverlays(d->settings);
}

bool IrisSlideView::hasCrosshair() const
{
    Q_D(const IrisSlideView);
    return d->settings.crosshair.has_value();
}

void IrisSlideView::setAnnotations(std::shared_ptr<iris::AnnotationStore> store)
{
    Q_D(IrisSlideView);
    if (store == d->settings.annotations)
        return;
    d->tools.cancel(); // from the old store
    d->tools.undoStack()->clear(); // its commands edit the old store
    d->tools.watchStore(store);
    d->settings.annotations = std::move(store);
    d->host.applyAnnotations(d->settings);
    Q_EMIT annotationsChanged();
}

std::shared_ptr<iris::AnnotationStore> IrisSlideView::annotations() const
{
    Q_D(const IrisSlideView);
    return d->settings.annotations;
}

bool IrisSlideView::annotationsVisible() const
{
    Q_D(const IrisSlideView);
    return d->settings.annotationsVisible;
}

void IrisSlideView::setAnnotationsVisible(bool visible)
{
    Q_D(IrisSlideView);
    if (visible == d->settings.annotationsVisible)
        return;
    d->settings.annotationsVisible = visible;
    d->host.applyAnnotations(d->settings);
    Q_EMIT annotationsChanged();
}

quint64 IrisSlideView::selectedAnnotation() const
{
    Q_D(const IrisSlideView);
    return d->settings.selectedAnnotation;
}

void IrisSlideView::setSelectedAnnotation(quint64 id)
{
    Q_D(IrisSlideView);
    if (id == d->settings.selectedAnnotation)
        return;
    d->settings.selectedAnnotation = id;
    d->host.applyAnnotations(d->settings);
    Q_EMIT annotationsChanged();
    d->tools.updateMeasurement();
}

IrisSlideView::AnnotationTool IrisSlideView::annotationTool() const
{
    Q_D(const IrisSlideView);
    return d->tools.tool();
}

void IrisSlideView::setAnnotationTool(AnnotationTool tool)
{
    Q_D(IrisSlideView);
    if (tool < Navigate || tool > Brush || tool == d->tools.tool())
        return;
    d->tools.setTool(tool);
    if (d->window)
        d->window->setCursor(d->tools.active() ? d->tools.cursor() : Qt::OpenHandCursor);
    Q_EMIT annotationToolChanged(tool);
}

bool IrisSlideView::annotationToolsEnabled() const
{
    Q_D(const IrisSlideView);
    return d->tools.enabled();
}

void IrisSlideView::setAnnotationToolsEnabled(bool on)
{
    Q_D(IrisSlideView);
    if (on == d->tools.enabled())
        return;
    d->tools.setEnabled(on);
    if (d->window)
        d->window->setCursor(d->tools.active() ? d->tools.cursor() : Qt::OpenHandCursor);
    Q_EMIT annotationToolsEnabledChanged(on);
}

QUndoStack *IrisSlideView::annotationUndoStack() const
{
    Q_D(const IrisSlideView);
    return const_cast<IrisWidget::AnnotationTools &>(d->tools).undoStack();
}

QString IrisSlideView::annotationMeasurement(quint64 id) const
{
    Q_D(const IrisSlideView);
    return d->tools.measurement(id);
}

QString IrisSlideView::annotationMeasurement() const
{
    Q_D(const IrisSlideView);
    return d->tools.currentMeasurement();
}

QSize IrisSlideView::targetSize() const
{
    Q_D(const IrisSlideView);
    if (d->engine()) {
        const auto [width, height] = d->engine()->targetSize();
        if (width > 0 && height > 0)
            return QSize(int(width), int(height));
    }
    return d->window ? d->window->targetSize() : size() * devicePixelRatioF();
}

void IrisSlideView::fitToWindow()
{
    Q_D(IrisSlideView);
    d->navigator.stopMotion();
    if (!d->engine() || !d->slide)
        return;
    if (!d->host.isBound()) {
        d->fitPending = true;
        return;
    }
    d->engine()->setView(d->engine()->fitView());
    d->notifyViewChanged();
}

void IrisSlideView::panBy(const QPointF &delta)
{
    Q_D(IrisSlideView);
    d->navigator.stopMotion();
    d->pan(delta);
}

void IrisSlideView::zoomBy(double factor)
{
    Q_D(IrisSlideView);
    d->navigator.stopMotion();
    d->zoom(factor, d->viewportCentre());
}

// --- appearance and resources ----------------------------------------------------------

QColor IrisSlideView::backgroundColor() const
{
    Q_D(const IrisSlideView);
    return d->background;
}

void IrisSlideView::setBackgroundColor(const QColor &color)
{
    Q_D(IrisSlideView);
    if (!color.isValid() || color == d->background)
        return;
    d->background = color;
    d->settings.background = toEngineRgb(color);
    if (d->engine()) {
        const auto &[r, g, b] = d->settings.background;
        d->engine()->setBackground(r, g, b);
    }
    Q_EMIT backgroundColorChanged(color);
}

bool IrisSlideView::enhance() const
{
    Q_D(const IrisSlideView);
    return d->settings.enhance;
}

void IrisSlideView::setEnhance(bool on)
{
    Q_D(IrisSlideView);
    if (on == d->settings.enhance)
        return;
    d->settings.enhance = on;
    if (d->engine())
        d->engine()->setEnhance(on);
    Q_EMIT enhanceChanged(on);
}

// --- colour management -----------------------------------------------------------------

bool IrisSlideView::colorManaged() const
{
    Q_D(const IrisSlideView);
    return d->settings.colorManaged;
}

void IrisSlideView::setColorManaged(bool on)
{
    Q_D(IrisSlideView);
    if (on == d->settings.colorManaged)
        return;
    d->settings.colorManaged = on;
    d->updateColor(true);
}

IrisSlideView::RenderingIntent IrisSlideView::renderingIntent() const
{
    Q_D(const IrisSlideView);
    return d->settings.intent == iris::RenderingIntent::RelativeColorimetric ? RelativeColorimetric : Perceptual;
}

void IrisSlideView::setRenderingIntent(RenderingIntent intent)
{
    Q_D(IrisSlideView);
    const iris::RenderingIntent engineIntent = intent == RelativeColorimetric
        ? iris::RenderingIntent::RelativeColorimetric
        : iris::RenderingIntent::Perceptual;
    if (engineIntent == d->settings.intent)
        return;
    d->settings.intent = engineIntent;
    d->updateColor(true);
}

QByteArray IrisSlideView::displayProfile() const
{
    Q_D(const IrisSlideView);
    return d->settings.displayProfile;
}

void IrisSlideView::setDisplayProfile(const QByteArray &iccProfile)
{
    Q_D(IrisSlideView);
    d->hostDisplayProfile = iccProfile;
    d->updateColor(true);
}

void IrisSlideView::resetDisplayProfile()
{
    Q_D(IrisSlideView);
    d->hostDisplayProfile.reset();
    d->updateColor(true);
}

bool IrisSlideView::isColorTransformApplied() const
{
    Q_D(const IrisSlideView);
    return d->engine() && d->engine()->colorStatus().applied;
}

QString IrisSlideView::slideProfileDescription() const
{
    Q_D(const IrisSlideView);
    return d->engine() ? QString::fromStdString(d->engine()->colorStatus().slideProfile) : QString();
}

QString IrisSlideView::displayProfileDescription() const
{
    Q_D(const IrisSlideView);
    return d->engine() ? QString::fromStdString(d->engine()->colorStatus().displayProfile) : QString();
}

QString IrisSlideView::colorManagementError() const
{
    Q_D(const IrisSlideView);
    if (!d->engine())
        return {};
    const iris::Result error = d->engine()->colorStatus().error;
    return error.ok() ? QString() : QString::fromStdString(error.message());
}

bool IrisSlideView::kineticPanning() const
{
    Q_D(const IrisSlideView);
    return d->navigator.kineticEnabled();
}

void IrisSlideView::setKineticPanning(bool on)
{
    Q_D(IrisSlideView);
    d->navigator.setKineticEnabled(on);
}

int IrisSlideView::ramBudgetMB() const
{
    Q_D(const IrisSlideView);
    return int(d->settings.ramBudgetBytes / kMiB);
}

void IrisSlideView::setRamBudgetMB(int mb)
{
    Q_D(IrisSlideView);
    if (mb > 0)
        d->settings.ramBudgetBytes = quint64(mb) * kMiB;
}

int IrisSlideView::vramBudgetMB() const
{
    Q_D(const IrisSlideView);
    return int(d->settings.vramBudgetBytes / kMiB);
}

void IrisSlideView::setVramBudgetMB(int mb)
{
    Q_D(IrisSlideView);
    if (mb > 0)
        d->settings.vramBudgetBytes = quint64(mb) * kMiB;
}

// --- overlays --------------------------------------------------------------------------

bool IrisSlideView::isOverlayVisible(Overlay overlay) const
{
    Q_D(const IrisSlideView);
    return overlay >= ScaleBar && overlay <= Legend && d->settings.overlayVisible[size_t(overlay)];
}

void IrisSlideView::setOverlayVisible(Overlay overlay, bool visible)
{
    Q_D(IrisSlideView);
    if (overlay < ScaleBar || overlay > Legend || d->settings.overlayVisible[size_t(overlay)] == visible)
        return;
    d->settings.overlayVisible[size_t(overlay)] = visible;
    d->host.applyOverlays(d->settings);
    Q_EMIT overlaysChanged();
}

IrisSlideView::OverlayCorner IrisSlideView::overlayCorner(Overlay overlay) const
{
    Q_D(const IrisSlideView);
    if (overlay < ScaleBar || overlay > Legend)
        return TopLeft;
    return OverlayCorner(int(d->settings.overlayCorner[size_t(overlay)]));
}

void IrisSlideView::setOverlayCorner(Overlay overlay, OverlayCorner corner)
{
    Q_D(IrisSlideView);
    if (overlay < ScaleBar || overlay > Legend || corner < TopLeft || corner > BottomRight
        || d->settings.overlayCorner[size_t(overlay)] == iris::Corner(int(corner))) {
        return;
    }
    d->settings.overlayCorner[size_t(overlay)] = iris::Corner(int(corner));
    d->host.applyOverlays(d->settings);
    Q_EMIT overlaysChanged();
}

QRectF IrisSlideView::overlayRect(Overlay overlay) const
{
    Q_D(const IrisSlideView);
    if (!d->engine() || overlay < ScaleBar || overlay > Legend)
        return {};
    const iris::PixelRect r = d->engine()->overlayLayout().rect(iris::Overlay(int(overlay)));
    if (r.empty())
        return {};
    return QRectF(d->fromTarget(QPointF(r.x, r.y)), d->fromTarget(QPointF(r.x + r.width, r.y + r.height)));
}

QString IrisSlideView::overlayFont() const
{
    Q_D(const IrisSlideView);
    return d->settings.overlayFont;
}

void IrisSlideView::setOverlayFont(const QString &path)
{
    Q_D(IrisSlideView);
    if (path == d->settings.overlayFont)
        return;
    d->settings.overlayFont = path;
    d->host.applyOverlays(d->settings); // a bad file is reported with the next frame (slideError)
    Q_EMIT overlaysChanged();
}

// --- state -----------------------------------------------------------------------------

bool IrisSlideView::isRendererAvailable() const
{
    Q_D(const IrisSlideView);
    return d->vulkan && d->rendererError.isEmpty();
}

QString IrisSlideView::rendererError() const
{
    Q_D(const IrisSlideView);
    return d->rendererError;
}

QString IrisSlideView::deviceName() const
{
    Q_D(const IrisSlideView);
    return d->engine() ? QString::fromStdString(d->engine()->device().name) : QString();
}

void IrisSlideView::setVulkanValidation(bool on)
{
    IrisWidget::setValidationRequested(on);
}

bool IrisSlideView::vulkanValidation()
{
    return IrisWidget::validationRequested();
}

quint64 IrisSlideView::validationMessageCount() const
{
    Q_D(const IrisSlideView);
    return d->engine() ? d->engine()->validationMessageCount() : 0;
}

QWindow *IrisSlideView::surfaceWindow() const
{
    Q_D(const IrisSlideView);
    return d->window;
}

QSize IrisSlideView::sizeHint() const
{
    return {640, 480};
}

QSize IrisSlideView::minimumSizeHint() const
{
    return {64, 64};
}

// --- input -----------------------------------------------------------------------------
// Input that reaches the embedded surface window is forwarded here (eventforwarding.cpp),
// so these handlers see every event, whether it arrived at the widget or at the window.

bool IrisSlideView::event(QEvent *event)
{
    Q_D(IrisSlideView);
    if (event->type() == QEvent::NativeGesture) {
        const bool used = d->navigator.nativeGesture(static_cast<QNativeGestureEvent *>(event));
        event->setAccepted(used);
        if (used)
            return true;
    }
    return QWidget::event(event);
}

namespace {
// A right or middle button event as the navigator's left-button drag (panning under a tool).
std::unique_ptr<QMouseEvent> asLeftButton(const QMouseEvent *event, QEvent::Type type)
{
    const Qt::MouseButton button = type == QEvent::MouseMove ? Qt::NoButton : Qt::LeftButton;
    const Qt::MouseButtons buttons = type == QEvent::MouseButtonRelease ? Qt::NoButton : Qt::LeftButton;
    auto copy = std::make_unique<QMouseEvent>(type, event->position(), event->scenePosition(), event->globalPosition(),
        button, buttons, event->modifiers() & ~Qt::ControlModifier, event->pointingDevice());
    copy->setTimestamp(event->timestamp());
    return copy;
}
} // namespace

void IrisSlideView::mousePressEvent(QMouseEvent *event)
{
    Q_D(IrisSlideView);
    // A press on the overview map moves the view there (and a drag keeps moving it) instead
    // of starting a pan.
    if (event->button() == Qt::LeftButton && d->moveToOverview(event->position(), false)) {
        d->overviewDragging = true;
        event->accept();
        return;
    }
    // Under a tool, the right and middle buttons pan as the left one does in Navigate.
    if (d->tools.active() && d->toolPanButton == Qt::NoButton
        && (event->button() == Qt::RightButton || event->button() == Qt::MiddleButton)) {
        const auto left = asLeftButton(event, QEvent::MouseButtonPress);
        if (d->navigator.mousePress(left.get())) {
            d->toolPanButton = event->button();
            event->accept();
            return;
        }
    }
    if (d->tools.mousePress(event)) {
        d->navigator.stopMotion(); // the view holds still under a shape being drawn
        event->accept();
        return;
    }
    if (d->navigator.mousePress(event))
        event->accept();
    else
        QWidget::mousePressEvent(event);
}

void IrisSlideView::mouseMoveEvent(QMouseEvent *event)
{
    Q_D(IrisSlideView);
    if (d->overviewDragging) {
        if (event->buttons() & Qt::LeftButton)
            d->moveToOverview(event->position(), true);
        else
            d->overviewDragging = false; // the release went elsewhere
        event->accept();
        return;
    }
    bool used = false;
    if (d->toolPanButton != Qt::NoButton) {
        if (event->buttons() & d->toolPanButton) {
            const auto left = asLeftButton(event, QEvent::MouseMove);
            used = d->navigator.mouseMove(left.get());
        } else {
            d->toolPanButton = Qt::NoButton; // the release went elsewhere
            d->navigator.stopMotion();
        }
    } else {
        used = d->tools.mouseMove(event) || d->navigator.mouseMove(event);
    }
    d->updateCursor(event->position());
    if (d->slide)
        Q_EMIT cursorMoved(mapToSlide(event->position()));
    if (used)
        event->accept();
    else
        QWidget::mouseMoveEvent(event);
}

void IrisSlideView::mouseReleaseEvent(QMouseEvent *event)
{
    Q_D(IrisSlideView);
    if (d->overviewDragging && event->button() == Qt::LeftButton) {
        d->overviewDragging = false;
        event->accept();
        return;
    }
    if (d->toolPanButton != Qt::NoButton && event->button() == d->toolPanButton) {
        d->toolPanButton = Qt::NoButton;
        const auto left = asLeftButton(event, QEvent::MouseButtonRelease);
        d->navigator.mouseRelease(left.get());
        event->accept();
        return;
    }
    if (d->tools.mouseRelease(event) || d->navigator.mouseRelease(event))
        event->accept();
    else
        QWidget::mouseReleaseEvent(event);
}

void IrisSlideView::mouseDoubleClickEvent(QMouseEvent *event)
{
    Q_D(IrisSlideView);
    // The second click of a double click on the overview moves the view again; it does not zoom.
    if (event->button() == Qt::LeftButton && d->moveToOverview(event->position(), false)) {
        d->overviewDragging = true;
        event->accept();
        return;
    }
    if (d->tools.mouseDoubleClick(event) || d->navigator.mouseDoubleClick(event))
        event->accept();
    else
        QWidget::mouseDoubleClickEvent(event);
}

void IrisSlideView::wheelEvent(QWheelEvent *event)
{
    Q_D(IrisSlideView);
    if (d->navigator.wheel(event))
        event->accept();
    else
        QWidget::wheelEvent(event);
}

void IrisSlideView::keyPressEvent(QKeyEvent *event)
{
    Q_D(IrisSlideView);
    if (d->tools.keyPress(event) || d->navigator.keyPress(event))
        event->accept();
    else
        QWidget::keyPressEvent(event);
}
