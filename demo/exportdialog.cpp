#include "exportdialog.h"

#include <QtCore/QDir>
#include <QtCore/QFileInfo>
#include <QtCore/QLocale>
#include <QtCore/QSettings>
#include <QtCore/QTimer>
#include <QtGui/QCloseEvent>
#include <QtWidgets/QFileDialog>
#include <QtWidgets/QMessageBox>
#include <QtWidgets/QPushButton>

#include <iris/encoder.h>

namespace {
constexpr int kProgressSteps = 1000; // the dialog's range: permille of the tiles
}

ExportDialog *ExportDialog::start(QWidget *parent, const QString &sourcePath)
{
    QSettings settings;
    const QFileInfo source(sourcePath);
    QString folder = settings.value(QStringLiteral("export/lastFolder")).toString();
    if (folder.isEmpty())
        folder = source.exists() ? source.absolutePath() : QDir::homePath();
    const QString suggested = QDir(folder).filePath(QString::fromStdString(iris::irisFileName(sourcePath.toStdString())));
    QString output = QFileDialog::getSaveFileName(parent, tr("Export as .iris"), suggested,
                                                  tr("Iris slides (*.iris);;All files (*)"));
    if (output.isEmpty())
        return nullptr;
    if (QFileInfo(output).suffix().isEmpty())
        output += QStringLiteral(".iris");
    settings.setValue(QStringLiteral("export/lastFolder"), QFileInfo(output).absolutePath());
    auto *dialog = new ExportDialog(parent, sourcePath, output);
    dialog->show();
    return dialog;
}

ExportDialog::ExportDialog(QWidget *parent, const QString &sourcePath, const QString &outputPath)
    : QProgressDialog(parent)
    , m_source(sourcePath)
    , m_output(outputPath)
    , m_timer(new QTimer(this))
{
    setAttribute(Qt::WA_DeleteOnClose);
    setWindowTitle(tr("Export as .iris"));
    setWindowModality(Qt::WindowModal);
    setMinimumDuration(0);
    setAutoClose(false);
    setAutoReset(false);
    setRange(0, kProgressSteps);
    setValue(0);
    setLabelText(tr("Reading %1…").arg(QFileInfo(sourcePath).fileName()));
    // Cancel asks the encoder to stop; the dialog stays until it has removed its partial file.
    disconnect(this, &QProgressDialog::canceled, this, &QProgressDialog::cancel);
    connect(this, &QProgressDialog::canceled, this, &ExportDialog::requestCancel);

    // The encoder calls back once per tile from its writing thread: the callback only stores
    // two numbers, and a timer on the GUI thread shows them.
    connect(m_timer, &QTimer::timeout, this, &ExportDialog::updateProgress);
    m_timer->start(100);
    m_clock.start();

    const std::string source = sourcePath.toStdString();
    const std::string output = outputPath.toStdString();
    m_worker = std::thread([this, source, output] {
        iris::EncodeOptions options;
        options.cancel = &m_cancel;
        options.progress = [this](uint64_t done, uint64_t total) {
            m_total.store(total, std::memory_order_relaxed);
            m_done.store(done, std::memory_order_relaxed);
        };
        const auto stats = iris::encodeIris(source, output, options);
        const bool ok = stats.ok();
        const int status = ok ? 0 : int(stats.error().status());
        const QString message = ok ? QString() : QString::fromStdString(stats.error().message());
        const quint64 bytes = ok ? stats->bytesWritten : 0;
        const double seconds = ok ? stats->seconds : 0;
        const quint64 tiles = ok ? stats->tiles : 0;
        // The dialog joins this thread before it is destroyed, so `this` is alive here; the
        // queued call runs on the GUI thread.
        QMetaObject::invokeMethod(
            this, [this, ok, status, message, bytes, seconds, tiles] { finish(ok, status, message, bytes, seconds, tiles); },
            Qt::QueuedConnection);
    });
}

ExportDialog::~ExportDialog()
{
    // Closing the window (or quitting) mid-export cancels it: the encoder removes its
    // partial file, and nothing appears under the output name.
    m_cancel.store(true);
    if (m_worker.joinable())
        m_worker.join();
}

void ExportDialog::updateProgress()
{
    const uint64_t total = m_total.load(std::memory_order_relaxed);
    const uint64_t done = m_done.load(std::memory_order_relaxed);
    if (total == 0 || m_cancel.load())
        return;
    setValue(int(double(done) / double(total) * kProgressSteps));
    const double seconds = m_clock.elapsed() / 1000.0;
    const double rate = seconds > 0 ? double(done) / seconds : 0;
    setLabelText(tr("Writing %1\n%2 of %3 tiles, %4 tiles/s")
                     .arg(QFileInfo(m_output).fileName(), QLocale().toString(qulonglong(done)),
                          QLocale().toString(qulonglong(total)), QLocale().toString(rate, 'f', 0)));
}

void ExportDialog::reject()
{
    requestCancel(); // Escape: stop the encoder; finish() closes the dialog
}

void ExportDialog::closeEvent(QCloseEvent *event)
{
    if (m_worker.joinable()) {
        requestCancel();
        event->ignore();
        return;
    }
    QDialog::closeEvent(event);
}

void ExportDialog::requestCancel()
{
    m_cancel.store(true);
    setLabelText(tr("Cancelling…"));
    if (QPushButton *button = findChild<QPushButton *>())
        button->setEnabled(false);
}

void ExportDialog::finish(bool ok, int status, const QString &message, quint64 bytes, double seconds, quint64 tiles)
{
    m_timer->stop();
    if (m_worker.joinable())
        m_worker.join();
    hide();
    QWidget *parent = parentWidget();
    const QString output = QDir::toNativeSeparators(m_output);
    if (ok) {
        const QString text = tr("Wrote %1\n%2 in %3 s (%4 tiles, %5 tiles/s).\n\nOpen it now?")
                                 .arg(output, QLocale().formattedDataSize(qint64(bytes)),
                                      QLocale().toString(seconds, 'f', 1), QLocale().toString(tiles),
                                      QLocale().toString(seconds > 0 ? double(tiles) / seconds : 0.0, 'f', 0));
        if (QMessageBox::question(parent, tr("Export as .iris"), text) == QMessageBox::Yes)
            Q_EMIT openRequested(m_output);
    } else if (status != int(iris::Status::Cancelled)) {
        QMessageBox::warning(parent, tr("Export as .iris"), tr("The export failed.\n\n%1").arg(message));
    }
    close(); // deletes the dialog (WA_DeleteOnClose)
}
