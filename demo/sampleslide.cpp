#include "sampleslide.h"

#include <QtCore/QCoreApplication>
#include <QtCore/QDir>
#include <QtCore/QFileInfo>
#include <QtCore/QProcess>
#include <QtCore/QStandardPaths>
#include <QtCore/QTimer>

#include <iris/version.h>

SampleSlide::SampleSlide(QObject *parent)
    : QObject(parent)
{
}

SampleSlide::~SampleSlide()
{
    if (m_process) {
        m_process->disconnect(this);
        m_process->kill();
        m_process->waitForFinished(3000);
        QFile::remove(m_partialPath);
    }
}

QString SampleSlide::path()
{
    const QString dir = QStandardPaths::writableLocation(QStandardPaths::CacheLocation);
    return QDir(dir).filePath(QStringLiteral("sample-%1.tiff").arg(QStringLiteral(IRIS_VIEW_VERSION_STRING)));
}

QString SampleSlide::generatorProgram()
{
    return QDir(QCoreApplication::applicationDirPath()).filePath(QStringLiteral("iris-sample"));
}

bool SampleSlide::isGenerating() const
{
    return m_process != nullptr;
}

void SampleSlide::ensure()
{
    const QString target = path();
    if (QFileInfo(target).size() > 0) {
        // Asynchronous like the other path, so callers handle one flow.
        QTimer::singleShot(0, this, [this, target] { Q_EMIT ready(target); });
        return;
    }
    if (m_process)
        return; // already on its way
    const QString program = generatorProgram();
    if (!QFileInfo(program).isExecutable()) {
        QTimer::singleShot(0, this, [this, program] {
            Q_EMIT failed(tr("Cannot make the sample slide: %1 is missing.").arg(QDir::toNativeSeparators(program)));
        });
        return;
    }
    if (!QDir().mkpath(QFileInfo(target).absolutePath())) {
        QTimer::singleShot(0, this, [this, target] {
            Q_EMIT failed(tr("Cannot create the folder for %1.").arg(QDir::toNativeSeparators(target)));
        });
        return;
    }

    m_partialPath = target + QStringLiteral(".part");
    m_process = new QProcess(this);
    m_process->setProgram(program);
    m_process->setArguments({QStringLiteral("--out"), m_partialPath});
    m_process->setProcessChannelMode(QProcess::MergedChannels);
    connect(m_process, &QProcess::finished, this,
            [this](int exitCode, QProcess::ExitStatus status) { onFinished(exitCode, int(status)); });
    connect(m_process, &QProcess::errorOccurred, this, [this](QProcess::ProcessError error) {
        if (error == QProcess::FailedToStart)
            onFinished(-1, int(QProcess::CrashExit));
    });
    m_clock.start();
    Q_EMIT generating(tr("Generating the sample slide (once)…"));
    m_process->start();
}

void SampleSlide::onFinished(int exitCode, int exitStatus)
{
    if (!m_process)
        return;
    const QString output = QString::fromLocal8Bit(m_process->readAll()).trimmed();
    const QString error = m_process->errorString();
    m_process->deleteLater();
    m_process = nullptr;

    const QString target = path();
    if (exitStatus != int(QProcess::NormalExit) || exitCode != 0) {
        QFile::remove(m_partialPath);
        const QString detail = output.isEmpty() ? error : output;
        Q_EMIT failed(tr("The sample slide could not be generated: %1").arg(detail));
        return;
    }
    QFile::remove(target);
    if (!QFile::rename(m_partialPath, target)) {
        QFile::remove(m_partialPath);
        Q_EMIT failed(tr("Cannot move the sample slide to %1.").arg(QDir::toNativeSeparators(target)));
        return;
    }
    Q_EMIT generating(tr("Sample slide ready after %1 s").arg(double(m_clock.elapsed()) / 1000.0, 0, 'f', 1));
    Q_EMIT ready(target);
}
