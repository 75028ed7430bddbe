// Iris View demo — one import of an annotation file into a store: iris::AnnotationLoader
// reads and parses it on its own thread (the store changes once, only if the whole file is
// good), a progress dialog shows how far it got and cancels it, and the outcome arrives as a
// signal on the GUI thread.
#pragma once

#include <atomic>
#include <memory>

#include <QtCore/QObject>
#include <QtCore/QPointer>
#include <QtCore/QTimer>

#include <iris/annotations.h>

QT_BEGIN_NAMESPACE
class QProgressDialog;
class QWidget;
QT_END_NAMESPACE

class AnnotationImport : public QObject
{
    Q_OBJECT
public:
    using Mode = iris::AnnotationLoader::Mode;
    // Starts at once. The progress dialog (window-modal over `dialogParent`) shows after a
    // moment, so a small file does not flash one.
    AnnotationImport(
        std::shared_ptr<iris::AnnotationStore> store, const QString &path, Mode mode, QWidget *dialogParent);
    // Cancels and waits for the loader's thread.
    ~AnnotationImport() override;

    QString path() const { return m_path; }
    Mode mode() const { return m_mode; }
    void cancel();

Q_SIGNALS:
    // Once. ok: the store holds the file's objects (`objects` of them were read); cancelled:
    // the user stopped it; else `message` is the reader's (it names the line or feature).
    // Either way a failure left the store as it was.
    void finished(bool ok, bool cancelled, qsizetype objects, const QString &message);

private:
    void showProgress();
    void done(iris::Status status, const QString &message, qsizetype objects);

    QString m_path;
    Mode m_mode;
    std::shared_ptr<iris::AnnotationStore> m_store; // outlives the loader (declared before it)
    QPointer<QProgressDialog> m_progress;
    QTimer m_poll;
    // Written by the loader's thread, read by the poll timer for the progress bar only.
    // relaxed: display values; no data is handed over through them.
    std::atomic<quint64> m_done{0};
    std::atomic<quint64> m_total{0};
    bool m_finished = false;
    std::unique_ptr<iris::AnnotationLoader> m_loader; // last: destroyed (joined) first
};
