// Iris View widget — export macro for libiris_widget.
#pragma once

#include <QtCore/qglobal.h>

#if defined(IRIS_BUILDING_WIDGET)
#  define IRIS_WIDGET_EXPORT Q_DECL_EXPORT
#else
#  define IRIS_WIDGET_EXPORT Q_DECL_IMPORT
#endif
