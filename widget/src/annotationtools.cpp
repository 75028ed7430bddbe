#include "annotationtools_p.h"

#include <cmath>

#include <QtCore/QCoreApplication>
#include <QtCore/QLineF>
#include <QtGui/QGuiApplication>
#include <QtGui/QKeyEvent>
#include <QtGui/QKeySequence>
#include <QtGui/QMouseEvent>
#include <QtGui/QStyleHints>

#include "logging_p.h"

namespace IrisWidget {

using iris::AnnotationKind;
using iris::AnnotationObject;
using iris::Point2;

AnnotationTools::AnnotationTools(IrisSlideView *view)
    : m_view(view)
{ }

AnnotationTools::~AnnotationTools() = default;

void AnnotationTools::setTool(Tool tool)
{
    if (tool == m_tool)
        return;
    cancel();
    m_tool = tool;
}

void AnnotationTools::setEnabled(bool on)
{
    if (on == m_enabled)
        return;
    cancel();
    m_enabled = on;
}

bool AnnotationTools::active() const
{
    return effectiveTool() != IrisSlideView::Navigate && m_view->annotations() && m_view->hasSlide();
}

Qt::CursorShape AnnotationTools::cursor() const
{
    return effectiveTool() == IrisSlideView::Select ? Qt::ArrowCursor : Qt::CrossCursor;
}

iris::AnnotationStore *AnnotationTools::editedStore() const
{
    return m_view->annotations().get();
}

std::shared_ptr<const iris::AnnotationSnapshot> AnnotationTools::snapshot() const
{
    const auto store = m_view->annotations();
    return store ? store->snapshot() : nullptr;
}

void AnnotationTools::objectAdded(quint64 id)
{
    m_added = id;
    Q_EMIT m_view->annotationAdded(id);
    updateMeasurement();
}

void AnnotationTools::objectChanged(quint64 id)
{
    Q_EMIT m_view->annotationChanged(id);
    updateMeasurement();
}

void AnnotationTools::objectRemoved(quint64 id)
{
    if (m_view->selectedAnnotation() == id)
        m_view->setSelectedAnnotation(0);
    Q_EMIT m_view->annotationRemoved(id);
    updateMeasurement();
}

Point2 AnnotationTools::toSlide(QPointF widgetPos) const
{
    const QPointF s = m_view->mapToSlide(widgetPos);
    return {s.x(), s.y()};
}

double AnnotationTools::levelZeroPerPixel() const
{
    const QPointF c = QRectF(m_view->rect()).center();
    const double scale = QLineF(m_view->mapToSlide(c), m_view->mapToSlide(c + QPointF(1, 0))).length();
    return scale > 0 && std::isfinite(scale) ? scale : 1;
}

AnnotationObject AnnotationTools::newObject(AnnotationKind kind) const
{
    AnnotationObject o;
    o.kind = kind;
    return o;
}

// --- mouse -------------------------------------------------------------------------------------

bool AnnotationTools::mousePress(const QMouseEvent *event)
{
    if (!active() || event->button() != Qt::LeftButton || (event->modifiers() & Qt::ControlModifier))
        return false; // Ctrl+drag turns the view, as in Navigate
    const Point2 p = toSlide(event->position());
    const Tool tool = effectiveTool();
    if (m_gesture == Gesture::Polygon && tool == IrisSlideView::Polygon) {
        m_path.push_back(p);
        m_pointer = p;
        showPreview();
        return true;
    }
    cancel(); // whatever was left (a release that went elsewhere)
    m_scale = levelZeroPerPixel();
    m_store = m_view->annotations();
    m_gestureTool = tool;
    m_start = m_pointer = p;
    m_square = event->modifiers() & Qt::ShiftModifier;
    m_path.clear();
    switch (tool) {
    case IrisSlideView::Navigate:
        return false;
    case IrisSlideView::Select:
        return pressSelect(event, p);
    case IrisSlideView::Point: {
        AnnotationObject o = newObject(AnnotationKind::Point);
        o.points = {p};
        commit(std::move(o));
        return true;
    }
    case IrisSlideView::Rectangle:
    case IrisSlideView::Ellipse:
        m_gesture = Gesture::Shape;
        return true;
    case IrisSlideView::Polygon:
        m_gesture = Gesture::Polygon;
        m_path = {p};
        showPreview();
        return true;
    case IrisSlideView::Freehand:
    case IrisSlideView::Brush:
        m_gesture = Gesture::Shape;
        m_path = {p};
        showPreview();
        return true;
    }
    return false;
}

bool AnnotationTools::pressSelect(const QMouseEvent *event, Point2 p)
{
    const auto snap = snapshot();
    if (!snap)
        return false;
    // A handle of the selected object first: it is drawn over everything.
    if (const iris::StoredAnnotation *selected = snap->find(m_view->selectedAnnotation())) {
        const double tolerance = kHandleTolerancePx * m_scale;
        const VertexHandle *nearest = nullptr;
        double best = tolerance;
        const std::vector<VertexHandle> handles = vertexHandles(selected->object);
        for (const VertexHandle &h : handles) {
            const double d = std::hypot(h.position.x - p.x, h.position.y - p.y);
            if (d <= best)
                best = d, nearest = &h;
        }
        if (nearest && !selected->object.locked) {
            m_gesture = Gesture::Vertex;
            m_handle = *nearest;
            m_before = m_current = selected->object;
            m_pressPos = event->position();
            m_dragStarted = false;
            m_locked = false;
            return true;
        }
    }
    const auto hit = snap->hitTest(p, kHitTolerancePx * m_scale);
    if (!hit) {
        m_view->setSelectedAnnotation(0);
        return false; // the navigator pans
    }
    const AnnotationObject &o = hit->annotation->object;
    m_view->setSelectedAnnotation(o.id);
    m_gesture = Gesture::Move;
    m_before = m_current = o;
    m_pressPos = event->position();
    m_dragStarted = false;
    m_locked = o.locked;
    return true;
}

bool AnnotationTools::mouseMove(const QMouseEvent *event)
{
    if (m_gesture == Gesture::None)
        return false;
    if (!m_view->hasSlide() || m_view->annotations() != m_store) {
        cancel();
        return false;
    }
    const Point2 p = toSlide(event->position());
    if (m_gesture != Gesture::Polygon && !(event->buttons() & Qt::LeftButton)) {
        cancel(); // the release went elsewhere
        return false;
    }
    m_pointer = p;
    switch (m_gesture) {
    case Gesture::None:
        return false;
    case Gesture::Shape:
        m_square = event->modifiers() & Qt::ShiftModifier;
        if (m_gestureTool == IrisSlideView::Freehand || m_gestureTool == IrisSlideView::Brush)
            appendThinned(m_path, p, kThinningPx * m_scale);
        showPreview();
        return true;
    case Gesture::Polygon:
        showPreview();
        return true;
    case Gesture::Move:
    case Gesture::Vertex: {
        if (m_locked)
            return true;
        if (!m_dragStarted
            && (event->position() - m_pressPos).manhattanLength() < QGuiApplication::styleHints()->startDragDistance())
            return true;
        m_dragStarted = true;
        m_current = m_gesture == Gesture::Move ? translated(m_before, p.x - m_start.x, p.y - m_start.y)
                                               : withHandleMoved(m_before, m_handle, p);
        if (const iris::Result r = m_store->update(m_current); !r.ok()) {
            qCWarning(lcIrisWidget).noquote()
                << "cannot move annotation" << m_current.id << ":" << QString::fromStdString(r.message());
            cancel();
        }
        updateMeasurement();
        return true;
    }
    }
    return false;
}

bool AnnotationTools::mouseRelease(const QMouseEvent *event)
{
    if (m_gesture == Gesture::None || event->button() != Qt::LeftButton)
        return false;
    if (!m_view->hasSlide() || m_view->annotations() != m_store) {
        cancel();
        return true;
    }
    const Point2 p = toSlide(event->position());
    switch (m_gesture) {
    case Gesture::None:
        return false;
    case Gesture::Polygon:
        return true; // vertices come with presses
    case Gesture::Shape:
        m_pointer = p;
        m_square = event->modifiers() & Qt::ShiftModifier;
        if (m_gestureTool == IrisSlideView::Freehand || m_gestureTool == IrisSlideView::Brush)
            appendThinned(m_path, p, kThinningPx * m_scale);
        finishShape();
        return true;
    case Gesture::Move:
    case Gesture::Vertex: {
        const bool move = m_gesture == Gesture::Move;
        if (m_dragStarted && !m_locked) { // where the pointer let go
            m_current = move ? translated(m_before, p.x - m_start.x, p.y - m_start.y)
                             : withHandleMoved(m_before, m_handle, p);
        }
        m_gesture = Gesture::None;
        m_store.reset();
        if (m_locked || !m_dragStarted || m_current == m_before)
            return true;
        const QString text = move ? QCoreApplication::translate("IrisSlideView", "Move %1")
                                        .arg(QString::fromUtf8(iris::annotationKindName(m_before.kind)))
                                  : QCoreApplication::translate("IrisSlideView", "Move vertex");
        m_stack.push(new ChangeAnnotationCommand(this, m_before, m_current, text));
        return true;
    }
    }
    return false;
}

bool AnnotationTools::mouseDoubleClick(const QMouseEvent *event)
{
    if (!active() || event->button() != Qt::LeftButton)
        return false;
    if (m_gesture == Gesture::Polygon)
        finishShape();
    return true; // no zoom while a tool is in effect
}

// --- shapes ------------------------------------------------------------------------------------

std::optional<AnnotationObject> AnnotationTools::shapeNow(bool final) const
{
    switch (m_gestureTool) {
    case IrisSlideView::Rectangle:
    case IrisSlideView::Ellipse: {
        AnnotationObject o = newObject(
            m_gestureTool == IrisSlideView::Rectangle ? AnnotationKind::Rectangle : AnnotationKind::Ellipse);
        o.box = boxFromDrag(m_start, m_pointer, m_square);
        if (final && !(o.box.width() > 0 && o.box.height() > 0))
            return std::nullopt;
        return o;
    }
    case IrisSlideView::Polygon:
    case IrisSlideView::Freehand: {
        std::vector<Point2> ring = m_path;
        if (m_gestureTool == IrisSlideView::Polygon && !final)
            ring.push_back(m_pointer); // the rubber band
        // A double click's two presses, a vertex clicked twice: half a screen pixel apart at most.
        ring = withoutRepeats(ring, final ? 0.5 * m_scale : 1e-9);
        if (ring.size() >= 3) {
            AnnotationObject o = newObject(AnnotationKind::Polygon);
            o.polygons = {{std::move(ring), {}}};
            return o;
        }
        if (final || ring.empty())
            return std::nullopt;
        AnnotationObject o = newObject(ring.size() == 2 ? AnnotationKind::Polyline : AnnotationKind::Point);
        o.points = std::move(ring);
        return o;
    }
    case IrisSlideView::Brush: {
        std::string error;
        std::vector<iris::PolygonPart> parts = brushOutline(m_path, kBrushRadiusPx * m_scale, &error);
        if (parts.empty()) {
            qCWarning(lcIrisWidget).noquote() << "brush:" << QString::fromStdString(error);
            return std::nullopt;
        }
        AnnotationObject o = newObject(AnnotationKind::Polygon);
        o.polygons = std::move(parts);
        return o;
    }
    default:
        return std::nullopt;
    }
}

void AnnotationTools::showPreview()
{
    if (!m_store)
        return;
    std::optional<AnnotationObject> o = shapeNow(false);
    if (!o)
        return;
    o->id = m_previewId;
    if (m_previewId == 0) {
        auto id = m_store->add(*o);
        if (!id.ok())
            return;
        m_previewId = *id;
        o->id = *id;
    } else if (!m_store->update(*o).ok()) {
        return; // keep the last preview (a degenerate moment of the drag)
    }
    m_preview = std::move(o);
    updateMeasurement();
}

void AnnotationTools::dropPreview()
{
    if (m_previewId && m_store)
        (void)m_store->remove(m_previewId);
    m_previewId = 0;
    m_preview.reset();
}

void AnnotationTools::finishShape()
{
    std::optional<AnnotationObject> o = shapeNow(true);
    if (!o) {
        cancel(); // a click without a drag, too few vertices: nothing is added
        return;
    }
    commit(std::move(*o));
}

void AnnotationTools::commit(AnnotationObject object)
{
    const quint64 previewId = m_previewId;
    object.id = previewId;
    m_previewId = 0;
    m_preview.reset();
    m_gesture = Gesture::None;
    m_path.clear();
    m_added = 0;
    m_stack.push(new AddAnnotationCommand(this, std::move(object), previewId != 0)); // redo(): store, signal
    if (m_added != 0)
        m_view->setSelectedAnnotation(m_added);
    else if (previewId != 0 && m_store)
        (void)m_store->remove(previewId); // the store refused the object: the preview goes too
    m_store.reset();
    updateMeasurement();
}

void AnnotationTools::cancel()
{
    switch (m_gesture) {
    case Gesture::None:
        break;
    case Gesture::Shape:
    case Gesture::Polygon:
        break; // the preview goes below
    case Gesture::Move:
    case Gesture::Vertex:
        if (m_dragStarted && !m_locked && m_store)
            (void)m_store->update(m_before); // back where it was; nothing was pushed
        break;
    }
    dropPreview();
    m_gesture = Gesture::None;
    m_path.clear();
    m_dragStarted = false;
    m_store.reset();
    updateMeasurement();
}

// --- keys --------------------------------------------------------------------------------------

void AnnotationTools::switchTool(Tool tool)
{
    m_view->setAnnotationTool(tool);
}

bool AnnotationTools::keyPress(const QKeyEvent *event)
{
    if (!m_enabled)
        return false;
    if (event->matches(QKeySequence::Undo)) {
        cancel();
        m_stack.undo();
        return true;
    }
    if (event->matches(QKeySequence::Redo)) {
        cancel();
        m_stack.redo();
        return true;
    }
    const Qt::KeyboardModifiers mods = event->modifiers() & ~Qt::KeypadModifier;
    if (mods & (Qt::ControlModifier | Qt::AltModifier | Qt::MetaModifier))
        return false;
    const bool shift = mods & Qt::ShiftModifier;
    const bool toolInEffect = effectiveTool() != IrisSlideView::Navigate;
    switch (event->key()) {
    case Qt::Key_Escape:
        if (m_gesture != Gesture::None) {
            cancel();
            return true;
        }
        if (toolInEffect && m_view->selectedAnnotation() != 0) {
            m_view->setSelectedAnnotation(0);
            return true;
        }
        return false;
    case Qt::Key_Return:
    case Qt::Key_Enter:
        if (m_gesture == Gesture::Polygon) {
            finishShape();
            return true;
        }
        return false;
    case Qt::Key_Backspace:
    case Qt::Key_Delete: {
        if (m_gesture == Gesture::Polygon) {
            if (m_path.size() > 1) {
                m_path.pop_back();
                showPreview();
            } else {
                cancel();
            }
            return true;
        }
        if (!toolInEffect || m_gesture != Gesture::None || !active())
            return false;
        const auto snap = snapshot();
        const iris::StoredAnnotation *selected = snap ? snap->find(m_view->selectedAnnotation()) : nullptr;
        if (!selected)
            return false;
        if (selected->object.locked)
            return true; // refused, as QuPath does
        m_stack.push(new RemoveAnnotationCommand(this, selected->object));
        return true;
    }
    // QuPath's tool keys (docs/ANNOTATIONS.md, "Editing in the widget").
    case Qt::Key_M:
        switchTool(IrisSlideView::Navigate);
        return true;
    case Qt::Key_S:
        switchTool(IrisSlideView::Select);
        return true;
    case Qt::Key_Period:
        switchTool(IrisSlideView::Point);
        return true;
    case Qt::Key_R:
        if (!toolInEffect || shift)
            return false; // in Navigate, R turns the view (the navigator's key)
        switchTool(IrisSlideView::Rectangle);
        return true;
    case Qt::Key_O:
        switchTool(IrisSlideView::Ellipse);
        return true;
    case Qt::Key_P:
        switchTool(shift ? IrisSlideView::Freehand : IrisSlideView::Polygon);
        return true;
    case Qt::Key_B:
        switchTool(IrisSlideView::Brush);
        return true;
    default:
        return false;
    }
}

// --- readouts ----------------------------------------------------------------------------------

void AnnotationTools::watchStore(const std::shared_ptr<iris::AnnotationStore> &store)
{
    m_watch.reset(); // waits for a call in progress
    if (!store)
        return;
    // The view outlives every call: ~IrisSlideView ends the subscription (waiting for a call in
    // progress) before anything else.
    IrisSlideView *view = m_view;
    std::shared_ptr<std::atomic<bool>> posted = m_refreshPosted;
    m_watch = store->onChange([view, posted, this] {
        // The writer's thread, its lock held: only post. acq_rel: pairs with the GUI thread's
        // store(false) below, so a publication after that store posts again.
        if (posted->exchange(true, std::memory_order_acq_rel))
            return;
        // Queued to the view: Qt drops it if the view is gone before it runs (the tools die with it).
        QMetaObject::invokeMethod(
            view,
            [this, posted] {
                posted->store(false, std::memory_order_release);
                updateMeasurement();
            },
            Qt::QueuedConnection);
    });
}

QString AnnotationTools::measurement(quint64 id) const
{
    const auto snap = snapshot();
    const iris::StoredAnnotation *a = snap ? snap->find(id) : nullptr;
    if (!a)
        return {};
    const IrisSlideInfo info = m_view->slideInfo();
    return QString::fromStdString(measurementText(a->object, info.mppX, info.mppY));
}

QString AnnotationTools::currentMeasurement() const
{
    if (m_preview) {
        const IrisSlideInfo info = m_view->slideInfo();
        return QString::fromStdString(measurementText(*m_preview, info.mppX, info.mppY));
    }
    return measurement(m_view->selectedAnnotation());
}

void AnnotationTools::updateMeasurement()
{
    const QString text = currentMeasurement();
    if (text == m_lastMeasurement)
        return;
    m_lastMeasurement = text;
    Q_EMIT m_view->annotationMeasurementChanged(text);
}

} // namespace IrisWidget
