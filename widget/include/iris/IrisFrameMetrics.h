// Iris View widget — per-frame figures that IrisSlideView::framePresented() reports.
#pragma once

#include <QtCore/QMetaType>
#include <QtCore/QPointF>

#include "iris/IrisWidgetGlobal.h"

struct IRIS_WIDGET_EXPORT IrisFrameMetrics {
    Q_GADGET
    Q_PROPERTY(quint64 serial MEMBER serial)
    Q_PROPERTY(double intervalMs MEMBER intervalMs)
    Q_PROPERTY(double cpuMs MEMBER cpuMs)
    Q_PROPERTY(quint32 tilesDrawn MEMBER tilesDrawn)
    Q_PROPERTY(double fps MEMBER fps)
    Q_PROPERTY(bool complete MEMBER complete)
    Q_PROPERTY(QPointF centre MEMBER centre)
    Q_PROPERTY(double downsample MEMBER downsample)
public:
    quint64 serial = 0;     // increases with every frame the engine renders
    double intervalMs = 0;  // since the previous frame
    double cpuMs = 0;       // render thread's time recording and submitting this frame
    quint32 tilesDrawn = 0;
    double fps = 0;         // frames per second over the recent frames of continuous rendering
    bool complete = false;  // every visible tile of the finest needed level was on the GPU
    QPointF centre;         // the view this frame shows: centre in level-0 pixels …
    double downsample = 0;  // … and level-0 pixels per device pixel
};

Q_DECLARE_METATYPE(IrisFrameMetrics)
