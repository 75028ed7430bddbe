// Iris View widget — not API. Marks private classes and functions that the widget's own
// test suites link against (as Qt's Q_AUTOTEST_EXPORT does); hosts must not use them.
#pragma once

#include "iris/IrisWidgetGlobal.h"

#define IRIS_WIDGET_AUTOTEST_EXPORT IRIS_WIDGET_EXPORT
