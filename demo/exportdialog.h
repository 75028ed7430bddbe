// Iris View demo — File › Export as .iris…: converts the open slide with the engine's encoder
// (iris::encodeIris) on a worker thread, behind a progress dialog whose Cancel button sets the
// encoder's cancel flag. On success it offers to open the new file; errors go to a message box.
#pragma once

#include <atomic>
#include <cstdint>
#include <thread>

#include <QtCore/QElapsedTimer>
#include <QtCore/QString>
#include <QtWidgets/QProgressDialog>

QT_BEGIN_NAMESPACE
class QTimer;
QT_END_NAMESPACE

class ExportDialog : public QProgressDialog {
    Q_OBJECT
public:
    // Asks where to write the .iris file for `sourcePath`, then starts the export and shows its
    // progress. Returns the dialog (it deletes itself when done), or nullptr when the user
    // chose no file.
    static ExportDialog *start(QWidget *parent, const QString &sourcePath);
    ~ExportDialog() override;

Q_SIGNALS:
    // The user asked to open the exported file.
    void openRequested(const QString &path);

protected:
    void reject() override;
    void closeEvent(QCloseEvent *event) override;

private:
    ExportDialog(QWidget *parent, const QString &sourcePath, const QString &outputPath);
    void updateProgress();
    void finish(bool ok, int status, const QString &message, quint64 bytes, double seconds, quint64 tiles);
    void requestCancel();

    QString m_source;
    QString m_output;
    QTimer *m_timer;
    QElapsedTimer m_clock;
    std::atomic<bool> m_cancel{false};
    std::atomic<uint64_t> m_done{0};   // written by the encoder's progress callback
    std::atomic<uint64_t> m_total{0};
    std::thread m_worker;
};
