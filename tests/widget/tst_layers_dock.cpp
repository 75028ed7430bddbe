// tst_layers_dock: the viewer's Layers dock (demo/layersdock.*) in the main window, on an X
// display with lavapipe and the validation layers on. It checks what the dock shows and what
// its controls do to the view's layers (IrisSlideView::layer), not the layer's pixels:
//   * the View menu's "Layers" toggle; a file added lists as "title — kind, W × H", top first;
//   * the controls start at the map's range (window low/high = min/max, threshold "none") and
//     each one changes the view's style; a label map's class table shows and toggles classes;
//   * Up/Down and Remove change the view's stack; a user LUT shows under its name;
//   * a hostile file or LUT: a message box, and nothing else changes;
//   * another slide opened: the list empties (the layers went with their slide).

#include <cmath>
#include <memory>

#include <QtCore/QSettings>
#include <QtCore/QTemporaryDir>
#include <QtTest/QSignalSpy>
#include <QtTest/QTest>
#include <QtWidgets/QApplication>
#include <QtWidgets/QCheckBox>
#include <QtWidgets/QComboBox>
#include <QtWidgets/QDoubleSpinBox>
#include <QtWidgets/QListWidget>
#include <QtWidgets/QMenu>
#include <QtWidgets/QMenuBar>
#include <QtWidgets/QMessageBox>
#include <QtWidgets/QPushButton>
#include <QtWidgets/QSlider>
#include <QtWidgets/QTableWidget>

#include <iris/IrisSlideView.h>

#include "enginehost_p.h"
#include "layer_files.h"
#include "layersdock.h"
#include "mainwindow.h"
#include "widget_test_support.h"

using namespace iriswidgettest;

namespace {

QMessageBox *errorBox(const QWidget *window)
{
    for (QMessageBox *box : window->findChildren<QMessageBox *>(QStringLiteral("layerErrorBox"))) {
        if (box->isVisible())
            return box;
    }
    return nullptr;
}

} // namespace

class TstLayersDock : public QObject {
    Q_OBJECT
private Q_SLOTS:
    void initTestCase();
    void init();
    void cleanup();
    void cleanupTestCase();

    void viewMenuTogglesTheDock();
    void scalarLayerControls();
    void labelMapClasses();
    void orderAndRemoval();
    void userColorMap();
    void hostileFilesShowAMessage();
    void anotherSlideEmptiesTheList();
    void openInTheBackground();

private:
    QString path(const QString &name) const { return m_dir.filePath(name); }
    LayersDock *dock() const { return m_main->layersDock(); }
    IrisSlideView *view() const { return m_main->view(); }

    QTemporaryDir m_dir;
    std::unique_ptr<MainWindow> m_main;
};

void TstLayersDock::initTestCase()
{
    QCOMPARE(QGuiApplication::platformName(), QStringLiteral("xcb"));
    QVERIFY2(!qEnvironmentVariableIsEmpty("XDG_CONFIG_HOME"), "the test's settings need a folder of their own");
    QApplication::setOrganizationName(QStringLiteral("IrisView"));
    QApplication::setApplicationName(QStringLiteral("tst_layers_dock"));
    QSettings().clear();
    IrisSlideView::setVulkanValidation(true);
    QVERIFY(m_dir.isValid());
    QVERIFY(layerfiles::writeGreyPng(path(QStringLiteral("heat.png")), 60, 40, [](int x, int y) { return (x + y) * 2; }));
    QVERIFY(layerfiles::writeGreyPng(path(QStringLiteral("labels.png")), 32, 16, [](int x, int) { return x / 8; }));
    QVERIFY(layerfiles::writeTextLut(path(QStringLiteral("lut.txt"))));
    QVERIFY(layerfiles::writeBytes(path(QStringLiteral("noise.npy")), QByteArray("\x93NUMPY\x01\x00\xff\xff{", 11)));
}

void TstLayersDock::init()
{
    m_main = std::make_unique<MainWindow>();
    m_main->resize(1100, 800);
    m_main->show();
    QVERIFY(QTest::qWaitForWindowExposed(m_main.get()));
    QVERIFY(view()->isRendererAvailable());
    QTRY_VERIFY(view()->surfaceWindow()->isExposed());
    QVERIFY(m_main->openSlide(sampleSlide(), false));
    dock()->show();
    dock()->raise(); // tabbed with the other docks
    QTRY_VERIFY(dock()->layerList()->isVisible());
}

void TstLayersDock::cleanup()
{
    if (m_main)
        QCOMPARE(view()->validationMessageCount(), quint64(0));
    m_main.reset();
    QSettings().clear();
}

void TstLayersDock::cleanupTestCase()
{
    QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 0);
}

void TstLayersDock::viewMenuTogglesTheDock()
{
    QAction *toggle = nullptr;
    for (QAction *menu : m_main->menuBar()->actions()) {
        if (menu->menu() && menu->text().remove(QLatin1Char('&')) == QStringLiteral("View")) {
            for (QAction *action : menu->menu()->actions()) {
                if (action == dock()->toggleViewAction())
                    toggle = action;
            }
        }
    }
    QVERIFY(toggle);
    QCOMPARE(toggle->text(), QStringLiteral("Layers"));
    QVERIFY(toggle->isChecked());
    toggle->trigger();
    QTRY_VERIFY(!dock()->isVisible());
    toggle->trigger();
    QTRY_VERIFY(dock()->isVisible());
}

void TstLayersDock::scalarLayerControls()
{
    QVERIFY(!dock()->removeButton()->isEnabled()); // nothing to remove yet
    const quint64 id = dock()->addLayerFile(path(QStringLiteral("heat.png")), false);
    QVERIFY(id);
    QCOMPARE(dock()->layerList()->count(), 1);
    QCOMPARE(dock()->layerList()->item(0)->text(), QStringLiteral("heat.png — scalar, 60 × 40"));
    QCOMPARE(dock()->currentLayer(), id);
    QVERIFY(dock()->removeButton()->isEnabled());
    QVERIFY(!dock()->classTable()->isVisible());

    // The controls start at the map's range and the default style.
    QCOMPARE(dock()->lowSpin()->value(), 0.0);
    QCOMPARE(dock()->highSpin()->value(), 196.0);
    QCOMPARE(dock()->thresholdSpin()->value(), dock()->thresholdSpin()->minimum());
    QCOMPARE(dock()->thresholdSpin()->text(), QStringLiteral("none"));
    QCOMPARE(dock()->opacitySlider()->value(), 50);
    QCOMPARE(dock()->colorMapCombo()->currentText(), QStringLiteral("viridis"));
    QVERIFY(dock()->visibleCheck()->isChecked());
    QVERIFY(std::isnan(view()->layer(id).low)); // untouched: still the map's own range

    dock()->opacitySlider()->setValue(80);
    QCOMPARE(view()->layer(id).opacity, 0.8);
    dock()->visibleCheck()->setChecked(false);
    QVERIFY(!view()->layer(id).visible);
    dock()->colorMapCombo()->setCurrentIndex(dock()->colorMapCombo()->findText(QStringLiteral("jet")));
    Q_EMIT dock()->colorMapCombo()->activated(dock()->colorMapCombo()->currentIndex());
    QCOMPARE(view()->layer(id).colorMap, QStringLiteral("jet"));
    dock()->lowSpin()->setValue(20);
    QCOMPARE(view()->layer(id).low, 20.0);
    QCOMPARE(view()->layer(id).high, 196.0);
    dock()->highSpin()->setValue(100);
    QCOMPARE(view()->layer(id).high, 100.0);
    dock()->thresholdSpin()->setValue(30);
    QCOMPARE(view()->layer(id).threshold, 30.0);
    dock()->thresholdSpin()->setValue(dock()->thresholdSpin()->minimum());
    QVERIFY(std::isinf(view()->layer(id).threshold));
    dock()->samplingCombo()->setCurrentIndex(dock()->samplingCombo()->findData(int(IrisLayerInfo::Nearest)));
    Q_EMIT dock()->samplingCombo()->activated(dock()->samplingCombo()->currentIndex());
    QCOMPARE(view()->layer(id).sampling, IrisLayerInfo::Nearest);

    // Set elsewhere (the view's API): the dock follows.
    QVERIFY(view()->setLayerOpacity(id, 0.1));
    QCOMPARE(dock()->opacitySlider()->value(), 10);
}

void TstLayersDock::labelMapClasses()
{
    dock()->labelsCheck()->setChecked(true);
    const quint64 id = dock()->addLayerFile(path(QStringLiteral("labels.png")), dock()->labelsCheck()->isChecked());
    QVERIFY(id);
    QCOMPARE(dock()->layerList()->item(0)->text(), QStringLiteral("labels.png — label, 32 × 16"));
    QVERIFY(dock()->classTable()->isVisible());
    QVERIFY(!dock()->colorMapCombo()->isEnabled());
    QVERIFY(!dock()->samplingCombo()->isEnabled());
    QTableWidget *table = dock()->classTable();
    QCOMPARE(table->rowCount(), 4);
    QCOMPARE(table->item(0, 0)->checkState(), Qt::Unchecked); // background
    QCOMPARE(table->item(2, 0)->checkState(), Qt::Checked);
    QCOMPARE(table->item(2, 2)->text(), view()->layer(id).classes[2].name);

    table->item(2, 0)->setCheckState(Qt::Unchecked);
    QVERIFY(!view()->layer(id).classes[2].visible);
    QCOMPARE(table->item(2, 0)->checkState(), Qt::Unchecked);
    QVERIFY(view()->setLayerClassColor(id, 3, QColor(200, 10, 10)));
    QCOMPARE(table->item(3, 1)->background().color(), QColor(200, 10, 10));
}

void TstLayersDock::orderAndRemoval()
{
    const quint64 a = dock()->addLayerFile(path(QStringLiteral("heat.png")), false);
    const quint64 b = dock()->addLayerFile(path(QStringLiteral("labels.png")), true);
    QVERIFY(a && b);
    QCOMPARE(dock()->layerList()->item(0)->data(Qt::UserRole).toULongLong(), b); // the top first
    QCOMPARE(dock()->currentLayer(), b);
    QVERIFY(!dock()->upButton()->isEnabled());
    QVERIFY(dock()->downButton()->isEnabled());

    dock()->downButton()->click();
    QCOMPARE(view()->layerIds(), (QList<quint64>{b, a}));
    QCOMPARE(dock()->currentLayer(), b); // it stays current
    QCOMPARE(dock()->layerList()->item(1)->data(Qt::UserRole).toULongLong(), b);
    dock()->upButton()->click();
    QCOMPARE(view()->layerIds(), (QList<quint64>{a, b}));

    dock()->removeButton()->click();
    QCOMPARE(view()->layerIds(), QList<quint64>{a});
    QCOMPARE(dock()->layerList()->count(), 1);
    QCOMPARE(dock()->currentLayer(), a);
}

void TstLayersDock::userColorMap()
{
    const quint64 id = dock()->addLayerFile(path(QStringLiteral("heat.png")), false);
    QVERIFY(dock()->loadColorMapFile(path(QStringLiteral("lut.txt"))));
    QCOMPARE(view()->layer(id).colorMap, QStringLiteral("lut.txt"));
    QCOMPARE(dock()->colorMapCombo()->currentText(), QStringLiteral("lut.txt"));
    QVERIFY(!errorBox(m_main.get()));

    QVERIFY(!dock()->loadColorMapFile(path(QStringLiteral("heat.png")))); // 60 × 40: no LUT strip
    QMessageBox *box = nullptr;
    QTRY_VERIFY((box = errorBox(m_main.get())));
    QVERIFY2(box->text().contains(QStringLiteral("heat.png")), qPrintable(box->text()));
    box->close();
    QCOMPARE(view()->layer(id).colorMap, QStringLiteral("lut.txt"));

    // A built-in map again: the LUT's row stays until another LUT replaces it.
    dock()->colorMapCombo()->setCurrentIndex(dock()->colorMapCombo()->findText(QStringLiteral("magma")));
    Q_EMIT dock()->colorMapCombo()->activated(dock()->colorMapCombo()->currentIndex());
    QCOMPARE(view()->layer(id).colorMap, QStringLiteral("magma"));
}

void TstLayersDock::hostileFilesShowAMessage()
{
    const quint64 kept = dock()->addLayerFile(path(QStringLiteral("heat.png")), false);
    QVERIFY(view()->setLayerOpacity(kept, 0.3));
    for (const QString &name : {QStringLiteral("noise.npy"), QStringLiteral("missing.tif")}) {
        QCOMPARE(dock()->addLayerFile(path(name), false), quint64(0));
        QMessageBox *box = nullptr;
        QTRY_VERIFY((box = errorBox(m_main.get())));
        QCOMPARE(box->windowTitle(), QStringLiteral("Cannot open the layer"));
        QVERIFY2(box->text().contains(name), qPrintable(box->text()));
        box->close();
        QTRY_VERIFY(!errorBox(m_main.get()));
    }
    QCOMPARE(dock()->layerList()->count(), 1);
    QCOMPARE(dock()->currentLayer(), kept);
    QCOMPARE(dock()->opacitySlider()->value(), 30);
    QVERIFY(view()->hasSlide());
    QCOMPARE(view()->layerIds(), QList<quint64>{kept});
}

void TstLayersDock::anotherSlideEmptiesTheList()
{
    QVERIFY(dock()->addLayerFile(path(QStringLiteral("heat.png")), false));
    QCOMPARE(dock()->layerList()->count(), 1);
    QVERIFY(m_main->openSlide(secondSampleSlide(), false));
    QCOMPARE(dock()->layerList()->count(), 0);
    QVERIFY(!dock()->removeButton()->isEnabled());
    QVERIFY(!dock()->currentLayer());
}

// Open Layer…'s path: the file read on a worker thread, the button waiting meanwhile, the
// outcome reported by layerFileAdded (a refusal after its message box).
void TstLayersDock::openInTheBackground()
{
    QSignalSpy added(dock(), &LayersDock::layerFileAdded);
    auto *open = dock()->findChild<QPushButton *>(QStringLiteral("openLayerButton"));
    QVERIFY(open);
    QVERIFY(dock()->addLayerFileInBackground(path(QStringLiteral("labels.png")), true));
    QVERIFY(dock()->loading());
    QVERIFY(!open->isEnabled());
    // One load at a time: the second waits for the user to ask again.
    QVERIFY(!dock()->addLayerFileInBackground(path(QStringLiteral("heat.png")), false));
    QVERIFY(added.wait(20000));
    const quint64 id = added.takeFirst().at(0).toULongLong();
    QVERIFY(id);
    QVERIFY(!dock()->loading());
    QVERIFY(open->isEnabled());
    QCOMPARE(dock()->currentLayer(), id);
    QCOMPARE(dock()->layerList()->count(), 1);
    QCOMPARE(view()->layerIds(), QList<quint64>{id});
    QCOMPARE(view()->layer(id).kindName(), QStringLiteral("label"));

    QVERIFY(dock()->addLayerFileInBackground(path(QStringLiteral("missing.tif")), false));
    QVERIFY(added.wait(20000));
    QCOMPARE(added.takeFirst().at(0).toULongLong(), quint64(0));
    QMessageBox *box = nullptr;
    QTRY_VERIFY((box = errorBox(m_main.get())));
    QCOMPARE(box->windowTitle(), QStringLiteral("Cannot open the layer"));
    QVERIFY2(box->text().contains(QStringLiteral("missing.tif")), qPrintable(box->text()));
    box->close();
    QTRY_VERIFY(!errorBox(m_main.get()));
    QCOMPARE(view()->layerIds(), QList<quint64>{id});
}

IRIS_WIDGET_TEST_MAIN(TstLayersDock)
#include "tst_layers_dock.moc"
