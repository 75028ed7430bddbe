// Iris View widget — not API. The annotation tools: IrisSlideView's mouse and key handlers hand
// their events here first while a tool other than Navigate is in effect (annotationTool, with
// annotationToolsEnabled on, a store set and a slide open); what the tools do not take goes on
// to the navigator (ViewNavigator), so the wheel still zooms and Select pans on empty slide.
//
//   Select     click: the object under the pointer (AnnotationSnapshot::hitTest, 4 px), or none;
//              drag it: moves it; drag one of the selected object's handles: moves that vertex
//              (a rectangle's corner, an ellipse's side); Delete/Backspace: removes it. Locked
//              objects are selected but neither moved, reshaped nor removed. A drag on empty
//              slide pans.
//   Point      click: a point
//   Rectangle, Ellipse  drag from corner to corner; Shift: a square / circle
//   Polygon    click by click; double click or Enter closes it, Backspace drops the last vertex
//   Freehand   drag: a lasso polygon, vertices at least a screen pixel apart
//   Brush      drag: the union of discs of kBrushRadiusPx along the path (GEOS), one polygon
//   Esc        drops the shape or drag in progress (nothing is added), else the selection
//
// Shapes are made in level-0 pixels through IrisSlideView::mapToSlide, so they follow the view's
// turn and flips. While a shape is drawn it is shown as a preview object in the view's store
// (it is what the engine draws); finishing turns it into the object, one AddAnnotationCommand
// on the undo stack, one annotationAdded. Drags of Select update the store as they go and push
// one ChangeAnnotationCommand on release. No signal fires for previews or live drags.
//
// GUI thread only. The store itself may be edited by other threads meanwhile; a command the
// store refuses (its object gone) is dropped (annotationcommands_p.h).
#pragma once

#include <atomic>
#include <memory>
#include <vector>

#include <QtCore/QPointF>
#include <QtCore/QString>
#include <QtGui/QUndoStack>

#include <iris/annotations.h>

#include "annotationcommands_p.h"
#include "annotationgeometry_p.h"
#include "iris/IrisSlideView.h"

QT_BEGIN_NAMESPACE
class QKeyEvent;
class QMouseEvent;
QT_END_NAMESPACE

namespace IrisWidget {

class AnnotationTools final : public AnnotationEditSink
{
public:
    using Tool = IrisSlideView::AnnotationTool;

    explicit AnnotationTools(IrisSlideView *view);
    ~AnnotationTools() override;
    AnnotationTools(const AnnotationTools &) = delete;
    AnnotationTools &operator=(const AnnotationTools &) = delete;

    QUndoStack *undoStack() { return &m_stack; }
    Tool tool() const { return m_tool; }
    void setTool(Tool tool);
    bool enabled() const { return m_enabled; }
    void setEnabled(bool on);
    Tool effectiveTool() const { return m_enabled ? m_tool : IrisSlideView::Navigate; }
    // A tool other than Navigate is in effect and has a store and a slide to work on.
    bool active() const;
    // The pointer's shape while active.
    Qt::CursorShape cursor() const;

    // Each returns whether it used the event (the view then gives it no one else).
    bool mousePress(const QMouseEvent *event);
    bool mouseMove(const QMouseEvent *event);
    bool mouseRelease(const QMouseEvent *event);
    bool mouseDoubleClick(const QMouseEvent *event);
    bool keyPress(const QKeyEvent *event);

    // Drops the shape or drag in progress: the preview leaves the store, a dragged object goes
    // back to where it was; no command, no signal.
    void cancel();
    bool isEditing() const { return m_gesture != Gesture::None; }

    // The view's store was replaced (null: none): the readout follows its edits from now on.
    void watchStore(const std::shared_ptr<iris::AnnotationStore> &store);

    QString measurement(quint64 id) const;
    // The shape in progress, else the selected object ("" for none); emits
    // IrisSlideView::annotationMeasurementChanged when the text changes.
    QString currentMeasurement() const;
    void updateMeasurement();

    // AnnotationEditSink
    iris::AnnotationStore *editedStore() const override;
    void objectAdded(quint64 id) override;
    void objectChanged(quint64 id) override;
    void objectRemoved(quint64 id) override;

    static constexpr double kHitTolerancePx = 4; // logical px, for picking objects
    static constexpr double kHandleTolerancePx = 6; // a handle is drawn 8 device px wide
    static constexpr double kBrushRadiusPx = 10; // logical px, fixed when the stroke starts
    static constexpr double kThinningPx = 1; // freehand and brush vertices, logical px

private:
    enum class Gesture { None, Shape, Polygon, Move, Vertex };

    iris::Point2 toSlide(QPointF widgetPos) const;
    double levelZeroPerPixel() const; // level-0 pixels per logical pixel
    iris::AnnotationObject newObject(iris::AnnotationKind kind) const;
    std::shared_ptr<const iris::AnnotationSnapshot> snapshot() const;

    bool pressSelect(const QMouseEvent *event, iris::Point2 p);
    // The shape the gesture makes now (a Polygon tool's rubber band included); nullopt: none yet.
    std::optional<iris::AnnotationObject> shapeNow(bool final) const;
    void showPreview();
    void dropPreview();
    void finishShape(); // the object, or nothing when the gesture made too little
    void commit(iris::AnnotationObject object);
    void switchTool(Tool tool);

    IrisSlideView *m_view;
    QUndoStack m_stack;
    Tool m_tool = IrisSlideView::Navigate;
    bool m_enabled = true;

    Gesture m_gesture = Gesture::None;
    Tool m_gestureTool = IrisSlideView::Navigate;
    std::shared_ptr<iris::AnnotationStore> m_store; // the store the gesture edits
    quint64 m_previewId = 0;
    std::optional<iris::AnnotationObject> m_preview; // as last shown
    iris::Point2 m_start; // the press, level-0
    iris::Point2 m_pointer; // the pointer now, level-0
    bool m_square = false; // Shift held (Rectangle, Ellipse)
    std::vector<iris::Point2> m_path; // Polygon vertices, Freehand and Brush paths
    double m_scale = 1; // level-0 px per logical px at the press
    // Select's drags
    iris::AnnotationObject m_before;
    iris::AnnotationObject m_current;
    VertexHandle m_handle;
    QPointF m_pressPos;
    bool m_dragStarted = false;
    bool m_locked = false;
    QString m_lastMeasurement;
    // Edits of the store from anywhere (another thread, the host) refresh the readout: one
    // queued call per burst, the flag set by the store's writer and cleared on the GUI thread.
    iris::AnnotationSubscription m_watch;
    std::shared_ptr<std::atomic<bool>> m_refreshPosted = std::make_shared<std::atomic<bool>>(false);
    quint64 m_added = 0; // set by objectAdded: the command's redo reached the store
};

} // namespace IrisWidget
