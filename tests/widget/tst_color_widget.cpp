// IrisSlideView's colour management (docs/COLOR.md), under Xvfb:
//
//   * the properties (colorManaged, renderingIntent, displayProfile) and their signal;
//   * the display profile taken from the X11 root window's _ICC_PROFILE property, followed when
//     a colour tool changes or removes it, and overridden by the host's setDisplayProfile();
//   * the presented frame: a slide whose profile has strong curves shown converted (each sampled
//     pixel within one 8-bit step of the CPU model of the baked table, tests/support), and its
//     stored bytes exactly once colour management is switched off.
#include <QtTest>

#include <QtGui/qguiapplication_platform.h>
#include <QtWidgets/QVBoxLayout>

#include <xcb/xcb.h>

#include <filesystem>

#include "color_reference.h"
#include "displayprofile_p.h"
#include "enginehost_p.h"
#include "test_support.h"
#include "widget_test_support.h"

using namespace iriswidgettest;
namespace ref = iristest::color;

namespace {

QByteArray bytesOf(const std::vector<uint8_t>& v) {
    return QByteArray(reinterpret_cast<const char*>(v.data()), qsizetype(v.size()));
}

// The root window's _ICC_PROFILE, as a colour tool (colord, DisplayCAL, xiccd) sets it.
class RootProfile {
public:
    RootProfile() {
        auto* x11 = qGuiApp->nativeInterface<QNativeInterface::QX11Application>();
        m_c = x11 ? x11->connection() : nullptr;
        if (!m_c) return;
        m_root = xcb_setup_roots_iterator(xcb_get_setup(m_c)).data->root;
        const char name[] = "_ICC_PROFILE";
        xcb_intern_atom_reply_t* reply =
            xcb_intern_atom_reply(m_c, xcb_intern_atom(m_c, 0, sizeof name - 1, name), nullptr);
        if (reply) m_atom = reply->atom;
        free(reply);
    }
    ~RootProfile() { remove(); }
    bool ok() const { return m_c && m_atom != XCB_ATOM_NONE; }
    void set(const QByteArray& profile) {
        xcb_change_property(m_c, XCB_PROP_MODE_REPLACE, m_root, m_atom, XCB_ATOM_CARDINAL, 8, uint32_t(profile.size()),
                            profile.constData());
        xcb_flush(m_c);
    }
    void remove() {
        if (!ok()) return;
        xcb_delete_property(m_c, m_root, m_atom);
        xcb_flush(m_c);
    }

private:
    xcb_connection_t* m_c = nullptr;
    xcb_window_t m_root = XCB_WINDOW_NONE;
    xcb_atom_t m_atom = XCB_ATOM_NONE;
};

struct ViewWindow {
    std::unique_ptr<QWidget> window = std::make_unique<QWidget>();
    IrisSlideView* view = new IrisSlideView;
    std::unique_ptr<FrameWatcher> frames;
    ViewWindow() {
        auto* layout = new QVBoxLayout(window.get());
        layout->setContentsMargins(0, 0, 0, 0);
        layout->addWidget(view);
        window->resize(480, 360);
        frames = std::make_unique<FrameWatcher>(view);
    }
};

} // namespace

class TstColorWidget : public QObject {
    Q_OBJECT
private Q_SLOTS:
    void initTestCase();
    void cleanup();

    void propertiesAndSignal();
    void followsTheScreenProfile();
    void presentedFrameIsConverted();

private:
    QString m_profiled; // a slide whose ICC profile has strong curves
};

void TstColorWidget::initTestCase() {
    QCOMPARE(QGuiApplication::platformName(), QStringLiteral("xcb"));
    IrisSlideView::setVulkanValidation(true);
    const std::filesystem::path dir = iristest::testOutDir() / "color-widget";
    std::filesystem::create_directories(dir);
    const std::filesystem::path slide = dir / "strong-curves.tiff";
    std::string error;
    QVERIFY2(iristest::writeOneLevelTiff(slide, 2048, 1536, {}, &error, ref::strongCurvesProfile()), error.c_str());
    m_profiled = QString::fromStdString(slide.string());
    RootProfile().remove(); // whatever an earlier run left behind
}

void TstColorWidget::cleanup() {
    RootProfile().remove();
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 0);
}

void TstColorWidget::propertiesAndSignal() {
    ViewWindow w;
    QSignalSpy changed(w.view, &IrisSlideView::colorManagementChanged);
    QVERIFY(w.view->colorManaged()); // on by default, as the engine
    QCOMPARE(w.view->renderingIntent(), IrisSlideView::Perceptual);
    QVERIFY(w.view->displayProfile().isEmpty()); // no _ICC_PROFILE on this display: sRGB

    w.view->setColorManaged(false);
    QCOMPARE(changed.count(), 1);
    w.view->setColorManaged(false);
    QCOMPARE(changed.count(), 1);
    w.view->setProperty("renderingIntent", IrisSlideView::RelativeColorimetric);
    QCOMPARE(w.view->renderingIntent(), IrisSlideView::RelativeColorimetric);
    QCOMPARE(changed.count(), 2);
    w.view->setColorManaged(true);
    QCOMPARE(changed.count(), 3);

    // Opening a slide with a profile: it is applied, and both profiles are described.
    w.window->show();
    QVERIFY(QTest::qWaitForWindowExposed(w.window.get()));
    QVERIFY(w.view->openSlide(m_profiled));
    QCOMPARE(changed.count(), 4);
    QVERIFY(w.frames->waitForCompleteFrame());
    QVERIFY(w.view->isColorTransformApplied());
    QCOMPARE(w.view->slideProfileDescription(), QStringLiteral("Iris test: strong curves"));
    QCOMPARE(w.view->displayProfileDescription(), QStringLiteral("sRGB (built-in)"));
    QVERIFY(w.view->colorManagementError().isEmpty());
    w.view->setColorManaged(false);
    QVERIFY(!w.view->isColorTransformApplied());
    QCOMPARE(w.view->slideProfileDescription(), QStringLiteral("Iris test: strong curves"));
    w.view->closeSlide();
    QCOMPARE(changed.count(), 6);
    QCOMPARE(w.view->validationMessageCount(), quint64(0));
}

void TstColorWidget::followsTheScreenProfile() {
    RootProfile root;
    QVERIFY2(root.ok(), "cannot reach the X server's root window");
    const QByteArray wide = bytesOf(ref::wideGamma18Profile());
    const QByteArray srgb = bytesOf(ref::srgbProfile());
    root.set(wide);

    ViewWindow w;
    w.window->show();
    QVERIFY(QTest::qWaitForWindowExposed(w.window.get()));
    QCOMPARE(w.view->displayProfile(), wide); // read when the view starts
    QVERIFY(w.view->openSlide(m_profiled));
    QCOMPARE(w.view->displayProfileDescription(), QStringLiteral("Iris test: wide gamut gamma 1.8"));
    QVERIFY(w.view->isColorTransformApplied());

    // A colour tool installs another profile: the view follows (a PropertyNotify).
    QSignalSpy changed(w.view, &IrisSlideView::colorManagementChanged);
    root.set(srgb);
    QTRY_COMPARE(w.view->displayProfile(), srgb);
    QVERIFY(changed.count() >= 1);
    QVERIFY(w.view->displayProfileDescription() != QStringLiteral("Iris test: wide gamut gamma 1.8"));

    // The host's profile wins over the screen's until reset.
    w.view->setDisplayProfile(wide);
    QCOMPARE(w.view->displayProfile(), wide);
    QSignalSpy screenChanged(IrisWidget::DisplayProfileWatcher::instance(),
                             &IrisWidget::DisplayProfileWatcher::changed);
    root.remove();
    QTRY_VERIFY(screenChanged.count() > 0); // the view has heard of it too
    QCOMPARE(w.view->displayProfile(), wide);
    w.view->resetDisplayProfile();
    QVERIFY(w.view->displayProfile().isEmpty()); // the property is gone: sRGB
    QCOMPARE(w.view->displayProfileDescription(), QStringLiteral("sRGB (built-in)"));

    // A profile that cannot be used: reported, the slide shown untransformed.
    w.view->setDisplayProfile(QByteArray(300, 'x'));
    QVERIFY(!w.view->isColorTransformApplied());
    QVERIFY(!w.view->colorManagementError().isEmpty());
    qInfo("unusable display profile: %s", qPrintable(w.view->colorManagementError()));
    QVERIFY(w.frames->waitForCompleteFrame());
    QCOMPARE(w.view->validationMessageCount(), quint64(0));
}

void TstColorWidget::presentedFrameIsConverted() {
    ViewWindow w;
    w.window->show();
    QVERIFY(QTest::qWaitForWindowExposed(w.window.get()));
    QVERIFY(w.view->openSlide(m_profiled));
    QTRY_VERIFY(w.view->surfaceWindow()->isExposed());
    // Level 0 at 1:1, the target's top-left on slide pixel (300, 200): device pixel (x, y)
    // shows slide pixel (300 + x, 200 + y).
    const QSize target = w.view->targetSize();
    QVERIFY(target.width() % 2 == 0 && target.height() % 2 == 0);
    w.view->setDownsample(1);
    w.view->setCentre(QPointF(300 + target.width() / 2, 200 + target.height() / 2));
    QVERIFY(w.frames->waitForCompleteFrame());

    const auto lut = iris::color::bakeLut(ref::strongCurvesProfile(), {}, iris::color::Intent::Perceptual);
    QVERIFY(lut.ok());
    // Away from the corners, where the overlays are.
    const QPoint points[] = {{target.width() / 2, target.height() / 2},
                             {target.width() / 2 + 37, target.height() / 2 - 41},
                             {target.width() / 3, target.height() / 2 + 23}};
    for (const QPoint& p : points) {
        uint8_t stored[4];
        iristest::syntheticPixel(300 + p.x(), 200 + p.y(), stored);
        const auto want = ref::applyLut(lut.value(), stored[0], stored[1], stored[2]);
        QColor seen;
        QTRY_VERIFY2(presentedPixelIs(w.view, p, QColor(want[0], want[1], want[2]), 1, &seen),
                     qPrintable(QStringLiteral("(%1, %2): %3, the table gives (%4, %5, %6)")
                                    .arg(p.x())
                                    .arg(p.y())
                                    .arg(seen.name())
                                    .arg(want[0])
                                    .arg(want[1])
                                    .arg(want[2])));
        QVERIFY2(QColor(stored[0], stored[1], stored[2]) != QColor(want[0], want[1], want[2]),
                 "the strong curves leave this pixel unchanged: pick another");
    }

    // Off: the stored bytes, exactly.
    w.view->setColorManaged(false);
    QVERIFY(w.frames->waitForCompleteFrame());
    for (const QPoint& p : points) {
        uint8_t stored[4];
        iristest::syntheticPixel(300 + p.x(), 200 + p.y(), stored);
        QColor seen;
        QTRY_VERIFY2(presentedPixelIs(w.view, p, QColor(stored[0], stored[1], stored[2]), 0, &seen),
                     qPrintable(seen.name()));
    }
    QCOMPARE(w.view->validationMessageCount(), quint64(0));
}

IRIS_WIDGET_TEST_MAIN(TstColorWidget)
#include "tst_color_widget.moc"
