#include "annotationimport.h"

#include <QtCore/QFile>
#include <QtCore/QFileInfo>
#include <QtWidgets/QProgressDialog>

namespace {
constexpr int kPollMs = 50;
constexpr int kShowAfterMs = 400;
constexpr int kSteps = 1000;
} // namespace

AnnotationImport::AnnotationImport(
    std::shared_ptr<iris::AnnotationStore> store, const QString &path, Mode mode, QWidget *dialogParent)
    : m_path(path)
    , m_mode(mode)
    , m_store(std::move(store))
{
    m_progress = new QProgressDialog(
        tr("Importing annotations from %1…").arg(QFileInfo(path).fileName()), tr("Cancel"), 0, kSteps, dialogParent);
    m_progress->setObjectName(QStringLiteral("annotationImportProgress"));
    m_progress->setWindowTitle(tr("Import Annotations"));
    m_progress->setWindowModality(Qt::WindowModal);
    m_progress->setMinimumDuration(kShowAfterMs);
    m_progress->setAutoClose(false);
    m_progress->setAutoReset(false);
    m_progress->setValue(0);
    connect(m_progress, &QProgressDialog::canceled, this, &AnnotationImport::cancel);
    m_poll.setInterval(kPollMs);
    connect(&m_poll, &QTimer::timeout, this, &AnnotationImport::showProgress);
    m_poll.start();

    iris::AnnotationLoader::Callbacks callbacks;
    callbacks.progress = [this](uint64_t done, uint64_t total) {
        m_done.store(done, std::memory_order_relaxed);
        m_total.store(total, std::memory_order_relaxed);
    };
    // On the loader's thread: hand the outcome to the GUI thread. `this` outlives the loader
    // (the destructor joins it), and a call still queued when this object goes is dropped.
    callbacks.finished = [this](const iris::Result &result, size_t objects) {
        const iris::Status status = result.status();
        const QString message = QString::fromStdString(result.message());
        QMetaObject::invokeMethod(
            this, [this, status, message, objects] { done(status, message, qsizetype(objects)); },
            Qt::QueuedConnection);
    };
    m_loader = std::make_unique<iris::AnnotationLoader>(
        *m_store, QFile::encodeName(path).toStdString(), std::move(callbacks), mode);
}

AnnotationImport::~AnnotationImport()
{
    m_loader.reset(); // cancels and joins
    delete m_progress;
}

void AnnotationImport::cancel()
{
    if (m_loader)
        m_loader->cancel();
}

void AnnotationImport::showProgress()
{
    const quint64 total = m_total.load(std::memory_order_relaxed);
    if (m_progress && total > 0)
        m_progress->setValue(int(double(m_done.load(std::memory_order_relaxed)) / double(total) * (kSteps - 1)));
}

void AnnotationImport::done(iris::Status status, const QString &message, qsizetype objects)
{
    if (m_finished)
        return;
    m_finished = true;
    m_poll.stop();
    (void)m_loader->wait(); // its thread is ending: the result came through `finished` already
    if (m_progress) {
        m_progress->hide();
        m_progress->deleteLater();
    }
    Q_EMIT finished(status == iris::Status::Ok, status == iris::Status::Cancelled, objects, message);
}
