// Iris View widget — what IrisSlideView::layer() reports about a raster layer (a heat map or a
// label map drawn over the slide; the engine's iris/layers.h and docs/LAYERS.md say the rest).
#pragma once

#include <limits>

#include <QtCore/QList>
#include <QtCore/QMetaType>
#include <QtCore/QSize>
#include <QtCore/QString>
#include <QtGui/QColor>

// One class of a label map: its name, its colour (alpha counts) and whether it is drawn.
struct IrisLayerClass {
    QString name;
    QColor color;
    bool visible = true;
};

struct IrisLayerInfo {
    // What the map holds (iris::RasterKind): values shaded through a colour map, class ids
    // coloured through the class table, or colours of its own.
    enum Kind { Scalar, Label, Rgba };
    enum Sampling { Bilinear, Nearest };

    quint64 id = 0;      // the view's id of the layer; 0: no such layer
    QString title;       // the map's title (a loaded file's name)
    Kind kind = Scalar;
    QSize size;          // the finest level, in map pixels
    int levels = 0;
    // The range found in the data (NaN when a scalar map holds no value at all).
    double minValue = std::numeric_limits<double>::quiet_NaN();
    double maxValue = std::numeric_limits<double>::quiet_NaN();
    // The style (iris::LayerStyle): low and high NaN stand for the map's range, threshold −∞
    // for none; colorMap is the colour map's name (a user LUT's file name).
    bool visible = true;
    double opacity = 0.5;
    QString colorMap;
    double low = std::numeric_limits<double>::quiet_NaN();
    double high = std::numeric_limits<double>::quiet_NaN();
    double threshold = -std::numeric_limits<double>::infinity();
    Sampling sampling = Bilinear;
    QList<IrisLayerClass> classes; // label maps

    bool isValid() const { return id != 0; }
    // "scalar", "label" or "rgba".
    QString kindName() const
    {
        switch (kind) {
        case Label: return QStringLiteral("label");
        case Rgba: return QStringLiteral("rgba");
        case Scalar: break;
        }
        return QStringLiteral("scalar");
    }
};

Q_DECLARE_METATYPE(IrisLayerInfo)
