// Iris View widget — not API. Logging category "iris.widget".
#pragma once

#include <QtCore/QLoggingCategory>

#include <iris/types.h>

Q_DECLARE_LOGGING_CATEGORY(lcIrisWidget)

namespace IrisWidget {
// Routes one engine log line (any thread) to the "iris.widget" category.
void logEngineMessage(iris::LogLevel level, std::string_view message);
}
