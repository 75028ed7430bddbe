// Iris View demo — the Annotations dock: the open slide's annotation classes (colour swatch,
// name and visibility, object count, total area) above the list of its objects (name or kind,
// class, area). Selecting an object selects it in the view (and an object selected in the
// view becomes the list's current row); double-clicking one centres the view on it; a swatch
// opens a colour dialog.
//
// Updates: the store calls back on whichever thread wrote it (AnnotationStore::onChange); the
// dock posts one queued call per burst to the GUI thread, waits kRefreshMs more on a
// single-shot timer so a stream of edits makes one refresh, and summarises the newest
// snapshot on a worker (annotationmodels.h: 10^6 detections take a while). Neither model
// holds a row object per annotation: both read the immutable snapshot.
#pragma once

#include <atomic>
#include <memory>

#include <QtCore/QPointer>
#include <QtCore/QThreadPool>
#include <QtCore/QTimer>
#include <QtWidgets/QDockWidget>

#include <iris/annotations.h>

#include "annotationmodels.h"

QT_BEGIN_NAMESPACE
class QCheckBox;
class QLabel;
class QTableView;
QT_END_NAMESPACE
class IrisSlideView;

class AnnotationsDock : public QDockWidget
{
    Q_OBJECT
public:
    static constexpr int kRefreshMs = 100;

    AnnotationsDock(IrisSlideView *view, QWidget *parent = nullptr);
    ~AnnotationsDock() override;

    // The store shown (null: none) and the slide's µm per pixel for areas (0: px²).
    void setStore(std::shared_ptr<iris::AnnotationStore> store, double mppX, double mppY);

    AnnotationClassModel *classModel() const { return m_classes; }
    AnnotationObjectModel *objectModel() const { return m_objects; }
    QTableView *classTable() const { return m_classTable; }
    QTableView *objectTable() const { return m_objectTable; }
    // The generation of the snapshot the models show (0 before the first summary).
    quint64 shownGeneration() const { return m_shownGeneration; }
    // Opens the colour dialog for a class row; its choice goes to the store.
    void chooseClassColour(int row);
    // Centres the view on an object row (as a double-click does).
    void centreOn(int row);

Q_SIGNALS:
    // The models show a new summary (tests wait on it).
    void refreshed();

private:
    void storeChanged(); // GUI thread, once per burst of publications
    void startSummary();
    void applySummary(quint64 serial, AnnotationSummary summary);
    void updateHeadline();
    // The list's current row follows the view's selected object (set from elsewhere).
    void followViewSelection();

    QPointer<IrisSlideView> m_view; // the main window's; it may go first when the window closes
    QLabel *m_headline;
    QCheckBox *m_showAll;
    AnnotationClassModel *m_classes;
    AnnotationObjectModel *m_objects;
    QTableView *m_classTable;
    QTableView *m_objectTable;
    double m_mppX = 0, m_mppY = 0;

    std::shared_ptr<iris::AnnotationStore> m_store;
    // Set by the writer's thread when it posts the queued call, cleared by the GUI thread
    // before it reads the snapshot: a publication after the clear posts again, so none is
    // missed. acq_rel/acquire only order the flag itself; the snapshot travels through the
    // store's own publication (Published<T>).
    std::atomic<bool> m_posted{false};
    QTimer m_refresh;
    // Summaries run here, one at a time; the destructor waits for the one running, so a
    // worker never posts to a dock that is gone.
    QThreadPool m_pool;
    std::shared_ptr<std::atomic<bool>> m_cancel; // of the summary running
    quint64 m_serial = 0; // bumped per summary started and per store set
    bool m_running = false;
    bool m_again = false; // a change came while a summary ran
    bool m_following = false; // the list is being moved to the view's selection
    quint64 m_shownGeneration = 0;
    std::shared_ptr<const std::vector<quint64>> m_lastIds; // the object list's rows
    iris::AnnotationSubscription m_subscription; // last: ends the callbacks first
};
