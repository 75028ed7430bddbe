// tst_annotation_tools: IrisSlideView's annotation tools (widget/src/annotationtools_p.h) on an X
// display (Xvfb in CI) with lavapipe and the validation layers on. Every gesture is synthesised
// on the view's Vulkan surface window with QTest's mouse and key events (press, moves, release;
// their timestamps are QTest's own, so a "slow" click costs no time), and then:
//   * the store holds what the gesture made: kind and geometry within a pixel of the level-0
//     points under the pointer (IrisSlideView::mapToSlide), also on a turned and mirrored view;
//   * annotationAdded/Changed/Removed fired once per finished object, never for the preview;
//   * undo then redo (the stack, and Ctrl+Z / Ctrl+Shift+Z on the view) restore the objects
//     exactly (AnnotationObject ==, ids included);
//   * Esc drops a shape in progress, Select moves by the pointer's level-0 delta, a handle moves
//     one vertex, Delete removes, locked objects stay as they are;
//   * annotationToolsEnabled = false and the right button under a tool pan as Navigate does;
//   * QuPath's tool keys; the readouts in µm / µm² from the slide's mpp.

#include <cmath>
#include <memory>
#include <numbers>
#include <thread>

#include <QtCore/QFileInfo>
#include <QtCore/QRegularExpression>
#include <QtGui/QUndoStack>
#include <QtGui/QWindow>
#include <QtTest/QSignalSpy>
#include <QtTest/QTest>
#include <QtWidgets/QApplication>
#include <QtWidgets/QVBoxLayout>

#include <iris/IrisSlideView.h>
#include <iris/annotations.h>

#include "annotationgeometry_p.h"
#include "annotationtools_p.h"
#include "enginehost_p.h"
#include "widget_test_support.h"

using namespace iriswidgettest;
using iris::AnnotationKind;
using iris::AnnotationObject;
using iris::Point2;

namespace {

constexpr QSize kViewSize(480, 360);
// A click that QGuiApplication does not pair with the previous one into a double click: QTest
// moves its event clock on by this much (no real waiting).
constexpr int kSlowClickMs = 1000;

struct ViewWindow {
    std::unique_ptr<QWidget> window = std::make_unique<QWidget>();
    IrisSlideView* view = new IrisSlideView;
    std::unique_ptr<FrameWatcher> frames = std::make_unique<FrameWatcher>(view);

    ViewWindow() {
        auto* layout = new QVBoxLayout(window.get());
        layout->setContentsMargins(0, 0, 0, 0);
        layout->addWidget(view);
        window->resize(kViewSize);
    }
    ~ViewWindow() { frames.reset(); }
    QWindow* surface() const { return view->surfaceWindow(); }
};

bool near(Point2 a, QPointF b, double tolerance = 1.0) {
    return std::abs(a.x - b.x()) <= tolerance && std::abs(a.y - b.y()) <= tolerance;
}

QString text(Point2 p) { return QStringLiteral("(%1, %2)").arg(p.x, 0, 'f', 3).arg(p.y, 0, 'f', 3); }

QString text(QPointF p) { return text(Point2{p.x(), p.y()}); }

std::vector<AnnotationObject> objectsOf(const iris::AnnotationStore& store) {
    std::vector<AnnotationObject> out;
    store.snapshot()->forEach([&](const iris::StoredAnnotation& a) { out.push_back(a.object); });
    std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
    return out;
}

} // namespace

class TstAnnotationTools : public QObject {
    Q_OBJECT

private Q_SLOTS:
    void initTestCase();
    void init();
    void cleanup();

    void propertiesAndDefaults();
    void rectangleIsOneUndoableObject();
    void ellipseWithShiftIsACircle();
    void polygonClickByClick();
    void pointsAreClicks();
    void escCancelsShapes();
    void selectMovesAndDeletes();
    void handlesMoveOneVertex();
    void lockedObjectsRefuseEdits();
    void freehandLasso();
    void brushPaintsTheUnionOfDiscs();
    void turnedAndMirroredView();
    void disabledToolsLeavePanning();
    void rightButtonPansUnderATool();
    void quPathKeysSwitchTools();
    void measurements();
    void dragsReportOnceAndEscPutsBack();
    void anotherStoreOrClosingDropsThePreview();
    void editsElsewhereDropStaleCommands();
    void geometryAlone();

private:
    void drag(QPoint from, QPoint to, Qt::KeyboardModifiers modifiers = {}, int steps = 8,
              Qt::MouseButton button = Qt::LeftButton);
    void click(QPoint at);
    QPointF slide(QPoint p) const { return m_w->view->mapToSlide(QPointF(p)); }
    void undoRedoRestores(const std::vector<AnnotationObject>& before, const std::vector<AnnotationObject>& after);

    QString m_sample;
    std::unique_ptr<ViewWindow> m_w;
    std::shared_ptr<iris::AnnotationStore> m_store;
};

void TstAnnotationTools::initTestCase() {
    QCOMPARE(QGuiApplication::platformName(), QStringLiteral("xcb"));
    IrisSlideView::setVulkanValidation(true);
    m_sample = sampleSlide();
    QVERIFY2(QFileInfo::exists(m_sample), qPrintable(m_sample));
}

void TstAnnotationTools::init() {
    m_w = std::make_unique<ViewWindow>();
    m_w->window->show();
    QVERIFY(QTest::qWaitForWindowExposed(m_w->window.get()));
    QVERIFY(m_w->view->isRendererAvailable());
    QVERIFY2(m_w->view->openSlide(m_sample), qPrintable(m_sample));
    QTRY_VERIFY(m_w->view->surfaceWindow()->isExposed());
    QVERIFY(m_w->frames->waitForCompleteFrame());
    m_w->view->setView(QPointF(2400, 1700), 2.0, 0);
    m_store = std::make_shared<iris::AnnotationStore>();
    m_w->view->setAnnotations(m_store);
    m_w->view->setKineticPanning(false);
    // A press on the overview map moves the view there, whatever the tool: out of the way.
    m_w->view->setOverviewVisible(false);
    QTRY_VERIFY(m_w->view->overlayRect(IrisSlideView::Overview).isEmpty()); // the next frame's layout
}

void TstAnnotationTools::cleanup() {
    if (m_w) {
        QVERIFY(m_w->frames->waitForCompleteFrame());
        QCOMPARE(m_w->view->validationMessageCount(), quint64(0));
    }
    m_w.reset();
    m_store.reset();
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 0);
}

void TstAnnotationTools::drag(QPoint from, QPoint to, Qt::KeyboardModifiers modifiers, int steps,
                              Qt::MouseButton button) {
    QTest::mousePress(m_w->surface(), button, modifiers, from, kSlowClickMs);
    for (int i = 1; i <= steps; ++i) QTest::mouseMove(m_w->surface(), from + (to - from) * i / steps, 16);
    QTest::mouseRelease(m_w->surface(), button, modifiers, to, 16);
}

void TstAnnotationTools::click(QPoint at) {
    QTest::mouseMove(m_w->surface(), at, 16);
    QTest::mousePress(m_w->surface(), Qt::LeftButton, {}, at, kSlowClickMs);
    QTest::mouseRelease(m_w->surface(), Qt::LeftButton, {}, at, 16);
}

// Undo gives `before` back exactly, redo `after`; through the stack and the view's keys.
void TstAnnotationTools::undoRedoRestores(const std::vector<AnnotationObject>& before,
                                          const std::vector<AnnotationObject>& after) {
    QUndoStack* stack = m_w->view->annotationUndoStack();
    QVERIFY(objectsOf(*m_store) == after);
    stack->undo();
    QVERIFY(objectsOf(*m_store) == before);
    stack->redo();
    QVERIFY(objectsOf(*m_store) == after);
    QTest::keyClick(m_w->surface(), Qt::Key_Z, Qt::ControlModifier);
    QVERIFY(objectsOf(*m_store) == before);
    QTest::keyClick(m_w->surface(), Qt::Key_Z, Qt::ControlModifier | Qt::ShiftModifier);
    QVERIFY(objectsOf(*m_store) == after);
}

// --- tests -----------------------------------------------------------------------------------

void TstAnnotationTools::propertiesAndDefaults() {
    IrisSlideView view;
    QCOMPARE(view.annotationTool(), IrisSlideView::Navigate);
    QVERIFY(view.annotationToolsEnabled());
    QVERIFY(view.annotationUndoStack() != nullptr);
    QCOMPARE(view.annotationMeasurement(), QString());
    const QMetaObject* mo = view.metaObject();
    for (const char* name : {"annotationTool", "annotationToolsEnabled"}) {
        const QMetaProperty p = mo->property(mo->indexOfProperty(name));
        QVERIFY2(p.isValid() && p.isWritable() && p.isDesignable() && p.hasNotifySignal(), name);
    }
    QSignalSpy toolChanged(&view, &IrisSlideView::annotationToolChanged);
    QVERIFY(view.setProperty("annotationTool", QVariant::fromValue(IrisSlideView::Polygon)));
    QCOMPARE(view.annotationTool(), IrisSlideView::Polygon);
    QCOMPARE(toolChanged.count(), 1);
    QSignalSpy enabledChanged(&view, &IrisSlideView::annotationToolsEnabledChanged);
    view.setAnnotationToolsEnabled(false);
    QCOMPARE(enabledChanged.count(), 1);
    QCOMPARE(view.annotationTool(), IrisSlideView::Polygon); // kept, not in effect
}

void TstAnnotationTools::rectangleIsOneUndoableObject() {
    IrisSlideView* view = m_w->view;
    QSignalSpy added(view, &IrisSlideView::annotationAdded);
    QSignalSpy changed(view, &IrisSlideView::annotationChanged);
    QSignalSpy removed(view, &IrisSlideView::annotationRemoved);
    view->setAnnotationTool(IrisSlideView::Rectangle);
    const QPoint p0(100, 80), p1(260, 200);
    QTest::mousePress(m_w->surface(), Qt::LeftButton, {}, p0, kSlowClickMs);
    for (int i = 1; i <= 8; ++i) QTest::mouseMove(m_w->surface(), p0 + (p1 - p0) * i / 8, 16);
    // The shape in progress is in the store (the engine draws it), without a signal.
    QCOMPARE(m_store->snapshot()->size(), size_t(1));
    QCOMPARE(added.count(), 0);
    QVERIFY(!view->annotationMeasurement().isEmpty());
    QTest::mouseRelease(m_w->surface(), Qt::LeftButton, {}, p1, 16);

    const auto objects = objectsOf(*m_store);
    QCOMPARE(objects.size(), size_t(1));
    const AnnotationObject& r = objects[0];
    QCOMPARE(r.kind, AnnotationKind::Rectangle);
    QVERIFY2(near({r.box.minX, r.box.minY}, slide(p0)) && near({r.box.maxX, r.box.maxY}, slide(p1)),
             qPrintable(text(Point2{r.box.minX, r.box.minY}) + text(slide(p0)) + text(Point2{r.box.maxX, r.box.maxY}) +
                        text(slide(p1))));
    QCOMPARE(added.count(), 1);
    QCOMPARE(added[0][0].toULongLong(), quint64(r.id));
    QCOMPARE(changed.count(), 0);
    QCOMPARE(removed.count(), 0);
    QCOMPARE(view->selectedAnnotation(), quint64(r.id)); // the new object is selected
    QCOMPARE(view->annotationUndoStack()->count(), 1);

    undoRedoRestores({}, objects);
    QCOMPARE(removed.count(), 2); // two undos
    QCOMPARE(added.count(), 3);   // the drawing and two redos
    QCOMPARE(removed[0][0].toULongLong(), quint64(r.id));
    QCOMPARE(changed.count(), 0);
}

void TstAnnotationTools::ellipseWithShiftIsACircle() {
    IrisSlideView* view = m_w->view;
    QSignalSpy added(view, &IrisSlideView::annotationAdded);
    view->setAnnotationTool(IrisSlideView::Ellipse);
    const QPoint p0(120, 100), p1(300, 160);
    drag(p0, p1, Qt::ShiftModifier);
    const auto objects = objectsOf(*m_store);
    QCOMPARE(objects.size(), size_t(1));
    const AnnotationObject& e = objects[0];
    QCOMPARE(e.kind, AnnotationKind::Ellipse);
    QCOMPARE(added.count(), 1);
    // A square box growing from the press towards the pointer, side = the larger extent.
    const QPointF a = slide(p0), b = slide(p1);
    const double side = std::max(std::abs(b.x() - a.x()), std::abs(b.y() - a.y()));
    QVERIFY(std::abs(e.box.width() - side) < 1e-6 && std::abs(e.box.height() - side) < 1e-6);
    QVERIFY(near({e.box.minX, e.box.minY}, a));
    undoRedoRestores({}, objects);
}

void TstAnnotationTools::polygonClickByClick() {
    IrisSlideView* view = m_w->view;
    QSignalSpy added(view, &IrisSlideView::annotationAdded);
    view->setAnnotationTool(IrisSlideView::Polygon);
    const QPoint v[] = {{100, 100}, {300, 110}, {280, 250}, {200, 300}, {120, 240}};
    for (const QPoint& p : v) click(p);
    QTest::mouseMove(m_w->surface(), QPoint(50, 50), 16); // the rubber band follows
    QCOMPARE(added.count(), 0);
    QCOMPARE(m_store->snapshot()->size(), size_t(1));   // the preview
    QTest::keyClick(m_w->surface(), Qt::Key_Backspace); // drops (120, 240)
    // A double click on the last vertex closes it (its two presses are one vertex).
    QTest::mouseMove(m_w->surface(), QPoint(140, 200), 16);
    QTest::mouseDClick(m_w->surface(), Qt::LeftButton, {}, QPoint(140, 200), kSlowClickMs);
    QCOMPARE(added.count(), 1);
    auto objects = objectsOf(*m_store);
    QCOMPARE(objects.size(), size_t(1));
    const AnnotationObject& poly = objects[0];
    QCOMPARE(poly.kind, AnnotationKind::Polygon);
    QCOMPARE(poly.polygons.size(), size_t(1));
    const auto& ring = poly.polygons[0].outer;
    const QPoint expected[] = {v[0], v[1], v[2], v[3], {140, 200}};
    QCOMPARE(ring.size(), size_t(5));
    for (size_t i = 0; i < ring.size(); ++i)
        QVERIFY2(near(ring[i], slide(expected[i])), qPrintable(text(ring[i]) + text(slide(expected[i]))));
    undoRedoRestores({}, objects);

    // Enter closes too; a polygon of two vertices is nothing.
    for (const QPoint& p : {QPoint(350, 100), QPoint(420, 120), QPoint(400, 200)}) click(p);
    QTest::keyClick(m_w->surface(), Qt::Key_Return);
    QCOMPARE(added.count(), 4); // the first, two redos, this one
    QCOMPARE(m_store->snapshot()->size(), size_t(2));
    click(QPoint(350, 300));
    click(QPoint(420, 320));
    QTest::keyClick(m_w->surface(), Qt::Key_Return);
    QCOMPARE(added.count(), 4);
    QCOMPARE(m_store->snapshot()->size(), size_t(2));
}

void TstAnnotationTools::pointsAreClicks() {
    IrisSlideView* view = m_w->view;
    QSignalSpy added(view, &IrisSlideView::annotationAdded);
    view->setAnnotationTool(IrisSlideView::Point);
    click(QPoint(150, 150));
    click(QPoint(250, 180));
    QCOMPARE(added.count(), 2);
    const auto objects = objectsOf(*m_store);
    QCOMPARE(objects.size(), size_t(2));
    QCOMPARE(objects[0].kind, AnnotationKind::Point);
    QVERIFY(near(objects[0].points.at(0), slide(QPoint(150, 150))));
    QVERIFY(near(objects[1].points.at(0), slide(QPoint(250, 180))));
    QCOMPARE(view->annotationUndoStack()->count(), 2);
    undoRedoRestores({objects[0]}, objects);
}

void TstAnnotationTools::escCancelsShapes() {
    IrisSlideView* view = m_w->view;
    QSignalSpy added(view, &IrisSlideView::annotationAdded);
    const QPoint p0(100, 80), p1(260, 200);
    for (auto tool :
         {IrisSlideView::Rectangle, IrisSlideView::Ellipse, IrisSlideView::Freehand, IrisSlideView::Brush}) {
        view->setAnnotationTool(tool);
        QTest::mousePress(m_w->surface(), Qt::LeftButton, {}, p0, kSlowClickMs);
        for (int i = 1; i <= 8; ++i) QTest::mouseMove(m_w->surface(), p0 + (p1 - p0) * i / 8, 16);
        QCOMPARE(m_store->snapshot()->size(), size_t(1));
        QTest::keyClick(m_w->surface(), Qt::Key_Escape);
        QCOMPARE(m_store->snapshot()->size(), size_t(0));
        QTest::mouseRelease(m_w->surface(), Qt::LeftButton, {}, p1, 16);
        QCOMPARE(m_store->snapshot()->size(), size_t(0));
    }
    view->setAnnotationTool(IrisSlideView::Polygon);
    click(QPoint(100, 100));
    click(QPoint(200, 100));
    click(QPoint(200, 200));
    QTest::keyClick(m_w->surface(), Qt::Key_Escape);
    QCOMPARE(m_store->snapshot()->size(), size_t(0));
    QCOMPARE(added.count(), 0);
    QCOMPARE(view->annotationUndoStack()->count(), 0);
    // A click without a drag makes no rectangle.
    view->setAnnotationTool(IrisSlideView::Rectangle);
    click(QPoint(200, 200));
    QCOMPARE(m_store->snapshot()->size(), size_t(0));
    QCOMPARE(added.count(), 0);
    // With nothing in progress, Esc clears the selection.
    drag(p0, p1);
    QVERIFY(view->selectedAnnotation() != 0);
    QTest::keyClick(m_w->surface(), Qt::Key_Escape);
    QCOMPARE(view->selectedAnnotation(), quint64(0));
}

void TstAnnotationTools::selectMovesAndDeletes() {
    IrisSlideView* view = m_w->view;
    const QPointF a = slide(QPoint(150, 120)), b = slide(QPoint(300, 240));
    AnnotationObject r;
    r.kind = AnnotationKind::Rectangle;
    r.box = {std::min(a.x(), b.x()), std::min(a.y(), b.y()), std::max(a.x(), b.x()), std::max(a.y(), b.y())};
    r.name = "tumour";
    r.properties = {{"lis", "42"}};
    QVERIFY(m_store->add(r).ok());
    const auto original = objectsOf(*m_store);
    QSignalSpy added(view, &IrisSlideView::annotationAdded);
    QSignalSpy changed(view, &IrisSlideView::annotationChanged);
    QSignalSpy removed(view, &IrisSlideView::annotationRemoved);
    view->setAnnotationTool(IrisSlideView::Select);

    // A click inside selects it; on empty slide, clears.
    click(QPoint(220, 180));
    QCOMPARE(view->selectedAnnotation(), quint64(original[0].id));
    click(QPoint(420, 320));
    QCOMPARE(view->selectedAnnotation(), quint64(0));

    // A drag from inside moves it by the pointer's level-0 delta.
    const QPoint from(220, 180), to(280, 220);
    drag(from, to);
    QCOMPARE(view->selectedAnnotation(), quint64(original[0].id));
    const auto moved = objectsOf(*m_store);
    const QPointF delta = slide(to) - slide(from);
    QVERIFY(std::abs(moved[0].box.minX - (original[0].box.minX + delta.x())) < 1e-6);
    QVERIFY(std::abs(moved[0].box.maxY - (original[0].box.maxY + delta.y())) < 1e-6);
    QCOMPARE(moved[0].name, original[0].name);
    QCOMPARE(moved[0].properties, original[0].properties);
    QCOMPARE(changed.count(), 1);
    QCOMPARE(added.count(), 0);
    undoRedoRestores(original, moved);
    QCOMPARE(changed.count(), 5);

    // Delete removes it; undo brings back the same object.
    QTest::keyClick(m_w->surface(), Qt::Key_Delete);
    QCOMPARE(m_store->snapshot()->size(), size_t(0));
    QCOMPARE(removed.count(), 1);
    QCOMPARE(view->selectedAnnotation(), quint64(0));
    undoRedoRestores(moved, {});
    view->annotationUndoStack()->undo();
    QVERIFY(objectsOf(*m_store) == moved);
    // Back to the start.
    view->annotationUndoStack()->undo();
    QVERIFY(objectsOf(*m_store) == original);

    // A drag on empty slide pans, as in Navigate; the object stays where it is in the slide.
    const QPointF c0 = view->centre();
    const double scale = view->downsample() * m_w->surface()->devicePixelRatio();
    drag(QPoint(400, 300), QPoint(340, 260));
    const QPointF expected = c0 - QPointF(-60, -40) * scale;
    QVERIFY2(std::hypot(view->centre().x() - expected.x(), view->centre().y() - expected.y()) < 1e-6,
             qPrintable(text(view->centre()) + text(expected)));
    QVERIFY(objectsOf(*m_store) == original);
}

void TstAnnotationTools::handlesMoveOneVertex() {
    IrisSlideView* view = m_w->view;
    const QPointF a = slide(QPoint(150, 120)), b = slide(QPoint(300, 240));
    AnnotationObject r;
    r.kind = AnnotationKind::Rectangle;
    r.box = {a.x(), a.y(), b.x(), b.y()};
    auto rid = m_store->add(r);
    AnnotationObject p;
    p.kind = AnnotationKind::Polygon;
    p.polygons = {{{{slide(QPoint(340, 60)).x(), slide(QPoint(340, 60)).y()},
                    {slide(QPoint(440, 60)).x(), slide(QPoint(440, 60)).y()},
                    {slide(QPoint(400, 150)).x(), slide(QPoint(400, 150)).y()}},
                   {}}};
    auto pid = m_store->add(p);
    QVERIFY(rid.ok() && pid.ok());
    QSignalSpy changed(view, &IrisSlideView::annotationChanged);
    view->setAnnotationTool(IrisSlideView::Select);
    view->setSelectedAnnotation(*rid);
    const auto before = objectsOf(*m_store);

    // The top-left corner to (120, 100): the opposite corner stays.
    drag(QPoint(150, 120), QPoint(120, 100));
    auto after = objectsOf(*m_store);
    QCOMPARE(changed.count(), 1);
    const iris::Box2 box = after[0].box;
    QVERIFY(near({box.minX, box.minY}, slide(QPoint(120, 100))));
    QCOMPARE(box.maxX, before[0].box.maxX);
    QCOMPARE(box.maxY, before[0].box.maxY);
    undoRedoRestores(before, after);

    // The polygon's third vertex.
    view->setSelectedAnnotation(*pid);
    const auto before2 = objectsOf(*m_store);
    drag(QPoint(400, 150), QPoint(420, 200));
    const auto after2 = objectsOf(*m_store);
    const auto& ring = after2[1].polygons[0].outer;
    QVERIFY(near(ring[2], slide(QPoint(420, 200))));
    QCOMPARE(ring[0], before2[1].polygons[0].outer[0]);
    QCOMPARE(ring[1], before2[1].polygons[0].outer[1]);
    undoRedoRestores(before2, after2);
}

void TstAnnotationTools::lockedObjectsRefuseEdits() {
    IrisSlideView* view = m_w->view;
    const QPointF a = slide(QPoint(150, 120)), b = slide(QPoint(300, 240));
    AnnotationObject r;
    r.kind = AnnotationKind::Rectangle;
    r.box = {a.x(), a.y(), b.x(), b.y()};
    r.locked = true;
    QVERIFY(m_store->add(r).ok());
    const auto before = objectsOf(*m_store);
    QSignalSpy changed(view, &IrisSlideView::annotationChanged);
    QSignalSpy removed(view, &IrisSlideView::annotationRemoved);
    const QPointF centre = view->centre();
    view->setAnnotationTool(IrisSlideView::Select);
    drag(QPoint(220, 180), QPoint(300, 260)); // selects it, moves nothing (nor the view)
    QCOMPARE(view->selectedAnnotation(), quint64(before[0].id));
    QVERIFY(objectsOf(*m_store) == before);
    QCOMPARE(view->centre(), centre);
    drag(QPoint(150, 120), QPoint(100, 100)); // its corner
    QVERIFY(objectsOf(*m_store) == before);
    QTest::keyClick(m_w->surface(), Qt::Key_Delete);
    QVERIFY(objectsOf(*m_store) == before);
    QCOMPARE(changed.count(), 0);
    QCOMPARE(removed.count(), 0);
    QCOMPARE(view->annotationUndoStack()->count(), 0);
}

void TstAnnotationTools::freehandLasso() {
    IrisSlideView* view = m_w->view;
    QSignalSpy added(view, &IrisSlideView::annotationAdded);
    view->setAnnotationTool(IrisSlideView::Freehand);
    // A circle of radius 80 around (240, 180), 90 steps, then a few moves of under a pixel.
    const QPoint c(240, 180);
    std::vector<QPoint> path;
    for (int i = 0; i <= 90; ++i) {
        const double t = 2 * std::numbers::pi * i / 90;
        path.push_back(c + QPoint(int(std::lround(80 * std::cos(t))), int(std::lround(80 * std::sin(t)))));
    }
    QTest::mousePress(m_w->surface(), Qt::LeftButton, {}, path[0], kSlowClickMs);
    for (size_t i = 1; i < path.size(); ++i) QTest::mouseMove(m_w->surface(), path[i], 16);
    QTest::mouseRelease(m_w->surface(), Qt::LeftButton, {}, path.back(), 16);
    QCOMPARE(added.count(), 1);
    const auto objects = objectsOf(*m_store);
    QCOMPARE(objects.size(), size_t(1));
    QCOMPARE(objects[0].kind, AnnotationKind::Polygon);
    const auto& ring = objects[0].polygons.at(0).outer;
    QVERIFY2(ring.size() >= 60 && ring.size() <= 91, qPrintable(QString::number(ring.size())));
    // Every vertex is a point of the path, a screen pixel or more from the one before.
    const double scale = view->downsample() * m_w->surface()->devicePixelRatio();
    for (size_t i = 0; i < ring.size(); ++i) {
        const QPointF w = view->mapFromSlide(QPointF(ring[i].x, ring[i].y));
        QVERIFY2(std::abs(std::hypot(w.x() - c.x(), w.y() - c.y()) - 80) < 1.5, qPrintable(text(w)));
        if (i > 0) QVERIFY(std::hypot(ring[i].x - ring[i - 1].x, ring[i].y - ring[i - 1].y) >= scale * 0.999);
    }
    // Its area is the circle's, within the rounding of the path to whole pixels.
    const IrisWidget::Measurement m = IrisWidget::measure(objects[0], 0, 0);
    const double circle = std::numbers::pi * std::pow(80 * scale, 2);
    QVERIFY2(std::abs(m.area - circle) < 0.03 * circle, qPrintable(QString::number(m.area / circle)));
    undoRedoRestores({}, objects);
}

void TstAnnotationTools::brushPaintsTheUnionOfDiscs() {
    IrisSlideView* view = m_w->view;
    QSignalSpy added(view, &IrisSlideView::annotationAdded);
    view->setAnnotationTool(IrisSlideView::Brush);
    // An L: right 150 px, then down 100 px.
    const QPoint p0(100, 100), p1(250, 100), p2(250, 200);
    QTest::mousePress(m_w->surface(), Qt::LeftButton, {}, p0, kSlowClickMs);
    for (int i = 1; i <= 15; ++i) QTest::mouseMove(m_w->surface(), p0 + (p1 - p0) * i / 15, 16);
    for (int i = 1; i <= 10; ++i) QTest::mouseMove(m_w->surface(), p1 + (p2 - p1) * i / 10, 16);
    QCOMPARE(added.count(), 0);
    QTest::mouseRelease(m_w->surface(), Qt::LeftButton, {}, p2, 16);
    QCOMPARE(added.count(), 1);
    const auto objects = objectsOf(*m_store);
    QCOMPARE(objects.size(), size_t(1));
    QCOMPARE(objects[0].kind, AnnotationKind::Polygon);
    QCOMPARE(objects[0].polygons.size(), size_t(1));
    // Bounds: the path's grown by the radius; area: two stadiums' union (rectangles 2r wide
    // along both legs, a disc at each end, less the overlap at the corner), polygonised.
    const double scale = view->downsample() * m_w->surface()->devicePixelRatio();
    const double r = IrisWidget::AnnotationTools::kBrushRadiusPx * scale;
    const iris::Box2 bounds = iris::annotationBounds(objects[0]);
    const QPointF s0 = slide(p0), s2 = slide(p2);
    QVERIFY2(std::abs(bounds.minX - (s0.x() - r)) < 0.5 * scale && std::abs(bounds.maxX - (s2.x() + r)) < 0.5 * scale,
             qPrintable(QStringLiteral("%1 %2").arg(bounds.minX).arg(bounds.maxX)));
    QVERIFY(std::abs(bounds.minY - (s0.y() - r)) < 0.5 * scale && std::abs(bounds.maxY - (s2.y() + r)) < 0.5 * scale);
    const double legA = 150 * scale, legB = 100 * scale;
    const double expected = 2 * r * (legA + legB) + std::numbers::pi * r * r;
    const double area = IrisWidget::measure(objects[0], 0, 0).area;
    QVERIFY2(std::abs(area - expected) < 0.02 * expected, qPrintable(QString::number(area / expected)));
    undoRedoRestores({}, objects);
}

void TstAnnotationTools::turnedAndMirroredView() {
    IrisSlideView* view = m_w->view;
    view->setView(QPointF(2400, 1700), 2.0, 90, true, false);
    view->setAnnotationTool(IrisSlideView::Rectangle);
    const QPoint p0(100, 80), p1(260, 200);
    drag(p0, p1);
    const auto objects = objectsOf(*m_store);
    QCOMPARE(objects.size(), size_t(1));
    // At a quarter turn the screen's box is a level-0 box: its corners are the drag's.
    const iris::Box2 expected =
        IrisWidget::boxFromDrag({slide(p0).x(), slide(p0).y()}, {slide(p1).x(), slide(p1).y()}, false);
    const iris::Box2& box = objects[0].box;
    QVERIFY(std::abs(box.minX - expected.minX) < 1 && std::abs(box.maxX - expected.maxX) < 1);
    QVERIFY(std::abs(box.minY - expected.minY) < 1 && std::abs(box.maxY - expected.maxY) < 1);
    // The polygon tool on a 30° turn: each vertex under its click.
    view->setView(QPointF(2400, 1700), 2.0, 30, false, true);
    view->setAnnotationTool(IrisSlideView::Polygon);
    const QPoint v[] = {{100, 100}, {300, 120}, {200, 260}};
    for (const QPoint& p : v) click(p);
    QTest::keyClick(m_w->surface(), Qt::Key_Enter);
    const auto all = objectsOf(*m_store);
    QCOMPARE(all.size(), size_t(2));
    for (int i = 0; i < 3; ++i) QVERIFY(near(all[1].polygons.at(0).outer.at(size_t(i)), slide(v[i])));
}

void TstAnnotationTools::disabledToolsLeavePanning() {
    IrisSlideView* view = m_w->view;
    view->setAnnotationTool(IrisSlideView::Rectangle);
    view->setAnnotationToolsEnabled(false);
    const QPointF c0 = view->centre();
    const double scale = view->downsample() * m_w->surface()->devicePixelRatio();
    const QPoint p0(100, 100), p1(260, 190);
    drag(p0, p1);
    QCOMPARE(m_store->snapshot()->size(), size_t(0));
    const QPointF expected = c0 - QPointF(p1 - p0) * scale;
    QVERIFY2(std::hypot(view->centre().x() - expected.x(), view->centre().y() - expected.y()) < 1e-6,
             qPrintable(text(view->centre()) + text(expected)));
    // Tool keys do nothing either.
    QTest::keyClick(m_w->surface(), Qt::Key_P);
    QCOMPARE(view->annotationTool(), IrisSlideView::Rectangle);
    // Enabled again: the same drag draws.
    view->setAnnotationToolsEnabled(true);
    drag(p0, p1);
    QCOMPARE(m_store->snapshot()->size(), size_t(1));
}

void TstAnnotationTools::rightButtonPansUnderATool() {
    IrisSlideView* view = m_w->view;
    view->setAnnotationTool(IrisSlideView::Polygon);
    const QPointF c0 = view->centre();
    const double scale = view->downsample() * m_w->surface()->devicePixelRatio();
    const QPoint p0(100, 100), p1(180, 150);
    drag(p0, p1, {}, 8, Qt::RightButton);
    QCOMPARE(m_store->snapshot()->size(), size_t(0));
    const QPointF expected = c0 - QPointF(p1 - p0) * scale;
    QVERIFY2(std::hypot(view->centre().x() - expected.x(), view->centre().y() - expected.y()) < 1e-6,
             qPrintable(text(view->centre()) + text(expected)));
}

void TstAnnotationTools::quPathKeysSwitchTools() {
    IrisSlideView* view = m_w->view;
    QSignalSpy toolChanged(view, &IrisSlideView::annotationToolChanged);
    // In Navigate, R turns the view (the navigator's key) …
    QTest::keyClick(m_w->surface(), Qt::Key_R);
    QCOMPARE(view->annotationTool(), IrisSlideView::Navigate);
    QTRY_COMPARE(view->rotation(), 90.0);
    // … and the other tool keys choose tools.
    const std::pair<Qt::Key, IrisSlideView::AnnotationTool> keys[] = {
        {Qt::Key_S, IrisSlideView::Select},   {Qt::Key_R, IrisSlideView::Rectangle},
        {Qt::Key_O, IrisSlideView::Ellipse},  {Qt::Key_P, IrisSlideView::Polygon},
        {Qt::Key_B, IrisSlideView::Brush},    {Qt::Key_Period, IrisSlideView::Point},
        {Qt::Key_M, IrisSlideView::Navigate},
    };
    for (const auto& [key, tool] : keys) {
        QTest::keyClick(m_w->surface(), key);
        QCOMPARE(view->annotationTool(), tool);
    }
    QTest::keyClick(m_w->surface(), Qt::Key_P, Qt::ShiftModifier);
    QCOMPARE(view->annotationTool(), IrisSlideView::Freehand);
    QCOMPARE(toolChanged.count(), 8);
}

void TstAnnotationTools::measurements() {
    IrisSlideView* view = m_w->view;
    const IrisSlideInfo info = view->slideInfo();
    QVERIFY(info.mppX > 0 && info.mppY > 0);
    AnnotationObject r;
    r.kind = AnnotationKind::Rectangle;
    r.box = {1000, 1000, 1400, 1200}; // 400 × 200 px
    const auto id = m_store->add(r);
    AnnotationObject line;
    line.kind = AnnotationKind::Polyline;
    line.points = {{0, 0}, {3000, 4000}}; // 5000 px
    const auto lid = m_store->add(line);
    QVERIFY(id.ok() && lid.ok());
    const double perimeter = 2 * (400 * info.mppX + 200 * info.mppY);
    const double area = 400 * info.mppX * 200 * info.mppY;
    const auto fmt = [](double v) { return QString::number(v, 'f', v >= 100 ? 0 : v >= 10 ? 1 : v >= 1 ? 2 : 3); };
    const QString expected =
        QStringLiteral("perimeter %1 \u00b5m, area %2 \u00b5m\u00b2").arg(fmt(perimeter), fmt(area));
    QCOMPARE(view->annotationMeasurement(*id), expected);
    const double length = std::hypot(3000 * info.mppX, 4000 * info.mppY);
    QCOMPARE(view->annotationMeasurement(*lid), length >= 1000 ? QStringLiteral("length %1 mm").arg(fmt(length / 1000))
                                                               : QStringLiteral("length %1 \u00b5m").arg(fmt(length)));
    QSignalSpy measured(view, &IrisSlideView::annotationMeasurementChanged);
    view->setSelectedAnnotation(*id);
    QCOMPARE(view->annotationMeasurement(), expected);
    QCOMPARE(measured.count(), 1);
    QCOMPARE(measured[0][0].toString(), expected);
    // An edit made elsewhere (another thread) reaches the readout.
    AnnotationObject wider = m_store->snapshot()->find(*id)->object;
    wider.box.maxX += 400; // 800 × 200 px
    bool updated = false;
    std::thread([&] { updated = m_store->update(wider).ok(); }).join();
    QVERIFY(updated);
    const QString widened =
        QStringLiteral("perimeter %1 \u00b5m, area %2 \u00b5m\u00b2")
            .arg(fmt(2 * (800 * info.mppX + 200 * info.mppY)), fmt(800 * info.mppX * 200 * info.mppY));
    QTRY_COMPARE_WITH_TIMEOUT(view->annotationMeasurement(), widened, 5000);
    QTRY_COMPARE_WITH_TIMEOUT(measured.count(), 2, 5000);
    QCOMPARE(measured[1][0].toString(), widened);
    // While a shape is drawn, the readout is the shape's.
    view->setAnnotationTool(IrisSlideView::Ellipse);
    QTest::mousePress(m_w->surface(), Qt::LeftButton, {}, QPoint(100, 100), kSlowClickMs);
    QTest::mouseMove(m_w->surface(), QPoint(200, 200), 16);
    const double d = 100 * view->downsample() * m_w->surface()->devicePixelRatio();
    const double circle = std::numbers::pi * (d / 2 * info.mppX) * (d / 2 * info.mppY);
    QVERIFY2(view->annotationMeasurement().contains(fmt(circle >= 1e6 ? circle / 1e6 : circle)),
             qPrintable(view->annotationMeasurement()));
    QTest::mouseRelease(m_w->surface(), Qt::LeftButton, {}, QPoint(200, 200), 16);
    // No mpp: pixels.
    AnnotationObject sq;
    sq.kind = AnnotationKind::Rectangle;
    sq.box = {0, 0, 10, 10};
    QCOMPARE(QString::fromStdString(IrisWidget::measurementText(sq, 0, 0)),
             QStringLiteral("perimeter 40.0 px, area 100 px\u00b2"));
    QCOMPARE(QString::fromStdString(IrisWidget::measurementText(sq, 100, 100)),
             QStringLiteral("perimeter 4.00 mm, area 1.00 mm\u00b2"));
}

// A Select drag updates the store as it goes, without a signal; Esc mid-drag puts the object
// back, with nothing on the stack.
void TstAnnotationTools::dragsReportOnceAndEscPutsBack() {
    IrisSlideView* view = m_w->view;
    const QPointF a = slide(QPoint(150, 120)), b = slide(QPoint(300, 240));
    AnnotationObject e;
    e.kind = AnnotationKind::Ellipse;
    e.box = {a.x(), a.y(), b.x(), b.y()};
    QVERIFY(m_store->add(e).ok());
    const auto before = objectsOf(*m_store);
    QSignalSpy changed(view, &IrisSlideView::annotationChanged);
    view->setAnnotationTool(IrisSlideView::Select);
    const QPoint from(225, 180), to(300, 260);
    QTest::mousePress(m_w->surface(), Qt::LeftButton, {}, from, kSlowClickMs);
    for (int i = 1; i <= 8; ++i) QTest::mouseMove(m_w->surface(), from + (to - from) * i / 8, 16);
    QVERIFY(objectsOf(*m_store) != before); // moved, live
    QCOMPARE(changed.count(), 0);
    QTest::keyClick(m_w->surface(), Qt::Key_Escape);
    QVERIFY(objectsOf(*m_store) == before);
    QTest::mouseRelease(m_w->surface(), Qt::LeftButton, {}, to, 16);
    QVERIFY(objectsOf(*m_store) == before);
    QCOMPARE(changed.count(), 0);
    QCOMPARE(view->annotationUndoStack()->count(), 0);
    // The ellipse's right side, by its handle: one change, the left side where it was.
    drag(view->mapFromSlide(QPointF(b.x(), (a.y() + b.y()) / 2)).toPoint(), QPoint(340, 180));
    const auto after = objectsOf(*m_store);
    QCOMPARE(changed.count(), 1);
    QCOMPARE(after[0].box.minX, before[0].box.minX);
    QCOMPARE(after[0].box.minY, before[0].box.minY);
    QVERIFY(std::abs(after[0].box.maxX - slide(QPoint(340, 180)).x()) < 1);
    undoRedoRestores(before, after);
}

// A preview never outlives its gesture: another store (the old one loses it, the undo stack is
// cleared), a closed slide, the view destroyed.
void TstAnnotationTools::anotherStoreOrClosingDropsThePreview() {
    IrisSlideView* view = m_w->view;
    view->setAnnotationTool(IrisSlideView::Rectangle);
    drag(QPoint(100, 100), QPoint(200, 200));
    QCOMPARE(view->annotationUndoStack()->count(), 1);
    const auto drawn = objectsOf(*m_store);
    const auto startDrawing = [&] {
        QTest::mousePress(m_w->surface(), Qt::LeftButton, {}, QPoint(250, 100), kSlowClickMs);
        QTest::mouseMove(m_w->surface(), QPoint(350, 200), 16);
    };
    startDrawing();
    QCOMPARE(m_store->snapshot()->size(), size_t(2));
    auto other = std::make_shared<iris::AnnotationStore>();
    view->setAnnotations(other);
    QVERIFY(objectsOf(*m_store) == drawn);
    QCOMPARE(view->annotationUndoStack()->count(), 0);
    QTest::mouseRelease(m_w->surface(), Qt::LeftButton, {}, QPoint(350, 200), 16);
    QCOMPARE(other->snapshot()->size(), size_t(0));
    QVERIFY(objectsOf(*m_store) == drawn);

    view->setAnnotations(m_store);
    startDrawing();
    QCOMPARE(m_store->snapshot()->size(), size_t(2));
    view->closeSlide();
    QVERIFY(objectsOf(*m_store) == drawn);
    QTest::mouseRelease(m_w->surface(), Qt::LeftButton, {}, QPoint(350, 200), 16);
    QVERIFY(objectsOf(*m_store) == drawn);

    QVERIFY(view->openSlide(m_sample));
    view->setView(QPointF(2400, 1700), 2.0, 0);
    startDrawing();
    QCOMPARE(m_store->snapshot()->size(), size_t(2));
    QVERIFY(m_w->frames->waitForCompleteFrame());
    QCOMPARE(view->validationMessageCount(), quint64(0));
    m_w.reset();
    QVERIFY(objectsOf(*m_store) == drawn);
}

// The host edits the store behind the tools' back: a command whose object is gone is dropped
// (logged), the others still undo.
void TstAnnotationTools::editsElsewhereDropStaleCommands() {
    IrisSlideView* view = m_w->view;
    QSignalSpy removed(view, &IrisSlideView::annotationRemoved);
    view->setAnnotationTool(IrisSlideView::Rectangle);
    drag(QPoint(100, 100), QPoint(200, 200));
    drag(QPoint(250, 100), QPoint(350, 200));
    const auto both = objectsOf(*m_store);
    QCOMPARE(both.size(), size_t(2));
    QVERIFY(m_store->remove(both[1].id).ok()); // the host's own edit
    QUndoStack* stack = view->annotationUndoStack();
    QCOMPARE(stack->count(), 2);
    QTest::ignoreMessage(QtWarningMsg,
                         QRegularExpression(QStringLiteral("annotation %1 removal .* failed").arg(both[1].id)));
    stack->undo();
    QCOMPARE(stack->count(), 1);
    QCOMPARE(removed.count(), 0);
    QVERIFY(objectsOf(*m_store) == std::vector<AnnotationObject>{both[0]});
    stack->undo();
    QCOMPARE(removed.count(), 1);
    QCOMPARE(m_store->snapshot()->size(), size_t(0));
    stack->redo();
    QVERIFY(objectsOf(*m_store) == std::vector<AnnotationObject>{both[0]});
}

// The pure functions under the tools (annotationgeometry_p.h), on hand-made objects.
void TstAnnotationTools::geometryAlone() {
    using namespace IrisWidget;
    // A polygon with a hole moves whole.
    AnnotationObject p;
    p.kind = AnnotationKind::Polygon;
    p.polygons = {{{{0, 0}, {10, 0}, {10, 10}, {0, 10}}, {{{2, 2}, {4, 2}, {4, 4}}}}};
    const AnnotationObject moved = translated(p, 5, -3);
    QCOMPARE(moved.polygons[0].outer[2], (Point2{15, 7}));
    QCOMPARE(moved.polygons[0].holes[0][1], (Point2{9, -1}));
    QCOMPARE(translated(moved, -5, 3), p);
    // Handles: every ring's vertices; a hole's vertex moves alone.
    const auto handles = vertexHandles(p);
    QCOMPARE(handles.size(), size_t(7));
    QCOMPARE(handles[5].ring, 1);
    const AnnotationObject reshaped = withHandleMoved(p, handles[5], {3, 5});
    QCOMPARE(reshaped.polygons[0].holes[0][1], (Point2{3, 5}));
    QCOMPARE(reshaped.polygons[0].outer, p.polygons[0].outer);
    // An ellipse's left side dragged past its right one: the box turns the right way round.
    AnnotationObject e;
    e.kind = AnnotationKind::Ellipse;
    e.box = {0, 0, 10, 4};
    const AnnotationObject flipped = withHandleMoved(e, vertexHandles(e)[2], {14, 2});
    QCOMPARE(flipped.box, (iris::Box2{10, 0, 14, 4}));
    // A rectangle's bottom-right corner: the top-left stays.
    AnnotationObject r;
    r.kind = AnnotationKind::Rectangle;
    r.box = {0, 0, 10, 4};
    QCOMPARE(withHandleMoved(r, vertexHandles(r)[2], {20, 8}).box, (iris::Box2{0, 0, 20, 8}));
    // Squares grow from the press towards the pointer, in every quadrant.
    QCOMPARE(boxFromDrag({10, 10}, {4, 12}, true), (iris::Box2{4, 10, 10, 16}));
    QCOMPARE(boxFromDrag({10, 10}, {4, 12}, false), (iris::Box2{4, 10, 10, 12}));
    // Repeats merged, the closing vertex dropped; thinning keeps a pixel between vertices.
    QCOMPARE(withoutRepeats({{0, 0}, {0, 0.2}, {5, 0}, {5, 5}, {0.1, 0}}, 0.5),
             (std::vector<Point2>{{0, 0}, {5, 0}, {5, 5}}));
    std::vector<Point2> path{{0, 0}};
    appendThinned(path, {0.5, 0}, 1);
    appendThinned(path, {1, 0}, 1);
    QCOMPARE(path.size(), size_t(2));
    // A brush stroke around a square loop leaves a hole in the middle.
    std::string error;
    const auto parts = brushOutline({{0, 0}, {100, 0}, {100, 100}, {0, 100}, {0, 0}}, 10, &error);
    QCOMPARE(parts.size(), size_t(1));
    QCOMPARE(parts[0].holes.size(), size_t(1));
    AnnotationObject loop;
    loop.kind = AnnotationKind::Polygon;
    loop.polygons = parts;
    const double area = measure(loop, 0, 0).area; // 120² rounded corners outside, less the 80² hole
    const double expected = 120.0 * 120 - (4 - std::numbers::pi) * 100 - 80.0 * 80;
    QVERIFY2(std::abs(area - expected) < 0.01 * expected, qPrintable(QString::number(area)));
    QVERIFY(brushOutline({}, 10, &error).empty());
    QVERIFY(!error.empty());
    // Readouts: a circle's perimeter, a polyline, points.
    AnnotationObject c;
    c.kind = AnnotationKind::Ellipse;
    c.box = {0, 0, 200, 200};
    QVERIFY(std::abs(measure(c, 0.5, 0.5).length - 2 * std::numbers::pi * 50) < 1e-9);
    // 0.785 mm²: below 1 mm², so in µm².
    QCOMPARE(QString::fromStdString(measurementText(c, 5, 5)),
             QStringLiteral("perimeter 3.14 mm, area 785398 \u00b5m\u00b2"));
    AnnotationObject pts;
    pts.kind = AnnotationKind::Point;
    pts.points = {{1, 1}, {2, 2}, {3, 3}};
    QCOMPARE(QString::fromStdString(measurementText(pts, 0.25, 0.25)), QStringLiteral("3 points"));
}

IRIS_WIDGET_TEST_MAIN(TstAnnotationTools)
#include "tst_annotation_tools.moc"
