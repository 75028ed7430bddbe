// Iris View widget — not API. The undoable edits of the annotation tools: every change the
// tools make to the store is one of these on IrisSlideView::annotationUndoStack(), so undo and
// redo restore the objects exactly (the same AnnotationObject values, ids included).
//
//   AddAnnotationCommand     redo: adds the object (the first time, it may instead turn the
//                            drawing preview of the same id into it: one publication); undo: removes it
//   RemoveAnnotationCommand  redo: removes; undo: adds the same value back, same id
//   ChangeAnnotationCommand  redo: the object after (a move, a vertex moved); undo: before
//
// Each emits the view's annotationAdded/Changed/Removed through the sink, on redo and on undo.
// An edit the store refuses (the host removed or re-used the id meanwhile) is logged and the
// command made obsolete, so the stack drops it instead of undoing something else.
#pragma once

#include <memory>

#include <QtCore/QtGlobal>
#include <QtGui/QUndoCommand>

#include <iris/annotations.h>

namespace IrisWidget {

// What the commands edit and whom they tell (AnnotationTools).
class AnnotationEditSink
{
public:
    virtual ~AnnotationEditSink() = default;
    virtual iris::AnnotationStore *editedStore() const = 0;
    virtual void objectAdded(quint64 id) = 0;
    virtual void objectChanged(quint64 id) = 0;
    virtual void objectRemoved(quint64 id) = 0;
};

class AddAnnotationCommand final : public QUndoCommand
{
public:
    // replacesPreview: the object's id is a preview in the store now; the first redo updates it.
    AddAnnotationCommand(AnnotationEditSink *sink, iris::AnnotationObject object, bool replacesPreview);
    void redo() override;
    void undo() override;

private:
    AnnotationEditSink *m_sink;
    iris::AnnotationObject m_object;
    bool m_replacesPreview;
};

class RemoveAnnotationCommand final : public QUndoCommand
{
public:
    RemoveAnnotationCommand(AnnotationEditSink *sink, iris::AnnotationObject object);
    void redo() override;
    void undo() override;

private:
    AnnotationEditSink *m_sink;
    iris::AnnotationObject m_object;
};

class ChangeAnnotationCommand final : public QUndoCommand
{
public:
    ChangeAnnotationCommand(
        AnnotationEditSink *sink, iris::AnnotationObject before, iris::AnnotationObject after, const QString &text);
    void redo() override;
    void undo() override;

private:
    AnnotationEditSink *m_sink;
    iris::AnnotationObject m_before;
    iris::AnnotationObject m_after;
};

} // namespace IrisWidget
