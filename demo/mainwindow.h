// Iris View demo — the viewer's main window: IrisSlideView in the middle, slide properties
// and associated images in docks, live figures in the status bar.
#pragma once

#include <QtCore/QList>
#include <QtWidgets/QMainWindow>

#include <iris/IrisSlideInfo.h>
#include <iris/IrisSlideView.h>

#include "recentfiles.h"

QT_BEGIN_NAMESPACE
class QAction;
class QMimeData;
class QProgressBar;
QT_END_NAMESPACE
class AssociatedImagesDock;
class CompareWindow;
class OrientationActions;
class RecentFiles;
class SampleSlide;
class ServerBrowser;
class SlidePropertiesDock;
class ViewStatus;

class MainWindow : public QMainWindow {
    Q_OBJECT
public:
    explicit MainWindow(QWidget *parent = nullptr);
    ~MainWindow() override;

    IrisSlideView *view() const { return m_view; }

public Q_SLOTS:
    // userInitiated: errors also appear in a message box (not only the status bar).
    bool openSlide(const QString &path, bool userInitiated = true);
    void openSample();
    void showOpenDialog();
    // File › Open from Server…: the QIDO-RS browser (made on first use, kept for the session).
    ServerBrowser *showServerBrowser();
    void exportAsIris();
    // View › Compare…: asks for up to three more slides and shows them beside the open one.
    void showCompareDialog();
    // A comparison window of the open slide (where the view is now) and `others` (up to
    // CompareWindow::kMaxSlides in all); it closes with this window.
    CompareWindow *compare(const QStringList &others);

protected:
    void dragEnterEvent(QDragEnterEvent *event) override;
    void dragMoveEvent(QDragMoveEvent *event) override;
    void dropEvent(QDropEvent *event) override;
    void closeEvent(QCloseEvent *event) override;

private:
    void createActions();
    void createMenus();
    void onSlideOpened(const IrisSlideInfo &info);
    void onSlideClosed();
    void onSlideError(const QString &message);
    void updateActions();
    // Shows what colour management applies (properties dock) and reloads the associated images,
    // which are shown in the same colours as the slide.
    void onColorManagementChanged();
    // The open slide's turn and flips into the recent files, when they changed.
    void rememberOrientation();
    static QString droppedSlide(const QMimeData *mime);

    IrisSlideView *m_view;
    SlidePropertiesDock *m_properties;
    AssociatedImagesDock *m_images;
    ViewStatus *m_status;
    SampleSlide *m_sample;
    RecentFiles *m_recent = nullptr;
    QProgressBar *m_busy;
    bool m_userInitiated = false;
    bool m_openingSample = false;
    // The slide whose orientation is being remembered (empty while one opens), and how it
    // was last remembered.
    QString m_orientedPath;
    RecentFiles::Orientation m_remembered;
    OrientationActions *m_orientation = nullptr;

    QAction *m_openAction = nullptr;
    QAction *m_sampleAction = nullptr;
    QAction *m_serverAction = nullptr;
    ServerBrowser *m_serverBrowser = nullptr;
    // What the server browser last gave m_view (a view cannot give its secret back): handed on
    // to the Compare window's views. Memory only, for the session.
    IrisSlideView::NetworkCredentials m_credentials;
    QAction *m_closeAction = nullptr;
    QAction *m_exportAction = nullptr;
    QAction *m_quitAction = nullptr;
    QAction *m_fitAction = nullptr;
    QAction *m_zoomInAction = nullptr;
    QAction *m_zoomOutAction = nullptr;
    QAction *m_enhanceAction = nullptr;
    QAction *m_compareAction = nullptr;
    QAction *m_colorAction = nullptr;
    QAction *m_perceptualAction = nullptr;
    QAction *m_relativeAction = nullptr;
    QList<QAction *> m_presetActions;
};
