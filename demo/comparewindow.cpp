#include "comparewindow.h"

#include <algorithm>

#include <QtCore/QDir>
#include <QtCore/QFileInfo>
#include <QtCore/QSettings>
#include <QtGui/QAction>
#include <QtWidgets/QFileDialog>
#include <QtWidgets/QGridLayout>
#include <QtWidgets/QMenuBar>
#include <QtWidgets/QStatusBar>
#include <QtWidgets/QToolButton>

#include <iris/IrisSlideView.h>
#include <iris/IrisViewGroup.h>

#include "comparepane.h"
#include "orientationactions.h"
#include "slideformats.h"

namespace {
constexpr int kMessageMs = 8000;
}

CompareWindow::CompareWindow(QWidget *parent)
    : QMainWindow(parent)
    , m_group(new IrisViewGroup(this))
    , m_grid(nullptr)
    , m_orientation(new OrientationActions(this))
{
    setWindowFlag(Qt::Window);
    auto *central = new QWidget;
    m_grid = new QGridLayout(central);
    m_grid->setContentsMargins(0, 0, 0, 0);
    m_grid->setSpacing(2);
    setCentralWidget(central);
    createMenus();
    connect(m_group, &IrisViewGroup::linkedChanged, this, [this](IrisSlideView *view, bool linked) {
        for (ComparePane *pane : std::as_const(m_panes)) {
            if (pane->view() == view)
                pane->setLinked(linked);
        }
    });
    statusBar()->showMessage(tr("Linked views move together; unlink one to align it by hand."), kMessageMs);
    resize(1400, 900);
    updateTitle();
    updateActions();
}

CompareWindow::~CompareWindow()
{
    // The group first: it lets go of the views, which the panes then take with them.
    delete m_group;
    m_group = nullptr;
}

void CompareWindow::createMenus()
{
    QMenu *file = menuBar()->addMenu(tr("&File"));
    m_addAction = file->addAction(tr("&Add Slide…"), this, &CompareWindow::showAddDialog);
    m_addAction->setShortcut(QKeySequence::Open);
    m_addAction->setObjectName(QStringLiteral("addSlideAction"));
    file->addSeparator();
    QAction *close = file->addAction(tr("&Close Window"), this, &QWidget::close);
    close->setShortcut(QKeySequence::Close);

    QMenu *view = menuBar()->addMenu(tr("&View"));
    m_fitAction = view->addAction(tr("&Fit to Window"), this, [this] {
        if (IrisSlideView *v = currentView())
            v->fitToWindow();
    });
    m_fitAction->setShortcut(Qt::CTRL | Qt::Key_0);
    view->addSeparator();
    m_orientation->addTo(view);
    view->addSeparator();
    m_linkAllAction = view->addAction(tr("&Link All Views"), this, [this] {
        for (ComparePane *pane : std::as_const(m_panes))
            m_group->setLinked(pane->view(), true);
    });
    m_linkAllAction->setObjectName(QStringLiteral("linkAllAction"));
    m_linkAllAction->setStatusTip(tr("Link every view, each keeping its present alignment"));
    m_crosshairAction = view->addAction(tr("Cursor &Cross-hair"));
    m_crosshairAction->setObjectName(QStringLiteral("crosshairAction"));
    m_crosshairAction->setCheckable(true);
    m_crosshairAction->setChecked(m_group->crosshairsEnabled());
    m_crosshairAction->setStatusTip(tr("Mark the pointer's place on the slide in every other linked view"));
    connect(m_crosshairAction, &QAction::toggled, m_group, &IrisViewGroup::setCrosshairsEnabled);
}

void CompareWindow::setNetworkCredentials(const IrisSlideView::NetworkCredentials &credentials)
{
    m_credentials = credentials;
    for (ComparePane *pane : std::as_const(m_panes))
        pane->view()->setNetworkCredentials(credentials); // for the slides they open from now on
}

void CompareWindow::setFrameCacheDirectory(const QString &directory)
{
    m_frameCache = directory;
    for (ComparePane *pane : std::as_const(m_panes))
        pane->view()->setFrameCacheDirectory(directory);
}

bool CompareWindow::addSlide(const QString &path, const Pose *start)
{
    if (count() >= kMaxSlides)
        return false;
    auto *pane = new ComparePane;
    IrisSlideView *view = pane->view();
    view->setNetworkCredentials(m_credentials);
    view->setFrameCacheDirectory(m_frameCache);
    m_panes << pane;
    m_group->addView(view);
    connect(pane, &ComparePane::linkToggled, this, [this, view](bool on) { m_group->setLinked(view, on); });
    connect(pane, &ComparePane::closeRequested, this, [this, pane] { removePane(pane); });
    connect(pane, &ComparePane::activated, this, [this, pane] { setCurrent(pane); });
    connect(pane, &ComparePane::opened, this, [this, pane] { onOpened(pane); });
    connect(pane, &ComparePane::failed, this, [this](const QString &failedPath, const QString &message) {
        statusBar()->showMessage(tr("Cannot open %1: %2").arg(QFileInfo(failedPath).fileName(), message), kMessageMs);
        updateTitle();
        if (std::none_of(m_panes.cbegin(), m_panes.cend(), [](const ComparePane *p) { return !p->pendingPath().isEmpty(); }))
            Q_EMIT slidesOpened();
    });
    connect(pane, &ComparePane::openRequested, this, [this, pane] {
        QSettings settings;
        const QString dir = settings.value(QStringLiteral("lastFolder"), QDir::homePath()).toString();
        const QString chosen = QFileDialog::getOpenFileName(this, tr("Open Slide"), dir,
                                                            SlideFormats::fileDialogFilters().join(QStringLiteral(";;")));
        if (chosen.isEmpty())
            return;
        settings.setValue(QStringLiteral("lastFolder"), QFileInfo(chosen).absolutePath());
        pane->openWhenShown(chosen);
    });
    if (start && start->downsample > 0) {
        m_start = *start;
        m_startPane = pane;
    }
    relayout();
    if (!m_current)
        setCurrent(pane);
    pane->openWhenShown(path);
    updateActions();
    return true;
}

IrisSlideView *CompareWindow::view(int index) const
{
    const ComparePane *p = pane(index);
    return p ? p->view() : nullptr;
}

IrisSlideView *CompareWindow::currentView() const
{
    return m_current ? m_current->view() : nullptr;
}

void CompareWindow::showAddDialog()
{
    if (count() >= kMaxSlides)
        return;
    QSettings settings;
    const QString dir = settings.value(QStringLiteral("lastFolder"), QDir::homePath()).toString();
    const QStringList chosen = QFileDialog::getOpenFileNames(
        this, tr("Add Slides to the Comparison"), dir, SlideFormats::fileDialogFilters().join(QStringLiteral(";;")));
    if (chosen.isEmpty())
        return;
    settings.setValue(QStringLiteral("lastFolder"), QFileInfo(chosen.first()).absolutePath());
    int added = 0;
    for (const QString &path : chosen) {
        if (!addSlide(path))
            break;
        ++added;
    }
    if (added < chosen.size())
        statusBar()->showMessage(tr("A comparison shows at most %1 slides; %2 left out.")
                                     .arg(kMaxSlides)
                                     .arg(chosen.size() - added),
                                 kMessageMs);
}

void CompareWindow::onOpened(ComparePane *pane)
{
    if (pane == m_startPane) {
        // Where the main window was; the group carries it to the others.
        IrisSlideView *view = pane->view();
        view->setFlipped(m_start.flippedHorizontally, m_start.flippedVertically);
        view->setView(m_start.centre, m_start.downsample, m_start.rotation);
        m_startPane = nullptr;
    }
    updateTitle();
    updateActions();
    if (std::none_of(m_panes.cbegin(), m_panes.cend(), [](const ComparePane *p) { return !p->pendingPath().isEmpty(); }))
        Q_EMIT slidesOpened();
}

void CompareWindow::removePane(ComparePane *pane)
{
    if (count() <= 1 || !m_panes.contains(pane))
        return;
    m_group->removeView(pane->view());
    m_panes.removeOne(pane);
    if (m_startPane == pane)
        m_startPane = nullptr;
    if (m_current == pane) {
        m_current = nullptr;
        setCurrent(m_panes.first());
    }
    m_grid->removeWidget(pane);
    pane->hide();
    pane->deleteLater(); // it asked from its own button's signal
    relayout();
    updateTitle();
    updateActions();
}

void CompareWindow::setCurrent(ComparePane *pane)
{
    if (m_current == pane)
        return;
    if (m_current)
        m_current->setCurrent(false);
    m_current = pane;
    if (pane)
        pane->setCurrent(true);
    m_orientation->setView(pane ? pane->view() : nullptr);
}

void CompareWindow::relayout()
{
    // One row for one or two slides, two by two for three or four.
    while (m_grid->count() > 0)
        delete m_grid->takeAt(0);
    const int columns = count() <= 2 ? std::max(count(), 1) : 2;
    for (int i = 0; i < count(); ++i)
        m_grid->addWidget(m_panes[i], i / columns, i % columns);
    for (int c = 0; c < 2; ++c)
        m_grid->setColumnStretch(c, c < columns ? 1 : 0);
    for (int r = 0; r < 2; ++r)
        m_grid->setRowStretch(r, r < (count() + columns - 1) / columns ? 1 : 0);
}

void CompareWindow::updateTitle()
{
    QStringList names;
    for (const ComparePane *pane : std::as_const(m_panes)) {
        if (pane->view()->hasSlide())
            names << QFileInfo(pane->view()->slidePath()).fileName();
    }
    setWindowTitle(names.isEmpty() ? tr("Compare — Iris View")
                                   : tr("Compare: %1 — Iris View").arg(names.join(QStringLiteral(" · "))));
}

void CompareWindow::updateActions()
{
    m_addAction->setEnabled(count() < kMaxSlides);
    for (ComparePane *pane : std::as_const(m_panes))
        pane->closeButton()->setEnabled(count() > 1);
}
