// Iris View demo — the built-in sample slide.
//
// Generated once by the iris-sample tool (beside iris-viewer) into the user's cache folder
// (~/.cache/IrisView/iris-viewer/sample-<version>.tiff), in the background: the GUI stays
// responsive and shows a busy indicator. The file is written under a temporary name and
// renamed when complete, so an interrupted run never leaves a half-written sample behind.
#pragma once

#include <QtCore/QElapsedTimer>
#include <QtCore/QObject>
#include <QtCore/QPointer>
#include <QtCore/QString>

QT_BEGIN_NAMESPACE
class QProcess;
QT_END_NAMESPACE

class SampleSlide : public QObject {
    Q_OBJECT
public:
    explicit SampleSlide(QObject *parent = nullptr);
    ~SampleSlide() override;

    // Where the sample lives (whether or not it exists yet).
    static QString path();
    // The iris-sample program this viewer uses.
    static QString generatorProgram();

    // Emits ready() with the sample's path, generating it first when missing.
    void ensure();
    bool isGenerating() const;

Q_SIGNALS:
    void generating(const QString &message);
    void ready(const QString &path);
    void failed(const QString &message);

private:
    void onFinished(int exitCode, int exitStatus);

    QPointer<QProcess> m_process;
    QString m_partialPath;
    QElapsedTimer m_clock;
};
