#include "associatedimagesdock.h"

#include <QtGui/QPainter>
#include <QtWidgets/QLabel>
#include <QtWidgets/QStackedWidget>
#include <QtWidgets/QTabWidget>

namespace {

// Paints an image scaled to fit, keeping its aspect ratio.
class ImagePreview : public QWidget {
public:
    explicit ImagePreview(const QImage &image)
        : m_image(image)
    {
        setMinimumSize(64, 64);
        setToolTip(QStringLiteral("%1 × %2 px").arg(image.width()).arg(image.height()));
    }
    QSize sizeHint() const override { return m_image.size().scaled(240, 240, Qt::KeepAspectRatio); }

protected:
    void paintEvent(QPaintEvent *) override
    {
        QPainter p(this);
        p.setRenderHint(QPainter::SmoothPixmapTransform);
        const QSize fitted = m_image.size().scaled(size(), Qt::KeepAspectRatio);
        const QRect target(QPoint((width() - fitted.width()) / 2, (height() - fitted.height()) / 2), fitted);
        p.drawImage(target, m_image);
    }

private:
    QImage m_image;
};

} // namespace

AssociatedImagesDock::AssociatedImagesDock(QWidget *parent)
    : QDockWidget(tr("Associated Images"), parent)
    , m_tabs(new QTabWidget)
    , m_none(new QLabel(tr("This slide has no associated images.")))
{
    setObjectName(QStringLiteral("associatedImagesDock"));
    m_none->setAlignment(Qt::AlignCenter);
    m_none->setWordWrap(true);
    auto *stack = new QStackedWidget;
    stack->addWidget(m_none);
    stack->addWidget(m_tabs);
    setWidget(stack);
}

void AssociatedImagesDock::addImage(const QString &name, const QImage &image)
{
    if (image.isNull())
        return;
    m_tabs->addTab(new ImagePreview(image), name);
    static_cast<QStackedWidget *>(widget())->setCurrentWidget(m_tabs);
}

void AssociatedImagesDock::clear()
{
    while (m_tabs->count() > 0) {
        QWidget *page = m_tabs->widget(0);
        m_tabs->removeTab(0);
        delete page;
    }
    static_cast<QStackedWidget *>(widget())->setCurrentWidget(m_none);
}

int AssociatedImagesDock::imageCount() const
{
    return m_tabs->count();
}
