// Small raster-layer files for the widget and viewer suites (tst_layers_widget.cpp,
// tst_layers_dock.cpp): an 8-bit grey PNG (a scalar map 0..255, or class ids with asLabels),
// a float32 NumPy .npy, a 256-entry text LUT, and hostile files. Header-only.
#pragma once

#include <cstdint>
#include <cstring>
#include <functional>
#include <vector>

#include <QtCore/QByteArray>
#include <QtCore/QFile>
#include <QtCore/QString>
#include <QtGui/QImage>

namespace layerfiles {

// value(x, y) as each pixel's grey level.
inline bool writeGreyPng(const QString &path, int width, int height, const std::function<int(int, int)> &value)
{
    QImage image(width, height, QImage::Format_Grayscale8);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
            image.scanLine(y)[x] = uchar(value(x, y));
    return image.save(path, "PNG");
}

inline bool writeBytes(const QString &path, const QByteArray &bytes)
{
    QFile f(path);
    return f.open(QIODevice::WriteOnly) && f.write(bytes) == bytes.size();
}

// A 2-D little-endian float32 array, C order (NumPy format 1.0).
inline bool writeNpy(const QString &path, int width, int height, const std::vector<float> &values)
{
    QByteArray header = "{'descr': '<f4', 'fortran_order': False, 'shape': (" + QByteArray::number(height) + ", "
        + QByteArray::number(width) + "), }";
    while ((10 + header.size() + 1) % 64 != 0)
        header += ' ';
    header += '\n';
    QByteArray bytes("\x93NUMPY\x01\x00", 8);
    bytes += char(header.size() & 0xff);
    bytes += char(header.size() >> 8);
    bytes += header;
    bytes += QByteArray(reinterpret_cast<const char *>(values.data()), qsizetype(values.size() * sizeof(float)));
    return writeBytes(path, bytes);
}

// Entry i = (i, 255 − i, 7, 255): tells it apart from every built-in map.
inline bool writeTextLut(const QString &path)
{
    QByteArray text = "# test LUT\n";
    for (int i = 0; i < 256; ++i)
        text += QByteArray::number(i) + ' ' + QByteArray::number(255 - i) + " 7\n";
    return writeBytes(path, text);
}

} // namespace layerfiles
