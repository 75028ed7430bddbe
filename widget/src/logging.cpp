#include "logging_p.h"

#include <QtCore/QString>

// Debug lines (surface and swapchain life) are off unless QT_LOGGING_RULES="iris.widget.debug=true".
Q_LOGGING_CATEGORY(lcIrisWidget, "iris.widget", QtInfoMsg)

namespace IrisWidget {

void logEngineMessage(iris::LogLevel level, std::string_view message)
{
    // QMessageLogger is thread-safe; the engine calls this from its own threads.
    const QString text = QString::fromUtf8(message.data(), qsizetype(message.size()));
    switch (level) {
    case iris::LogLevel::Debug:
        qCDebug(lcIrisWidget).noquote() << "engine:" << text;
        break;
    case iris::LogLevel::Info:
        qCInfo(lcIrisWidget).noquote() << "engine:" << text;
        break;
    case iris::LogLevel::Warning:
        qCWarning(lcIrisWidget).noquote() << "engine:" << text;
        break;
    case iris::LogLevel::Error:
        qCCritical(lcIrisWidget).noquote() << "engine:" << text;
        break;
    }
}

} // namespace IrisWidget
