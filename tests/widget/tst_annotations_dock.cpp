// tst_annotations_dock: the demo viewer's annotations (demo/annotation*.{h,cpp} in
// MainWindow) on an X display (Xvfb in CI) with lavapipe and the validation layers on:
//   * a GeoJSON file written here (iris::writeGeoJson) and imported fills the dock: each
//     class's count and area (shoelace with a hole, a rectangle, an ellipse π·a·b) in µm² from
//     the sample's mpp; the object list selects in the view and centres it on a double-click;
//   * a class's check box and colour go to the store (setClassVisible / setClassColor);
//   * edits from another thread reach the dock, coalesced, and the object list fetches its
//     rows a batch at a time;
//   * export as GeoJSON and as ASAP XML, then import, gives the same document; Append adds;
//   * Save Annotations Beside Slide, another slide (a store of its own), the first again: the
//     annotations come back, with a status message counting them;
//   * a malformed file: a message box naming the file and the line, the store as it was;
//   * no slide: the menu entries are disabled; a DICOMweb slide cannot keep them beside it.
// Settings go to a folder of the test's own (XDG_CONFIG_HOME), emptied first.

#include <algorithm>
#include <functional>
#include <cmath>
#include <memory>
#include <numbers>
#include <thread>

#include <unistd.h>

#include <QtCore/QDir>
#include <QtCore/QFile>
#include <QtCore/QFileInfo>
#include <QtCore/QSettings>
#include <QtCore/QTemporaryDir>
#include <QtCore/QTimer>
#include <QtGui/QAction>
#include <QtGui/QCursor>
#include <QtGui/QScreen>
#include <QtGui/QWindow>
#include <QtTest/QSignalSpy>
#include <QtTest/QTest>
#include <QtWidgets/QApplication>
#include <QtWidgets/QCheckBox>
#include <QtWidgets/QColorDialog>
#include <QtWidgets/QMenu>
#include <QtWidgets/QMenuBar>
#include <QtWidgets/QMessageBox>
#include <QtWidgets/QProgressDialog>
#include <QtWidgets/QPushButton>
#include <QtWidgets/QScrollBar>
#include <QtWidgets/QStatusBar>
#include <QtWidgets/QTableView>

#include <iris/IrisSlideView.h>
#include <iris/annotations.h>

#include "annotationfiles.h"
#include "annotationmodels.h"
#include "annotationsdock.h"
#include "enginehost_p.h"
#include "mainwindow.h"
#include "widget_test_support.h"

using namespace iriswidgettest;
using Mode = iris::AnnotationLoader::Mode;

namespace {

constexpr int kWaitMs = 20000;

QAction* action(const QWidget* window, const char* name) {
    auto* found = window->findChild<QAction*>(QLatin1String(name));
    if (!found) qWarning("no action %s", name);
    return found;
}

iris::AnnotationObject polygon(uint64_t id, std::string cls, std::vector<iris::Point2> outer,
                               std::vector<std::vector<iris::Point2>> holes = {}) {
    iris::AnnotationObject o;
    o.id = id;
    o.kind = iris::AnnotationKind::Polygon;
    o.className = std::move(cls);
    o.polygons.push_back({std::move(outer), std::move(holes)});
    return o;
}

iris::AnnotationObject boxed(uint64_t id, iris::AnnotationKind kind, std::string cls, iris::Box2 box) {
    iris::AnnotationObject o;
    o.id = id;
    o.kind = kind;
    o.className = std::move(cls);
    o.box = box;
    return o;
}

// Five objects in three classes (Unclassified included):
//   Tumor:  a 400² square less a 100² hole (150 000 px²) and a 300 × 200 rectangle (60 000)
//   Stroma: an ellipse in a 400 × 200 box (π·200·100) and a detected triangle (5 000)
//   —:      a point (no area)
iris::AnnotationDocument testDocument() {
    iris::AnnotationDocument doc;
    iris::AnnotationObject outline = polygon(1, "Tumor", {{1000, 1000}, {1400, 1000}, {1400, 1400}, {1000, 1400}},
                                             {{{1100, 1100}, {1200, 1100}, {1200, 1200}, {1100, 1200}}});
    outline.name = "Tumour outline";
    outline.fill = true;
    doc.objects.push_back(outline);
    doc.objects.push_back(boxed(2, iris::AnnotationKind::Rectangle, "Tumor", {2000, 1000, 2300, 1200}));
    doc.objects.push_back(boxed(3, iris::AnnotationKind::Ellipse, "Stroma", {3000, 2000, 3400, 2200}));
    iris::AnnotationObject cell = polygon(5, "Stroma", {{100, 100}, {200, 100}, {100, 200}});
    cell.type = iris::AnnotationType::Detection;
    cell.measurements = {{"Nucleus: Area", 12.5}};
    doc.objects.push_back(cell);
    iris::AnnotationObject point;
    point.id = 4;
    point.kind = iris::AnnotationKind::Point;
    point.points = {{500, 500}};
    point.name = "mitosis";
    doc.objects.push_back(point);
    doc.classes = {{"Tumor", {200, 0, 0, 255}, true}, {"Stroma", {0, 150, 0, 255}, true}};
    return doc;
}
constexpr double kTumorArea = 400.0 * 400 - 100 * 100 + 300 * 200;
const double kStromaArea = std::numbers::pi * 200 * 100 + 5000;

bool writeText(const QString& path, const std::string& text) {
    QFile file(path);
    return file.open(QIODevice::WriteOnly) && file.write(text.data(), qint64(text.size())) == qint64(text.size());
}

// Objects by id and classes by name: the store keeps objects in its own order.
iris::AnnotationDocument sorted(iris::AnnotationDocument doc) {
    std::sort(doc.objects.begin(), doc.objects.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
    std::sort(doc.classes.begin(), doc.classes.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
    return doc;
}

bool sameDocument(const iris::AnnotationDocument& a, const iris::AnnotationDocument& b) {
    const iris::AnnotationDocument x = sorted(a), y = sorted(b);
    return x.objects == y.objects && x.classes == y.classes;
}

QMessageBox* errorBox(const QWidget* window) {
    for (QMessageBox* box : window->findChildren<QMessageBox*>(QStringLiteral("annotationErrorBox"))) {
        if (box->isVisible()) return box;
    }
    return nullptr;
}

} // namespace

class TstAnnotationsDock : public QObject {
    Q_OBJECT

private Q_SLOTS:
    void initTestCase();
    void cleanup();
    void cleanupTestCase();

    void areasAndTheirUnits();
    void importFillsTheDock();
    void classVisibilityAndColourGoToTheStore();
    void editsFromAnotherThreadAndLazyRows();
    void exportThenImportRoundTrips();
    void savedBesideTheSlideComesBack();
    void malformedFileShowsErrorAndKeepsTheStore();
    void appendOrReplaceIsAsked();
    void cancelledImportChangesNothing();
    void noSlideNoAnnotationActions();

private:
    void showMain(const QString& path);
    // Imports `path` and waits for the outcome; the dock is then brought up to date.
    void importAndWait(const QString& path, Mode mode, bool expectOk = true);
    // Waits for the write that `start` begins (an export or a save beside the slide).
    void writeAndWait(const std::function<bool()>& start, const QString& path, bool expectOk = true);
    // Waits until the dock shows the store's newest snapshot.
    void waitForDock();
    void checkValidation(const IrisSlideView* view);

    QTemporaryDir m_dir;
    QString m_sample;
    QString m_second;
    QString m_good; // testDocument() as GeoJSON
    std::unique_ptr<MainWindow> m_main;
};

void TstAnnotationsDock::initTestCase() {
    QCOMPARE(QGuiApplication::platformName(), QStringLiteral("xcb"));
    QVERIFY2(!qEnvironmentVariableIsEmpty("XDG_CONFIG_HOME"), "the test's settings need a folder of their own");
    QApplication::setOrganizationName(QStringLiteral("IrisView"));
    QApplication::setApplicationName(QStringLiteral("tst_annotations_dock"));
    QSettings().clear();
    IrisSlideView::setVulkanValidation(true);
    QCursor::setPos(QGuiApplication::primaryScreen()->geometry().bottomRight());
    QVERIFY(m_dir.isValid());
    // The slides are copies in a folder of the test's own: saving beside them leaves nothing
    // beside the fixtures' samples, which other suites open.
    m_sample = m_dir.filePath(QStringLiteral("sample.tiff"));
    m_second = m_dir.filePath(QStringLiteral("second.tiff"));
    QVERIFY(QFile::copy(sampleSlide(), m_sample));
    QVERIFY(QFile::copy(secondSampleSlide(), m_second));
    m_good = m_dir.filePath(QStringLiteral("good.geojson"));
    QVERIFY(writeText(m_good, iris::writeGeoJson(testDocument())));
}

void TstAnnotationsDock::cleanup() {
    if (m_main) checkValidation(m_main->view());
    m_main.reset();
    QSettings().clear();
    for (const QString& slide : {m_sample, m_second}) QFile::remove(AnnotationFiles::besidePath(slide));
}

void TstAnnotationsDock::cleanupTestCase() { QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 0); }

void TstAnnotationsDock::checkValidation(const IrisSlideView* view) {
    QVERIFY2(
        view->validationMessageCount() == 0,
        qPrintable(
            QStringLiteral("%1 Vulkan validation messages (see the log above)").arg(view->validationMessageCount())));
}

void TstAnnotationsDock::showMain(const QString& path) {
    m_main = std::make_unique<MainWindow>();
    m_main->resize(1100, 800);
    m_main->show();
    QVERIFY(QTest::qWaitForWindowExposed(m_main.get()));
    QVERIFY(m_main->view()->isRendererAvailable());
    QTRY_VERIFY(m_main->view()->surfaceWindow()->isExposed());
    QVERIFY(m_main->openSlide(path, false));
    AnnotationsDock* dock = m_main->annotationsDock();
    dock->show();
    dock->raise(); // tabbed with the associated images
    QTRY_VERIFY(dock->objectTable()->isVisible());
}

void TstAnnotationsDock::importAndWait(const QString& path, Mode mode, bool expectOk) {
    QSignalSpy finished(m_main.get(), &MainWindow::annotationImportFinished);
    QVERIFY(m_main->importAnnotations(path, mode));
    QVERIFY(finished.wait(kWaitMs));
    QCOMPARE(finished.size(), 1);
    QCOMPARE(finished.first().at(0).toString(), path);
    QVERIFY2(finished.first().at(1).toBool() == expectOk, qPrintable(finished.first().at(3).toString()));
    waitForDock();
}

void TstAnnotationsDock::writeAndWait(const std::function<bool()>& start, const QString& path, bool expectOk) {
    QSignalSpy written(m_main.get(), &MainWindow::annotationsWritten);
    QVERIFY(start());
    QVERIFY(written.wait(kWaitMs));
    QCOMPARE(written.size(), 1);
    QCOMPARE(written.first().at(0).toString(), path);
    QVERIFY2(written.first().at(1).toBool() == expectOk, qPrintable(written.first().at(2).toString()));
}

void TstAnnotationsDock::waitForDock() {
    const auto store = m_main->annotationStore();
    QVERIFY(store);
    QTRY_COMPARE_WITH_TIMEOUT(m_main->annotationsDock()->shownGeneration(), store->snapshot()->generation(), kWaitMs);
}

void TstAnnotationsDock::areasAndTheirUnits() {
    // The shoelace in either winding, holes subtracted, several parts added.
    const std::vector<iris::Point2> square{{0, 0}, {10, 0}, {10, 10}, {0, 10}};
    std::vector<iris::Point2> reversed(square.rbegin(), square.rend());
    QCOMPARE(AnnotationMeasure::ringArea(square), 100.0);
    QCOMPARE(AnnotationMeasure::ringArea(reversed), 100.0);
    iris::AnnotationObject two = polygon(0, "", square, {{{2, 2}, {4, 2}, {4, 4}}});
    two.polygons.push_back({{{1e6, 1e6}, {1e6 + 3, 1e6}, {1e6 + 3, 1e6 + 2}, {1e6, 1e6 + 2}}, {}});
    QCOMPARE(AnnotationMeasure::area(two), 100.0 - 2 + 6);
    QCOMPARE(AnnotationMeasure::area(boxed(0, iris::AnnotationKind::Rectangle, "", {0, 0, 4, 5})), 20.0);
    QVERIFY(std::abs(AnnotationMeasure::area(boxed(0, iris::AnnotationKind::Ellipse, "", {0, 0, 4, 2})) -
                     std::numbers::pi * 2 * 1) < 1e-12);
    iris::AnnotationObject line;
    line.kind = iris::AnnotationKind::Polyline;
    line.points = {{0, 0}, {5, 5}, {0, 5}};
    QCOMPARE(AnnotationMeasure::area(line), 0.0);

    // µm² below a square millimetre, mm² from there, px² without a resolution.
    QLocale::setDefault(QLocale::c());
    QCOMPARE(AnnotationMeasure::formatArea(1000, 0.5, 0.25), QStringLiteral("125.0 µm²"));
    QCOMPARE(AnnotationMeasure::formatArea(2e7, 0.25, 0.25), QStringLiteral("1.250 mm²"));
    QCOMPARE(AnnotationMeasure::formatArea(1234.4, 0, 0), QStringLiteral("1234 px²"));
}

void TstAnnotationsDock::importFillsTheDock() {
    showMain(m_sample);
    IrisSlideView* view = m_main->view();
    const IrisSlideInfo info = view->slideInfo();
    QVERIFY(info.mppX > 0 && info.mppY > 0);
    const auto store = m_main->annotationStore();
    QVERIFY(store);
    QCOMPARE(view->annotations(), store);
    importAndWait(m_good, Mode::Replace);
    QCOMPARE(store->snapshot()->size(), size_t(5));
    QVERIFY(m_main->statusBar()->currentMessage().contains(QStringLiteral("Imported 5 annotations")));

    // One row per class: counts and areas (px² in ValueRole, shown in µm²).
    AnnotationClassModel* classes = m_main->annotationsDock()->classModel();
    QCOMPARE(classes->rowCount(), 3);
    const auto cell = [&](const char* cls, int column, int role) {
        return classes->index(classes->rowOf(QLatin1String(cls)), column).data(role);
    };
    QCOMPARE(cell("Tumor", AnnotationClassModel::CountColumn, AnnotationClassModel::ValueRole).toLongLong(), 2);
    QCOMPARE(cell("Stroma", AnnotationClassModel::CountColumn, AnnotationClassModel::ValueRole).toLongLong(), 2);
    QCOMPARE(cell("", AnnotationClassModel::CountColumn, AnnotationClassModel::ValueRole).toLongLong(), 1);
    QVERIFY(std::abs(cell("Tumor", AnnotationClassModel::AreaColumn, AnnotationClassModel::ValueRole).toDouble() -
                     kTumorArea) < 1e-6);
    QVERIFY(std::abs(cell("Stroma", AnnotationClassModel::AreaColumn, AnnotationClassModel::ValueRole).toDouble() -
                     kStromaArea) < 1e-6);
    QCOMPARE(cell("", AnnotationClassModel::AreaColumn, AnnotationClassModel::ValueRole).toDouble(), 0.0);
    QCOMPARE(cell("Tumor", AnnotationClassModel::AreaColumn, Qt::DisplayRole).toString(),
             AnnotationMeasure::formatArea(kTumorArea, info.mppX, info.mppY));
    QVERIFY(
        cell("Tumor", AnnotationClassModel::AreaColumn, Qt::DisplayRole).toString().endsWith(QStringLiteral(" µm²")));
    QCOMPARE(cell("Tumor", AnnotationClassModel::NameColumn, Qt::DisplayRole).toString(), QStringLiteral("Tumor"));
    QCOMPARE(cell("", AnnotationClassModel::NameColumn, Qt::DisplayRole).toString(), QStringLiteral("Unclassified"));
    QCOMPARE(cell("Tumor", AnnotationClassModel::ColourColumn, Qt::DecorationRole).value<QColor>(), QColor(200, 0, 0));
    QCOMPARE(cell("Tumor", AnnotationClassModel::NameColumn, Qt::CheckStateRole).value<Qt::CheckState>(), Qt::Checked);
    QCOMPARE(classes->rowOf(QString()), 2); // unclassified last

    // The object list: every object, with its name or kind and its area.
    AnnotationObjectModel* objects = m_main->annotationsDock()->objectModel();
    QCOMPARE(objects->objectCount(), 5);
    QCOMPARE(objects->rowCount(), 5);
    int ellipse = -1, outline = -1;
    for (int row = 0; row < objects->rowCount(); ++row) {
        const quint64 id = objects->index(row, 0).data(AnnotationObjectModel::IdRole).toULongLong();
        if (id == 3) ellipse = row;
        if (id == 1) outline = row;
    }
    QVERIFY(ellipse >= 0 && outline >= 0);
    QCOMPARE(objects->index(outline, AnnotationObjectModel::NameColumn).data().toString(),
             QStringLiteral("Tumour outline"));
    QCOMPARE(objects->index(ellipse, AnnotationObjectModel::NameColumn).data().toString(), QStringLiteral("Ellipse"));
    QCOMPARE(objects->index(ellipse, AnnotationObjectModel::ClassColumn).data().toString(), QStringLiteral("Stroma"));
    QCOMPARE(objects->index(outline, AnnotationObjectModel::AreaColumn).data().toString(),
             AnnotationMeasure::formatArea(150000, info.mppX, info.mppY));

    // A click selects in the view; a double-click centres the view on the object.
    QTableView* table = m_main->annotationsDock()->objectTable();
    const QModelIndex at = objects->index(ellipse, AnnotationObjectModel::NameColumn);
    table->scrollTo(at);
    QTest::mouseClick(table->viewport(), Qt::LeftButton, {}, table->visualRect(at).center());
    QCOMPARE(view->selectedAnnotation(), quint64(3));
    QTest::mouseDClick(table->viewport(), Qt::LeftButton, {}, table->visualRect(at).center());
    QTRY_VERIFY(std::hypot(view->centre().x() - 3200, view->centre().y() - 2100) < 1e-6);

    // A selection made in the view moves the list's current row, also across a new summary
    // that resets the list (an object added).
    const auto currentId = [&] { return table->currentIndex().data(AnnotationObjectModel::IdRole).toULongLong(); };
    view->setSelectedAnnotation(1);
    QCOMPARE(currentId(), quint64(1));
    QVERIFY(store->add(boxed(0, iris::AnnotationKind::Rectangle, "Tumor", {10, 10, 20, 20})).ok());
    waitForDock();
    QCOMPARE(objects->objectCount(), 6);
    QCOMPARE(view->selectedAnnotation(), quint64(1));
    QCOMPARE(currentId(), quint64(1));
    view->setSelectedAnnotation(0);
    QVERIFY(!table->selectionModel()->hasSelection());

    // The dock's check box shows and hides them all.
    auto* showAll = m_main->annotationsDock()->findChild<QCheckBox*>(QStringLiteral("showAnnotationsCheck"));
    QVERIFY(showAll && showAll->isChecked());
    showAll->click();
    QVERIFY(!view->annotationsVisible());
    view->setAnnotationsVisible(true);
    QVERIFY(showAll->isChecked());
}

void TstAnnotationsDock::classVisibilityAndColourGoToTheStore() {
    showMain(m_sample);
    importAndWait(m_good, Mode::Replace);
    const auto store = m_main->annotationStore();
    AnnotationClassModel* classes = m_main->annotationsDock()->classModel();
    const int tumor = classes->rowOf(QStringLiteral("Tumor"));
    QVERIFY(tumor >= 0);
    const QModelIndex check = classes->index(tumor, AnnotationClassModel::NameColumn);
    QVERIFY(classes->flags(check) & Qt::ItemIsUserCheckable);

    QVERIFY(classes->setData(check, Qt::Unchecked, Qt::CheckStateRole));
    QVERIFY(!store->snapshot()->classInfo("Tumor").visible);
    QVERIFY(store->snapshot()->classInfo("Stroma").visible);
    waitForDock();
    // The rows stayed (no object changed) and show the class hidden.
    QCOMPARE(classes->rowOf(QStringLiteral("Tumor")), tumor);
    QCOMPARE(check.data(Qt::CheckStateRole).value<Qt::CheckState>(), Qt::Unchecked);
    QVERIFY(classes->setData(check, Qt::Checked, Qt::CheckStateRole));
    QVERIFY(store->snapshot()->classInfo("Tumor").visible);
    // Through the table's own check box: Space on the current cell, as a user would.
    QTableView* table = m_main->annotationsDock()->classTable();
    table->setFocus();
    table->setCurrentIndex(check);
    QTest::keyClick(table, Qt::Key_Space);
    QVERIFY(!store->snapshot()->classInfo("Tumor").visible);
    QTest::keyClick(table, Qt::Key_Space);
    QVERIFY(store->snapshot()->classInfo("Tumor").visible);

    const QModelIndex swatch = classes->index(tumor, AnnotationClassModel::ColourColumn);
    QVERIFY(classes->setData(swatch, QColor(10, 20, 30, 200), Qt::EditRole));
    QCOMPARE(store->snapshot()->classInfo("Tumor").color, (iris::Rgba8{10, 20, 30, 200}));
    waitForDock();
    QCOMPARE(swatch.data(Qt::DecorationRole).value<QColor>(), QColor(10, 20, 30, 200));

    // A click on the swatch opens the colour dialog; its choice goes to the store.
    auto* chooser = new QTimer(this);
    chooser->setInterval(20);
    connect(chooser, &QTimer::timeout, chooser, [chooser] {
        for (QWidget* w : QApplication::topLevelWidgets()) {
            if (auto* dialog = qobject_cast<QColorDialog*>(w)) {
                dialog->setCurrentColor(QColor(40, 50, 60));
                dialog->accept();
                chooser->deleteLater();
                return;
            }
        }
    });
    chooser->start();
    table->scrollTo(swatch);
    QTest::mouseClick(table->viewport(), Qt::LeftButton, {}, table->visualRect(swatch).center());
    QCOMPARE(store->snapshot()->classInfo("Tumor").color, (iris::Rgba8{40, 50, 60, 255}));
}

void TstAnnotationsDock::editsFromAnotherThreadAndLazyRows() {
    showMain(m_sample);
    const auto store = m_main->annotationStore();
    AnnotationsDock* dock = m_main->annotationsDock();
    QSignalSpy refreshed(dock, &AnnotationsDock::refreshed);

    // A batch from a worker thread, then single additions one after another: the dock
    // catches up without a refresh per edit.
    constexpr int kBatch = 5000, kSingles = 100;
    std::thread writer([store] {
        std::vector<iris::AnnotationObject> many;
        for (int i = 0; i < kBatch; ++i) {
            const double x = 10 + (i % 100) * 50, y = 10 + (i / 100) * 50;
            iris::AnnotationObject o = polygon(0, "Cell", {{x, y}, {x + 20, y}, {x + 20, y + 10}, {x, y + 10}});
            o.type = iris::AnnotationType::Detection;
            many.push_back(std::move(o));
        }
        (void)store->addBatch(std::move(many));
        for (int i = 0; i < kSingles; ++i)
            (void)store->add(boxed(0, iris::AnnotationKind::Rectangle, "Other", {0, 0, 10, double(1 + i)}));
    });
    // The GUI thread goes on meanwhile (refreshing as the edits come), then catches up.
    QTRY_COMPARE_WITH_TIMEOUT(store->snapshot()->size(), size_t(kBatch + kSingles), kWaitMs);
    writer.join();
    waitForDock();
    qInfo("%lld refreshes for %d publications", qlonglong(refreshed.size()), 1 + kSingles);
    QVERIFY2(refreshed.size() < kSingles / 2, qPrintable(QStringLiteral("%1 refreshes").arg(refreshed.size())));

    AnnotationClassModel* classes = dock->classModel();
    QCOMPARE(classes->index(classes->rowOf(QStringLiteral("Cell")), AnnotationClassModel::CountColumn)
                 .data(AnnotationClassModel::ValueRole)
                 .toLongLong(),
             kBatch);
    QCOMPARE(classes->index(classes->rowOf(QStringLiteral("Cell")), AnnotationClassModel::AreaColumn)
                 .data(AnnotationClassModel::ValueRole)
                 .toDouble(),
             200.0 * kBatch);
    QCOMPARE(classes->index(classes->rowOf(QStringLiteral("Other")), AnnotationClassModel::CountColumn)
                 .data(AnnotationClassModel::ValueRole)
                 .toLongLong(),
             kSingles);

    // The list holds a batch of rows, more as it scrolls to the end.
    AnnotationObjectModel* objects = dock->objectModel();
    QCOMPARE(objects->objectCount(), kBatch + kSingles);
    QCOMPARE(objects->rowCount(), AnnotationObjectModel::kFetchBatch);
    QTableView* table = dock->objectTable();
    table->scrollToBottom();
    QTRY_VERIFY(objects->rowCount() >= 2 * AnnotationObjectModel::kFetchBatch);
    QVERIFY(objects->rowCount() < objects->objectCount());
}

void TstAnnotationsDock::exportThenImportRoundTrips() {
    showMain(m_sample);
    importAndWait(m_good, Mode::Replace);
    const auto store = m_main->annotationStore();
    const iris::AnnotationDocument before = iris::documentOf(*store->snapshot());
    QVERIFY(sorted(before).objects == sorted(testDocument()).objects);

    for (const char* name : {"out.geojson", "out.xml"}) {
        const QString path = m_dir.filePath(QLatin1String(name));
        writeAndWait([&] { return m_main->exportAnnotations(path); }, path);
        QFile file(path);
        QVERIFY(file.open(QIODevice::ReadOnly));
        const QByteArray text = file.readAll();
        const auto format = iris::detectAnnotationFormat(std::string_view(text.constData(), size_t(text.size())));
        QVERIFY(format);
        QCOMPARE(*format, path.endsWith(QLatin1String(".xml")) ? iris::AnnotationFormat::AsapXml
                                                               : iris::AnnotationFormat::GeoJson);
        // Something else first, then the file: the same document again.
        QVERIFY(store->replaceAll({}, {}).ok());
        importAndWait(path, Mode::Replace);
        QVERIFY2(sameDocument(iris::documentOf(*store->snapshot()), before), name);
    }
    // Append: the file's objects beside those held, with fresh ids.
    importAndWait(m_good, Mode::Append);
    QCOMPARE(store->snapshot()->size(), size_t(10));
    AnnotationClassModel* classes = m_main->annotationsDock()->classModel();
    QCOMPARE(classes->index(classes->rowOf(QStringLiteral("Tumor")), AnnotationClassModel::CountColumn)
                 .data(AnnotationClassModel::ValueRole)
                 .toLongLong(),
             4);

    // A write that fails (no such folder) says so and leaves nothing behind.
    const QString nowhere = m_dir.filePath(QStringLiteral("missing/out.geojson"));
    writeAndWait([&] { return m_main->exportAnnotations(nowhere); }, nowhere, false);
    QVERIFY(!QFileInfo::exists(nowhere));
    QMessageBox* box = errorBox(m_main.get());
    QVERIFY(box);
    QVERIFY2(box->text().contains(QStringLiteral("out.geojson")), qPrintable(box->text()));
    box->close();
    // The name picks the format; a name without one of the two suffixes takes the filter's.
    QCOMPARE(AnnotationFiles::exportName(QStringLiteral("/a/b"), AnnotationFiles::asapFilter()),
             QStringLiteral("/a/b.xml"));
    QCOMPARE(AnnotationFiles::exportName(QStringLiteral("/a/b"), AnnotationFiles::geoJsonFilter()),
             QStringLiteral("/a/b.geojson"));
    QCOMPARE(AnnotationFiles::exportName(QStringLiteral("/a/b.xml"), AnnotationFiles::geoJsonFilter()),
             QStringLiteral("/a/b.xml"));
}

void TstAnnotationsDock::savedBesideTheSlideComesBack() {
    showMain(m_second);
    const auto first = m_main->annotationStore();
    importAndWait(m_good, Mode::Replace);
    const iris::AnnotationDocument saved = iris::documentOf(*first->snapshot());
    QAction* save = action(m_main.get(), "saveAnnotationsAction");
    QVERIFY(save && save->isEnabled());
    QCOMPARE(save->shortcut(), QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_S));
    const QString beside = m_second + QStringLiteral(".annotations.geojson");
    writeAndWait(
        [&] {
            save->trigger();
            return true;
        },
        beside);
    QVERIFY(QFileInfo(beside).isFile());
    QVERIFY(m_main->statusBar()->currentMessage().contains(QStringLiteral("Saved 5 annotations")));

    // Another slide: a store of its own, empty, on the view and in the dock.
    QVERIFY(m_main->openSlide(m_sample, false));
    const auto other = m_main->annotationStore();
    QVERIFY(other && other != first);
    QCOMPARE(m_main->view()->annotations(), other);
    QCOMPARE(other->snapshot()->size(), size_t(0));
    waitForDock();
    QCOMPARE(m_main->annotationsDock()->objectModel()->objectCount(), 0);
    QCOMPARE(m_main->annotationsDock()->classModel()->rowCount(), 0);

    // The first again: its annotations read back from beside it.
    QSignalSpy finished(m_main.get(), &MainWindow::annotationImportFinished);
    QVERIFY(m_main->openSlide(m_second, false));
    QVERIFY(finished.wait(kWaitMs));
    QCOMPARE(finished.first().at(0).toString(), beside);
    QVERIFY(finished.first().at(1).toBool());
    const auto again = m_main->annotationStore();
    QVERIFY(sameDocument(iris::documentOf(*again->snapshot()), saved));
    QVERIFY2(m_main->statusBar()->currentMessage().contains(QStringLiteral("Restored 5 annotations")),
             qPrintable(m_main->statusBar()->currentMessage()));
    waitForDock();
    QCOMPARE(m_main->annotationsDock()->objectModel()->objectCount(), 5);
}

void TstAnnotationsDock::malformedFileShowsErrorAndKeepsTheStore() {
    showMain(m_sample);
    importAndWait(m_good, Mode::Replace);
    const auto store = m_main->annotationStore();
    const auto before = store->snapshot();

    const QString bad = m_dir.filePath(QStringLiteral("broken.geojson"));
    QVERIFY(writeText(
        bad,
        "{\"type\": \"FeatureCollection\",\n"
        " \"features\": [\n"
        "  {\"type\": \"Feature\", \"geometry\": {\"type\": \"Point\", \"coordinates\": [1, 2]}, \"properties\": {]}\n"
        " ]}\n"));
    for (const Mode mode : {Mode::Replace, Mode::Append}) {
        importAndWait(bad, mode, false);
        QCOMPARE(store->snapshot(), before); // not even a new publication
        QMessageBox* box = nullptr;
        QTRY_VERIFY((box = errorBox(m_main.get())) != nullptr);
        QVERIFY2(box->text().contains(QStringLiteral("broken.geojson")), qPrintable(box->text()));
        QVERIFY2(box->informativeText().contains(QStringLiteral("line 3")), qPrintable(box->informativeText()));
        box->close();
        QTRY_VERIFY(!errorBox(m_main.get()));
    }
    QCOMPARE(m_main->annotationsDock()->objectModel()->objectCount(), 5);

    // A file that is not there says so, too.
    importAndWait(m_dir.filePath(QStringLiteral("absent.geojson")), Mode::Replace, false);
    QMessageBox* box = nullptr;
    QTRY_VERIFY((box = errorBox(m_main.get())) != nullptr);
    QVERIFY(box->text().contains(QStringLiteral("absent.geojson")));
    box->close();
    QCOMPARE(store->snapshot(), before);
}

void TstAnnotationsDock::appendOrReplaceIsAsked() {
    showMain(m_sample);
    // An empty store: nothing to ask, the file replaces nothing.
    QSignalSpy finished(m_main.get(), &MainWindow::annotationImportFinished);
    QVERIFY(m_main->chooseModeAndImport(m_good));
    QVERIFY(finished.wait(kWaitMs));
    const auto store = m_main->annotationStore();
    QCOMPARE(store->snapshot()->size(), size_t(5));

    // Now the question, answered by a click on one of its buttons once it shows.
    const auto answer = [](const QString& button) {
        auto* timer = new QTimer;
        timer->setInterval(20);
        QObject::connect(timer, &QTimer::timeout, timer, [timer, button] {
            auto* box = qobject_cast<QMessageBox*>(QApplication::activeModalWidget());
            if (!box || box->objectName() != QLatin1String("annotationImportModeBox")) return;
            for (QAbstractButton* b : box->buttons()) {
                if (b->text().remove(QLatin1Char('&')) == button) {
                    b->click();
                    timer->deleteLater();
                    return;
                }
            }
        });
        timer->start();
    };
    answer(QStringLiteral("Cancel"));
    QVERIFY(!m_main->chooseModeAndImport(m_good));
    QCOMPARE(store->snapshot()->size(), size_t(5));
    answer(QStringLiteral("Append"));
    QVERIFY(m_main->chooseModeAndImport(m_good));
    QVERIFY(finished.wait(kWaitMs));
    QCOMPARE(store->snapshot()->size(), size_t(10));
    answer(QStringLiteral("Replace"));
    QVERIFY(m_main->chooseModeAndImport(m_good));
    QVERIFY(finished.wait(kWaitMs));
    QCOMPARE(store->snapshot()->size(), size_t(5));
}

void TstAnnotationsDock::cancelledImportChangesNothing() {
    showMain(m_sample);
    importAndWait(m_good, Mode::Replace);
    const auto store = m_main->annotationStore();
    const auto before = store->snapshot();

    // A file large enough that parsing it takes far longer than a click.
    iris::AnnotationDocument big;
    for (int i = 0; i < 60000; ++i) {
        const double x = (i % 300) * 20, y = (i / 300) * 20;
        big.objects.push_back(polygon(uint64_t(i + 1), "Cell", {{x, y}, {x + 10, y}, {x, y + 10}}));
    }
    const QString path = m_dir.filePath(QStringLiteral("big.geojson"));
    QVERIFY(writeText(path, iris::writeGeoJson(big)));

    QSignalSpy finished(m_main.get(), &MainWindow::annotationImportFinished);
    QVERIFY(m_main->importAnnotations(path, Mode::Replace));
    auto* progress = m_main->findChild<QProgressDialog*>(QStringLiteral("annotationImportProgress"));
    QVERIFY(progress);
    QVERIFY(!m_main->importAnnotations(m_good, Mode::Replace)); // one import at a time
    auto* cancel = progress->findChild<QPushButton*>();
    QVERIFY(cancel);
    cancel->click();
    QVERIFY(finished.wait(kWaitMs));
    QCOMPARE(finished.size(), 1);
    QVERIFY(!finished.first().at(1).toBool());
    QVERIFY(finished.first().at(2).toBool()); // cancelled
    QCOMPARE(store->snapshot(), before);
    QVERIFY(m_main->statusBar()->currentMessage().contains(QStringLiteral("cancelled")));
    QVERIFY(!errorBox(m_main.get()));
    QTRY_VERIFY(!m_main->findChild<QProgressDialog*>(QStringLiteral("annotationImportProgress")));
}

void TstAnnotationsDock::noSlideNoAnnotationActions() {
    showMain(m_sample);
    const char* names[] = {"importAnnotationsAction", "exportAnnotationsAction", "saveAnnotationsAction"};
    for (const char* name : names) QVERIFY(action(m_main.get(), name)->isEnabled());
    m_main->view()->closeSlide();
    for (const char* name : names) QVERIFY2(!action(m_main.get(), name)->isEnabled(), name);
    QVERIFY(!m_main->annotationStore());
    QVERIFY(!m_main->view()->annotations());
    QVERIFY(!m_main->importAnnotations(m_good, Mode::Replace));
    QCOMPARE(m_main->annotationsDock()->objectModel()->objectCount(), 0);
    // The View menu shows and hides the dock.
    bool listed = false;
    for (const QAction* menu : m_main->menuBar()->actions()) {
        if (menu->menu() && menu->menu()->actions().contains(m_main->annotationsDock()->toggleViewAction()))
            listed = true;
    }
    QVERIFY(listed);

    // A DICOMweb slide cannot keep its annotations beside it; a read-only folder neither.
    QVERIFY(AnnotationFiles::whyNotBeside(QStringLiteral("https://pacs.example/dicomweb/studies/1/series/2"))
                .contains(QStringLiteral("DICOMweb")));
    QVERIFY(AnnotationFiles::whyNotBeside(m_sample).isEmpty());
    if (geteuid() != 0) { // root writes anywhere
        const QString locked = m_dir.filePath(QStringLiteral("locked"));
        QVERIFY(QDir().mkpath(locked));
        QVERIFY(QFile::setPermissions(locked, QFile::ReadOwner | QFile::ExeOwner));
        QVERIFY(
            AnnotationFiles::whyNotBeside(locked + QStringLiteral("/slide.svs")).contains(QStringLiteral("read-only")));
        QFile::setPermissions(locked, QFile::ReadOwner | QFile::WriteOwner | QFile::ExeOwner);
    }
}

IRIS_WIDGET_TEST_MAIN(TstAnnotationsDock)

#include "tst_annotations_dock.moc"
