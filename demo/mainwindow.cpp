#include "mainwindow.h"

#include <QtCore/QDir>
#include <QtCore/QDirIterator>
#include <QtCore/QFileInfo>
#include <QtCore/QLocale>
#include <QtCore/QMimeData>
#include <QtCore/QSettings>
#include <QtCore/QStandardPaths>
#include <QtGui/QAction>
#include <QtGui/QActionGroup>
#include <QtGui/QCloseEvent>
#include <QtGui/QDragEnterEvent>
#include <QtWidgets/QApplication>
#include <QtWidgets/QFileDialog>
#include <QtWidgets/QLabel>
#include <QtWidgets/QToolBar>
#include <QtGui/QUndoStack>
#include <QtWidgets/QMenuBar>
#include <QtWidgets/QMessageBox>
#include <QtWidgets/QProgressBar>
#include <QtWidgets/QPushButton>
#include <QtWidgets/QStatusBar>

#include <iris/IrisSlideView.h>
#include <iris/version.h>

#include "annotationfiles.h"
#include "annotationimport.h"
#include "annotationsdock.h"
#include "associatedimagesdock.h"
#include "comparewindow.h"
#include "exportdialog.h"
#include "layersdock.h"
#include "orientationactions.h"
#include "recentfiles.h"
#include "sampleslide.h"
#include "serverbrowser.h"
#include "slideformats.h"
#include "slidepropertiesdock.h"
#include "viewstatus.h"

namespace {
constexpr int kMessageMs = 8000;
const double kPresets[] = {5, 10, 20, 40};

// "1 annotation", "12,345 annotations" (the demo ships no translations, so no %n plurals).
QString annotationCount(qsizetype n)
{
    return n == 1 ? MainWindow::tr("1 annotation")
                  : MainWindow::tr("%1 annotations").arg(QLocale().toString(qlonglong(n)));
}
} // namespace

MainWindow::MainWindow(QWidget *parent)
    : QMainWindow(parent)
    , m_view(new IrisSlideView)
    , m_properties(new SlidePropertiesDock(this))
    , m_images(new AssociatedImagesDock(this))
    , m_annotationsDock(new AnnotationsDock(m_view, this))
    , m_layersDock(new LayersDock(m_view, this))
    , m_writing(new QProgressBar)
    , m_status(nullptr)
    , m_sample(new SampleSlide(this))
    , m_busy(new QProgressBar)
{
    setWindowTitle(tr("Iris View"));
    setAcceptDrops(true);
    m_view->setObjectName(QStringLiteral("slideView"));
    setCentralWidget(m_view);
    addDockWidget(Qt::RightDockWidgetArea, m_properties);
    addDockWidget(Qt::RightDockWidgetArea, m_images);
    addDockWidget(Qt::RightDockWidgetArea, m_annotationsDock);
    tabifyDockWidget(m_images, m_annotationsDock);
    addDockWidget(Qt::RightDockWidgetArea, m_layersDock);
    tabifyDockWidget(m_annotationsDock, m_layersDock);
    m_images->raise();

    m_busy->setRange(0, 0); // busy: iris-sample reports no progress through a pipe
    m_busy->setMaximumWidth(120);
    m_busy->hide();
    statusBar()->addWidget(m_busy);
    m_writing->setRange(0, 0);
    m_writing->setMaximumWidth(120);
    m_writing->setObjectName(QStringLiteral("annotationWriteBusy"));
    m_writing->hide();
    statusBar()->addWidget(m_writing);
    m_writer.setMaxThreadCount(1);
    m_status = new ViewStatus(m_view, statusBar());

    createActions();
    createMenus();

    connect(m_view, &IrisSlideView::slideOpened, this, &MainWindow::onSlideOpened);
    connect(m_view, &IrisSlideView::slideClosed, this, &MainWindow::onSlideClosed);
    connect(m_view, &IrisSlideView::slideError, this, &MainWindow::onSlideError);
    connect(m_view, &IrisSlideView::viewChanged, this, &MainWindow::updateActions);
    connect(m_view, &IrisSlideView::viewChanged, this, &MainWindow::rememberOrientation);
    connect(m_view, &IrisSlideView::colorManagementChanged, this, &MainWindow::onColorManagementChanged);

    connect(m_sample, &SampleSlide::generating, this, [this](const QString &message) {
        statusBar()->showMessage(message);
        m_busy->setVisible(m_sample->isGenerating());
    });
    connect(m_sample, &SampleSlide::ready, this, [this](const QString &path) {
        m_busy->hide();
        m_sampleAction->setEnabled(true);
        openSlide(path, m_openingSample);
    });
    connect(m_sample, &SampleSlide::failed, this, [this](const QString &message) {
        m_busy->hide();
        m_sampleAction->setEnabled(true);
        statusBar()->showMessage(message, kMessageMs);
        if (m_openingSample)
            QMessageBox::warning(this, tr("Sample slide"), message);
    });

    QSettings settings;
    restoreGeometry(settings.value(QStringLiteral("window/geometry")).toByteArray());
    restoreState(settings.value(QStringLiteral("window/state")).toByteArray());
    m_enhanceAction->setChecked(settings.value(QStringLiteral("view/enhance"), true).toBool());
    m_keepFramesAction->setChecked(settings.value(QStringLiteral("network/keepFrames"), true).toBool());
    m_view->setFrameCacheDirectory(frameCacheDirectory());
    m_colorAction->setChecked(settings.value(QStringLiteral("view/colorManaged"), m_view->colorManaged()).toBool());
    if (settings.value(QStringLiteral("view/renderingIntent")).toString() == QLatin1String("relative"))
        m_relativeAction->trigger();
    if (!settings.contains(QStringLiteral("window/geometry")))
        resize(1280, 800);
    updateActions();
}

MainWindow::~MainWindow()
{
    m_writer.waitForDone();
}

void MainWindow::createActions()
{
    m_openAction = new QAction(tr("&Open…"), this);
    m_openAction->setShortcut(QKeySequence::Open);
    connect(m_openAction, &QAction::triggered, this, &MainWindow::showOpenDialog);

    m_openFolderAction = new QAction(tr("Open DICOM &Folder…"), this);
    m_openFolderAction->setObjectName(QStringLiteral("openFolderAction"));
    m_openFolderAction->setShortcut(QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_O));
    m_openFolderAction->setStatusTip(tr("Open a DICOM whole-slide image series: the folder holding its files"));
    connect(m_openFolderAction, &QAction::triggered, this, &MainWindow::showOpenFolderDialog);

    // DICOMweb: studies and series found through QIDO-RS (serverbrowser.h).
    m_serverAction = new QAction(tr("Open from Ser&ver…"), this);
    m_serverAction->setObjectName(QStringLiteral("openFromServerAction"));
    connect(m_serverAction, &QAction::triggered, this, &MainWindow::showServerBrowser);
    m_keepFramesAction = new QAction(tr("&Keep Server Frames on This Computer"), this);
    m_keepFramesAction->setObjectName(QStringLiteral("keepFramesAction"));
    m_keepFramesAction->setCheckable(true);
    m_keepFramesAction->setStatusTip(tr("Keep the frames fetched from a DICOMweb server in %1 (yours alone, at most "
                                        "2 GiB), so that a slide opened again loads from this computer")
                                         .arg(QDir::toNativeSeparators(keptFramesFolder())));
    connect(m_keepFramesAction, &QAction::toggled, this, [this](bool on) {
        QSettings().setValue(QStringLiteral("network/keepFrames"), on);
        m_view->setFrameCacheDirectory(frameCacheDirectory()); // for the series opened from now on
    });
    m_clearFramesAction = new QAction(tr("C&lear Kept Server Frames"), this);
    m_clearFramesAction->setObjectName(QStringLiteral("clearFramesAction"));
    m_clearFramesAction->setStatusTip(tr("Remove the frames kept from DICOMweb servers from this computer"));
    connect(m_clearFramesAction, &QAction::triggered, this, &MainWindow::clearKeptFrames);

    m_sampleAction = new QAction(tr("Open &Sample Slide"), this);
    connect(m_sampleAction, &QAction::triggered, this, [this] {
        m_openingSample = true;
        openSample();
    });

    m_closeAction = new QAction(tr("&Close"), this);
    m_closeAction->setShortcut(QKeySequence::Close);
    connect(m_closeAction, &QAction::triggered, m_view, &IrisSlideView::closeSlide);

    m_exportAction = new QAction(tr("&Export as .iris…"), this);
    connect(m_exportAction, &QAction::triggered, this, &MainWindow::exportAsIris);

    m_importAnnotationsAction = new QAction(tr("&Import Annotations…"), this);
    m_importAnnotationsAction->setObjectName(QStringLiteral("importAnnotationsAction"));
    m_importAnnotationsAction->setStatusTip(tr("Read QuPath GeoJSON or ASAP XML annotations onto the open slide"));
    connect(m_importAnnotationsAction, &QAction::triggered, this, &MainWindow::showImportAnnotationsDialog);

    m_exportAnnotationsAction = new QAction(tr("E&xport Annotations…"), this);
    m_exportAnnotationsAction->setObjectName(QStringLiteral("exportAnnotationsAction"));
    m_exportAnnotationsAction->setStatusTip(tr("Write the open slide's annotations as QuPath GeoJSON or ASAP XML"));
    connect(m_exportAnnotationsAction, &QAction::triggered, this, &MainWindow::showExportAnnotationsDialog);

    m_saveAnnotationsAction = new QAction(tr("&Save Annotations Beside Slide"), this);
    m_saveAnnotationsAction->setObjectName(QStringLiteral("saveAnnotationsAction"));
    m_saveAnnotationsAction->setShortcut(Qt::CTRL | Qt::SHIFT | Qt::Key_S);
    m_saveAnnotationsAction->setStatusTip(
        tr("Write the annotations to <slide>.annotations.geojson, read back when the slide opens again"));
    connect(m_saveAnnotationsAction, &QAction::triggered, this, [this] { saveAnnotationsBesideSlide(); });

    m_quitAction = new QAction(tr("&Quit"), this);
    m_quitAction->setShortcut(QKeySequence::Quit);
    m_quitAction->setMenuRole(QAction::QuitRole);
    connect(m_quitAction, &QAction::triggered, this, &QWidget::close);

    // The view itself answers 0, +, −, 1–4 and the arrows while it has focus; the menu
    // carries Ctrl chords so that both work from anywhere without clashing.
    m_fitAction = new QAction(tr("&Fit to Window"), this);
    m_fitAction->setShortcut(Qt::CTRL | Qt::Key_0);
    connect(m_fitAction, &QAction::triggered, m_view, &IrisSlideView::fitToWindow);

    m_zoomInAction = new QAction(tr("Zoom &In"), this);
    m_zoomInAction->setShortcut(QKeySequence::ZoomIn);
    connect(m_zoomInAction, &QAction::triggered, m_view, [this] { m_view->zoomBy(2); });

    m_zoomOutAction = new QAction(tr("Zoom &Out"), this);
    m_zoomOutAction->setShortcut(QKeySequence::ZoomOut);
    connect(m_zoomOutAction, &QAction::triggered, m_view, [this] { m_view->zoomBy(0.5); });

    m_orientation = new OrientationActions(this);
    m_orientation->setView(m_view);

    m_compareAction = new QAction(tr("&Compare…"), this);
    m_compareAction->setObjectName(QStringLiteral("compareAction"));
    m_compareAction->setStatusTip(tr("Show up to three more slides beside this one, moving together"));
    connect(m_compareAction, &QAction::triggered, this, &MainWindow::showCompareDialog);

    for (int i = 0; i < 4; ++i) {
        auto *action = new QAction(tr("%1×").arg(kPresets[i]), this);
        action->setShortcut(QKeyCombination(Qt::CTRL, Qt::Key(Qt::Key_1 + i)));
        const double magnification = kPresets[i];
        connect(action, &QAction::triggered, m_view, [this, magnification] { m_view->setMagnification(magnification); });
        m_presetActions << action;
    }

    m_enhanceAction = new QAction(tr("&Enhance Detail"), this);
    m_enhanceAction->setCheckable(true);
    m_enhanceAction->setShortcut(Qt::CTRL | Qt::Key_E);
    m_enhanceAction->setStatusTip(tr("Sharpen reduced levels (reduction enhancement)"));
    connect(m_enhanceAction, &QAction::toggled, m_view, &IrisSlideView::setEnhance);
    connect(m_view, &IrisSlideView::enhanceChanged, m_enhanceAction, &QAction::setChecked);

    // Colour management: the slide's ICC profile applied (on by default), and the intent.
    m_colorAction = new QAction(tr("&Colour Management"), this);
    m_colorAction->setCheckable(true);
    m_colorAction->setChecked(m_view->colorManaged());
    m_colorAction->setShortcut(Qt::CTRL | Qt::SHIFT | Qt::Key_M);
    m_colorAction->setStatusTip(tr("Show the slide in the colours its scanner's ICC profile describes"));
    connect(m_colorAction, &QAction::toggled, m_view, &IrisSlideView::setColorManaged);
    auto *intents = new QActionGroup(this);
    m_perceptualAction = intents->addAction(tr("&Perceptual"));
    m_relativeAction = intents->addAction(tr("&Relative Colorimetric"));
    m_perceptualAction->setStatusTip(tr("Compress the slide's whole gamut into the display's"));
    m_relativeAction->setStatusTip(
        tr("Keep the colours the display can show exact and clip the others (black-point compensated)"));
    for (QAction *action : {m_perceptualAction, m_relativeAction})
        action->setCheckable(true);
    m_perceptualAction->setChecked(m_view->renderingIntent() == IrisSlideView::Perceptual);
    m_relativeAction->setChecked(m_view->renderingIntent() == IrisSlideView::RelativeColorimetric);
    connect(m_perceptualAction, &QAction::triggered, m_view,
        [this] { m_view->setRenderingIntent(IrisSlideView::Perceptual); });
    connect(m_relativeAction, &QAction::triggered, m_view,
        [this] { m_view->setRenderingIntent(IrisSlideView::RelativeColorimetric); });
}

void MainWindow::createMenus()
{
    QMenu *file = menuBar()->addMenu(tr("&File"));
    file->addAction(m_openAction);
    file->addAction(m_openFolderAction);
    QMenu *recent = file->addMenu(tr("Open &Recent"));
    m_recent = new RecentFiles(recent, this);
    connect(m_recent, &RecentFiles::openRequested, this, [this](const QString &path) { openSlide(path, true); });
    file->addAction(m_serverAction);
    file->addAction(m_keepFramesAction);
    file->addAction(m_clearFramesAction);
    file->addAction(m_sampleAction);
    file->addSeparator();
    file->addAction(m_closeAction);
    file->addAction(m_exportAction);
    file->addSeparator();
    file->addAction(m_importAnnotationsAction);
    file->addAction(m_exportAnnotationsAction);
    file->addAction(m_saveAnnotationsAction);
    file->addSeparator();
    file->addAction(m_quitAction);

    QMenu *view = menuBar()->addMenu(tr("&View"));
    view->addAction(m_fitAction);
    view->addAction(m_zoomInAction);
    view->addAction(m_zoomOutAction);
    QMenu *presets = view->addMenu(tr("&Magnification"));
    presets->addActions(m_presetActions);
    view->addSeparator();
    m_orientation->addTo(view);
    view->addSeparator();
    view->addAction(m_compareAction);
    view->addSeparator();
    view->addAction(m_enhanceAction);
    QMenu *color = view->addMenu(tr("Co&lour"));
    color->addAction(m_colorAction);
    color->addSeparator();
    color->addAction(m_perceptualAction);
    color->addAction(m_relativeAction);

    // Overlays the engine draws over the slide: each shown or hidden and put in a corner,
    // remembered across runs. The checks follow the view (also when set from elsewhere).
    QMenu *overlays = view->addMenu(tr("O&verlays"));
    const struct {
        IrisSlideView::Overlay overlay;
        QString title;
        QString key;
    } kinds[] = {
        {IrisSlideView::ScaleBar, tr("&Scale Bar"), QStringLiteral("scaleBar")},
        {IrisSlideView::MagnificationLabel, tr("&Magnification Readout"), QStringLiteral("magnification")},
        {IrisSlideView::Overview, tr("&Overview Map"), QStringLiteral("overview")},
        {IrisSlideView::Legend, tr("&Legend"), QStringLiteral("legend")},
    };
    const std::pair<IrisSlideView::OverlayCorner, QString> corners[] = {
        {IrisSlideView::TopLeft, tr("Top &Left")},
        {IrisSlideView::TopRight, tr("Top &Right")},
        {IrisSlideView::BottomLeft, tr("&Bottom Left")},
        {IrisSlideView::BottomRight, tr("Bottom Ri&ght")},
    };
    QSettings settings;
    for (const auto &kind : kinds) {
        const IrisSlideView::Overlay overlay = kind.overlay;
        const QString visibleKey = QStringLiteral("overlays/%1/visible").arg(kind.key);
        const QString cornerKey = QStringLiteral("overlays/%1/corner").arg(kind.key);
        m_view->setOverlayVisible(overlay, settings.value(visibleKey, m_view->isOverlayVisible(overlay)).toBool());
        const int corner = settings.value(cornerKey, int(m_view->overlayCorner(overlay))).toInt();
        if (corner >= IrisSlideView::TopLeft && corner <= IrisSlideView::BottomRight)
            m_view->setOverlayCorner(overlay, IrisSlideView::OverlayCorner(corner));

        QMenu *menu = overlays->addMenu(kind.title);
        QAction *show = menu->addAction(tr("&Show"));
        show->setCheckable(true);
        connect(show, &QAction::triggered, m_view, [this, overlay, visibleKey](bool on) {
            m_view->setOverlayVisible(overlay, on);
            QSettings().setValue(visibleKey, on);
        });
        menu->addSeparator();
        QList<QAction *> placed;
        for (const auto &[where, title] : corners) {
            QAction *action = menu->addAction(title);
            action->setCheckable(true);
            action->setData(int(where));
            placed << action;
        }
        const auto sync = [this, overlay, show, placed] {
            show->setChecked(m_view->isOverlayVisible(overlay));
            for (QAction *action : placed)
                action->setChecked(action->data().toInt() == int(m_view->overlayCorner(overlay)));
        };
        for (QAction *action : placed) {
            connect(action, &QAction::triggered, m_view, [this, overlay, cornerKey, action, sync] {
                m_view->setOverlayCorner(overlay, IrisSlideView::OverlayCorner(action->data().toInt()));
                QSettings().setValue(cornerKey, action->data().toInt());
                sync(); // one corner stays checked, also when the checked one was clicked again
            });
        }
        connect(m_view, &IrisSlideView::overlaysChanged, menu, sync);
        sync();
    }

    view->addSeparator();
    view->addAction(m_properties->toggleViewAction());
    view->addAction(m_images->toggleViewAction());
    view->addAction(m_annotationsDock->toggleViewAction());
    view->addAction(m_layersDock->toggleViewAction());

    createAnnotationMenu();

    QMenu *help = menuBar()->addMenu(tr("&Help"));
    help->addAction(tr("&About Iris View"), this, [this] {
        const QString device = m_view->deviceName();
        QMessageBox::about(this, tr("About Iris View"),
                           tr("<h3>Iris View %1</h3><p>Whole-slide image viewer with a Vulkan engine.</p>"
                              "<p>Renderer: %2</p><p>Drag to pan, wheel or pinch to zoom, double-click to "
                              "zoom in, arrow keys to move one field, 0 to fit, 1–4 for 5×–40×, "
                              "R / Shift+R to turn a quarter, F to flip.</p>")
                               .arg(QStringLiteral(IRIS_VIEW_VERSION_STRING),
                                    device.isEmpty() ? m_view->rendererError().toHtmlEscaped() : device.toHtmlEscaped()));
    });
    help->addAction(tr("About &Qt"), qApp, &QApplication::aboutQt);
}

QString MainWindow::frameCacheDirectory() const
{
    if (!m_keepFramesAction->isChecked())
        return {};
    return keptFramesFolder();
}

QString MainWindow::keptFramesFolder()
{
    return QStandardPaths::writableLocation(QStandardPaths::CacheLocation) + QStringLiteral("/dicomweb-frames");
}

qint64 MainWindow::clearKeptFrames()
{
    // The folder goes whole. An engine that keeps frames there meanwhile is not disturbed: a
    // kept frame whose file is gone is fetched again, and the next one written makes the
    // folder again (the user's alone).
    QDir folder(keptFramesFolder());
    qint64 bytes = 0;
    QDirIterator it(folder.path(), QDir::Files | QDir::Hidden, QDirIterator::Subdirectories);
    while (it.hasNext()) {
        it.next();
        bytes += it.fileInfo().size();
    }
    const bool removed = !folder.exists() || folder.removeRecursively();
    statusBar()->showMessage(removed
            ? tr("Removed %1 MB of frames kept from servers").arg(double(bytes) / (1 << 20), 0, 'f', 1)
            : tr("Could not remove everything in %1").arg(QDir::toNativeSeparators(folder.path())),
        kMessageMs);
    return removed ? bytes : -1;
}

ServerBrowser *MainWindow::showServerBrowser()
{
    // Made once and kept (hidden when closed): the credentials typed in stay for the session,
    // in memory only.
    if (!m_serverBrowser) {
        m_serverBrowser = new ServerBrowser(this);
        connect(m_serverBrowser, &ServerBrowser::openRequested, this,
                [this](const QString &url, const IrisSlideView::NetworkCredentials &credentials) {
                    m_credentials = credentials;
                    m_view->setNetworkCredentials(credentials);
                    if (openSlide(url, true))
                        m_serverBrowser->hide();
                });
    }
    m_serverBrowser->show();
    m_serverBrowser->raise();
    m_serverBrowser->activateWindow();
    return m_serverBrowser;
}

bool MainWindow::openSlide(const QString &path, bool userInitiated)
{
    statusBar()->showMessage(tr("Opening %1…").arg(QDir::toNativeSeparators(path)));
    m_userInitiated = userInitiated;
    m_orientedPath.clear(); // the new slide opens unturned: that is not a change to remember
    const bool opened = m_view->openSlide(path);
    m_userInitiated = false;
    m_openingSample = false;
    if (opened) {
        statusBar()->showMessage(tr("Opened %1").arg(QDir::toNativeSeparators(path)), kMessageMs);
        if (path != SampleSlide::path()) {
            m_recent->add(path);
            // As it was turned and flipped when last seen, fitted that way.
            m_remembered = m_recent->orientation(path);
            if (!m_remembered.isDefault()) {
                m_view->setFlipped(m_remembered.flippedHorizontally, m_remembered.flippedVertically);
                m_view->setRotation(m_remembered.rotation);
                m_view->fitToWindow();
            }
            m_orientedPath = path;
        }
    } else if (userInitiated && !RecentFiles::isUrl(path)) {
        // A file that is gone leaves the list; a server URL stays (the server may be down, or
        // want credentials this session has not been given yet).
        m_recent->remove(path);
    }
    return opened;
}

void MainWindow::rememberOrientation()
{
    if (m_orientedPath.isEmpty() || m_view->slidePath() != m_orientedPath)
        return;
    const RecentFiles::Orientation now{m_view->rotation(), m_view->isFlippedHorizontally(),
                                       m_view->isFlippedVertically()};
    if (now == m_remembered)
        return;
    m_remembered = now;
    m_recent->setOrientation(m_orientedPath, now);
}

void MainWindow::showCompareDialog()
{
    QSettings settings;
    const QString dir = settings.value(QStringLiteral("lastFolder"), QDir::homePath()).toString();
    const int room = CompareWindow::kMaxSlides - (m_view->hasSlide() ? 1 : 0);
    const QStringList chosen = QFileDialog::getOpenFileNames(
        this, m_view->hasSlide() ? tr("Compare With (up to %1 slides)").arg(room) : tr("Compare Slides (up to %1)").arg(room),
        dir, SlideFormats::fileDialogFilters().join(QStringLiteral(";;")));
    if (chosen.isEmpty())
        return;
    settings.setValue(QStringLiteral("lastFolder"), QFileInfo(chosen.first()).absolutePath());
    if (chosen.size() > room)
        statusBar()->showMessage(tr("A comparison shows at most %1 slides; %2 left out.")
                                     .arg(CompareWindow::kMaxSlides)
                                     .arg(chosen.size() - room),
                                 kMessageMs);
    compare(chosen);
}

CompareWindow *MainWindow::compare(const QStringList &others)
{
    auto *window = new CompareWindow(this);
    window->setAttribute(Qt::WA_DeleteOnClose);
    window->setNetworkCredentials(m_credentials); // a protected series the main view shows opens there too
    window->setFrameCacheDirectory(frameCacheDirectory());
    if (m_view->hasSlide()) {
        const CompareWindow::Pose here{m_view->centre(), m_view->downsample(), m_view->rotation(),
                                       m_view->isFlippedHorizontally(), m_view->isFlippedVertically()};
        window->addSlide(m_view->slidePath(), &here);
    }
    for (const QString &path : others) {
        if (!window->addSlide(path))
            break;
    }
    window->show();
    return window;
}

void MainWindow::openSample()
{
    m_sampleAction->setEnabled(false);
    m_sample->ensure();
}

void MainWindow::showOpenDialog()
{
    QSettings settings;
    const QString dir = settings.value(QStringLiteral("lastFolder"), QDir::homePath()).toString();
    const QString path = QFileDialog::getOpenFileName(this, tr("Open Slide"), dir,
                                                      SlideFormats::fileDialogFilters().join(QStringLiteral(";;")));
    if (path.isEmpty())
        return;
    settings.setValue(QStringLiteral("lastFolder"), QFileInfo(path).absolutePath());
    openSlide(path, true);
}

void MainWindow::createAnnotationMenu()
{
    // The view's annotation tools (IrisSlideView::AnnotationTool), in a menu and a toolbar, one
    // checked; the view's own keys (QuPath's: M, S, ".", R, O, P, Shift+P, B) switch them too,
    // and the checks follow. Undo and redo are the view's stack's.
    QMenu *menu = menuBar()->addMenu(tr("&Annotations"));
    menu->setObjectName(QStringLiteral("annotationsMenu"));
    QAction *undo = m_view->annotationUndoStack()->createUndoAction(this, tr("&Undo"));
    undo->setShortcut(QKeySequence::Undo);
    QAction *redo = m_view->annotationUndoStack()->createRedoAction(this, tr("&Redo"));
    redo->setShortcut(QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_Z));
    menu->addAction(undo);
    menu->addAction(redo);
    menu->addSeparator();
    QToolBar *bar = addToolBar(tr("Annotation Tools"));
    bar->setObjectName(QStringLiteral("annotationToolBar"));
    auto *group = new QActionGroup(this);
    const struct {
        IrisSlideView::AnnotationTool tool;
        QString text;
        QString key;
        const char *name;
    } tools[] = {
        {IrisSlideView::Navigate, tr("&Navigate"), QStringLiteral("M"), "navigate"},
        {IrisSlideView::Select, tr("&Select and Edit"), QStringLiteral("S"), "select"},
        {IrisSlideView::Point, tr("P&oint"), QStringLiteral("."), "point"},
        {IrisSlideView::Rectangle, tr("&Rectangle"), QStringLiteral("R"), "rectangle"},
        {IrisSlideView::Ellipse, tr("&Ellipse"), QStringLiteral("O"), "ellipse"},
        {IrisSlideView::Polygon, tr("&Polygon"), QStringLiteral("P"), "polygon"},
        {IrisSlideView::Freehand, tr("&Freehand"), QStringLiteral("Shift+P"), "freehand"},
        {IrisSlideView::Brush, tr("&Brush"), QStringLiteral("B"), "brush"},
    };
    for (const auto &t : tools) {
        auto *action = new QAction(t.text + QLatin1Char('\t') + t.key, this);
        action->setObjectName(QStringLiteral("tool_") + QLatin1String(t.name));
        action->setCheckable(true);
        action->setChecked(m_view->annotationTool() == t.tool);
        action->setToolTip(QString(t.text).remove(QLatin1Char('&')) + QStringLiteral(" (") + t.key + QLatin1Char(')'));
        group->addAction(action);
        menu->addAction(action);
        bar->addAction(action);
        const IrisSlideView::AnnotationTool tool = t.tool;
        connect(action, &QAction::triggered, m_view, [this, tool] { m_view->setAnnotationTool(tool); });
        connect(m_view, &IrisSlideView::annotationToolChanged, action,
            [action, tool](IrisSlideView::AnnotationTool now) { action->setChecked(now == tool); });
    }
    // The length and area of the object selected or being drawn, in the status bar.
    auto *measurement = new QLabel(statusBar());
    measurement->setObjectName(QStringLiteral("annotationMeasurement"));
    statusBar()->addPermanentWidget(measurement);
    connect(m_view, &IrisSlideView::annotationMeasurementChanged, measurement, &QLabel::setText);
}

void MainWindow::showOpenFolderDialog()
{
    QSettings settings;
    const QString dir = settings.value(QStringLiteral("lastFolder"), QDir::homePath()).toString();
    // Window-modal and not blocking, so that the dialog is one of the window's children (tests
    // find and answer it); Qt's own dialog where the platform has none.
    auto *dialog = new QFileDialog(this, tr("Open DICOM Series Folder"), dir);
    dialog->setObjectName(QStringLiteral("openFolderDialog"));
    dialog->setFileMode(QFileDialog::Directory);
    dialog->setOption(QFileDialog::ShowDirsOnly);
    dialog->setAttribute(Qt::WA_DeleteOnClose);
    connect(dialog, &QFileDialog::fileSelected, this, [this](const QString &folder) {
        if (folder.isEmpty())
            return;
        QSettings().setValue(QStringLiteral("lastFolder"), QFileInfo(folder).absolutePath());
        openSlide(folder, true);
    });
    dialog->open();
}

void MainWindow::exportAsIris()
{
    if (!m_view->hasSlide())
        return;
    if (ExportDialog *dialog = ExportDialog::start(this, m_view->slidePath()))
        connect(dialog, &ExportDialog::openRequested, this, [this](const QString &path) { openSlide(path, true); });
}

void MainWindow::onSlideOpened(const IrisSlideInfo &info)
{
    setWindowTitle(tr("%1 — Iris View").arg(QFileInfo(info.path).fileName()));
    m_properties->showSlide(info);
    attachAnnotations(info);
    // The colour row and the associated images follow: the view announces colorManagementChanged.
    updateActions();
}

void MainWindow::onColorManagementChanged()
{
    m_colorAction->setChecked(m_view->colorManaged());
    const bool relative = m_view->renderingIntent() == IrisSlideView::RelativeColorimetric;
    (relative ? m_relativeAction : m_perceptualAction)->setChecked(true);
    m_perceptualAction->setEnabled(m_view->colorManaged());
    m_relativeAction->setEnabled(m_view->colorManaged());
    if (!m_view->hasSlide())
        return;
    m_properties->showColor(m_view->slideProfileDescription(), m_view->displayProfileDescription(),
        m_view->colorManaged(), m_view->isColorTransformApplied(), m_view->colorManagementError());
    m_images->clear();
    for (const QString &name : m_view->slideInfo().associatedImages)
        m_images->addImage(name, m_view->associatedImage(name));
}

void MainWindow::onSlideClosed()
{
    setWindowTitle(tr("Iris View"));
    m_properties->clear();
    m_images->clear();
    detachAnnotations();
    updateActions();
}

void MainWindow::onSlideError(const QString &message)
{
    statusBar()->showMessage(message, kMessageMs);
    if (m_userInitiated)
        QMessageBox::warning(this, tr("Cannot open the slide"), message);
}

void MainWindow::updateActions()
{
    const bool has = m_view->hasSlide();
    const bool magnifications = has && m_view->objectivePower() > 0;
    m_closeAction->setEnabled(has);
    m_exportAction->setEnabled(has);
    for (QAction *action : {m_importAnnotationsAction, m_exportAnnotationsAction, m_saveAnnotationsAction})
        action->setEnabled(has && m_annotations);
    m_fitAction->setEnabled(has);
    m_zoomInAction->setEnabled(has);
    m_zoomOutAction->setEnabled(has);
    for (QAction *action : std::as_const(m_presetActions))
        action->setEnabled(magnifications);
}

void MainWindow::attachAnnotations(const IrisSlideInfo &info)
{
    delete m_import.data(); // an import into the last slide's store: cancelled and joined
    m_annotations = std::make_shared<iris::AnnotationStore>();
    m_view->setAnnotations(m_annotations);
    m_annotationsDock->setStore(m_annotations, info.mppX, info.mppY);
    const QString slide = m_view->slidePath();
    if (RecentFiles::isUrl(slide))
        return;
    const QString beside = AnnotationFiles::besidePath(slide);
    if (QFileInfo(beside).isFile())
        startImport(beside, iris::AnnotationLoader::Mode::Replace, true);
}

void MainWindow::detachAnnotations()
{
    delete m_import.data();
    m_annotations.reset();
    m_view->setAnnotations(nullptr);
    m_annotationsDock->setStore(nullptr, 0, 0);
}

void MainWindow::showImportAnnotationsDialog()
{
    if (!m_annotations)
        return;
    QSettings settings;
    const QString slide = m_view->slidePath();
    const QString near = RecentFiles::isUrl(slide) ? QDir::homePath() : QFileInfo(slide).absolutePath();
    const QString dir = settings.value(QStringLiteral("annotations/lastFolder"), near).toString();
    const QString path = QFileDialog::getOpenFileName(
        this, tr("Import Annotations"), dir, AnnotationFiles::importFilters().join(QStringLiteral(";;")));
    if (path.isEmpty())
        return;
    settings.setValue(QStringLiteral("annotations/lastFolder"), QFileInfo(path).absolutePath());
    chooseModeAndImport(path);
}

bool MainWindow::chooseModeAndImport(const QString &path)
{
    if (!m_annotations)
        return false;
    auto mode = iris::AnnotationLoader::Mode::Replace;
    const qsizetype held = qsizetype(m_annotations->snapshot()->size());
    if (held > 0) {
        QMessageBox ask(QMessageBox::Question, tr("Import Annotations"),
            tr("The slide has %1 already.").arg(annotationCount(held)), QMessageBox::NoButton, this);
        ask.setObjectName(QStringLiteral("annotationImportModeBox"));
        ask.setInformativeText(tr("Add those of %1 to them, or replace them?").arg(QFileInfo(path).fileName()));
        QPushButton *append = ask.addButton(tr("&Append"), QMessageBox::AcceptRole);
        QPushButton *replace = ask.addButton(tr("&Replace"), QMessageBox::DestructiveRole);
        ask.addButton(QMessageBox::Cancel);
        ask.setDefaultButton(append);
        ask.exec();
        if (ask.clickedButton() == append)
            mode = iris::AnnotationLoader::Mode::Append;
        else if (ask.clickedButton() != replace)
            return false;
    }
    return importAnnotations(path, mode);
}

bool MainWindow::importAnnotations(const QString &path, iris::AnnotationLoader::Mode mode)
{
    if (!m_annotations)
        return false;
    if (m_import) {
        statusBar()->showMessage(tr("Annotations are being imported already; wait for that to finish."), kMessageMs);
        return false;
    }
    startImport(path, mode, false);
    return true;
}

void MainWindow::startImport(const QString &path, iris::AnnotationLoader::Mode mode, bool automatic)
{
    auto *import = new AnnotationImport(m_annotations, path, mode, this);
    import->setParent(this); // its destructor cancels and joins the loader's thread
    m_import = import;
    statusBar()->showMessage(tr("Reading annotations from %1…").arg(QDir::toNativeSeparators(path)));
    connect(import, &AnnotationImport::finished, this,
        [this, import, automatic](bool ok, bool cancelled, qsizetype objects, const QString &message) {
            onImportFinished(import, automatic, ok, cancelled, objects, message);
        });
}

void MainWindow::onImportFinished(
    AnnotationImport *import, bool automatic, bool ok, bool cancelled, qsizetype objects, const QString &message)
{
    const QString path = import->path();
    const QString name = QDir::toNativeSeparators(path);
    if (m_import == import)
        m_import = nullptr;
    import->deleteLater();
    if (ok) {
        statusBar()->showMessage(automatic ? tr("Restored %1 from %2").arg(annotationCount(objects), name)
                                           : tr("Imported %1 from %2").arg(annotationCount(objects), name),
            kMessageMs);
    } else if (cancelled) {
        statusBar()->showMessage(tr("Import of %1 cancelled; the annotations are as they were.").arg(name), kMessageMs);
    } else {
        statusBar()->showMessage(tr("Cannot import %1: %2").arg(name, message), kMessageMs);
        showAnnotationError(tr("Cannot import annotations"),
            tr("%1 could not be imported; the annotations are as they were.").arg(name), message);
    }
    Q_EMIT annotationImportFinished(path, ok, cancelled, message);
}

void MainWindow::showExportAnnotationsDialog()
{
    if (!m_annotations)
        return;
    QSettings settings;
    const QString slide = m_view->slidePath();
    QString suggested;
    if (RecentFiles::isUrl(slide)) {
        suggested = settings.value(QStringLiteral("annotations/lastFolder"), QDir::homePath()).toString()
            + QStringLiteral("/annotations.geojson");
    } else {
        const QFileInfo info(slide);
        suggested = settings.value(QStringLiteral("annotations/lastFolder"), info.absolutePath()).toString()
            + QLatin1Char('/') + info.completeBaseName() + QStringLiteral(".geojson");
    }
    QString filter = AnnotationFiles::geoJsonFilter();
    QString path = QFileDialog::getSaveFileName(this, tr("Export Annotations"), suggested,
        AnnotationFiles::exportFilters().join(QStringLiteral(";;")), &filter);
    if (path.isEmpty())
        return;
    path = AnnotationFiles::exportName(path, filter);
    settings.setValue(QStringLiteral("annotations/lastFolder"), QFileInfo(path).absolutePath());
    exportAnnotations(path);
}

bool MainWindow::exportAnnotations(const QString &path)
{
    if (!m_annotations)
        return false;
    startWrite(path, AnnotationFiles::formatOfName(path).value_or(iris::AnnotationFormat::GeoJson),
        tr("Cannot export annotations"));
    return true;
}

bool MainWindow::saveAnnotationsBesideSlide()
{
    if (!m_annotations)
        return false;
    const QString slide = m_view->slidePath();
    const QString why = AnnotationFiles::whyNotBeside(slide);
    if (!why.isEmpty()) {
        statusBar()->showMessage(why, kMessageMs);
        showAnnotationError(tr("Cannot save annotations beside the slide"), why);
        return false;
    }
    startWrite(AnnotationFiles::besidePath(slide), iris::AnnotationFormat::GeoJson,
        tr("Cannot save annotations beside the slide"));
    return true;
}

void MainWindow::startWrite(const QString &path, iris::AnnotationFormat format, const QString &failureTitle)
{
    // The snapshot as it is now: edits made while it is written are not in the file.
    auto snapshot = m_annotations->snapshot();
    const qsizetype objects = qsizetype(snapshot->size());
    ++m_writes;
    m_writing->show();
    statusBar()->showMessage(tr("Writing %1 to %2…").arg(annotationCount(objects), QDir::toNativeSeparators(path)));
    m_writer.start([this, snapshot = std::move(snapshot), path, format, failureTitle, objects] {
        const QString error = AnnotationFiles::write(*snapshot, path, format);
        QMetaObject::invokeMethod(
            this, [this, path, objects, failureTitle, error] { onWritten(path, objects, failureTitle, error); },
            Qt::QueuedConnection);
    });
}

void MainWindow::onWritten(const QString &path, qsizetype objects, const QString &failureTitle, const QString &error)
{
    m_writing->setVisible(--m_writes > 0);
    if (error.isEmpty()) {
        statusBar()->showMessage(
            tr("Saved %1 to %2").arg(annotationCount(objects), QDir::toNativeSeparators(path)), kMessageMs);
    } else {
        statusBar()->showMessage(error, kMessageMs);
        showAnnotationError(failureTitle, error);
    }
    Q_EMIT annotationsWritten(path, error.isEmpty(), error);
}

void MainWindow::showAnnotationError(const QString &title, const QString &text, const QString &details)
{
    auto *box = new QMessageBox(QMessageBox::Warning, title, text, QMessageBox::Ok, this);
    box->setObjectName(QStringLiteral("annotationErrorBox"));
    box->setInformativeText(details);
    box->setAttribute(Qt::WA_DeleteOnClose);
    box->open();
}

QString MainWindow::droppedSlide(const QMimeData *mime)
{
    if (!mime || !mime->hasUrls())
        return {};
    // A slide by its extension first; otherwise any file or folder (a DICOM series), and the
    // engine judges it.
    QString anyFile;
    for (const QUrl &url : mime->urls()) {
        const QString path = url.toLocalFile();
        const QFileInfo info(path);
        if (!url.isLocalFile() || !(info.isFile() || info.isDir()))
            continue;
        if (SlideFormats::looksLikeSlide(path))
            return path;
        if (anyFile.isEmpty())
            anyFile = path;
    }
    return anyFile;
}

void MainWindow::dragEnterEvent(QDragEnterEvent *event)
{
    if (!droppedSlide(event->mimeData()).isEmpty())
        event->acceptProposedAction();
}

void MainWindow::dragMoveEvent(QDragMoveEvent *event)
{
    if (!droppedSlide(event->mimeData()).isEmpty())
        event->acceptProposedAction();
}

void MainWindow::dropEvent(QDropEvent *event)
{
    const QString path = droppedSlide(event->mimeData());
    if (path.isEmpty())
        return;
    event->acceptProposedAction();
    // Leave the drag-and-drop machinery before a possible message box.
    QMetaObject::invokeMethod(this, [this, path] { openSlide(path, true); }, Qt::QueuedConnection);
}

void MainWindow::closeEvent(QCloseEvent *event)
{
    QSettings settings;
    settings.setValue(QStringLiteral("window/geometry"), saveGeometry());
    settings.setValue(QStringLiteral("window/state"), saveState());
    settings.setValue(QStringLiteral("view/enhance"), m_view->enhance());
    settings.setValue(QStringLiteral("view/colorManaged"), m_view->colorManaged());
    settings.setValue(QStringLiteral("view/renderingIntent"),
        m_view->renderingIntent() == IrisSlideView::RelativeColorimetric ? QStringLiteral("relative")
                                                                         : QStringLiteral("perceptual"));
    QMainWindow::closeEvent(event);
}
