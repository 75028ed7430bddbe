// Pixel checks of raster layers shown by an IrisSlideView (tst_layers_pixels.cpp,
// tst_layers_dock_pixels.cpp): a headless twin of the view, one iris::Engine on an offscreen
// target of the view's device size on the same slide, with the view's background, no overlays,
// and the view's layers as the view holds them (IrisSlideView::layerMap and layerStyle, each
// spanning the slide), rendered at the view's centre, downsample, turn and flips; and the
// presented frame (grabbed from the X server) compared with it. Header-only.
#pragma once

#include <chrono>
#include <cstring>
#include <memory>

#include <QtCore/QFile>
#include <QtCore/QString>
#include <QtGui/QImage>

#include <iris/IrisSlideView.h>
#include <iris/engine.h>
#include <iris/layers.h>

#include "widget_test_support.h"

namespace layerpixels {

class HeadlessTwin
{
public:
    // Opens the view's slide on an offscreen target of its device size; false and *error on failure.
    bool start(const IrisSlideView *view, QString *error)
    {
        iris::EngineConfig config;
        config.validation = true;
        config.loaderThreads = 2;
        const QColor bg = view->backgroundColor();
        config.background = {float(bg.redF()), float(bg.greenF()), float(bg.blueF())};
        auto created = iris::Engine::create(config);
        if (!created) {
            *error = QString::fromStdString(created.error().message());
            return false;
        }
        m_engine = std::move(created).value();
        m_size = view->targetSize();
        m_engine->setEnhance(view->enhance());
        iris::ColorSettings color;
        color.managed = view->colorManaged();
        color.intent = view->renderingIntent() == IrisSlideView::RelativeColorimetric
            ? iris::RenderingIntent::RelativeColorimetric
            : iris::RenderingIntent::Perceptual;
        const QByteArray profile = view->displayProfile();
        color.displayProfile.assign(profile.begin(), profile.end());
        m_engine->setColorSettings(color);
        if (auto r = m_engine->bindOffscreen(uint32_t(m_size.width()), uint32_t(m_size.height())); !r) {
            *error = QString::fromStdString(r.message());
            return false;
        }
        if (auto r = m_engine->open(QFile::encodeName(view->slidePath()).toStdString()); !r) {
            *error = QString::fromStdString(r.message());
            return false;
        }
        return true;
    }

    // The frame of the view's current pose and size with its current layers; null and *error on
    // failure.
    QImage render(const IrisSlideView *view, QString *error)
    {
        if (!m_engine) {
            *error = QStringLiteral("the twin was not started");
            return {};
        }
        if (view->targetSize() != m_size) { // the window's layout changed since
            m_size = view->targetSize();
            m_engine->resize(uint32_t(m_size.width()), uint32_t(m_size.height()));
        }
        m_engine->clearLayers();
        for (quint64 id : view->layerIds()) {
            if (auto added = m_engine->addLayer(view->layerMap(id), view->layerStyle(id)); !added) {
                *error = QString::fromStdString(added.error().message());
                return {};
            }
        }
        iris::View v{view->centre().x(), view->centre().y(), view->downsample(), view->rotation()};
        v.flipH = view->isFlippedHorizontally();
        v.flipV = view->isFlippedVertically();
        m_engine->setView(v);
        if (auto r = m_engine->waitForFrame(std::chrono::seconds(30)); !r) {
            *error = QStringLiteral("waitForFrame: ") + QString::fromStdString(r.message());
            return {};
        }
        auto frame = m_engine->readFrame();
        if (!frame) {
            *error = QString::fromStdString(frame.error().message());
            return {};
        }
        if (m_engine->validationMessageCount() != 0) {
            *error = QStringLiteral("the headless engine reported %1 validation messages")
                         .arg(m_engine->validationMessageCount());
            return {};
        }
        const iris::Image &image = frame->image;
        if (QSize(int(image.width), int(image.height)) != m_size) {
            *error
                = QStringLiteral("the headless frame is %1x%2, not the view's size").arg(image.width).arg(image.height);
            return {};
        }
        QImage out(int(image.width), int(image.height), QImage::Format_RGBA8888);
        for (int y = 0; y < out.height(); ++y)
            std::memcpy(out.scanLine(y), image.rgba.data() + size_t(y) * image.width * 4, size_t(image.width) * 4);
        return out;
    }

private:
    std::unique_ptr<iris::Engine> m_engine;
    QSize m_size;
};

// Hides the view's overlays (scale bar, magnification, overview, legend): the twin draws none.
inline void hideOverlays(IrisSlideView *view)
{
    for (auto o :
        {IrisSlideView::ScaleBar, IrisSlideView::MagnificationLabel, IrisSlideView::Overview, IrisSlideView::Legend})
        view->setOverlayVisible(o, false);
}

// Whether the presented frame is `expected` exactly (RGB); *seen gets the difference.
inline bool presentedEquals(
    IrisSlideView *view, const QImage &expected, iriswidgettest::ImageDifference *seen, QImage *presented)
{
    *presented = iriswidgettest::grabPresented(view);
    *seen = iriswidgettest::compareImages(*presented, expected, 0);
    return presented->size() == expected.size() && seen->maxAbs == 0;
}

} // namespace layerpixels
