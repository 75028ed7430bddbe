// Iris View demo — View › Compare…: up to four slides side by side in one window (one
// row for two, a 2 × 2 grid for three or four), linked by an IrisViewGroup: moving, zooming
// or turning one moves the others, and the pointer's place is marked by a cross-hair in
// every other linked view. Each view has its own link toggle (unlink, align by hand,
// relink: the alignment is kept). The menus' turn, flip and fit act on the current view (the
// one the pointer was last over), and so on every linked one.
#pragma once

#include <QtCore/QList>
#include <QtCore/QPointF>
#include <QtWidgets/QMainWindow>

#include <iris/IrisSlideView.h>

QT_BEGIN_NAMESPACE
class QAction;
class QGridLayout;
QT_END_NAMESPACE
class ComparePane;
class IrisViewGroup;
class OrientationActions;

class CompareWindow : public QMainWindow {
    Q_OBJECT
public:
    static constexpr int kMaxSlides = 4;

    // What a view shows, to start the first slide where the main window was.
    struct Pose {
        QPointF centre;
        double downsample = 0;
        double rotation = 0;
        bool flippedHorizontally = false;
        bool flippedVertically = false;
    };

    explicit CompareWindow(QWidget *parent = nullptr);
    ~CompareWindow() override;

    // Credentials and TLS for the DICOMweb series the views open: given to every view, and to
    // each one added later (the main window passes its own view's, which a view cannot give
    // back, so that a protected series it shows opens here too). Memory only, never logged.
    void setNetworkCredentials(const IrisSlideView::NetworkCredentials &credentials);
    // The folder where DICOMweb frames are kept (IrisSlideView::setFrameCacheDirectory), for
    // every view and each one added later; empty: none kept.
    void setFrameCacheDirectory(const QString &directory);

    // Adds a view showing `path` (opened once the view is on screen), linked; with a pose,
    // it starts there and the others follow. False when there are kMaxSlides already.
    bool addSlide(const QString &path, const Pose *start = nullptr);
    int count() const { return int(m_panes.size()); }
    IrisSlideView *view(int index) const;
    ComparePane *pane(int index) const { return m_panes.value(index); }
    IrisViewGroup *group() const { return m_group; }
    IrisSlideView *currentView() const;

public Q_SLOTS:
    void showAddDialog();

Q_SIGNALS:
    // Every view that was asked to open a slide has opened it or failed.
    void slidesOpened();

private:
    void createMenus();
    void removePane(ComparePane *pane);
    void setCurrent(ComparePane *pane);
    void relayout();
    void updateTitle();
    void updateActions();
    void onOpened(ComparePane *pane);

    IrisViewGroup *m_group;
    QGridLayout *m_grid;
    QList<ComparePane *> m_panes;
    ComparePane *m_current = nullptr;
    ComparePane *m_startPane = nullptr; // the pane that starts at m_start
    Pose m_start;
    IrisSlideView::NetworkCredentials m_credentials;
    QString m_frameCache;
    OrientationActions *m_orientation;
    QAction *m_addAction = nullptr;
    QAction *m_fitAction = nullptr;
    QAction *m_linkAllAction = nullptr;
    QAction *m_crosshairAction = nullptr;
};
