// Iris View demo — annotation files: where a slide's own annotations are kept
// (`<slide>.annotations.geojson` beside it), the file dialogs' filters, the format a name
// asks for, and writing a snapshot so that a failed write loses nothing (QSaveFile: a
// temporary file in the same folder, renamed over the old one only once it is complete).
#pragma once

#include <optional>

#include <QtCore/QString>
#include <QtCore/QStringList>

#include <iris/annotations.h>

namespace AnnotationFiles {

// "<slide path>.annotations.geojson" (a DICOM folder's is beside the folder).
QString besidePath(const QString &slidePath);
// Why annotations cannot be kept beside this slide (a DICOMweb URL, a read-only folder); an
// empty string when they can.
QString whyNotBeside(const QString &slidePath);

QString geoJsonFilter(); // "QuPath GeoJSON (*.geojson *.json)"
QString asapFilter(); // "ASAP XML (*.xml)"
QStringList importFilters(); // both, then both in one, then all files
QStringList exportFilters(); // GeoJSON, ASAP

// The format a file name's suffix names (.geojson/.json, .xml); none for another suffix.
std::optional<iris::AnnotationFormat> formatOfName(const QString &path);
// The name an export writes: `path` as chosen, given the filter's suffix when it has none of
// the two formats' own.
QString exportName(const QString &path, const QString &selectedFilter);

// Writes the snapshot's document in `format`; an empty string on success, else what went
// wrong, naming the file. Whatever `path` held stays as it was unless the write completes.
QString write(const iris::AnnotationSnapshot &snapshot, const QString &path, iris::AnnotationFormat format);

} // namespace AnnotationFiles
