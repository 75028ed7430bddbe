#include "recentfiles.h"

#include <cmath>

#include <QtCore/QDir>
#include <QtCore/QFileInfo>
#include <QtCore/QSettings>
#include <QtCore/QVariantMap>
#include <QtWidgets/QMenu>

namespace {
const QString kKey = QStringLiteral("recentFiles");
// { absolute path: { rotation, flipH, flipV } } for slides of the list that are turned or flipped.
const QString kOrientationsKey = QStringLiteral("recentOrientations");
} // namespace

RecentFiles::RecentFiles(QMenu *menu, QObject *parent)
    : QObject(parent)
    , m_menu(menu)
{
    connect(m_menu, &QMenu::aboutToShow, this, &RecentFiles::rebuild);
    rebuild();
}

QStringList RecentFiles::files() const
{
    return QSettings().value(kKey).toStringList();
}

void RecentFiles::add(const QString &path)
{
    const QString absolute = QFileInfo(path).absoluteFilePath();
    QStringList list = files();
    list.removeAll(absolute);
    list.prepend(absolute);
    while (list.size() > kMaxEntries)
        list.removeLast();
    store(list);
}

void RecentFiles::remove(const QString &path)
{
    QStringList list = files();
    list.removeAll(QFileInfo(path).absoluteFilePath());
    store(list);
}

void RecentFiles::clear()
{
    store({});
}

void RecentFiles::store(const QStringList &list)
{
    // The menu is rebuilt when it next shows: not now, since this may run from one of its
    // actions' triggered() signal.
    QSettings settings;
    settings.setValue(kKey, list);
    // Orientations only of slides still in the list.
    QVariantMap orientations = settings.value(kOrientationsKey).toMap();
    for (auto it = orientations.begin(); it != orientations.end();) {
        if (list.contains(it.key()))
            ++it;
        else
            it = orientations.erase(it);
    }
    settings.setValue(kOrientationsKey, orientations);
}

RecentFiles::Orientation RecentFiles::orientation(const QString &path) const
{
    const QVariantMap entry
        = QSettings().value(kOrientationsKey).toMap().value(QFileInfo(path).absoluteFilePath()).toMap();
    Orientation o;
    o.rotation = entry.value(QStringLiteral("rotation"), 0.0).toDouble();
    o.flippedHorizontally = entry.value(QStringLiteral("flipH"), false).toBool();
    o.flippedVertically = entry.value(QStringLiteral("flipV"), false).toBool();
    if (!std::isfinite(o.rotation))
        o.rotation = 0;
    return o;
}

void RecentFiles::setOrientation(const QString &path, const Orientation &orientation)
{
    const QString absolute = QFileInfo(path).absoluteFilePath();
    if (!files().contains(absolute))
        return;
    QSettings settings;
    QVariantMap orientations = settings.value(kOrientationsKey).toMap();
    if (orientation.isDefault()) {
        if (orientations.remove(absolute) == 0)
            return;
    } else {
        orientations.insert(absolute, QVariantMap{{QStringLiteral("rotation"), orientation.rotation},
                                                  {QStringLiteral("flipH"), orientation.flippedHorizontally},
                                                  {QStringLiteral("flipV"), orientation.flippedVertically}});
    }
    settings.setValue(kOrientationsKey, orientations);
}

void RecentFiles::rebuild()
{
    m_menu->clear();
    const QStringList list = files();
    int number = 1;
    for (const QString &path : list) {
        const QString label = number < 10
            ? QStringLiteral("&%1 %2").arg(number).arg(QFileInfo(path).fileName())
            : QFileInfo(path).fileName();
        QAction *action = m_menu->addAction(label);
        action->setToolTip(QDir::toNativeSeparators(path));
        action->setStatusTip(QDir::toNativeSeparators(path));
        connect(action, &QAction::triggered, this, [this, path] { Q_EMIT openRequested(path); });
        ++number;
    }
    if (list.isEmpty()) {
        m_menu->addAction(tr("No recent slides"))->setEnabled(false);
    } else {
        m_menu->addSeparator();
        connect(m_menu->addAction(tr("&Clear list")), &QAction::triggered, this, &RecentFiles::clear);
    }
}
