#include "slidepropertiesdock.h"

#include <QtCore/QLocale>
#include <QtCore/QSortFilterProxyModel>
#include <QtGui/QStandardItemModel>
#include <QtWidgets/QFormLayout>
#include <QtWidgets/QHeaderView>
#include <QtWidgets/QLabel>
#include <QtWidgets/QLineEdit>
#include <QtWidgets/QTableView>
#include <QtWidgets/QTreeWidget>
#include <QtWidgets/QVBoxLayout>

namespace {

QString dash()
{
    return QStringLiteral("—");
}

QString pixels(qint64 width, qint64 height)
{
    const QLocale locale;
    return QStringLiteral("%1 × %2").arg(locale.toString(width), locale.toString(height));
}

} // namespace

SlidePropertiesDock::SlidePropertiesDock(QWidget *parent)
    : QDockWidget(tr("Slide Properties"), parent)
    , m_vendor(new QLabel)
    , m_dimensions(new QLabel)
    , m_resolution(new QLabel)
    , m_objective(new QLabel)
    , m_color(new QLabel)
    , m_levels(new QTreeWidget)
    , m_filter(new QLineEdit)
    , m_model(new QStandardItemModel(this))
    , m_proxy(new QSortFilterProxyModel(this))
    , m_table(new QTableView)
{
    setObjectName(QStringLiteral("slidePropertiesDock"));
    auto *body = new QWidget;
    auto *layout = new QVBoxLayout(body);

    auto *summary = new QFormLayout;
    for (QLabel *label : {m_vendor, m_dimensions, m_resolution, m_objective, m_color})
        label->setTextInteractionFlags(Qt::TextSelectableByMouse);
    m_color->setObjectName(QStringLiteral("colorProfileLabel"));
    m_color->setWordWrap(true);
    summary->addRow(tr("Vendor:"), m_vendor);
    summary->addRow(tr("Dimensions:"), m_dimensions);
    summary->addRow(tr("Resolution:"), m_resolution);
    summary->addRow(tr("Objective:"), m_objective);
    summary->addRow(tr("Colour:"), m_color);
    layout->addLayout(summary);

    m_levels->setHeaderLabels({tr("Level"), tr("Size (px)"), tr("Downsample")});
    m_levels->setRootIsDecorated(false);
    m_levels->setMaximumHeight(140);
    layout->addWidget(m_levels);

    m_filter->setPlaceholderText(tr("Filter properties"));
    m_filter->setClearButtonEnabled(true);
    layout->addWidget(m_filter);

    m_model->setHorizontalHeaderLabels({tr("Property"), tr("Value")});
    m_proxy->setSourceModel(m_model);
    m_proxy->setFilterCaseSensitivity(Qt::CaseInsensitive);
    m_proxy->setFilterKeyColumn(-1); // names and values
    m_table->setModel(m_proxy);
    m_table->setSortingEnabled(true);
    m_table->sortByColumn(0, Qt::AscendingOrder);
    m_table->verticalHeader()->hide();
    m_table->verticalHeader()->setDefaultSectionSize(m_table->fontMetrics().height() + 6);
    m_table->horizontalHeader()->setStretchLastSection(true);
    m_table->setSelectionBehavior(QAbstractItemView::SelectRows);
    m_table->setEditTriggers(QAbstractItemView::NoEditTriggers);
    m_table->setWordWrap(false);
    layout->addWidget(m_table, 1);
    connect(m_filter, &QLineEdit::textChanged, m_proxy, &QSortFilterProxyModel::setFilterFixedString);

    setWidget(body);
    clear();
}

void SlidePropertiesDock::showSlide(const IrisSlideInfo &info)
{
    m_vendor->setText(info.vendor.isEmpty() ? dash() : info.vendor);
    m_dimensions->setText(pixels(info.width, info.height));
    if (info.mppX > 0 || info.mppY > 0) {
        m_resolution->setText(tr("%1 × %2 µm per pixel")
                                  .arg(info.mppX, 0, 'f', 4)
                                  .arg(info.mppY, 0, 'f', 4));
    } else {
        m_resolution->setText(tr("not stated"));
    }
    const double objective = info.effectiveObjectivePower();
    if (info.objectivePower > 0)
        m_objective->setText(tr("%1×").arg(info.objectivePower));
    else if (objective > 0)
        m_objective->setText(tr("not stated (≈ %1× from the resolution)").arg(objective, 0, 'f', 1));
    else
        m_objective->setText(tr("not stated"));

    m_levels->clear();
    for (int i = 0; i < info.levels.size(); ++i) {
        const IrisSlideLevel &level = info.levels[i];
        const QString name = level.synthetic ? tr("%1 (computed)").arg(i) : QString::number(i);
        auto *item = new QTreeWidgetItem(m_levels, {name, pixels(level.width, level.height),
                                                    QString::number(level.downsample, 'g', 6)});
        item->setTextAlignment(2, Qt::AlignRight);
        if (level.synthetic) {
            const QString why = tr("Not stored in the file: the viewer computes this level from the "
                                   "coarsest stored one, so that a thumbnail of the whole slide stays loaded.");
            for (int column = 0; column < 3; ++column)
                item->setToolTip(column, why);
        }
    }
    m_levels->resizeColumnToContents(0);
    m_levels->resizeColumnToContents(1);

    m_model->removeRows(0, m_model->rowCount());
    for (auto it = info.properties.cbegin(); it != info.properties.cend(); ++it) {
        auto *name = new QStandardItem(it.key());
        auto *value = new QStandardItem(it.value());
        value->setToolTip(it.value());
        m_model->appendRow({name, value});
    }
    m_table->resizeColumnToContents(0);
}

void SlidePropertiesDock::showColor(
    const QString &slideProfile, const QString &displayProfile, bool managed, bool applied, const QString &error)
{
    QString text;
    if (slideProfile.isEmpty())
        text = tr("no embedded profile: shown as stored");
    else if (applied)
        text = tr("%1 → display: %2").arg(slideProfile, displayProfile);
    else if (!managed)
        text = tr("%1, not applied (colour management is off)").arg(slideProfile);
    else
        text = tr("%1, not applied: %2").arg(slideProfile, error);
    m_color->setText(text);
    m_color->setToolTip(text);
}

void SlidePropertiesDock::clear()
{
    for (QLabel *label : {m_vendor, m_dimensions, m_resolution, m_objective, m_color})
        label->setText(dash());
    m_levels->clear();
    m_model->removeRows(0, m_model->rowCount());
}

int SlidePropertiesDock::visiblePropertyCount() const
{
    return m_proxy->rowCount();
}

void SlidePropertiesDock::setFilterText(const QString &text)
{
    m_filter->setText(text);
}
