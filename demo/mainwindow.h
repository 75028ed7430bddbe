// Iris View demo — the viewer's main window: IrisSlideView in the middle, slide properties,
// associated images and annotations in docks, live figures in the status bar.
//
// Annotations: one iris::AnnotationStore per open slide, attached to the view and shown in the
// Annotations dock; a slide opened later gets a new store (and `<slide>.annotations.geojson`
// from beside it when there is one). File › Import/Export Annotations… and Save Annotations
// Beside Slide act on it.
#pragma once

#include <memory>

#include <QtCore/QList>
#include <QtCore/QPointer>
#include <QtCore/QThreadPool>
#include <QtWidgets/QMainWindow>

#include <iris/IrisSlideInfo.h>
#include <iris/IrisSlideView.h>
#include <iris/annotations.h>

#include "recentfiles.h"

QT_BEGIN_NAMESPACE
class QAction;
class QMimeData;
class QProgressBar;
QT_END_NAMESPACE
class AnnotationImport;
class AnnotationsDock;
class LayersDock;
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
    // The open slide's annotations (null while no slide is open) and their dock.
    std::shared_ptr<iris::AnnotationStore> annotationStore() const { return m_annotations; }
    AnnotationsDock *annotationsDock() const { return m_annotationsDock; }
    LayersDock *layersDock() const { return m_layersDock; }

public Q_SLOTS:
    // userInitiated: errors also appear in a message box (not only the status bar).
    bool openSlide(const QString &path, bool userInitiated = true);
    void openSample();
    void showOpenDialog();
    // A DICOM series is a folder of files (a level or more each): chosen as a folder.
    void showOpenFolderDialog();
    void createAnnotationMenu();
    // File › Open from Server…: the QIDO-RS browser (made on first use, kept for the session).
    ServerBrowser *showServerBrowser();
    // Where DICOMweb frames are kept while File › Keep Server Frames on This Computer is on
    // (the default): <cache location>/dicomweb-frames; empty while it is off.
    QString frameCacheDirectory() const;
    static QString keptFramesFolder();
    // File › Clear Kept Server Frames: removes the folder; the bytes it held, or -1 when some
    // could not be removed (said in the status bar either way).
    qint64 clearKeptFrames();
    void exportAsIris();
    // View › Compare…: asks for up to three more slides and shows them beside the open one.
    void showCompareDialog();
    // A comparison window of the open slide (where the view is now) and `others` (up to
    // CompareWindow::kMaxSlides in all); it closes with this window.
    CompareWindow *compare(const QStringList &others);

    // File › Import Annotations…: a file dialog, then chooseModeAndImport().
    void showImportAnnotationsDialog();
    // Asks Append or Replace when the slide has annotations already (Cancel: false, nothing
    // started), then importAnnotations().
    bool chooseModeAndImport(const QString &path);
    // Reads a GeoJSON or ASAP XML file into the open slide's store on a worker thread, with a
    // progress dialog that cancels; annotationImportFinished follows. An error shows in a
    // message box naming the file and the reader's message, and changes nothing. False when
    // no slide is open (nothing started).
    bool importAnnotations(const QString &path, iris::AnnotationLoader::Mode mode);
    // File › Export Annotations…: a file dialog; the format by the name's suffix or the filter.
    void showExportAnnotationsDialog();
    // Writes the open slide's annotations as they are now to `path` (ASAP XML for .xml, else
    // GeoJSON) on a worker thread, through a temporary file renamed over `path`, so a failed
    // write loses nothing; annotationsWritten follows, and an error shows in a message box.
    // False when no slide is open (nothing started).
    bool exportAnnotations(const QString &path);
    // File › Save Annotations Beside Slide: the same into `<slide path>.annotations.geojson`,
    // read back when the slide is opened again. False, with a message box saying why, for a
    // DICOMweb slide or a read-only folder.
    bool saveAnnotationsBesideSlide();

Q_SIGNALS:
    // An import started by importAnnotations() (or a slide's own file, read when it opened)
    // ended: ok, or cancelled, or failed with `message`.
    void annotationImportFinished(const QString &path, bool ok, bool cancelled, const QString &message);
    // A write started by exportAnnotations() or saveAnnotationsBesideSlide() ended.
    void annotationsWritten(const QString &path, bool ok, const QString &message);

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
    // A new, empty store for the slide just opened, on the view and in the dock; the slide's
    // own annotations file read into it when there is one.
    void attachAnnotations(const IrisSlideInfo &info);
    void detachAnnotations();
    void startImport(const QString &path, iris::AnnotationLoader::Mode mode, bool automatic);
    void startWrite(const QString &path, iris::AnnotationFormat format, const QString &failureTitle);
    void onWritten(const QString &path, qsizetype objects, const QString &failureTitle, const QString &error);
    void onImportFinished(
        AnnotationImport *import, bool automatic, bool ok, bool cancelled, qsizetype objects, const QString &message);
    // A message box that does not block (open(), deleted on close): the outcome of work that
    // ended on its own, and a test can read and close it.
    void showAnnotationError(const QString &title, const QString &text, const QString &details = QString());
    static QString droppedSlide(const QMimeData *mime);

    IrisSlideView *m_view;
    SlidePropertiesDock *m_properties;
    AssociatedImagesDock *m_images;
    AnnotationsDock *m_annotationsDock;
    LayersDock *m_layersDock;
    std::shared_ptr<iris::AnnotationStore> m_annotations;
    QPointer<AnnotationImport> m_import; // at most one at a time
    QProgressBar *m_writing; // busy while a write runs
    int m_writes = 0; // writes started and not yet reported
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
    QAction *m_openFolderAction = nullptr;
    QAction *m_sampleAction = nullptr;
    QAction *m_serverAction = nullptr;
    QAction *m_keepFramesAction = nullptr; // keep DICOMweb frames on this computer (QSettings network/keepFrames)
    QAction *m_clearFramesAction = nullptr;
    ServerBrowser *m_serverBrowser = nullptr;
    // What the server browser last gave m_view (a view cannot give its secret back): handed on
    // to the Compare window's views. Memory only, for the session.
    IrisSlideView::NetworkCredentials m_credentials;
    QAction *m_closeAction = nullptr;
    QAction *m_exportAction = nullptr;
    QAction *m_importAnnotationsAction = nullptr;
    QAction *m_exportAnnotationsAction = nullptr;
    QAction *m_saveAnnotationsAction = nullptr;
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

    // Annotation files are written here, one at a time; the destructor waits for the one
    // running (its file is complete or untouched), so no worker posts to a window that is gone.
    QThreadPool m_writer;
};
