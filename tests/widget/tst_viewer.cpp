// tst_viewer: the demo viewer's own windows (demo/, linked in as iris_viewer_ui) on an X
// display (Xvfb in CI) with lavapipe and the validation layers on:
//   * the recent files remember each slide's turn and flips, and only for slides of the list;
//   * View › Rotate / Flip / Reset act on the view, and a slide opened again comes back turned
//     and flipped as it was left, fitted that way;
//   * View › Compare… shows the open slide where it was and the others beside it, linked by
//     default, with a link toggle per view, a cross-hair in the other views, the menus acting
//     on the current view, and at most four slides, two by two.
// Settings go to a folder of the test's own (XDG_CONFIG_HOME), emptied first.

#include <cmath>
#include <memory>

#include <QtCore/QFileInfo>
#include <QtCore/QPointer>
#include <QtCore/QSettings>
#include <QtGui/QAction>
#include <QtGui/QCursor>
#include <QtGui/QScreen>
#include <QtGui/QWindow>
#include <QtTest/QSignalSpy>
#include <QtTest/QTest>
#include <QtWidgets/QApplication>
#include <QtWidgets/QFileDialog>
#include <QtWidgets/QLabel>
#include <QtWidgets/QToolBar>
#include <QtWidgets/QMenu>
#include <QtWidgets/QToolButton>

#include <iris/IrisSlideView.h>
#include <iris/IrisViewGroup.h>

#include "comparepane.h"
#include "comparewindow.h"
#include "enginehost_p.h"
#include "mainwindow.h"
#include "recentfiles.h"
#include "widget_test_support.h"

using namespace iriswidgettest;

namespace {

bool near(double a, double b, double tolerance)
{
    return std::abs(a - b) <= tolerance;
}

double distance(QPointF a, QPointF b)
{
    return std::hypot(a.x() - b.x(), a.y() - b.y());
}

QAction *action(const QWidget *window, const char *name)
{
    auto *found = window->findChild<QAction *>(QLatin1String(name));
    if (!found)
        qWarning("no action %s", name);
    return found;
}

double normalizedDegreesForTest(double degrees)
{
    const double r = std::fmod(degrees, 360.0);
    return r < 0 ? r + 360.0 : r;
}

RecentFiles::Orientation orientationOf(const IrisSlideView *view)
{
    return {view->rotation(), view->isFlippedHorizontally(), view->isFlippedVertically()};
}

} // namespace

class TstViewer : public QObject {
    Q_OBJECT

private Q_SLOTS:
    void initTestCase();
    void cleanup();
    void cleanupTestCase();

    void recentFilesRememberOrientation();
    void menuTurnsAndFlipsTheView();
    void reopenedSlideComesBackAsItWasLeft();
    void compareStartsWhereTheViewWasAndLinks();
    void compareLinkToggleCrosshairAndCurrentView();
    void compareHoldsFourSlidesTwoByTwo();
    void openDicomFolderFromTheFileMenu();
    void annotationToolsFromTheMenu();

private:
    // Shows the main window and opens `path` in it once its view is on screen.
    void showMain(const QString &path);
    void waitForSlides(CompareWindow *window);
    void checkValidation(const IrisSlideView *view);

    QString m_sample;
    QString m_second;
    std::unique_ptr<MainWindow> m_main;
};

void TstViewer::initTestCase()
{
    QCOMPARE(QGuiApplication::platformName(), QStringLiteral("xcb"));
    QVERIFY2(!qEnvironmentVariableIsEmpty("XDG_CONFIG_HOME"), "the test's settings need a folder of their own");
    QApplication::setOrganizationName(QStringLiteral("IrisView"));
    QApplication::setApplicationName(QStringLiteral("tst_viewer"));
    QSettings().clear();
    IrisSlideView::setVulkanValidation(true);
    QCursor::setPos(QGuiApplication::primaryScreen()->geometry().bottomRight());
    m_sample = sampleSlide();
    m_second = secondSampleSlide();
    QVERIFY(QFileInfo::exists(m_sample));
    QVERIFY(QFileInfo::exists(m_second));
}

void TstViewer::cleanup()
{
    if (m_main) {
        const QList<IrisSlideView *> views = m_main->findChildren<IrisSlideView *>();
        for (const IrisSlideView *view : views)
            checkValidation(view);
    }
    m_main.reset();
    QSettings().clear();
}

void TstViewer::cleanupTestCase()
{
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 0);
}

void TstViewer::checkValidation(const IrisSlideView *view)
{
    QVERIFY2(view->validationMessageCount() == 0,
             qPrintable(QStringLiteral("%1 Vulkan validation messages (see the log above)")
                            .arg(view->validationMessageCount())));
}

void TstViewer::showMain(const QString &path)
{
    m_main = std::make_unique<MainWindow>();
    m_main->resize(900, 650);
    m_main->show();
    QVERIFY(QTest::qWaitForWindowExposed(m_main.get()));
    QVERIFY(m_main->view()->isRendererAvailable());
    QTRY_VERIFY(m_main->view()->surfaceWindow()->isExposed());
    QVERIFY(m_main->openSlide(path, false));
}

void TstViewer::waitForSlides(CompareWindow *window)
{
    QTRY_VERIFY_WITH_TIMEOUT(
        [window] {
            for (int i = 0; i < window->count(); ++i) {
                if (!window->pane(i)->pendingPath().isEmpty() || !window->view(i)->hasSlide())
                    return false;
            }
            return true;
        }(),
        20000);
}

// Issue 15: File › Open DICOM Folder… opens a series given as its folder (the shared test data's
// two-file DICOM WSI), and the folder joins the recent files.
void TstViewer::openDicomFolderFromTheFileMenu()
{
    const QString boxes = testDataSlide(QStringLiteral("unsupported/dicom-boxes"));
    if (boxes.isEmpty())
        QSKIP("the shared test data's dicom-boxes series is not present");
    showMain(m_sample);
    auto *action = m_main->findChild<QAction *>(QStringLiteral("openFolderAction"));
    QVERIFY(action);
    QCOMPARE(action->shortcut(), QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_O));
    action->trigger();
    QFileDialog *dialog = nullptr;
    QTRY_VERIFY((dialog = m_main->findChild<QFileDialog *>(QStringLiteral("openFolderDialog"))) != nullptr);
    QCOMPARE(dialog->fileMode(), QFileDialog::Directory);
    QSignalSpy opened(m_main->view(), &IrisSlideView::slideOpened);
    dialog->setDirectory(QFileInfo(boxes).absolutePath());
    dialog->selectFile(boxes);
    QVERIFY(QMetaObject::invokeMethod(dialog, "accept")); // protected in QFileDialog, a slot of QDialog
    QVERIFY(opened.count() > 0 || opened.wait(20000));
    QCOMPARE(QFileInfo(m_main->view()->slidePath()).canonicalFilePath(), QFileInfo(boxes).canonicalFilePath());
    QVERIFY(m_main->view()->hasSlide());
    QCOMPARE(m_main->view()->slideInfo().vendor.isEmpty(), false);
}

// Issue 18: the Annotations menu and toolbar switch the view's tool, follow the view's own
// switches, and undo what the view's stack holds.
void TstViewer::annotationToolsFromTheMenu()
{
    showMain(m_sample);
    IrisSlideView *view = m_main->view();
    QCOMPARE(view->annotationTool(), IrisSlideView::Navigate);
    auto *rectangle = m_main->findChild<QAction *>(QStringLiteral("tool_rectangle"));
    auto *polygon = m_main->findChild<QAction *>(QStringLiteral("tool_polygon"));
    auto *navigate = m_main->findChild<QAction *>(QStringLiteral("tool_navigate"));
    QVERIFY(rectangle && polygon && navigate);
    QVERIFY(navigate->isChecked());
    rectangle->trigger();
    QCOMPARE(view->annotationTool(), IrisSlideView::Rectangle);
    QVERIFY(rectangle->isChecked() && !navigate->isChecked());
    view->setAnnotationTool(IrisSlideView::Polygon);
    QVERIFY(polygon->isChecked() && !rectangle->isChecked());
    QVERIFY(m_main->findChild<QToolBar *>(QStringLiteral("annotationToolBar")));
    QVERIFY(m_main->findChild<QLabel *>(QStringLiteral("annotationMeasurement")));
    navigate->trigger();
    QCOMPARE(view->annotationTool(), IrisSlideView::Navigate);
}

void TstViewer::recentFilesRememberOrientation()
{
    QMenu menu;
    RecentFiles recent(&menu);
    const QString a = QFileInfo(m_sample).absoluteFilePath();
    const QString b = QFileInfo(m_second).absoluteFilePath();
    const RecentFiles::Orientation turned{90, true, false};

    // Not in the list: not remembered.
    recent.setOrientation(a, turned);
    QVERIFY(recent.orientation(a).isDefault());

    recent.add(a);
    recent.add(b);
    recent.setOrientation(a, turned);
    recent.setOrientation(b, {217.5, false, true});
    QCOMPARE(recent.orientation(a), turned);
    QCOMPARE(recent.orientation(b), (RecentFiles::Orientation{217.5, false, true}));
    // Another RecentFiles (the next run) reads the same.
    QMenu otherMenu;
    QCOMPARE(RecentFiles(&otherMenu).orientation(a), turned);

    // Back to the default: forgotten.
    recent.setOrientation(b, {});
    QVERIFY(recent.orientation(b).isDefault());
    QVERIFY(!QSettings().value(QStringLiteral("recentOrientations")).toMap().contains(b));
    // Out of the list: forgotten too.
    recent.remove(a);
    QVERIFY(recent.orientation(a).isDefault());
    recent.add(a);
    QVERIFY(recent.orientation(a).isDefault());
}

void TstViewer::menuTurnsAndFlipsTheView()
{
    showMain(m_sample);
    IrisSlideView *view = m_main->view();
    QAction *clockwise = action(m_main.get(), "rotateClockwiseAction");
    QAction *anticlockwise = action(m_main.get(), "rotateAnticlockwiseAction");
    QAction *flipH = action(m_main.get(), "flipHorizontallyAction");
    QAction *flipV = action(m_main.get(), "flipVerticallyAction");
    QAction *reset = action(m_main.get(), "resetOrientationAction");
    QVERIFY(clockwise && anticlockwise && flipH && flipV && reset);
    // Ctrl chords: the view's own R and Shift+R stay the view's.
    QCOMPARE(clockwise->shortcut(), QKeySequence(Qt::CTRL | Qt::Key_R));
    QCOMPARE(anticlockwise->shortcut(), QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_R));

    clockwise->trigger();
    QVERIFY(near(view->rotation(), 90, 1e-9));
    anticlockwise->trigger();
    anticlockwise->trigger();
    QVERIFY(near(view->rotation(), 270, 1e-9));
    // Flips mirror what is on screen, whatever the turn: left and right change places.
    const QPointF middle(view->width() / 2.0, view->height() / 2.0);
    const QPointF right = view->mapToSlide(middle + QPointF(50, 20));
    flipH->trigger();
    QVERIFY(view->isFlippedHorizontally());
    QVERIFY(flipH->isChecked());
    QVERIFY(near(view->rotation(), 90, 1e-9)); // the slide's flip before a turn the other way
    QVERIFY(distance(view->mapFromSlide(right), middle + QPointF(-50, 20)) < 1e-6);
    const QPointF below = view->mapToSlide(middle + QPointF(-30, 40));
    flipV->trigger();
    QVERIFY(view->isFlippedVertically() && flipV->isChecked());
    QVERIFY(distance(view->mapFromSlide(below), middle + QPointF(-30, -40)) < 1e-6);
    flipV->trigger();
    QVERIFY(!view->isFlippedVertically() && !flipV->isChecked());
    // The checks follow the view, also when it is flipped from elsewhere.
    view->setFlippedVertically(true);
    QVERIFY(flipV->isChecked());
    reset->trigger();
    QCOMPARE(view->rotation(), 0.0);
    QVERIFY(!view->isFlippedHorizontally() && !view->isFlippedVertically());
    QVERIFY(!flipH->isChecked() && !flipV->isChecked());

    // No slide: nothing to turn.
    view->closeSlide();
    QVERIFY(!clockwise->isEnabled() && !flipH->isEnabled() && !reset->isEnabled());
}

void TstViewer::reopenedSlideComesBackAsItWasLeft()
{
    showMain(m_sample);
    IrisSlideView *view = m_main->view();
    action(m_main.get(), "rotateClockwiseAction")->trigger();
    action(m_main.get(), "flipHorizontallyAction")->trigger();
    const RecentFiles::Orientation left{270, true, false}; // a screen flip reverses the turn
    QCOMPARE(orientationOf(view), left);

    // Another slide opens as scanned.
    QVERIFY(m_main->openSlide(m_second, false));
    QCOMPARE(orientationOf(view), RecentFiles::Orientation{});
    // The first comes back turned and flipped, fitted that way: its corners inside the view.
    QVERIFY(m_main->openSlide(m_sample, false));
    QCOMPARE(orientationOf(view), left);
    const IrisSlideInfo info = view->slideInfo();
    const QRectF inside = QRectF(QPointF(0, 0), QSizeF(view->size())).adjusted(-1, -1, 1, 1);
    bool touches = false;
    for (const QPointF corner : {QPointF(0, 0), QPointF(info.width, 0), QPointF(0, info.height),
                                 QPointF(info.width, info.height)}) {
        const QPointF at = view->mapFromSlide(corner);
        QVERIFY2(inside.contains(at), qPrintable(QStringLiteral("corner at %1, %2").arg(at.x()).arg(at.y())));
        touches = touches || at.x() < 2 || at.y() < 2 || at.x() > view->width() - 2 || at.y() > view->height() - 2;
    }
    QVERIFY(touches); // fitted, not merely inside

    // And across runs: a new window reads the same settings.
    m_main.reset();
    showMain(m_sample);
    QCOMPARE(orientationOf(m_main->view()), left);
    // Reset is remembered as well (as nothing).
    action(m_main.get(), "resetOrientationAction")->trigger();
    QMenu menu;
    QVERIFY(RecentFiles(&menu).orientation(m_sample).isDefault());
}

void TstViewer::compareStartsWhereTheViewWasAndLinks()
{
    showMain(m_sample);
    IrisSlideView *main = m_main->view();
    main->setView(QPointF(2500, 1700), 1.5, 30);
    QPointer<CompareWindow> window = m_main->compare({m_second});
    QVERIFY(window);
    QVERIFY(QTest::qWaitForWindowExposed(window));
    waitForSlides(window);
    QCOMPARE(window->count(), 2);
    IrisSlideView *first = window->view(0);
    IrisSlideView *second = window->view(1);
    QCOMPARE(first->slidePath(), m_sample);
    QCOMPARE(second->slidePath(), m_second);
    QVERIFY(window->group()->isLinked(first) && window->group()->isLinked(second));
    QVERIFY(window->pane(0)->linkButton()->isChecked() && window->pane(1)->linkButton()->isChecked());

    // The open slide where the main window shows it; the other at the same place (the two
    // samples share their resolution and the offsets are the identity).
    QTRY_VERIFY(distance(first->centre(), QPointF(2500, 1700)) < 1e-6 && near(first->rotation(), 30, 1e-9));
    QVERIFY(near(first->downsample(), 1.5, 1e-9));
    QVERIFY(distance(second->centre(), first->centre()) < 1e-6);
    QVERIFY(near(second->downsample(), first->downsample(), 1e-9));
    QVERIFY(near(second->rotation(), 30, 1e-9));

    // Moving one moves the other.
    second->panBy(QPointF(25, -40));
    QVERIFY(distance(second->centre(), first->centre()) < 1e-6);
    first->zoomBy(2);
    QVERIFY(near(second->downsample(), first->downsample(), 1e-9));
    for (int i = 0; i < window->count(); ++i)
        checkValidation(window->view(i));
    window->close();
    QTRY_VERIFY(!window);
}

void TstViewer::compareLinkToggleCrosshairAndCurrentView()
{
    showMain(m_sample);
    QPointer<CompareWindow> window = m_main->compare({m_second});
    QVERIFY(QTest::qWaitForWindowExposed(window));
    waitForSlides(window);
    IrisSlideView *first = window->view(0);
    IrisSlideView *second = window->view(1);
    IrisViewGroup *group = window->group();

    // Unlinked by its button: the second view stays while the first moves.
    QTest::mouseClick(window->pane(1)->linkButton(), Qt::LeftButton);
    QVERIFY(!group->isLinked(second));
    QVERIFY(!window->pane(1)->linkButton()->isChecked());
    const QPointF secondCentre = second->centre();
    first->panBy(QPointF(60, 0));
    QCOMPARE(second->centre(), secondCentre);
    // Aligned by hand and linked again: both move together from there, the offset kept.
    second->panBy(QPointF(0, 30));
    QTest::mouseClick(window->pane(1)->linkButton(), Qt::LeftButton);
    QVERIFY(group->isLinked(second));
    const QPointF apart = second->centre() - first->centre();
    first->panBy(QPointF(-15, 22));
    QVERIFY(distance(second->centre() - first->centre(), apart) < 1e-6);
    // View › Link All Views links an unlinked one (without moving it).
    group->setLinked(second, false);
    QVERIFY(!window->pane(1)->linkButton()->isChecked()); // the button follows the group
    action(window, "linkAllAction")->trigger();
    QVERIFY(group->isLinked(second) && window->pane(1)->linkButton()->isChecked());

    // The pointer over the first: a cross-hair in the second, and the first is current.
    QTest::mouseMove(first->surfaceWindow(), QPoint(100, 80));
    QTRY_VERIFY(second->hasCrosshair());
    QVERIFY(!first->hasCrosshair());
    QCOMPARE(window->currentView(), first);
    QTest::mouseMove(second->surfaceWindow(), QPoint(120, 90));
    QTRY_VERIFY(first->hasCrosshair());
    QCOMPARE(window->currentView(), second);
    // View › Cursor Cross-hair off: none.
    action(window, "crosshairAction")->trigger();
    QVERIFY(!group->crosshairsEnabled());
    QVERIFY(!first->hasCrosshair());
    action(window, "crosshairAction")->trigger();

    // The window's Rotate acts on the current view, and the group turns both.
    const double before = first->rotation();
    action(window, "rotateClockwiseAction")->trigger();
    QVERIFY(near(second->rotation(), 90, 1e-9));
    QVERIFY(near(first->rotation(), normalizedDegreesForTest(before + 90), 1e-9));
    action(window, "flipVerticallyAction")->trigger();
    QVERIFY(first->isFlippedVertically() && second->isFlippedVertically());
    for (int i = 0; i < window->count(); ++i)
        checkValidation(window->view(i));
    window->close();
    QTRY_VERIFY(!window);
}

void TstViewer::compareHoldsFourSlidesTwoByTwo()
{
    showMain(m_sample);
    QPointer<CompareWindow> window = m_main->compare({m_second, m_sample, m_second, m_sample});
    QVERIFY(QTest::qWaitForWindowExposed(window));
    QCOMPARE(window->count(), CompareWindow::kMaxSlides); // the fifth left out
    QVERIFY(!window->addSlide(m_second));
    QVERIFY(!action(window, "addSlideAction")->isEnabled());
    waitForSlides(window);
    QCOMPARE(window->group()->views().size(), 4);

    // Two by two: the second beside the first, the third below it.
    const auto topLeft = [&](int i) { return window->pane(i)->mapTo(window, QPoint(0, 0)); };
    QVERIFY(topLeft(1).x() > topLeft(0).x() && topLeft(1).y() == topLeft(0).y());
    QVERIFY(topLeft(2).y() > topLeft(0).y() && topLeft(2).x() == topLeft(0).x());
    QVERIFY(topLeft(3).x() == topLeft(1).x() && topLeft(3).y() == topLeft(2).y());
    // Every view at the same place (the samples share their resolution).
    for (int i = 1; i < 4; ++i)
        QVERIFY(distance(window->view(i)->centre(), window->view(0)->centre()) < 1e-6);

    // A view removed by its close button leaves the group; the others go on together.
    QPointer<ComparePane> third = window->pane(2);
    QTest::mouseClick(third->closeButton(), Qt::LeftButton);
    QTRY_VERIFY(!third);
    QCOMPARE(window->count(), 3);
    QCOMPARE(window->group()->views().size(), 3);
    QVERIFY(action(window, "addSlideAction")->isEnabled());
    window->view(2)->panBy(QPointF(30, 30));
    QVERIFY(distance(window->view(0)->centre(), window->view(2)->centre()) < 1e-6);
    for (int i = 0; i < window->count(); ++i)
        checkValidation(window->view(i));
    window->close();
    QTRY_VERIFY(!window);
}

IRIS_WIDGET_TEST_MAIN(TstViewer)

#include "tst_viewer.moc"
