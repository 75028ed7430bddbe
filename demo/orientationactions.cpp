#include "orientationactions.h"

#include <QtGui/QAction>
#include <QtWidgets/QMenu>

#include <iris/IrisSlideView.h>

OrientationActions::OrientationActions(QObject *parent)
    : QObject(parent)
    , m_clockwise(new QAction(tr("Rotate 90° &Clockwise"), this))
    , m_anticlockwise(new QAction(tr("Rotate 90° &Anticlockwise"), this))
    , m_flipH(new QAction(tr("Flip &Horizontally"), this))
    , m_flipV(new QAction(tr("Flip &Vertically"), this))
    , m_reset(new QAction(tr("Reset &Rotation and Flips"), this))
{
    m_clockwise->setObjectName(QStringLiteral("rotateClockwiseAction"));
    m_anticlockwise->setObjectName(QStringLiteral("rotateAnticlockwiseAction"));
    m_flipH->setObjectName(QStringLiteral("flipHorizontallyAction"));
    m_flipV->setObjectName(QStringLiteral("flipVerticallyAction"));
    m_reset->setObjectName(QStringLiteral("resetOrientationAction"));
    m_clockwise->setShortcut(Qt::CTRL | Qt::Key_R);
    m_anticlockwise->setShortcut(Qt::CTRL | Qt::SHIFT | Qt::Key_R);
    m_flipH->setCheckable(true);
    m_flipV->setCheckable(true);
    m_clockwise->setStatusTip(tr("Turn the slide a quarter turn clockwise about the view's centre (R in the view)"));
    m_anticlockwise->setStatusTip(tr("Turn the slide a quarter turn anticlockwise (Shift+R in the view)"));
    m_flipH->setStatusTip(tr("Mirror the slide left to right"));
    m_flipV->setStatusTip(tr("Mirror the slide top to bottom"));
    m_reset->setStatusTip(tr("Show the slide as scanned: no turn, no flips"));

    connect(m_clockwise, &QAction::triggered, this, [this] {
        if (m_view)
            m_view->rotateBy(90);
    });
    connect(m_anticlockwise, &QAction::triggered, this, [this] {
        if (m_view)
            m_view->rotateBy(-90);
    });
    connect(m_flipH, &QAction::triggered, this, [this] { flipOnScreen(Qt::Horizontal); });
    connect(m_flipV, &QAction::triggered, this, [this] { flipOnScreen(Qt::Vertical); });
    connect(m_reset, &QAction::triggered, this, [this] {
        if (m_view)
            m_view->resetOrientation();
    });
    sync();
}

void OrientationActions::setView(IrisSlideView *view)
{
    if (view == m_view)
        return;
    for (const QMetaObject::Connection &c : std::as_const(m_connections))
        disconnect(c);
    m_connections.clear();
    m_view = view;
    if (view) {
        m_connections << connect(view, &IrisSlideView::viewChanged, this, &OrientationActions::sync)
                      << connect(view, &IrisSlideView::slideOpened, this, &OrientationActions::sync)
                      << connect(view, &IrisSlideView::slideClosed, this, &OrientationActions::sync)
                      << connect(view, &QObject::destroyed, this, [this] {
                             m_view.clear(); // it is being destroyed: ask it nothing
                             sync();
                         });
    }
    sync();
}

void OrientationActions::addTo(QMenu *menu) const
{
    menu->addAction(m_clockwise);
    menu->addAction(m_anticlockwise);
    menu->addAction(m_flipH);
    menu->addAction(m_flipV);
    menu->addAction(m_reset);
}

void OrientationActions::flipOnScreen(Qt::Orientation orientation)
{
    if (m_view) {
        // Mirroring the screen after a turn by r is mirroring the slide before a turn by −r
        // (as the view's F key does): the flag toggles and the turn reverses.
        const bool h = m_view->isFlippedHorizontally() != (orientation == Qt::Horizontal);
        const bool v = m_view->isFlippedVertically() != (orientation == Qt::Vertical);
        const double rotation = -m_view->rotation();
        m_view->setFlipped(h, v);
        m_view->setRotation(rotation);
    }
    sync(); // the checks as the view is (no slide: unchecked)
}

void OrientationActions::sync()
{
    const bool has = m_view && m_view->hasSlide();
    for (QAction *action : {m_clockwise, m_anticlockwise, m_flipH, m_flipV, m_reset})
        action->setEnabled(has);
    m_flipH->setChecked(has && m_view->isFlippedHorizontally());
    m_flipV->setChecked(has && m_view->isFlippedVertically());
}
