// Iris View demo — what the Annotations dock shows of a store, as item models:
//   * areas: of one object (shoelace with holes subtracted, rectangles, ellipses π·a·b) and
//     written in µm² or mm² from the slide's mpp (px² when it states none);
//   * summarise(): one pass over a snapshot, run on a worker thread (10^6 objects take a
//     while): the objects' ids in storage order and each class's count and total area;
//   * AnnotationClassModel: one row per class — colour swatch, name with a visibility check
//     box (setClassVisible), count, area; a colour set through setData goes to setClassColor;
//   * AnnotationObjectModel: one row per object over the snapshot and the id list, fetched a
//     batch at a time as the view scrolls (canFetchMore/fetchMore), never a widget per object.
#pragma once

#include <atomic>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <QtCore/QAbstractTableModel>

#include <iris/annotations.h>

namespace AnnotationMeasure {
// Level-0 pixels²: a polygon's parts (outer ring less its holes), a rectangle's box, an
// ellipse's π·a·b; 0 for points and polylines (they enclose nothing).
double area(const iris::AnnotationObject &o);
// The shoelace area of a closed ring stored open (non-negative).
double ringArea(const std::vector<iris::Point2> &ring);
// "1,234.5 µm²", "12.345 mm²" (from 1 mm² up) with the slide's µm per pixel; "1,234 px²"
// when either mpp is 0.
QString formatArea(double pixels2, double mppX, double mppY);
} // namespace AnnotationMeasure

// One pass over a snapshot (any thread).
struct AnnotationSummary
{
    struct Totals
    {
        qsizetype count = 0;
        double area = 0; // level-0 pixels²
    };
    std::shared_ptr<const iris::AnnotationSnapshot> snapshot;
    std::shared_ptr<const std::vector<quint64>> ids; // storage order
    std::map<std::string, Totals> classes; // by class name ("" = unclassified)
    bool sameRows = false; // ids equal to `previous`'s
};
// `previous` (may be null) lets the object list keep its rows, selection and scroll position
// when an edit changed no object (a class's colour or visibility). `cancelled` is polled.
AnnotationSummary summarise(std::shared_ptr<const iris::AnnotationSnapshot> snapshot,
    std::shared_ptr<const std::vector<quint64>> previous, const std::atomic<bool> *cancelled = nullptr);

class AnnotationClassModel : public QAbstractTableModel
{
    Q_OBJECT
public:
    enum Column { ColourColumn, NameColumn, CountColumn, AreaColumn, ColumnCount };
    // Column data for tests and sorting: the count (qsizetype) and area (pixels², double).
    static constexpr int ValueRole = Qt::UserRole + 1;
    // The class name as the store knows it ("" = unclassified).
    static constexpr int ClassNameRole = Qt::UserRole + 2;

    explicit AnnotationClassModel(QObject *parent = nullptr);

    // The store edited by setData (null: read-only), and the slide's µm per pixel for areas.
    void setStore(std::shared_ptr<iris::AnnotationStore> store, double mppX, double mppY);
    // Rows from the summary's snapshot (its class table) and totals.
    void setSummary(const AnnotationSummary &summary);
    void clear();

    int rowCount(const QModelIndex &parent = {}) const override;
    int columnCount(const QModelIndex &parent = {}) const override;
    QVariant data(const QModelIndex &index, int role) const override;
    QVariant headerData(int section, Qt::Orientation orientation, int role) const override;
    Qt::ItemFlags flags(const QModelIndex &index) const override;
    // NameColumn + Qt::CheckStateRole: setClassVisible; ColourColumn + Qt::DecorationRole or
    // Qt::EditRole with a QColor: setClassColor. Shown at once, confirmed by the next summary.
    bool setData(const QModelIndex &index, const QVariant &value, int role) override;

    int rowOf(const QString &className) const;
    static QString displayName(const std::string &className);

private:
    struct Row
    {
        iris::AnnotationClass cls;
        AnnotationSummary::Totals totals;
    };
    std::shared_ptr<iris::AnnotationStore> m_store;
    double m_mppX = 0, m_mppY = 0;
    std::vector<Row> m_rows;
};

class AnnotationObjectModel : public QAbstractTableModel
{
    Q_OBJECT
public:
    enum Column { NameColumn, ClassColumn, AreaColumn, ColumnCount };
    static constexpr int IdRole = Qt::UserRole + 1; // quint64
    static constexpr int AreaRole = Qt::UserRole + 2; // pixels², double
    static constexpr int kFetchBatch = 1000;

    explicit AnnotationObjectModel(QObject *parent = nullptr);

    void setMpp(double mppX, double mppY);
    // Rows from the summary's id list; a reset unless summary.sameRows (then the rows stay
    // and only their contents are refreshed).
    void setSummary(const AnnotationSummary &summary);
    void clear();

    // Every object of the snapshot (rowCount() counts those fetched so far).
    qsizetype objectCount() const;
    const iris::StoredAnnotation *objectAt(int row) const;
    // The row of the object with that id, fetching rows up to it; -1 when there is none.
    int rowOfId(quint64 id);

    int rowCount(const QModelIndex &parent = {}) const override;
    int columnCount(const QModelIndex &parent = {}) const override;
    QVariant data(const QModelIndex &index, int role) const override;
    QVariant headerData(int section, Qt::Orientation orientation, int role) const override;
    bool canFetchMore(const QModelIndex &parent) const override;
    void fetchMore(const QModelIndex &parent) override;

private:
    std::shared_ptr<const iris::AnnotationSnapshot> m_snapshot;
    std::shared_ptr<const std::vector<quint64>> m_ids;
    int m_fetched = 0;
    double m_mppX = 0, m_mppY = 0;
};
