#include "comparepane.h"

#include <QtCore/QDir>
#include <QtCore/QFileInfo>
#include <QtCore/QTimer>
#include <QtGui/QWindow>
#include <QtWidgets/QHBoxLayout>
#include <QtWidgets/QLabel>
#include <QtWidgets/QToolButton>
#include <QtWidgets/QVBoxLayout>

#include <iris/IrisSlideView.h>

ComparePane::ComparePane(QWidget *parent)
    : QWidget(parent)
    , m_view(new IrisSlideView)
    , m_header(new QWidget)
    , m_title(new QLabel)
    , m_magnification(new QLabel)
    , m_link(new QToolButton)
    , m_open(new QToolButton)
    , m_close(new QToolButton)
{
    m_view->setObjectName(QStringLiteral("compareView"));
    m_link->setObjectName(QStringLiteral("linkButton"));
    m_close->setObjectName(QStringLiteral("closeButton"));
    m_header->setAutoFillBackground(true);
    m_title->setTextFormat(Qt::PlainText);
    m_title->setMinimumWidth(40);
    m_title->setSizePolicy(QSizePolicy::Ignored, QSizePolicy::Preferred);

    m_link->setCheckable(true);
    m_link->setChecked(true);
    m_link->setText(tr("Linked"));
    m_link->setToolTip(tr("Linked: moves, zooms and turns with the other views.\n"
                          "Unlink to align this slide by hand; linking it again keeps the alignment."));
    m_link->setToolButtonStyle(Qt::ToolButtonTextOnly);
    m_open->setText(tr("Open…"));
    m_open->setToolTip(tr("Show another slide in this view"));
    m_close->setText(QStringLiteral("✕"));
    m_close->setToolTip(tr("Remove this view from the comparison"));
    m_close->setAutoRaise(true);

    auto *bar = new QHBoxLayout(m_header);
    bar->setContentsMargins(6, 2, 2, 2);
    bar->addWidget(m_title, 1);
    bar->addWidget(m_magnification);
    bar->addWidget(m_link);
    bar->addWidget(m_open);
    bar->addWidget(m_close);

    auto *layout = new QVBoxLayout(this);
    layout->setContentsMargins(1, 1, 1, 1);
    layout->setSpacing(0);
    layout->addWidget(m_header);
    layout->addWidget(m_view, 1);

    connect(m_link, &QToolButton::toggled, this, [this](bool on) {
        m_link->setText(on ? tr("Linked") : tr("Unlinked"));
        Q_EMIT linkToggled(on);
    });
    connect(m_open, &QToolButton::clicked, this, &ComparePane::openRequested);
    connect(m_close, &QToolButton::clicked, this, &ComparePane::closeRequested);
    connect(m_view, &IrisSlideView::viewChanged, this, &ComparePane::updateHeader);
    connect(m_view, &IrisSlideView::slideOpened, this, &ComparePane::updateHeader);
    connect(m_view, &IrisSlideView::slideClosed, this, &ComparePane::updateHeader);
    connect(m_view, &IrisSlideView::cursorMoved, this, [this] {
        if (!m_current)
            Q_EMIT activated();
    });
    m_header->installEventFilter(this);
    updateHeader();
}

void ComparePane::openWhenShown(const QString &path)
{
    m_pending = path;
    m_title->setText(tr("Opening %1…").arg(QFileInfo(path).fileName()));
    QWindow *surface = m_view->surfaceWindow();
    if (!surface || surface->isExposed()) {
        openNow();
        return;
    }
    surface->removeEventFilter(this); // a second request replaces the first
    surface->installEventFilter(this);
}

void ComparePane::openNow()
{
    const QString path = m_pending;
    m_pending.clear();
    if (path.isEmpty())
        return;
    QString error;
    const auto connection = connect(m_view, &IrisSlideView::slideError, this,
                                    [&error](const QString &message) { error = message; });
    const bool ok = m_view->openSlide(path);
    disconnect(connection);
    updateHeader();
    if (ok)
        Q_EMIT opened(path);
    else
        Q_EMIT failed(path, error);
}

bool ComparePane::eventFilter(QObject *watched, QEvent *event)
{
    if (watched == m_view->surfaceWindow() && event->type() == QEvent::Expose && !m_pending.isEmpty()) {
        // After the view has seen the expose too (it binds its surface then).
        m_view->surfaceWindow()->removeEventFilter(this);
        QTimer::singleShot(0, this, &ComparePane::openNow);
    } else if (watched == m_header && event->type() == QEvent::MouseButtonPress) {
        Q_EMIT activated();
    }
    return QWidget::eventFilter(watched, event);
}

void ComparePane::setLinked(bool linked)
{
    m_link->setChecked(linked);
}

void ComparePane::setCurrent(bool current)
{
    m_current = current;
    QPalette palette = this->palette();
    if (current) {
        palette.setColor(QPalette::Window, palette.color(QPalette::Highlight));
        palette.setColor(QPalette::WindowText, palette.color(QPalette::HighlightedText));
    }
    m_header->setPalette(palette);
    QFont font = m_title->font();
    font.setBold(current);
    m_title->setFont(font);
}

void ComparePane::updateHeader()
{
    if (!m_pending.isEmpty())
        return;
    if (!m_view->hasSlide()) {
        m_title->setText(tr("No slide"));
        m_title->setToolTip({});
        m_magnification->clear();
        return;
    }
    const QString path = m_view->slidePath();
    m_title->setText(QFileInfo(path).fileName());
    m_title->setToolTip(QDir::toNativeSeparators(path));
    const double magnification = m_view->magnification();
    m_magnification->setText(magnification > 0 ? tr("%1×").arg(magnification, 0, 'f', 1) : QString());
}
