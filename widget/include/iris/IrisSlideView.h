// Iris View widget — IrisSlideView, a whole-slide image view to drop into any Qt form.
//
// The view hosts a Vulkan surface (a QWindow inside a window container) into which the
// Iris engine renders and presents from its own render thread; the GUI thread only
// publishes view changes and never waits for tiles. Coordinates:
//   * widget positions and panBy() deltas are in logical (device-independent) pixels;
//   * centre() and mapToSlide() are in level-0 pixels of the slide;
//   * downsample() is level-0 pixels per *device* pixel, and magnification() is the
//     objective magnification at which one slide pixel would meet one device pixel
//     (objectivePower × level-0 downsample / downsample).
#pragma once

#include <memory>

#include <QtCore/QByteArray>
#include <QtCore/QPointF>
#include <QtCore/QRectF>
#include <QtCore/QScopedPointer>
#include <QtCore/QString>
#include <QtGui/QColor>
#include <QtGui/QImage>
#include <QtWidgets/QWidget>

#include "iris/IrisFrameMetrics.h"
#include "iris/IrisLayerInfo.h"
#include "iris/IrisSlideInfo.h"
#include "iris/IrisWidgetGlobal.h"

QT_BEGIN_NAMESPACE
class QUndoStack;
class QWindow;
namespace iris {
class AnnotationStore; // iris/annotations.h (the engine's public API)
struct LayerStyle;     // iris/layers.h
struct Placement;
struct RasterMap;
}
QT_END_NAMESPACE

class IrisSlideViewPrivate;

class IRIS_WIDGET_EXPORT IrisSlideView : public QWidget {
    Q_OBJECT
    Q_PROPERTY(QString slidePath READ slidePath WRITE setSlidePath RESET closeSlide NOTIFY slidePathChanged)
    Q_PROPERTY(double magnification READ magnification WRITE setMagnification NOTIFY viewChanged STORED false)
    Q_PROPERTY(QPointF centre READ centre WRITE setCentre NOTIFY viewChanged STORED false)
    Q_PROPERTY(double downsample READ downsample WRITE setDownsample NOTIFY viewChanged STORED false)
    Q_PROPERTY(double rotation READ rotation WRITE setRotation NOTIFY viewChanged STORED false)
    Q_PROPERTY(bool flippedHorizontally READ isFlippedHorizontally WRITE setFlippedHorizontally NOTIFY viewChanged
                   STORED false)
    Q_PROPERTY(
        bool flippedVertically READ isFlippedVertically WRITE setFlippedVertically NOTIFY viewChanged STORED false)
    Q_PROPERTY(QColor backgroundColor READ backgroundColor WRITE setBackgroundColor NOTIFY backgroundColorChanged)
    Q_PROPERTY(bool enhance READ enhance WRITE setEnhance NOTIFY enhanceChanged)
    Q_PROPERTY(bool kineticPanning READ kineticPanning WRITE setKineticPanning)
    Q_PROPERTY(int ramBudgetMB READ ramBudgetMB WRITE setRamBudgetMB)
    Q_PROPERTY(int vramBudgetMB READ vramBudgetMB WRITE setVramBudgetMB)
    Q_PROPERTY(double objectivePower READ objectivePower NOTIFY slidePathChanged STORED false)
    // Overlays the engine draws over the slide (all shown by default; see the README).
    Q_PROPERTY(bool scaleBarVisible READ isScaleBarVisible WRITE setScaleBarVisible NOTIFY overlaysChanged)
    Q_PROPERTY(OverlayCorner scaleBarCorner READ scaleBarCorner WRITE setScaleBarCorner NOTIFY overlaysChanged)
    Q_PROPERTY(bool magnificationLabelVisible READ isMagnificationLabelVisible WRITE setMagnificationLabelVisible
                   NOTIFY overlaysChanged)
    Q_PROPERTY(OverlayCorner magnificationLabelCorner READ magnificationLabelCorner WRITE setMagnificationLabelCorner
                   NOTIFY overlaysChanged)
    Q_PROPERTY(bool overviewVisible READ isOverviewVisible WRITE setOverviewVisible NOTIFY overlaysChanged)
    Q_PROPERTY(OverlayCorner overviewCorner READ overviewCorner WRITE setOverviewCorner NOTIFY overlaysChanged)
    Q_PROPERTY(bool legendVisible READ isLegendVisible WRITE setLegendVisible NOTIFY overlaysChanged)
    Q_PROPERTY(OverlayCorner legendCorner READ legendCorner WRITE setLegendCorner NOTIFY overlaysChanged)
    Q_PROPERTY(QString overlayFont READ overlayFont WRITE setOverlayFont RESET resetOverlayFont NOTIFY overlaysChanged)
    // Colour management (docs/COLOR.md): on by default.
    Q_PROPERTY(bool colorManaged READ colorManaged WRITE setColorManaged NOTIFY colorManagementChanged)
    Q_PROPERTY(
        RenderingIntent renderingIntent READ renderingIntent WRITE setRenderingIntent NOTIFY colorManagementChanged)
    Q_PROPERTY(QByteArray displayProfile READ displayProfile WRITE setDisplayProfile RESET resetDisplayProfile NOTIFY
            colorManagementChanged DESIGNABLE false STORED false)
    // Annotations (setAnnotations, docs/ANNOTATIONS.md): shown by default.
    Q_PROPERTY(bool annotationsVisible READ annotationsVisible WRITE setAnnotationsVisible NOTIFY annotationsChanged)
    Q_PROPERTY(quint64 selectedAnnotation READ selectedAnnotation WRITE setSelectedAnnotation NOTIFY annotationsChanged
                   DESIGNABLE false STORED false)
    // Editing them (docs/ANNOTATIONS.md, "Editing in the widget"): the tool the left button
    // uses (Navigate: it pans, as always), and whether tools may be used at all.
    Q_PROPERTY(AnnotationTool annotationTool READ annotationTool WRITE setAnnotationTool NOTIFY annotationToolChanged)
    Q_PROPERTY(bool annotationToolsEnabled READ annotationToolsEnabled WRITE setAnnotationToolsEnabled NOTIFY
            annotationToolsEnabledChanged)
    Q_PROPERTY(QString annotationMeasurement READ annotationMeasurement NOTIFY annotationMeasurementChanged
            DESIGNABLE false STORED false)

public:
    // The overlays: a scale bar (hidden when the slide states no mpp), the magnification
    // readout (hidden when it states no objective power) and the overview map, a thumbnail
    // of the whole slide with the current field outlined; clicking it moves the view there;
    // the legend, the key of the topmost visible layer: a heat map's colour bar, window and
    // title, or a label map's classes (swatch and name); hidden while there is none.
    enum Overlay { ScaleBar, MagnificationLabel, Overview, Legend };
    Q_ENUM(Overlay)
    enum OverlayCorner { TopLeft, TopRight, BottomLeft, BottomRight };
    Q_ENUM(OverlayCorner)
    // How colours outside the display's gamut are brought in: Perceptual (the default)
    // compresses the whole gamut; RelativeColorimetric keeps in-gamut colours exact and
    // clips the rest, with black-point compensation.
    enum RenderingIntent { Perceptual, RelativeColorimetric };
    Q_ENUM(RenderingIntent)
    // What the left button does on the slide. Navigate pans (the default); the others edit the
    // store set with setAnnotations(): Select picks, moves, reshapes and deletes objects; the
    // rest draw a new object each. Keys (QuPath's where it has them): M, S, ".", R, O, P,
    // Shift+P, B; see docs/ANNOTATIONS.md.
    enum AnnotationTool { Navigate, Select, Point, Rectangle, Ellipse, Polygon, Freehand, Brush };
    Q_ENUM(AnnotationTool)

    // How the view authenticates to a DICOMweb server when openSlide() is given a series URL
    // (https://host/prefix/studies/<StudyUID>/series/<SeriesUID>). Deliberately not a
    // Q_PROPERTY: it is never stored in a form, in settings or in a recent-files list, and
    // never logged; the view keeps it in memory only and there is no getter for the secret.
    struct NetworkCredentials {
        enum Kind { None, Basic, Bearer };
        Kind kind = None;
        QString user;      // Basic: the user name
        QString secret;    // Basic: the password; Bearer: the token
        QString caFile;    // PEM file of the certificate authorities to trust; empty: the system's
        bool verifyTls = true; // check the server's certificate and host name (off only to debug a server)
    };

    explicit IrisSlideView(QWidget *parent = nullptr);
    ~IrisSlideView() override;

    // --- slide ---------------------------------------------------------------------
    QString slidePath() const;        // empty when no slide is open
    bool hasSlide() const;
    IrisSlideInfo slideInfo() const;  // invalid when no slide is open
    // The stated objective power, or one estimated from mpp (10 µm / mpp); 0 when the
    // slide says neither, in which case magnification() is 0 and presets are disabled.
    double objectivePower() const;
    // An associated image ("label", "macro", "thumbnail", …) of the open slide; a null
    // QImage when there is none (the reason is logged). Reads the file on the calling thread.
    // While colour management applies the slide's profile, the image is converted the same
    // way (so a label shown beside the slide has the slide's colours); else as stored.
    QImage associatedImage(const QString &name) const;
    // Credentials and TLS for the DICOMweb series URLs opened after this call (a slide already
    // open keeps the ones it was opened with); kept across engine restarts (budget changes).
    // A host that asks the user for a password sets it here before openSlide(url).
    void setNetworkCredentials(const NetworkCredentials &credentials);
    void clearNetworkCredentials() { setNetworkCredentials(NetworkCredentials()); }
    // Whether credentials (Basic or Bearer) are set; the secret itself cannot be read back.
    bool hasNetworkCredentials() const;
    // A folder where the frames of DICOMweb series are kept once fetched, so that a series opened
    // again (now or in a later session) draws them without asking the server; at most maxBytes,
    // the least recently used going first. Empty (the default) keeps none. Created readable by
    // the user alone; for the series opened after this call. See iris::NetworkOptions.
    void setFrameCacheDirectory(const QString &directory, qint64 maxBytes = qint64(2) << 30);
    QString frameCacheDirectory() const;

    // --- view ----------------------------------------------------------------------
    double magnification() const;
    QPointF centre() const;
    double downsample() const;
    // The slide turned clockwise on screen, degrees in [0, 360), about the view's centre.
    double rotation() const;
    // The slide mirrored before it is turned: left and right swapped (horizontally), top and
    // bottom swapped (vertically), as seen at rotation 0.
    bool isFlippedHorizontally() const;
    bool isFlippedVertically() const;
    // Level-0 slide position under a widget position (logical pixels), and back; rotation and
    // flips included.
    QPointF mapToSlide(const QPointF &widgetPos) const;
    QPointF mapFromSlide(const QPointF &slidePos) const;
    // A cross-hair marker drawn by the engine over the slide at a level-0 position (a linked
    // view's cursor: IrisViewGroup); hidden until set, and by clearCrosshair().
    void setCrosshair(const QPointF &slidePos);
    void clearCrosshair();
    bool hasCrosshair() const;
    // The annotations drawn over the slide by the engine, under the overlays (null: none, the
    // default): the host keeps the store and may change it from any thread; every change is
    // drawn. The view keeps it across engine re-creation and slides opened later (a host that
    // shows annotations per slide sets another store, or null, when it opens one).
    void setAnnotations(std::shared_ptr<iris::AnnotationStore> store);
    std::shared_ptr<iris::AnnotationStore> annotations() const;
    bool annotationsVisible() const;
    // The object drawn selected, with its vertex handles (0: none).
    quint64 selectedAnnotation() const;
    // The editing tool chosen; it is in effect while annotationToolsEnabled() (else the view
    // navigates whatever is chosen), a store is set and a slide is open. Changing it drops a
    // shape in progress.
    AnnotationTool annotationTool() const;
    bool annotationToolsEnabled() const;
    // Every edit the tools make is a command here (Ctrl+Z / Ctrl+Shift+Z on the view, or a
    // host's Edit menu through QUndoStack::createUndoAction); setting another store clears it.
    QUndoStack *annotationUndoStack() const;
    // Length (polylines) or perimeter and area (closed shapes) of an object of the store, in µm
    // and µm² from the slide's mpp (mm, mm² from 1 mm and 1 mm² up; px without mpp); "" when the
    // store has no such object.
    QString annotationMeasurement(quint64 id) const;
    // The same for the shape being drawn, else the selected object ("" for none).
    QString annotationMeasurement() const;
    // The render target's size in device pixels (the widget's size × devicePixelRatio).
    QSize targetSize() const;

    // --- raster layers: heat maps and label maps (iris/layers.h, docs/LAYERS.md) ----------
    // Maps drawn by the engine over the slide and under the annotations, a later layer over
    // an earlier one; each spans the slide's level 0 unless placed otherwise.
    // A model's output belongs to its slide: closing the slide, opening another one (another
    // path, or an open that fails and so closes the slide shown) removes every layer (one
    // layersChanged()). Opening the same path again keeps them, and so does the engine being
    // re-created (budget changes, a lost device): the view keeps its own list and gives it to
    // each new engine. Layers added while no slide is open wait for the next slide opened.
    // Ids are the view's own: never 0, never reused, unchanged across engines.
    // Each setter returns false, changing nothing, for an id the view does not have or a value
    // it cannot use (a non-finite opacity, a NaN threshold, an unknown colour map, a class
    // outside the table); a file or map that cannot be used is also reported through
    // slideError(). Every change emits layersChanged().
    //
    // Reads a map file on the calling thread (PNG, TIFF, NumPy .npy, by content: see
    // iris::loadRasterMap; asLabels: a single-channel integer file holds class ids) and adds it
    // with the default style. Returns its id, or 0 with slideError() naming the file and the
    // problem; nothing else changes then.
    quint64 addLayer(const QString &path, bool asLabels = false);
    // Adds a map the host made (shared, never copied), with the default style or `style`. A
    // label map whose style has no class table gets iris::defaultLabelClasses for its ids.
    // 0 and slideError() for a map that cannot be shown (iris::rasterMapProblem).
    quint64 addLayer(std::shared_ptr<const iris::RasterMap> map);
    quint64 addLayer(std::shared_ptr<const iris::RasterMap> map, const iris::LayerStyle &style);
    QList<quint64> layerIds() const; // bottom first
    IrisLayerInfo layer(quint64 id) const; // invalid (id 0) for an id the view does not have
    QList<IrisLayerInfo> layers() const;   // bottom first
    std::shared_ptr<const iris::RasterMap> layerMap(quint64 id) const; // null for an unknown id
    iris::LayerStyle layerStyle(quint64 id) const; // the default style for an unknown id
    // Replaces a layer's map (a model streaming its results); false and slideError() for a map
    // that cannot be shown.
    bool setLayerMap(quint64 id, std::shared_ptr<const iris::RasterMap> map);
    bool setLayerStyle(quint64 id, const iris::LayerStyle &style);
    // Where the map lies on the slide; resetLayerPlacement: spanning level 0 again.
    bool setLayerPlacement(quint64 id, const iris::Placement &placement);
    bool resetLayerPlacement(quint64 id);
    bool setLayerVisible(quint64 id, bool visible);
    bool setLayerOpacity(quint64 id, double opacity); // clamped to 0..1
    // A built-in colour map: "viridis", "magma", "jet", "gray" (iris::ColorMap::builtin).
    bool setLayerColorMap(quint64 id, const QString &name);
    // A user LUT file (iris::ColorMap::fromFile: a 256-entry PNG strip or text table); false
    // and slideError() when it cannot be read.
    bool loadLayerColorMap(quint64 id, const QString &path);
    // The values mapped onto the colour map's ends; NaN for either: the map's minimum / maximum.
    bool setLayerWindow(quint64 id, double low, double high);
    // Scalar values below it are not drawn; −∞: none.
    bool setLayerThreshold(quint64 id, double threshold);
    bool setLayerSampling(quint64 id, IrisLayerInfo::Sampling sampling);
    // A label map's class (its id, an index into layer(id).classes): colour and visibility.
    bool setLayerClassColor(quint64 id, int classId, const QColor &color);
    bool setLayerClassVisible(quint64 id, int classId, bool visible);
    // Moves a layer to position `index` of the stack (0: the bottom; past the end: the top).
    bool moveLayer(quint64 id, int index);
    void removeLayer(quint64 id);
    void clearLayers();

    // --- appearance and resources ----------------------------------------------------
    QColor backgroundColor() const;
    void setBackgroundColor(const QColor &color);
    bool enhance() const;
    void setEnhance(bool on);
    bool kineticPanning() const;
    void setKineticPanning(bool on);
    // RAM and VRAM budgets in MiB; they take effect when the engine is next created
    // (the first slide opened or shown after a change).
    int ramBudgetMB() const;
    void setRamBudgetMB(int mb);
    int vramBudgetMB() const;
    void setVramBudgetMB(int mb);

    // --- overlays ------------------------------------------------------------------
    bool isOverlayVisible(Overlay overlay) const;
    void setOverlayVisible(Overlay overlay, bool visible);
    OverlayCorner overlayCorner(Overlay overlay) const;
    void setOverlayCorner(Overlay overlay, OverlayCorner corner);
    // Where the overlay is drawn in the last presented frame, in widget coordinates (logical
    // pixels); empty when it is not shown.
    QRectF overlayRect(Overlay overlay) const;
    bool isScaleBarVisible() const { return isOverlayVisible(ScaleBar); }
    void setScaleBarVisible(bool visible) { setOverlayVisible(ScaleBar, visible); }
    OverlayCorner scaleBarCorner() const { return overlayCorner(ScaleBar); }
    void setScaleBarCorner(OverlayCorner corner) { setOverlayCorner(ScaleBar, corner); }
    bool isMagnificationLabelVisible() const { return isOverlayVisible(MagnificationLabel); }
    void setMagnificationLabelVisible(bool visible) { setOverlayVisible(MagnificationLabel, visible); }
    OverlayCorner magnificationLabelCorner() const { return overlayCorner(MagnificationLabel); }
    void setMagnificationLabelCorner(OverlayCorner corner) { setOverlayCorner(MagnificationLabel, corner); }
    bool isOverviewVisible() const { return isOverlayVisible(Overview); }
    void setOverviewVisible(bool visible) { setOverlayVisible(Overview, visible); }
    OverlayCorner overviewCorner() const { return overlayCorner(Overview); }
    void setOverviewCorner(OverlayCorner corner) { setOverlayCorner(Overview, corner); }
    bool isLegendVisible() const { return isOverlayVisible(Legend); }
    void setLegendVisible(bool visible) { setOverlayVisible(Legend, visible); }
    OverlayCorner legendCorner() const { return overlayCorner(Legend); }
    void setLegendCorner(OverlayCorner corner) { setOverlayCorner(Legend, corner); }
    // A font file for the overlays' labels; empty: the system's sans-serif (fontconfig's
    // DejaVu Sans). A file that cannot be used is reported through slideError() and the
    // labels are left out until a usable font is set.
    QString overlayFont() const;
    void setOverlayFont(const QString &path);
    void resetOverlayFont() { setOverlayFont(QString()); }

    // --- colour management --------------------------------------------------------------
    // On, the slide's embedded ICC profile (Aperio/TIFF, .iris, DICOM) is converted to the
    // display's profile on the GPU, for every pixel of the slide and the overview map; the
    // HUD's own colours and the background are not converted. Off, or for a slide without a
    // profile, the stored bytes are shown.
    bool colorManaged() const;
    void setColorManaged(bool on);
    RenderingIntent renderingIntent() const;
    void setRenderingIntent(RenderingIntent intent);
    // The display profile in use: the one set with setDisplayProfile(), or else the one the
    // platform states for the screen the view is on (X11: the root window's _ICC_PROFILE
    // property, followed when it or the screen changes); empty means sRGB.
    QByteArray displayProfile() const;
    // Uses `iccProfile` (empty: sRGB) whatever the screen says, until resetDisplayProfile().
    void setDisplayProfile(const QByteArray &iccProfile);
    void resetDisplayProfile();
    // What is applied: whether the slide's pixels are converted now, the descriptions of the
    // slide's and the display's profiles ("" when the slide has none), and why a profile could
    // not be used (the slide is then shown as stored; empty when nothing is wrong).
    bool isColorTransformApplied() const;
    QString slideProfileDescription() const;
    QString displayProfileDescription() const;
    QString colorManagementError() const;

    // --- state ---------------------------------------------------------------------
    // False when Vulkan could not be started; the widget then shows why in its place.
    bool isRendererAvailable() const;
    QString rendererError() const;
    QString deviceName() const;
    // Messages the Vulkan validation layers reported (setVulkanValidation(true) enables them).
    quint64 validationMessageCount() const;
    // Whether the Khronos validation layer is used (off by default; for development and tests:
    // it slows rendering down). The process's Vulkan instance is shared by every view and made
    // when the first one starts, so call this before the first view is shown; it applies to
    // instances and engines created afterwards. The widget never reads the environment: a host
    // maps its own switch onto this (iris-viewer: --validation or IRIS_VALIDATION=1).
    static void setVulkanValidation(bool on);
    static bool vulkanValidation();
    // The Vulkan surface window inside the widget's window container (for screenshots and
    // event synthesis); null when Vulkan is unavailable.
    QWindow *surfaceWindow() const;

    QSize sizeHint() const override;
    QSize minimumSizeHint() const override;

public Q_SLOTS:
    // Opens a slide (the file's header is read now, tiles later on engine threads) and fits
    // it into the view. Returns false and emits slideError() when it cannot be opened.
    bool openSlide(const QString &path);
    void setSlidePath(const QString &path);
    void closeSlide();
    void fitToWindow();
    // Zooms about the centre to an objective magnification. Where that is a level's own scale
    // (20× on a 20× scan), the centre also moves by under half a device pixel onto the level's
    // pixel grid, so that each slide pixel lies on one device pixel, not between them.
    void setMagnification(double magnification);
    void setCentre(const QPointF &slidePos);
    void setDownsample(double downsample);
    void setRotation(double degrees);
    // Turns the slide clockwise by `degrees` (negative: anticlockwise) about the view's
    // centre, or about a widget position, whose slide point stays put. Not animated.
    void rotateBy(double degrees);
    void rotateBy(double degrees, const QPointF &widgetAnchor);
    void setFlipped(bool horizontally, bool vertically);
    void setFlippedHorizontally(bool on);
    void setFlippedVertically(bool on);
    // Rotation 0 and no flips, about the view's centre.
    void resetOrientation();
    // Centre, downsample and rotation at once (one viewChanged; flips as they are), or with
    // the flips too.
    void setView(const QPointF &centre, double downsample, double rotation);
    void setView(const QPointF &centre, double downsample, double rotation, bool flippedHorizontally,
                 bool flippedVertically);
    // Ends a kinetic glide and drops a zoom or turn still animating (a linked view taken hold
    // of elsewhere: IrisViewGroup).
    void stopMotion();
    // Moves the image by delta logical pixels, as a drag of that length would.
    void panBy(const QPointF &delta);
    // Multiplies the magnification by factor (>1 zooms in) about the view's centre.
    void zoomBy(double factor);
    void setAnnotationsVisible(bool visible);
    void setSelectedAnnotation(quint64 id);
    void setAnnotationTool(AnnotationTool tool);
    // Off: the view navigates whatever tool is chosen, and the tool keys do nothing (hosts that
    // only show annotations). On by default.
    void setAnnotationToolsEnabled(bool on);

Q_SIGNALS:
    void slideOpened(const IrisSlideInfo &info);
    void slideClosed();
    void slideError(const QString &message);
    void slidePathChanged(const QString &path);
    void viewChanged();
    void framePresented(const IrisFrameMetrics &metrics);
    // The pointer moved over the view; slidePos is in level-0 pixels.
    void cursorMoved(const QPointF &slidePos);
    void backgroundColorChanged(const QColor &color);
    void enhanceChanged(bool on);
    // An overlay was shown, hidden or moved, or the overlay font changed.
    void overlaysChanged();
    // Colour management was switched, its intent or display profile changed, or a slide was
    // opened or closed (what is applied, and the descriptions, may then differ).
    void colorManagementChanged();
    // Another store was set, the annotations were shown or hidden, or the selection changed.
    void annotationsChanged();
    // The tools (or their undo and redo) added, changed or removed an object of the store: once
    // per finished object, never for the shape being drawn. For a host that saves each edit.
    void annotationAdded(quint64 id);
    void annotationChanged(quint64 id);
    void annotationRemoved(quint64 id);
    void annotationToolChanged(IrisSlideView::AnnotationTool tool);
    void annotationToolsEnabledChanged(bool on);
    // annotationMeasurement() changed (a shape drawn, a selection, an edit): for a status bar.
    void annotationMeasurementChanged(const QString &text);
    // A layer was added, removed, moved, or its map, style or placement changed; or the layers
    // were removed with their slide.
    void layersChanged();

protected:
    bool event(QEvent *event) override;
    void mousePressEvent(QMouseEvent *event) override;
    void mouseMoveEvent(QMouseEvent *event) override;
    void mouseReleaseEvent(QMouseEvent *event) override;
    void mouseDoubleClickEvent(QMouseEvent *event) override;
    void wheelEvent(QWheelEvent *event) override;
    void keyPressEvent(QKeyEvent *event) override;

private:
    Q_DECLARE_PRIVATE(IrisSlideView)
    Q_DISABLE_COPY_MOVE(IrisSlideView)
    QScopedPointer<IrisSlideViewPrivate> d_ptr;
};
