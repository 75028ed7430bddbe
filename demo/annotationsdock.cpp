#include "annotationsdock.h"

#include <QtCore/QLocale>
#include <QtWidgets/QCheckBox>
#include <QtWidgets/QColorDialog>
#include <QtWidgets/QHeaderView>
#include <QtWidgets/QLabel>
#include <QtWidgets/QSplitter>
#include <QtWidgets/QTableView>
#include <QtWidgets/QVBoxLayout>

#include <iris/IrisSlideView.h>

namespace {

void setUpTable(QTableView *table)
{
    table->verticalHeader()->hide();
    // Fixed row heights: the view never measures rows (the object list may hold 10^6).
    table->verticalHeader()->setSectionResizeMode(QHeaderView::Fixed);
    table->verticalHeader()->setDefaultSectionSize(table->fontMetrics().height() + 6);
    table->setSelectionBehavior(QAbstractItemView::SelectRows);
    table->setSelectionMode(QAbstractItemView::SingleSelection);
    table->setEditTriggers(QAbstractItemView::NoEditTriggers);
    table->setWordWrap(false);
    table->setShowGrid(false);
}

} // namespace

AnnotationsDock::AnnotationsDock(IrisSlideView *view, QWidget *parent)
    : QDockWidget(tr("Annotations"), parent)
    , m_view(view)
    , m_headline(new QLabel)
    , m_showAll(new QCheckBox(tr("Show annotations")))
    , m_classes(new AnnotationClassModel(this))
    , m_objects(new AnnotationObjectModel(this))
    , m_classTable(new QTableView)
    , m_objectTable(new QTableView)
{
    setObjectName(QStringLiteral("annotationsDock"));
    m_showAll->setObjectName(QStringLiteral("showAnnotationsCheck"));
    m_classTable->setObjectName(QStringLiteral("annotationClassTable"));
    m_objectTable->setObjectName(QStringLiteral("annotationObjectTable"));
    m_pool.setMaxThreadCount(1);
    m_refresh.setSingleShot(true);
    m_refresh.setInterval(kRefreshMs);
    connect(&m_refresh, &QTimer::timeout, this, &AnnotationsDock::startSummary);

    auto *body = new QWidget;
    auto *layout = new QVBoxLayout(body);
    m_headline->setWordWrap(true);
    layout->addWidget(m_headline);
    m_showAll->setChecked(m_view->annotationsVisible());
    layout->addWidget(m_showAll);
    connect(m_showAll, &QCheckBox::toggled, m_view, &IrisSlideView::setAnnotationsVisible);
    connect(m_view, &IrisSlideView::annotationsChanged, this, [this] {
        m_showAll->setChecked(m_view->annotationsVisible());
        followViewSelection();
    });

    setUpTable(m_classTable);
    m_classTable->setModel(m_classes);
    m_classTable->horizontalHeader()->setSectionResizeMode(AnnotationClassModel::ColourColumn, QHeaderView::Fixed);
    m_classTable->horizontalHeader()->resizeSection(AnnotationClassModel::ColourColumn, 28);
    m_classTable->horizontalHeader()->setSectionResizeMode(AnnotationClassModel::NameColumn, QHeaderView::Stretch);
    // A few classes: their figures sized to fit (the object list, which may be long, is not).
    for (int column : {AnnotationClassModel::CountColumn, AnnotationClassModel::AreaColumn})
        m_classTable->horizontalHeader()->setSectionResizeMode(column, QHeaderView::ResizeToContents);
    // Room for four classes before it scrolls.
    m_classTable->setMinimumHeight(m_classTable->horizontalHeader()->sizeHint().height()
        + 4 * m_classTable->verticalHeader()->defaultSectionSize() + 2 * m_classTable->frameWidth());
    // A click on the swatch chooses the class's colour; the check box is the item's own.
    connect(m_classTable, &QTableView::clicked, this, [this](const QModelIndex &index) {
        if (index.column() == AnnotationClassModel::ColourColumn)
            chooseClassColour(index.row());
    });

    setUpTable(m_objectTable);
    m_objectTable->setModel(m_objects);
    m_objectTable->horizontalHeader()->setSectionResizeMode(AnnotationObjectModel::NameColumn, QHeaderView::Stretch);
    connect(m_objectTable->selectionModel(), &QItemSelectionModel::currentRowChanged, this,
        [this](const QModelIndex &current) {
            const iris::StoredAnnotation *a = m_objects->objectAt(current.row());
            if (m_view && !m_following)
                m_view->setSelectedAnnotation(a ? a->object.id : 0);
        });
    connect(
        m_objectTable, &QTableView::doubleClicked, this, [this](const QModelIndex &index) { centreOn(index.row()); });

    auto *split = new QSplitter(Qt::Vertical);
    split->addWidget(m_classTable);
    split->addWidget(m_objectTable);
    split->setChildrenCollapsible(false);
    split->setStretchFactor(0, 1);
    split->setStretchFactor(1, 2);
    layout->addWidget(split, 1);
    setWidget(body);
    updateHeadline();
}

AnnotationsDock::~AnnotationsDock()
{
    m_subscription.reset(); // no more calls from writers' threads
    if (m_cancel)
        m_cancel->store(true, std::memory_order_relaxed); // a request to stop early, no data with it
    m_pool.waitForDone();
}

void AnnotationsDock::setStore(std::shared_ptr<iris::AnnotationStore> store, double mppX, double mppY)
{
    m_subscription.reset();
    if (m_cancel)
        m_cancel->store(true, std::memory_order_relaxed);
    ++m_serial; // a summary of the old store that still arrives is dropped
    m_running = false;
    m_again = false;
    m_lastIds.reset();
    m_refresh.stop();
    m_store = std::move(store);
    m_mppX = mppX;
    m_mppY = mppY;
    m_shownGeneration = 0;
    m_classes->setStore(m_store, mppX, mppY);
    m_objects->setMpp(mppX, mppY);
    m_objects->clear();
    if (m_view)
        m_view->setSelectedAnnotation(0);
    if (m_store) {
        m_subscription = m_store->onChange([this] {
            // Any thread, with the store's writers' lock held: post once per burst.
            // acq_rel: pairs with the GUI thread's release store in storeChanged().
            if (!m_posted.exchange(true, std::memory_order_acq_rel))
                QMetaObject::invokeMethod(this, &AnnotationsDock::storeChanged, Qt::QueuedConnection);
        });
        startSummary(); // what it holds already
    }
    updateHeadline();
}

void AnnotationsDock::storeChanged()
{
    // Cleared before the timer reads the snapshot: a later publication posts again.
    m_posted.store(false, std::memory_order_release);
    if (!m_refresh.isActive())
        m_refresh.start();
}

void AnnotationsDock::startSummary()
{
    if (!m_store)
        return;
    if (m_running) {
        m_again = true;
        return;
    }
    m_running = true;
    m_cancel = std::make_shared<std::atomic<bool>>(false);
    const quint64 serial = ++m_serial;
    auto snapshot = m_store->snapshot();
    // The ids shown: the object list keeps its rows if no object changed.
    m_pool.start([this, serial, snapshot = std::move(snapshot), previous = m_lastIds, cancel = m_cancel] {
        AnnotationSummary summary = summarise(snapshot, previous, cancel.get());
        QMetaObject::invokeMethod(
            this, [this, serial, summary = std::move(summary)]() mutable { applySummary(serial, std::move(summary)); },
            Qt::QueuedConnection);
    });
}

void AnnotationsDock::applySummary(quint64 serial, AnnotationSummary summary)
{
    if (serial != m_serial)
        return; // of a store no longer shown (its worker was asked to stop)
    m_running = false;
    m_shownGeneration = summary.snapshot->generation();
    m_lastIds = summary.ids;
    m_classes->setSummary(summary);
    m_objects->setSummary(summary);
    followViewSelection(); // a reset of the list forgets its current row
    updateHeadline();
    Q_EMIT refreshed();
    if (m_again) {
        m_again = false;
        startSummary();
    }
}

void AnnotationsDock::followViewSelection()
{
    if (!m_view)
        return;
    const quint64 id = m_view->selectedAnnotation();
    const iris::StoredAnnotation *current = m_objects->objectAt(m_objectTable->currentIndex().row());
    if ((current ? current->object.id : 0) == id)
        return;
    m_following = true;
    const int row = m_objects->rowOfId(id); // a linear search: 10^6 ids take about a millisecond
    if (row < 0) {
        m_objectTable->selectionModel()->clear();
    } else {
        const QModelIndex index = m_objects->index(row, AnnotationObjectModel::NameColumn);
        m_objectTable->selectionModel()->setCurrentIndex(
            index, QItemSelectionModel::ClearAndSelect | QItemSelectionModel::Rows);
        m_objectTable->scrollTo(index);
    }
    m_following = false;
}

void AnnotationsDock::updateHeadline()
{
    if (!m_store) {
        m_headline->setText(tr("No slide open."));
        return;
    }
    const qsizetype objects = m_objects->objectCount();
    if (objects == 0) {
        m_headline->setText(tr("No annotations. File › Import Annotations… reads QuPath GeoJSON or ASAP XML."));
        return;
    }
    m_headline->setText(
        tr("%1 objects in %2 classes").arg(QLocale().toString(qlonglong(objects))).arg(m_classes->rowCount()));
}

void AnnotationsDock::chooseClassColour(int row)
{
    const QModelIndex index = m_classes->index(row, AnnotationClassModel::ColourColumn);
    if (!index.isValid())
        return;
    const QString name
        = m_classes->data(index.siblingAtColumn(AnnotationClassModel::NameColumn), Qt::DisplayRole).toString();
    const QColor chosen = QColorDialog::getColor(
        index.data(Qt::EditRole).value<QColor>(), this, tr("Colour of %1").arg(name), QColorDialog::ShowAlphaChannel);
    if (chosen.isValid())
        m_classes->setData(index, chosen, Qt::EditRole);
}

void AnnotationsDock::centreOn(int row)
{
    const iris::StoredAnnotation *a = m_objects->objectAt(row);
    if (!a || a->bounds.empty() || !m_view)
        return;
    m_view->setSelectedAnnotation(a->object.id);
    m_view->setCentre(QPointF((a->bounds.minX + a->bounds.maxX) / 2, (a->bounds.minY + a->bounds.maxY) / 2));
}
