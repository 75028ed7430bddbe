#include "annotationfiles.h"

#include <QtCore/QCoreApplication>
#include <QtCore/QDir>
#include <QtCore/QFileInfo>
#include <QtCore/QSaveFile>

#include "recentfiles.h"

namespace {

QString tr(const char *text)
{
    return QCoreApplication::translate("AnnotationFiles", text);
}

} // namespace

QString AnnotationFiles::besidePath(const QString &slidePath)
{
    QString path = QDir::cleanPath(slidePath); // a folder's trailing separator goes
    return path + QStringLiteral(".annotations.geojson");
}

QString AnnotationFiles::whyNotBeside(const QString &slidePath)
{
    if (slidePath.isEmpty())
        return tr("No slide is open.");
    if (RecentFiles::isUrl(slidePath))
        return tr("The slide is on a DICOMweb server; annotations cannot be saved beside it. "
                  "Use File › Export Annotations… to save them to a file.");
    const QFileInfo folder(QFileInfo(besidePath(slidePath)).absolutePath());
    if (!folder.isDir() || !folder.isWritable())
        return tr("The folder %1 is read-only; annotations cannot be saved beside the slide. "
                  "Use File › Export Annotations… to save them elsewhere.")
            .arg(QDir::toNativeSeparators(folder.absoluteFilePath()));
    return {};
}

QString AnnotationFiles::geoJsonFilter()
{
    return tr("QuPath GeoJSON (*.geojson *.json)");
}

QString AnnotationFiles::asapFilter()
{
    return tr("ASAP XML (*.xml)");
}

QStringList AnnotationFiles::importFilters()
{
    return {tr("Annotations (*.geojson *.json *.xml)"), geoJsonFilter(), asapFilter(), tr("All files (*)")};
}

QStringList AnnotationFiles::exportFilters()
{
    return {geoJsonFilter(), asapFilter()};
}

std::optional<iris::AnnotationFormat> AnnotationFiles::formatOfName(const QString &path)
{
    const QString suffix = QFileInfo(path).suffix().toLower();
    if (suffix == QLatin1String("geojson") || suffix == QLatin1String("json"))
        return iris::AnnotationFormat::GeoJson;
    if (suffix == QLatin1String("xml"))
        return iris::AnnotationFormat::AsapXml;
    return std::nullopt;
}

QString AnnotationFiles::exportName(const QString &path, const QString &selectedFilter)
{
    if (formatOfName(path))
        return path;
    return path + (selectedFilter == asapFilter() ? QStringLiteral(".xml") : QStringLiteral(".geojson"));
}

QString AnnotationFiles::write(
    const iris::AnnotationSnapshot &snapshot, const QString &path, iris::AnnotationFormat format)
{
    const iris::AnnotationDocument document = iris::documentOf(snapshot);
    const std::string text
        = format == iris::AnnotationFormat::AsapXml ? iris::writeAsapXml(document) : iris::writeGeoJson(document);
    QSaveFile file(path);
    const QString name = QDir::toNativeSeparators(path);
    if (!file.open(QIODevice::WriteOnly))
        return tr("Cannot write %1: %2").arg(name, file.errorString());
    if (file.write(text.data(), qint64(text.size())) != qint64(text.size())) {
        const QString why = file.errorString();
        file.cancelWriting();
        return tr("Cannot write %1: %2").arg(name, why);
    }
    if (!file.commit())
        return tr("Cannot write %1: %2").arg(name, file.errorString());
    return {};
}
