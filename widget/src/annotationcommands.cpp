#include "annotationcommands_p.h"

#include <QtCore/QCoreApplication>

#include "logging_p.h"

namespace IrisWidget {

namespace {

QString kindText(const iris::AnnotationObject &o)
{
    return QCoreApplication::translate("IrisSlideView", iris::annotationKindName(o.kind));
}

// Logs why the store refused an edit; true when it did not.
bool succeeded(const iris::Result &r, const char *what, quint64 id)
{
    if (r.ok())
        return true;
    qCWarning(lcIrisWidget).noquote() << "annotation" << id << what << "failed:" << QString::fromStdString(r.message());
    return false;
}

} // namespace

AddAnnotationCommand::AddAnnotationCommand(
    AnnotationEditSink *sink, iris::AnnotationObject object, bool replacesPreview)
    : m_sink(sink)
    , m_object(std::move(object))
    , m_replacesPreview(replacesPreview)
{
    setText(QCoreApplication::translate("IrisSlideView", "Add %1").arg(kindText(m_object)));
}

void AddAnnotationCommand::redo()
{
    iris::AnnotationStore *store = m_sink->editedStore();
    bool ok = false;
    if (!store) {
        ok = false;
    } else if (m_replacesPreview) {
        m_replacesPreview = false;
        ok = succeeded(store->update(m_object), "add", m_object.id);
    } else {
        auto id = store->add(m_object);
        ok = succeeded(id.ok() ? iris::Result() : id.error(), "add", m_object.id);
        if (ok)
            m_object.id = *id; // the store's id the first time (0 asked for one), the same id after
    }
    if (!ok) {
        setObsolete(true);
        return;
    }
    m_sink->objectAdded(m_object.id);
}

void AddAnnotationCommand::undo()
{
    iris::AnnotationStore *store = m_sink->editedStore();
    if (!store || !succeeded(store->remove(m_object.id), "removal (undoing its addition)", m_object.id)) {
        setObsolete(true);
        return;
    }
    m_sink->objectRemoved(m_object.id);
}

RemoveAnnotationCommand::RemoveAnnotationCommand(AnnotationEditSink *sink, iris::AnnotationObject object)
    : m_sink(sink)
    , m_object(std::move(object))
{
    setText(QCoreApplication::translate("IrisSlideView", "Delete %1").arg(kindText(m_object)));
}

void RemoveAnnotationCommand::redo()
{
    iris::AnnotationStore *store = m_sink->editedStore();
    if (!store || !succeeded(store->remove(m_object.id), "removal", m_object.id)) {
        setObsolete(true);
        return;
    }
    m_sink->objectRemoved(m_object.id);
}

void RemoveAnnotationCommand::undo()
{
    iris::AnnotationStore *store = m_sink->editedStore();
    if (!store) {
        setObsolete(true);
        return;
    }
    auto id = store->add(m_object);
    if (!succeeded(id.ok() ? iris::Result() : id.error(), "restoration", m_object.id)) {
        setObsolete(true);
        return;
    }
    m_sink->objectAdded(m_object.id);
}

ChangeAnnotationCommand::ChangeAnnotationCommand(
    AnnotationEditSink *sink, iris::AnnotationObject before, iris::AnnotationObject after, const QString &text)
    : m_sink(sink)
    , m_before(std::move(before))
    , m_after(std::move(after))
{
    setText(text);
}

void ChangeAnnotationCommand::redo()
{
    iris::AnnotationStore *store = m_sink->editedStore();
    if (!store || !succeeded(store->update(m_after), "change", m_after.id)) {
        setObsolete(true);
        return;
    }
    m_sink->objectChanged(m_after.id);
}

void ChangeAnnotationCommand::undo()
{
    iris::AnnotationStore *store = m_sink->editedStore();
    if (!store || !succeeded(store->update(m_before), "change (undoing it)", m_before.id)) {
        setObsolete(true);
        return;
    }
    m_sink->objectChanged(m_before.id);
}

} // namespace IrisWidget
