#include "layersdock.h"

#include <cmath>
#include <memory>
#include <optional>
#include <limits>

#include <QtCore/QDir>
#include <QtCore/QFile>
#include <QtCore/QFileInfo>
#include <QtCore/QLocale>
#include <QtCore/QSettings>
#include <QtCore/QThread>
#include <QtWidgets/QCheckBox>
#include <QtWidgets/QColorDialog>
#include <QtWidgets/QComboBox>
#include <QtWidgets/QDoubleSpinBox>
#include <QtWidgets/QFileDialog>
#include <QtWidgets/QFormLayout>
#include <QtWidgets/QHBoxLayout>
#include <QtWidgets/QHeaderView>
#include <QtWidgets/QLabel>
#include <QtWidgets/QListWidget>
#include <QtWidgets/QMessageBox>
#include <QtWidgets/QPushButton>
#include <QtWidgets/QSlider>
#include <QtWidgets/QTableWidget>
#include <QtWidgets/QVBoxLayout>

#include <iris/IrisSlideView.h>
#include <iris/layers.h>

namespace {

const QStringList kBuiltinColorMaps{QStringLiteral("viridis"), QStringLiteral("magma"), QStringLiteral("jet"),
                                    QStringLiteral("gray")};
const QString kCustomLutItem = QStringLiteral("Custom LUT…");
enum ClassColumn { ShowColumn, ColourColumn, NameColumn, ClassColumns };

// "heat.png — scalar, 1,024 × 768".
QString rowText(const IrisLayerInfo &info)
{
    const QLocale locale;
    return LayersDock::tr("%1 — %2, %3 × %4")
        .arg(info.title.isEmpty() ? LayersDock::tr("(untitled)") : info.title, info.kindName(),
             locale.toString(info.size.width()), locale.toString(info.size.height()));
}

// Calls `call` and returns the first slideError() it caused ("" for none).
template <class Call>
QString firstError(IrisSlideView *view, QObject *context, Call call)
{
    QString error;
    const QMetaObject::Connection c = QObject::connect(view, &IrisSlideView::slideError, context,
        [&error](const QString &message) {
            if (error.isEmpty())
                error = message;
        });
    call();
    QObject::disconnect(c);
    return error;
}

void setValueRange(QDoubleSpinBox *spin, double lo, double hi, double value)
{
    const double span = hi - lo;
    spin->setDecimals(span > 0 && span <= 10 ? 4 : 2);
    spin->setSingleStep(span > 0 ? span / 100 : 1);
    spin->setRange(lo, hi);
    spin->setValue(value);
}

} // namespace

LayersDock::LayersDock(IrisSlideView *view, QWidget *parent)
    : QDockWidget(tr("Layers"), parent)
    , m_view(view)
    , m_list(new QListWidget)
    , m_asLabels(new QCheckBox(tr("as label map")))
    , m_remove(new QPushButton(tr("Remove")))
    , m_up(new QPushButton(tr("Up")))
    , m_down(new QPushButton(tr("Down")))
    , m_controls(new QWidget)
    , m_visible(new QCheckBox(tr("Visible")))
    , m_opacity(new QSlider(Qt::Horizontal))
    , m_colorMap(new QComboBox)
    , m_low(new QDoubleSpinBox)
    , m_high(new QDoubleSpinBox)
    , m_threshold(new QDoubleSpinBox)
    , m_sampling(new QComboBox)
    , m_classes(new QTableWidget(0, ClassColumns))
{
    setObjectName(QStringLiteral("layersDock"));
    m_list->setObjectName(QStringLiteral("layerList"));
    m_asLabels->setObjectName(QStringLiteral("layerAsLabelsCheck"));
    m_asLabels->setToolTip(tr("Read a single-channel integer file as class ids (a segmentation)"));
    m_classes->setObjectName(QStringLiteral("layerClassTable"));

    auto *body = new QWidget;
    auto *layout = new QVBoxLayout(body);
    auto *open = new QPushButton(tr("Open Layer…"));
    m_open = open;
    open->setObjectName(QStringLiteral("openLayerButton"));
    connect(open, &QPushButton::clicked, this, &LayersDock::showOpenDialog);
    auto *openRow = new QHBoxLayout;
    openRow->addWidget(open);
    openRow->addWidget(m_asLabels);
    openRow->addStretch();
    layout->addLayout(openRow);

    m_list->setToolTip(tr("The top of the list is drawn on top"));
    layout->addWidget(m_list, 1);
    auto *buttons = new QHBoxLayout;
    m_up->setToolTip(tr("Draw the layer over the one above it"));
    m_down->setToolTip(tr("Draw the layer under the one below it"));
    for (QPushButton *b : {m_remove, m_up, m_down})
        buttons->addWidget(b);
    buttons->addStretch();
    layout->addLayout(buttons);
    connect(m_remove, &QPushButton::clicked, this, [this] {
        if (m_view)
            m_view->removeLayer(currentLayer());
    });
    connect(m_up, &QPushButton::clicked, this, [this] { moveCurrent(+1); });
    connect(m_down, &QPushButton::clicked, this, [this] { moveCurrent(-1); });

    auto *form = new QFormLayout(m_controls);
    form->setContentsMargins(0, 0, 0, 0);
    form->addRow(m_visible);
    m_opacity->setRange(0, 100);
    form->addRow(tr("Opacity"), m_opacity);
    m_colorMap->addItems(kBuiltinColorMaps);
    m_colorMap->addItem(kCustomLutItem);
    form->addRow(tr("Colour map"), m_colorMap);
    form->addRow(tr("Window low"), m_low);
    form->addRow(tr("Window high"), m_high);
    m_threshold->setSpecialValueText(tr("none"));
    m_threshold->setToolTip(tr("Values below it are not drawn"));
    form->addRow(tr("Threshold"), m_threshold);
    m_sampling->addItem(tr("Bilinear"), int(IrisLayerInfo::Bilinear));
    m_sampling->addItem(tr("Nearest"), int(IrisLayerInfo::Nearest));
    form->addRow(tr("Sampling"), m_sampling);
    m_classes->setHorizontalHeaderLabels({tr("Show"), QString(), tr("Class")});
    m_classes->verticalHeader()->hide();
    m_classes->setEditTriggers(QAbstractItemView::NoEditTriggers);
    m_classes->setSelectionMode(QAbstractItemView::NoSelection);
    m_classes->horizontalHeader()->setSectionResizeMode(ShowColumn, QHeaderView::ResizeToContents);
    m_classes->horizontalHeader()->setSectionResizeMode(ColourColumn, QHeaderView::Fixed);
    m_classes->horizontalHeader()->resizeSection(ColourColumn, 28);
    m_classes->horizontalHeader()->setSectionResizeMode(NameColumn, QHeaderView::Stretch);
    form->addRow(m_classes);
    layout->addWidget(m_controls);
    setWidget(body);

    connect(m_visible, &QCheckBox::toggled, this, [this](bool on) {
        if (!m_updating && m_view)
            m_view->setLayerVisible(currentLayer(), on);
    });
    connect(m_opacity, &QSlider::valueChanged, this, [this](int percent) {
        if (!m_updating && m_view)
            m_view->setLayerOpacity(currentLayer(), percent / 100.0);
    });
    connect(m_colorMap, &QComboBox::activated, this, &LayersDock::colorMapChosen);
    for (QDoubleSpinBox *spin : {m_low, m_high})
        connect(spin, &QDoubleSpinBox::valueChanged, this, &LayersDock::applyWindow);
    connect(m_threshold, &QDoubleSpinBox::valueChanged, this, &LayersDock::applyThreshold);
    connect(m_sampling, &QComboBox::activated, this, [this] {
        if (!m_updating && m_view)
            m_view->setLayerSampling(currentLayer(), IrisLayerInfo::Sampling(m_sampling->currentData().toInt()));
    });
    connect(m_classes, &QTableWidget::itemChanged, this, [this](QTableWidgetItem *item) {
        if (!m_updating && m_view && item->column() == ShowColumn)
            m_view->setLayerClassVisible(currentLayer(), item->row(), item->checkState() == Qt::Checked);
    });
    connect(m_classes, &QTableWidget::cellClicked, this, [this](int row, int column) {
        if (column == ColourColumn)
            chooseClassColour(row);
    });
    connect(m_list, &QListWidget::currentRowChanged, this, [this] {
        if (!m_updating)
            refreshControls();
    });
    connect(m_view, &IrisSlideView::layersChanged, this, &LayersDock::refreshList);
    refreshList();
}

void LayersDock::showOpenDialog()
{
    QSettings settings;
    const QString dir = settings.value(QStringLiteral("layers/lastDir"), QDir::homePath()).toString();
    const QString path = QFileDialog::getOpenFileName(this, tr("Open Layer"), dir,
        tr("Layer maps (*.png *.tif *.tiff *.npy);;All files (*)"));
    if (path.isEmpty())
        return;
    settings.setValue(QStringLiteral("layers/lastDir"), QFileInfo(path).absolutePath());
    addLayerFileInBackground(path, m_asLabels->isChecked());
}

LayersDock::~LayersDock()
{
    if (m_loading) {
        m_loading->disconnect(this); // its result has no dock to go to
        m_loading->wait();
        delete m_loading;
    }
}

bool LayersDock::addLayerFileInBackground(const QString &path, bool asLabels)
{
    if (!m_view || m_loading)
        return false;
    // What IrisSlideView::addLayer(path) reads, read here off the UI thread.
    auto result = std::make_shared<std::optional<iris::Expected<iris::RasterMap>>>();
    iris::RasterLoadOptions options;
    options.asLabels = asLabels;
    options.title = QFileInfo(path).fileName().toStdString();
    const std::string file = QFile::encodeName(path).toStdString();
    m_loading = QThread::create([result, options, file] { result->emplace(iris::loadRasterMap(file, options)); });
    m_open->setEnabled(false);
    m_open->setText(tr("Loading…"));
    connect(m_loading, &QThread::finished, this, [this, result, path] {
        m_loading->deleteLater();
        m_loading = nullptr;
        m_open->setEnabled(true);
        m_open->setText(tr("Open Layer…"));
        quint64 id = 0;
        if (!result->has_value() || !**result) {
            const QString why = result->has_value() ? QString::fromStdString((**result).error().message())
                                                    : tr("%1: the load did not finish").arg(path);
            showError(tr("Cannot open the layer"), why);
        } else if (m_view) {
            const QString error = firstError(m_view, this, [&] {
                id = m_view->addLayer(std::make_shared<const iris::RasterMap>(std::move(**result).value()));
            });
            if (id)
                setCurrentLayer(id);
            else
                showError(tr("Cannot open the layer"), error);
        }
        Q_EMIT layerFileAdded(id);
    });
    m_loading->start();
    return true;
}

quint64 LayersDock::addLayerFile(const QString &path, bool asLabels)
{
    if (!m_view)
        return 0;
    quint64 id = 0;
    const QString error = firstError(m_view, this, [&] { id = m_view->addLayer(path, asLabels); });
    if (!id) {
        showError(tr("Cannot open the layer"), error);
        return 0;
    }
    setCurrentLayer(id);
    return id;
}

void LayersDock::showColorMapDialog()
{
    QSettings settings;
    const QString dir = settings.value(QStringLiteral("layers/lastLutDir"), QDir::homePath()).toString();
    const QString path = QFileDialog::getOpenFileName(this, tr("Colour Map"), dir,
        tr("Colour tables (*.png *.txt *.lut);;All files (*)"));
    if (!path.isEmpty()) {
        settings.setValue(QStringLiteral("layers/lastLutDir"), QFileInfo(path).absolutePath());
        loadColorMapFile(path);
    }
    refreshControls(); // the combo back to the map in use when nothing was chosen
}

bool LayersDock::loadColorMapFile(const QString &path)
{
    if (!m_view || !currentLayer())
        return false;
    bool ok = false;
    const QString error = firstError(m_view, this, [&] { ok = m_view->loadLayerColorMap(currentLayer(), path); });
    if (!ok)
        showError(tr("Cannot use the colour map"), error);
    return ok;
}

void LayersDock::chooseClassColour(int classId)
{
    if (!m_view)
        return;
    const IrisLayerInfo info = m_view->layer(currentLayer());
    if (classId < 0 || classId >= info.classes.size())
        return;
    const QColor chosen = QColorDialog::getColor(info.classes[classId].color, this,
        tr("Colour of %1").arg(info.classes[classId].name), QColorDialog::ShowAlphaChannel);
    if (chosen.isValid() && m_view)
        m_view->setLayerClassColor(currentLayer(), classId, chosen);
}

quint64 LayersDock::currentLayer() const
{
    const QListWidgetItem *item = m_list->currentItem();
    return item ? item->data(Qt::UserRole).toULongLong() : 0;
}

void LayersDock::setCurrentLayer(quint64 id)
{
    for (int row = 0; row < m_list->count(); ++row) {
        if (m_list->item(row)->data(Qt::UserRole).toULongLong() == id)
            m_list->setCurrentRow(row);
    }
}

void LayersDock::refreshList()
{
    if (!m_view)
        return;
    const quint64 current = currentLayer();
    const QList<IrisLayerInfo> layers = m_view->layers();
    m_updating = true;
    m_list->clear();
    int currentRow = layers.isEmpty() ? -1 : 0;
    for (qsizetype i = layers.size() - 1; i >= 0; --i) { // the top of the stack first
        auto *item = new QListWidgetItem(rowText(layers[i]), m_list);
        item->setData(Qt::UserRole, layers[i].id);
        if (layers[i].id == current)
            currentRow = m_list->count() - 1;
    }
    m_list->setCurrentRow(currentRow);
    m_updating = false;
    refreshControls();
}

void LayersDock::refreshControls()
{
    const IrisLayerInfo info = m_view ? m_view->layer(currentLayer()) : IrisLayerInfo();
    const int row = m_list->currentRow();
    m_remove->setEnabled(info.isValid());
    m_up->setEnabled(info.isValid() && row > 0);
    m_down->setEnabled(info.isValid() && row + 1 < m_list->count());
    m_controls->setEnabled(info.isValid());
    const bool scalar = info.kind == IrisLayerInfo::Scalar;
    for (QWidget *w : std::initializer_list<QWidget *>{m_colorMap, m_low, m_high, m_threshold})
        w->setEnabled(scalar);
    m_sampling->setEnabled(info.kind != IrisLayerInfo::Label);
    m_classes->setVisible(info.kind == IrisLayerInfo::Label);
    if (!info.isValid())
        return;

    m_updating = true;
    m_visible->setChecked(info.visible);
    m_opacity->setValue(int(std::lround(info.opacity * 100)));
    // A user LUT shows under its file's name, before "Custom LUT…".
    int mapIndex = m_colorMap->findText(info.colorMap);
    if (mapIndex < 0) {
        while (m_colorMap->count() > kBuiltinColorMaps.size() + 1)
            m_colorMap->removeItem(kBuiltinColorMaps.size());
        m_colorMap->insertItem(kBuiltinColorMaps.size(), info.colorMap);
        mapIndex = kBuiltinColorMaps.size();
    }
    m_colorMap->setCurrentIndex(mapIndex);
    // The window and threshold start at the map's own range.
    const double lo = std::isfinite(info.minValue) ? info.minValue : 0;
    const double hi = std::isfinite(info.maxValue) ? info.maxValue : 1;
    const double span = hi > lo ? hi - lo : 1;
    setValueRange(m_low, lo - span, hi + span, std::isnan(info.low) ? lo : info.low);
    setValueRange(m_high, lo - span, hi + span, std::isnan(info.high) ? hi : info.high);
    // Its lowest step is "none".
    const double none = lo - span / 100;
    setValueRange(m_threshold, none, hi, std::isfinite(info.threshold) ? std::max(info.threshold, none) : none);
    m_sampling->setCurrentIndex(m_sampling->findData(int(info.sampling)));
    fillClasses(info);
    m_updating = false;
}

void LayersDock::fillClasses(const IrisLayerInfo &info)
{
    const int rows = int(std::min<qsizetype>(info.classes.size(), kMaxClassRows));
    // Updated in place when the rows stay (a check box's own itemChanged may be on the stack).
    if (m_classes->rowCount() != rows) {
        m_classes->setRowCount(rows);
        for (int row = 0; row < rows; ++row) {
            auto *show = new QTableWidgetItem;
            show->setFlags(Qt::ItemIsEnabled | Qt::ItemIsUserCheckable);
            m_classes->setItem(row, ShowColumn, show);
            m_classes->setItem(row, ColourColumn, new QTableWidgetItem);
            m_classes->setItem(row, NameColumn, new QTableWidgetItem);
        }
    }
    for (int row = 0; row < rows; ++row) {
        const IrisLayerClass &c = info.classes[row];
        m_classes->item(row, ShowColumn)->setCheckState(c.visible ? Qt::Checked : Qt::Unchecked);
        m_classes->item(row, ColourColumn)->setBackground(c.color);
        m_classes->item(row, ColourColumn)->setToolTip(c.color.name(QColor::HexArgb));
        m_classes->item(row, NameColumn)->setText(c.name);
    }
    m_classes->setToolTip(info.classes.size() > rows
            ? tr("The first %1 of %2 classes").arg(rows).arg(info.classes.size())
            : QString());
}

void LayersDock::moveCurrent(int towardsTop)
{
    if (!m_view)
        return;
    const quint64 id = currentLayer();
    const int index = int(m_view->layerIds().indexOf(id)); // 0: the bottom
    if (index < 0 || index + towardsTop < 0)
        return;
    m_view->moveLayer(id, index + towardsTop);
    setCurrentLayer(id);
}

void LayersDock::applyWindow()
{
    if (!m_updating && m_view)
        m_view->setLayerWindow(currentLayer(), m_low->value(), m_high->value());
}

void LayersDock::applyThreshold()
{
    if (m_updating || !m_view)
        return;
    const double value = m_threshold->value();
    m_view->setLayerThreshold(currentLayer(),
        value <= m_threshold->minimum() ? -std::numeric_limits<double>::infinity() : value);
}

void LayersDock::colorMapChosen(int index)
{
    if (m_updating || !m_view)
        return;
    const QString text = m_colorMap->itemText(index);
    if (text == kCustomLutItem)
        showColorMapDialog();
    else if (kBuiltinColorMaps.contains(text))
        m_view->setLayerColorMap(currentLayer(), text);
}

void LayersDock::showError(const QString &title, const QString &text)
{
    auto *box = new QMessageBox(QMessageBox::Warning, title, text, QMessageBox::Ok, this);
    box->setObjectName(QStringLiteral("layerErrorBox"));
    box->setAttribute(Qt::WA_DeleteOnClose);
    box->open();
}
