// Iris View demo — the Slide Properties dock: a summary (vendor, size, levels, resolution,
// objective) above every property the file carries, in a table that a filter narrows.
#pragma once

#include <QtWidgets/QDockWidget>

#include <iris/IrisSlideInfo.h>

QT_BEGIN_NAMESPACE
class QFormLayout;
class QLabel;
class QLineEdit;
class QSortFilterProxyModel;
class QStandardItemModel;
class QTableView;
class QTreeWidget;
QT_END_NAMESPACE

class SlidePropertiesDock : public QDockWidget {
    Q_OBJECT
public:
    explicit SlidePropertiesDock(QWidget *parent = nullptr);

    void showSlide(const IrisSlideInfo &info);
    // The colour row: the slide's profile, what the view does with it, and the display's.
    void showColor(
        const QString &slideProfile, const QString &displayProfile, bool managed, bool applied, const QString &error);
    void clear();

    // For tests and scripting: rows the filter currently shows.
    int visiblePropertyCount() const;
    void setFilterText(const QString &text);

private:
    QLabel *m_vendor;
    QLabel *m_dimensions;
    QLabel *m_resolution;
    QLabel *m_objective;
    QLabel *m_color;
    QTreeWidget *m_levels;
    QLineEdit *m_filter;
    QStandardItemModel *m_model;
    QSortFilterProxyModel *m_proxy;
    QTableView *m_table;
};
