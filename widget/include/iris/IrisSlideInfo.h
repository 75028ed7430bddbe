// Iris View widget — what IrisSlideView::slideOpened() reports about a slide.
#pragma once

#include <QtCore/QList>
#include <QtCore/QMap>
#include <QtCore/QMetaType>
#include <QtCore/QSize>
#include <QtCore/QString>
#include <QtCore/QStringList>

#include "iris/IrisWidgetGlobal.h"

// One pyramid level. Sizes are pixels of that level; downsample is level-0 pixels per
// pixel of the level (1 for level 0). A synthetic level is not stored in the file: the
// engine computes it from the coarsest stored level, for slides whose stored pyramid stops
// at a level too large to keep resident (a slide without reduced levels, for example).
struct IRIS_WIDGET_EXPORT IrisSlideLevel {
    Q_GADGET
    Q_PROPERTY(qint64 width MEMBER width)
    Q_PROPERTY(qint64 height MEMBER height)
    Q_PROPERTY(double downsample MEMBER downsample)
    Q_PROPERTY(bool synthetic MEMBER synthetic)
public:
    qint64 width = 0;
    qint64 height = 0;
    double downsample = 1;
    bool synthetic = false;

    friend bool operator==(const IrisSlideLevel &a, const IrisSlideLevel &b)
    {
        return a.width == b.width && a.height == b.height && a.downsample == b.downsample
            && a.synthetic == b.synthetic;
    }
};

// A slide's metadata: format, geometry, resolution and everything the file says about itself.
struct IRIS_WIDGET_EXPORT IrisSlideInfo {
    Q_GADGET
    Q_PROPERTY(QString path MEMBER path)
    Q_PROPERTY(QString vendor MEMBER vendor)
    Q_PROPERTY(qint64 width MEMBER width)
    Q_PROPERTY(qint64 height MEMBER height)
    Q_PROPERTY(QList<IrisSlideLevel> levels MEMBER levels)
    Q_PROPERTY(double mppX MEMBER mppX)
    Q_PROPERTY(double mppY MEMBER mppY)
    Q_PROPERTY(double objectivePower MEMBER objectivePower)
    Q_PROPERTY(QMap<QString, QString> properties MEMBER properties)
    Q_PROPERTY(QStringList associatedImages MEMBER associatedImages)
public:
    QString path;
    QString vendor;                    // "aperio", "generic-tiff", "iris", …
    qint64 width = 0;                  // level-0 pixels
    qint64 height = 0;
    QList<IrisSlideLevel> levels;      // finest first
    double mppX = 0;                   // microns per level-0 pixel; 0 when the slide does not say
    double mppY = 0;
    double objectivePower = 0;         // as the slide states it; 0 when it does not
    QMap<QString, QString> properties; // every property the slide carries, by name
    QStringList associatedImages;      // "label", "macro", "thumbnail", …

    Q_INVOKABLE bool isValid() const { return width > 0 && height > 0; }
    // The objective the view's magnification is based on: the stated objective power, or
    // 10 µm / mpp when only the resolution is known (0.25 µm/px → 40×); 0 when neither is.
    Q_INVOKABLE double effectiveObjectivePower() const;
};

Q_DECLARE_METATYPE(IrisSlideLevel)
Q_DECLARE_METATYPE(IrisSlideInfo)
