#include "viewstatus.h"

#include <QtWidgets/QLabel>
#include <QtWidgets/QStatusBar>

#include <iris/IrisSlideView.h>

ViewStatus::ViewStatus(IrisSlideView *view, QStatusBar *bar)
    : QObject(bar)
    , m_view(view)
    , m_magnification(new QLabel)
    , m_position(new QLabel)
    , m_fps(new QLabel)
{
    m_magnification->setObjectName(QStringLiteral("magnificationLabel"));
    m_position->setObjectName(QStringLiteral("positionLabel"));
    m_fps->setObjectName(QStringLiteral("fpsLabel"));
    m_magnification->setMinimumWidth(m_magnification->fontMetrics().horizontalAdvance(QStringLiteral("000.0×  ")));
    m_position->setMinimumWidth(m_position->fontMetrics().horizontalAdvance(QStringLiteral("x 00000.0 µm, y 00000.0 µm  ")));
    m_fps->setMinimumWidth(m_fps->fontMetrics().horizontalAdvance(QStringLiteral("000 fps  ")));
    bar->addPermanentWidget(m_position);
    bar->addPermanentWidget(m_magnification);
    bar->addPermanentWidget(m_fps);

    m_idle.setSingleShot(true);
    m_idle.setInterval(1000);
    connect(&m_idle, &QTimer::timeout, this, [this] { m_fps->setText(tr("idle")); });

    connect(view, &IrisSlideView::viewChanged, this, &ViewStatus::updateMagnification);
    connect(view, &IrisSlideView::cursorMoved, this, &ViewStatus::updatePosition);
    connect(view, &IrisSlideView::framePresented, this, &ViewStatus::updateFps);
    connect(view, &IrisSlideView::slideClosed, this, &ViewStatus::reset);
    reset();
}

QString ViewStatus::magnificationText() const
{
    return m_magnification->text();
}

QString ViewStatus::positionText() const
{
    return m_position->text();
}

QString ViewStatus::fpsText() const
{
    return m_fps->text();
}

void ViewStatus::reset()
{
    m_magnification->setText(QStringLiteral("—"));
    m_position->clear();
    m_fps->setText(tr("idle"));
}

void ViewStatus::updateMagnification()
{
    const double magnification = m_view->magnification();
    if (magnification > 0)
        m_magnification->setText(tr("%1×").arg(magnification, 0, 'f', magnification < 10 ? 2 : 1));
    else if (m_view->hasSlide())
        m_magnification->setText(tr("1 px : %1 px").arg(m_view->downsample(), 0, 'g', 3));
    else
        m_magnification->setText(QStringLiteral("—"));
}

void ViewStatus::updatePosition(const QPointF &slidePos)
{
    const IrisSlideInfo info = m_view->slideInfo();
    if (!info.isValid())
        return;
    if (info.mppX > 0 && info.mppY > 0) {
        m_position->setText(tr("x %1 µm, y %2 µm")
                                .arg(slidePos.x() * info.mppX, 0, 'f', 1)
                                .arg(slidePos.y() * info.mppY, 0, 'f', 1));
    } else {
        m_position->setText(tr("x %1 px, y %2 px").arg(slidePos.x(), 0, 'f', 0).arg(slidePos.y(), 0, 'f', 0));
    }
}

void ViewStatus::updateFps(const IrisFrameMetrics &metrics)
{
    if (metrics.fps > 0)
        m_fps->setText(tr("%1 fps").arg(metrics.fps, 0, 'f', 0));
    m_idle.start();
}
