#include "annotationmodels.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <QtCore/QLocale>
#include <QtGui/QColor>

namespace {

QColor toQColor(iris::Rgba8 c)
{
    return QColor(c.r, c.g, c.b, c.a);
}

iris::Rgba8 toRgba8(const QColor &c)
{
    return {uint8_t(c.red()), uint8_t(c.green()), uint8_t(c.blue()), uint8_t(c.alpha())};
}

QString objectTitle(const iris::AnnotationObject &o)
{
    if (!o.name.empty())
        return QString::fromStdString(o.name);
    QString kind = QString::fromLatin1(iris::annotationKindName(o.kind));
    if (!kind.isEmpty())
        kind[0] = kind[0].toUpper();
    return o.type == iris::AnnotationType::Detection ? AnnotationObjectModel::tr("%1 (detection)").arg(kind) : kind;
}

} // namespace

// ---- Areas ------------------------------------------------------------------------------------

double AnnotationMeasure::ringArea(const std::vector<iris::Point2> &ring)
{
    if (ring.size() < 3)
        return 0;
    // Shoelace about the first vertex: the same sum, with smaller products for rings far from
    // the origin (level-0 coordinates reach 10^5 and more).
    const iris::Point2 o = ring.front();
    double twice = 0;
    for (size_t i = 1; i + 1 < ring.size(); ++i) {
        const double ax = ring[i].x - o.x, ay = ring[i].y - o.y;
        const double bx = ring[i + 1].x - o.x, by = ring[i + 1].y - o.y;
        twice += ax * by - bx * ay;
    }
    return std::abs(twice) / 2;
}

double AnnotationMeasure::area(const iris::AnnotationObject &o)
{
    switch (o.kind) {
    case iris::AnnotationKind::Polygon: {
        double sum = 0;
        for (const iris::PolygonPart &part : o.polygons) {
            double a = ringArea(part.outer);
            for (const auto &hole : part.holes)
                a -= ringArea(hole);
            sum += std::max(a, 0.0);
        }
        return sum;
    }
    case iris::AnnotationKind::Rectangle:
        return o.box.width() * o.box.height();
    case iris::AnnotationKind::Ellipse:
        return std::numbers::pi * (o.box.width() / 2) * (o.box.height() / 2);
    case iris::AnnotationKind::Point:
    case iris::AnnotationKind::Polyline:
        break;
    }
    return 0;
}

QString AnnotationMeasure::formatArea(double pixels2, double mppX, double mppY)
{
    const QLocale locale;
    if (!(mppX > 0 && mppY > 0))
        return QStringLiteral("%1 px²").arg(locale.toString(pixels2, 'f', 0));
    const double um2 = pixels2 * mppX * mppY;
    if (um2 >= 1e6)
        return QStringLiteral("%1 mm²").arg(locale.toString(um2 / 1e6, 'f', 3));
    return QStringLiteral("%1 µm²").arg(locale.toString(um2, 'f', 1));
}

// ---- The summary ------------------------------------------------------------------------------

AnnotationSummary summarise(std::shared_ptr<const iris::AnnotationSnapshot> snapshot,
    std::shared_ptr<const std::vector<quint64>> previous, const std::atomic<bool> *cancelled)
{
    AnnotationSummary out;
    out.snapshot = std::move(snapshot);
    auto ids = std::make_shared<std::vector<quint64>>();
    ids->reserve(out.snapshot->size());
    // One map lookup per object would dominate at 10^6 detections of a handful of classes:
    // remember the last class seen (detections of one class come in runs).
    const std::string *lastName = nullptr;
    AnnotationSummary::Totals *last = nullptr;
    size_t seen = 0;
    bool stop = false;
    out.snapshot->forEach([&](const iris::StoredAnnotation &a) {
        if (stop)
            return;
        // relaxed: a request to stop early, no data travels with it.
        if (cancelled && (++seen & 0xfff) == 0 && cancelled->load(std::memory_order_relaxed)) {
            stop = true;
            return;
        }
        ids->push_back(a.object.id);
        if (!lastName || *lastName != a.object.className) {
            last = &out.classes[a.object.className];
            lastName = &a.object.className;
        }
        ++last->count;
        last->area += AnnotationMeasure::area(a.object);
    });
    out.sameRows = previous && *previous == *ids;
    out.ids = out.sameRows ? std::move(previous) : std::shared_ptr<const std::vector<quint64>>(std::move(ids));
    return out;
}

// ---- Classes ----------------------------------------------------------------------------------

AnnotationClassModel::AnnotationClassModel(QObject *parent)
    : QAbstractTableModel(parent)
{ }

void AnnotationClassModel::setStore(std::shared_ptr<iris::AnnotationStore> store, double mppX, double mppY)
{
    m_store = std::move(store);
    m_mppX = mppX;
    m_mppY = mppY;
    clear();
}

void AnnotationClassModel::clear()
{
    beginResetModel();
    m_rows.clear();
    endResetModel();
}

void AnnotationClassModel::setSummary(const AnnotationSummary &summary)
{
    std::vector<Row> rows;
    for (const iris::AnnotationClass &cls : summary.snapshot->classes()) {
        const auto it = summary.classes.find(cls.name);
        rows.push_back({cls, it == summary.classes.end() ? AnnotationSummary::Totals{} : it->second});
    }
    // Objects of a class the table does not list (it lists every class named, but be sure).
    for (const auto &[name, totals] : summary.classes) {
        if (std::none_of(rows.begin(), rows.end(), [&](const Row &r) { return r.cls.name == name; }))
            rows.push_back({summary.snapshot->classInfo(name), totals});
    }
    // Unclassified last, as QuPath lists it.
    std::stable_partition(rows.begin(), rows.end(), [](const Row &r) { return !r.cls.name.empty(); });

    const bool sameNames = rows.size() == m_rows.size()
        && std::equal(rows.begin(), rows.end(), m_rows.begin(),
            [](const Row &a, const Row &b) { return a.cls.name == b.cls.name; });
    if (sameNames) {
        m_rows = std::move(rows);
        if (!m_rows.empty())
            Q_EMIT dataChanged(index(0, 0), index(rowCount() - 1, ColumnCount - 1));
    } else {
        beginResetModel();
        m_rows = std::move(rows);
        endResetModel();
    }
}

int AnnotationClassModel::rowCount(const QModelIndex &parent) const
{
    return parent.isValid() ? 0 : int(m_rows.size());
}

int AnnotationClassModel::columnCount(const QModelIndex &parent) const
{
    return parent.isValid() ? 0 : ColumnCount;
}

QString AnnotationClassModel::displayName(const std::string &className)
{
    return className.empty() ? tr("Unclassified") : QString::fromStdString(className);
}

int AnnotationClassModel::rowOf(const QString &className) const
{
    const std::string name = className.toStdString();
    for (size_t i = 0; i < m_rows.size(); ++i) {
        if (m_rows[i].cls.name == name)
            return int(i);
    }
    return -1;
}

QVariant AnnotationClassModel::data(const QModelIndex &index, int role) const
{
    if (!index.isValid() || index.row() >= rowCount())
        return {};
    const Row &row = m_rows[size_t(index.row())];
    if (role == ClassNameRole)
        return QString::fromStdString(row.cls.name);
    switch (index.column()) {
    case ColourColumn:
        if (role == Qt::DecorationRole || role == Qt::EditRole)
            return toQColor(row.cls.color);
        if (role == Qt::ToolTipRole)
            return tr("%1 — click to choose another colour").arg(toQColor(row.cls.color).name(QColor::HexArgb));
        break;
    case NameColumn:
        if (role == Qt::DisplayRole || role == Qt::EditRole)
            return displayName(row.cls.name);
        if (role == Qt::CheckStateRole)
            return row.cls.visible ? Qt::Checked : Qt::Unchecked;
        if (role == Qt::ToolTipRole)
            return row.cls.visible ? tr("Shown: uncheck to hide this class") : tr("Hidden: check to show this class");
        break;
    case CountColumn:
        if (role == Qt::DisplayRole)
            return QLocale().toString(qlonglong(row.totals.count));
        if (role == ValueRole)
            return qlonglong(row.totals.count);
        if (role == Qt::TextAlignmentRole)
            return int(Qt::AlignRight | Qt::AlignVCenter);
        break;
    case AreaColumn:
        if (role == Qt::DisplayRole)
            return AnnotationMeasure::formatArea(row.totals.area, m_mppX, m_mppY);
        if (role == ValueRole)
            return row.totals.area;
        if (role == Qt::TextAlignmentRole)
            return int(Qt::AlignRight | Qt::AlignVCenter);
        break;
    default:
        break;
    }
    return {};
}

QVariant AnnotationClassModel::headerData(int section, Qt::Orientation orientation, int role) const
{
    if (orientation != Qt::Horizontal || role != Qt::DisplayRole)
        return {};
    switch (section) {
    case ColourColumn:
        return QString();
    case NameColumn:
        return tr("Class");
    case CountColumn:
        return tr("Objects");
    case AreaColumn:
        return tr("Area");
    default:
        return {};
    }
}

Qt::ItemFlags AnnotationClassModel::flags(const QModelIndex &index) const
{
    Qt::ItemFlags f = QAbstractTableModel::flags(index);
    if (index.isValid() && index.column() == NameColumn && m_store)
        f |= Qt::ItemIsUserCheckable;
    return f;
}

bool AnnotationClassModel::setData(const QModelIndex &index, const QVariant &value, int role)
{
    if (!m_store || !index.isValid() || index.row() >= rowCount())
        return false;
    Row &row = m_rows[size_t(index.row())];
    if (index.column() == NameColumn && role == Qt::CheckStateRole) {
        const bool visible = value.toInt() == Qt::Checked; // a delegate sends the state as an int
        row.cls.visible = visible;
        m_store->setClassVisible(row.cls.name, visible);
        Q_EMIT dataChanged(index, index, {Qt::CheckStateRole, Qt::ToolTipRole});
        return true;
    }
    if (index.column() == ColourColumn && (role == Qt::DecorationRole || role == Qt::EditRole)) {
        const QColor colour = value.value<QColor>();
        if (!colour.isValid())
            return false;
        row.cls.color = toRgba8(colour);
        m_store->setClassColor(row.cls.name, row.cls.color);
        Q_EMIT dataChanged(index, index, {Qt::DecorationRole, Qt::EditRole, Qt::ToolTipRole});
        return true;
    }
    return false;
}

// ---- Objects ----------------------------------------------------------------------------------

AnnotationObjectModel::AnnotationObjectModel(QObject *parent)
    : QAbstractTableModel(parent)
{ }

void AnnotationObjectModel::setMpp(double mppX, double mppY)
{
    m_mppX = mppX;
    m_mppY = mppY;
}

void AnnotationObjectModel::clear()
{
    beginResetModel();
    m_snapshot.reset();
    m_ids.reset();
    m_fetched = 0;
    endResetModel();
}

void AnnotationObjectModel::setSummary(const AnnotationSummary &summary)
{
    if (summary.sameRows && m_ids == summary.ids) {
        m_snapshot = summary.snapshot;
        if (m_fetched > 0)
            Q_EMIT dataChanged(index(0, 0), index(m_fetched - 1, ColumnCount - 1));
        return;
    }
    beginResetModel();
    m_snapshot = summary.snapshot;
    m_ids = summary.ids;
    m_fetched = int(std::min<qsizetype>(kFetchBatch, objectCount()));
    endResetModel();
}

qsizetype AnnotationObjectModel::objectCount() const
{
    return m_ids ? qsizetype(m_ids->size()) : 0;
}

const iris::StoredAnnotation *AnnotationObjectModel::objectAt(int row) const
{
    if (!m_snapshot || row < 0 || row >= m_fetched)
        return nullptr;
    return m_snapshot->find((*m_ids)[size_t(row)]);
}

int AnnotationObjectModel::rowOfId(quint64 id)
{
    if (!m_ids || id == 0)
        return -1;
    const auto it = std::find(m_ids->begin(), m_ids->end(), id);
    if (it == m_ids->end())
        return -1;
    const int row = int(it - m_ids->begin());
    if (row >= m_fetched) {
        // Up to the end of the batch holding it, in one insertion.
        const int to = int(std::min<qsizetype>((row / kFetchBatch + 1) * qsizetype(kFetchBatch), objectCount()));
        beginInsertRows({}, m_fetched, to - 1);
        m_fetched = to;
        endInsertRows();
    }
    return row;
}

int AnnotationObjectModel::rowCount(const QModelIndex &parent) const
{
    return parent.isValid() ? 0 : m_fetched;
}

int AnnotationObjectModel::columnCount(const QModelIndex &parent) const
{
    return parent.isValid() ? 0 : ColumnCount;
}

bool AnnotationObjectModel::canFetchMore(const QModelIndex &parent) const
{
    return !parent.isValid() && m_fetched < objectCount();
}

void AnnotationObjectModel::fetchMore(const QModelIndex &parent)
{
    if (!canFetchMore(parent))
        return;
    // int rows: a QAbstractItemModel counts in int, and 2^31 objects would not fit in memory.
    const int more = int(std::min<qsizetype>(kFetchBatch, objectCount() - m_fetched));
    beginInsertRows({}, m_fetched, m_fetched + more - 1);
    m_fetched += more;
    endInsertRows();
}

QVariant AnnotationObjectModel::data(const QModelIndex &index, int role) const
{
    const iris::StoredAnnotation *a = index.isValid() ? objectAt(index.row()) : nullptr;
    if (!a)
        return {};
    const iris::AnnotationObject &o = a->object;
    if (role == IdRole)
        return quint64(o.id);
    if (role == AreaRole)
        return AnnotationMeasure::area(o);
    switch (index.column()) {
    case NameColumn:
        if (role == Qt::DisplayRole)
            return objectTitle(o);
        if (role == Qt::DecorationRole)
            return toQColor(m_snapshot->colorOf(o));
        if (role == Qt::ToolTipRole)
            return tr("%1, id %2%3")
                .arg(QString::fromLatin1(iris::annotationKindName(o.kind)))
                .arg(o.id)
                .arg(m_snapshot->drawn(o) ? QString() : tr(" (hidden)"));
        break;
    case ClassColumn:
        if (role == Qt::DisplayRole)
            return AnnotationClassModel::displayName(o.className);
        break;
    case AreaColumn:
        if (role == Qt::DisplayRole) {
            if (o.kind == iris::AnnotationKind::Point || o.kind == iris::AnnotationKind::Polyline)
                return QStringLiteral("—");
            return AnnotationMeasure::formatArea(AnnotationMeasure::area(o), m_mppX, m_mppY);
        }
        if (role == Qt::TextAlignmentRole)
            return int(Qt::AlignRight | Qt::AlignVCenter);
        break;
    default:
        break;
    }
    return {};
}

QVariant AnnotationObjectModel::headerData(int section, Qt::Orientation orientation, int role) const
{
    if (orientation != Qt::Horizontal || role != Qt::DisplayRole)
        return {};
    switch (section) {
    case NameColumn:
        return tr("Object");
    case ClassColumn:
        return tr("Class");
    case AreaColumn:
        return tr("Area");
    default:
        return {};
    }
}
