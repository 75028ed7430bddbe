// Iris View demo — the slide file formats the viewer offers to open.
#pragma once

#include <QtCore/QString>
#include <QtCore/QStringList>

namespace SlideFormats {

// Every extension OpenSlide 3.4.1 reads, plus the Iris File Extension.
QStringList extensions(); // "svs", "tif", …
// A QFileDialog name filter list: all slides, then one entry per format, then all files.
QStringList fileDialogFilters();
// Whether path looks like a slide (by extension); the engine has the final word.
bool looksLikeSlide(const QString &path);

} // namespace SlideFormats
