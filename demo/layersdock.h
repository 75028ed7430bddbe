// Iris View demo — the Layers dock: the raster layers (heat maps, label maps; issue 19) drawn
// over the open slide, top of the stack first (title, kind, size), with Open Layer… (PNG,
// TIFF, NumPy .npy; "as label map" reads a single-channel integer file as class ids), Remove,
// Up and Down, and the current layer's controls: visible, opacity, colour map (the built-in
// ones or a user LUT file), window low/high and threshold (starting at the map's own range),
// sampling, and for a label map its classes (visibility, colour swatch, name).
//
// The view keeps the layers (IrisSlideView::addLayer and its setters): the dock only shows
// them and edits them through the view, and follows layersChanged(), so layers removed with
// their slide leave the dock too. A file or LUT that cannot be read shows a message box
// (objectName "layerErrorBox") and changes nothing. There is no legend overlay yet.
#pragma once

#include <QtCore/QPointer>
#include <QtWidgets/QDockWidget>

QT_BEGIN_NAMESPACE
class QCheckBox;
class QComboBox;
class QDoubleSpinBox;
class QListWidget;
class QPushButton;
class QSlider;
class QTableWidget;
class QThread;
class QWidget;
QT_END_NAMESPACE
class IrisSlideView;
struct IrisLayerInfo;

class LayersDock : public QDockWidget
{
    Q_OBJECT
public:
    // Rows of a label map's class table (a map of more ids lists the first ones and says so).
    static constexpr int kMaxClassRows = 256;

    explicit LayersDock(IrisSlideView *view, QWidget *parent = nullptr);

    ~LayersDock() override;

    // Asks for a file (Open Layer…) and adds it as addLayerFileInBackground does.
    void showOpenDialog();
    // Adds a map file, as a label map when asLabels; the new layer becomes the current one.
    // Returns its id, or 0 after showing why in a message box.
    quint64 addLayerFile(const QString &path, bool asLabels);
    // The same, the file read on a worker thread (a large map is streamed, and its load reads
    // every pixel once: seconds for a map of a gigabyte): the Open button says "Loading…" and
    // waits meanwhile, and layerFileAdded() reports the outcome. False when a load is going on.
    bool addLayerFileInBackground(const QString &path, bool asLabels);
    bool loading() const { return m_loading != nullptr; }
    // Asks for a LUT file (the colour map combo's "Custom LUT…") and uses it as loadColorMapFile.
    void showColorMapDialog();
    // The current layer's colour map from a LUT file; false after a message box.
    bool loadColorMapFile(const QString &path);
    // Opens the colour dialog for a class of the current label map; its choice goes to the view.
    void chooseClassColour(int classId);

    // The layer of the list's current row (0: none).
    quint64 currentLayer() const;
    void setCurrentLayer(quint64 id);

    QListWidget *layerList() const { return m_list; }
    QCheckBox *labelsCheck() const { return m_asLabels; }
    QPushButton *removeButton() const { return m_remove; }
    QPushButton *upButton() const { return m_up; }
    QPushButton *downButton() const { return m_down; }
    QCheckBox *visibleCheck() const { return m_visible; }
    QSlider *opacitySlider() const { return m_opacity; }
    QComboBox *colorMapCombo() const { return m_colorMap; }
    QDoubleSpinBox *lowSpin() const { return m_low; }
    QDoubleSpinBox *highSpin() const { return m_high; }
    QDoubleSpinBox *thresholdSpin() const { return m_threshold; }
    QComboBox *samplingCombo() const { return m_sampling; }
    QTableWidget *classTable() const { return m_classes; }

Q_SIGNALS:
    // A background load ended: the new layer's id, or 0 after the message box said why.
    void layerFileAdded(quint64 id);

private:
    void refreshList();      // the view's layers, keeping the current one
    void refreshControls();  // the current layer's style into the controls
    void fillClasses(const IrisLayerInfo &info);
    void moveCurrent(int towardsTop); // +1 up the stack, −1 down
    void applyWindow();
    void applyThreshold();
    void colorMapChosen(int index);
    void showError(const QString &title, const QString &text);

    QPointer<IrisSlideView> m_view; // the main window's; it may go first when the window closes
    QListWidget *m_list;
    QCheckBox *m_asLabels;
    QPushButton *m_remove;
    QPushButton *m_up;
    QPushButton *m_down;
    QWidget *m_controls;
    QCheckBox *m_visible;
    QSlider *m_opacity;
    QComboBox *m_colorMap;
    QDoubleSpinBox *m_low;
    QDoubleSpinBox *m_high;
    QDoubleSpinBox *m_threshold;
    QComboBox *m_sampling;
    QTableWidget *m_classes;
    bool m_updating = false; // the controls are being set from the view: no edits back
    QPushButton *m_open;
    QThread *m_loading = nullptr; // the background load, waited for when the dock goes
};
