#include "slideformats.h"

#include <QtCore/QCoreApplication>
#include <QtCore/QFileInfo>

namespace SlideFormats {

namespace {

struct Format {
    const char *name;
    QStringList extensions;
};

const QList<Format> &formats()
{
    static const QList<Format> table{
        {QT_TRANSLATE_NOOP("SlideFormats", "Iris File Extension"), {QStringLiteral("iris")}},
        {QT_TRANSLATE_NOOP("SlideFormats", "Aperio"), {QStringLiteral("svs"), QStringLiteral("tif")}},
        // Any one file of a series opens the whole series (the files beside it).
        {QT_TRANSLATE_NOOP("SlideFormats", "DICOM whole-slide image"), {QStringLiteral("dcm")}},
        {QT_TRANSLATE_NOOP("SlideFormats", "Hamamatsu"),
         {QStringLiteral("ndpi"), QStringLiteral("vms"), QStringLiteral("vmu")}},
        {QT_TRANSLATE_NOOP("SlideFormats", "Leica"), {QStringLiteral("scn")}},
        {QT_TRANSLATE_NOOP("SlideFormats", "MIRAX"), {QStringLiteral("mrxs")}},
        {QT_TRANSLATE_NOOP("SlideFormats", "Sakura"), {QStringLiteral("svslide")}},
        {QT_TRANSLATE_NOOP("SlideFormats", "Trestle"), {QStringLiteral("tif")}},
        {QT_TRANSLATE_NOOP("SlideFormats", "Ventana"), {QStringLiteral("bif"), QStringLiteral("tif")}},
        {QT_TRANSLATE_NOOP("SlideFormats", "Philips"), {QStringLiteral("tiff")}},
        {QT_TRANSLATE_NOOP("SlideFormats", "Generic tiled TIFF"), {QStringLiteral("tif"), QStringLiteral("tiff")}},
    };
    return table;
}

QString patterns(const QStringList &extensions)
{
    QStringList globs;
    for (const QString &ext : extensions)
        globs << QStringLiteral("*.") + ext;
    return globs.join(QLatin1Char(' '));
}

} // namespace

QStringList extensions()
{
    QStringList all;
    for (const Format &format : formats()) {
        for (const QString &ext : format.extensions) {
            if (!all.contains(ext))
                all << ext;
        }
    }
    return all;
}

QStringList fileDialogFilters()
{
    QStringList filters;
    filters << QCoreApplication::translate("SlideFormats", "All slides (%1)").arg(patterns(extensions()));
    for (const Format &format : formats()) {
        filters << QStringLiteral("%1 (%2)")
                       .arg(QCoreApplication::translate("SlideFormats", format.name), patterns(format.extensions));
    }
    filters << QCoreApplication::translate("SlideFormats", "All files (*)");
    return filters;
}

bool looksLikeSlide(const QString &path)
{
    return extensions().contains(QFileInfo(path).suffix().toLower());
}

} // namespace SlideFormats
