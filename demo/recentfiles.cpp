#include "recentfiles.h"

#include <cmath>

#include <QtCore/QDir>
#include <QtCore/QFileInfo>
#include <QtCore/QSettings>
#include <QtCore/QUrl>
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

bool RecentFiles::isUrl(const QString &path)
{
    return path.startsWith(QLatin1String("http://"), Qt::CaseInsensitive)
        || path.startsWith(QLatin1String("https://"), Qt::CaseInsensitive);
}

QString RecentFiles::entryFor(const QString &path)
{
    // A URL is not a file name: QFileInfo would make "http://h/x" into "<cwd>/http:/h/x".
    if (isUrl(path))
        return QUrl(path).adjusted(QUrl::RemoveUserInfo).toString();
    return QFileInfo(path).absoluteFilePath();
}

QStringList RecentFiles::files() const
{
    return QSettings().value(kKey).toStringList();
}

void RecentFiles::add(const QString &path)
{
    const QString absolute = entryFor(path);
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
    list.removeAll(entryFor(path));
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
        = QSettings().value(kOrientationsKey).toMap().value(entryFor(path)).toMap();
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
    const QString absolute = entryFor(path);
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
        // A series URL shows as "series …<end of its UID> on host"; a file by its name.
        QString name = QFileInfo(path).fileName();
        QString shown = QDir::toNativeSeparators(path);
        if (isUrl(path)) {
            const QUrl url(path);
            const QString series = url.path().section(QLatin1Char('/'), -1, -1, QString::SectionSkipEmpty);
            name = tr("series …%1 on %2").arg(series.right(12), url.host());
            shown = path;
        }
        const QString label = number < 10 ? QStringLiteral("&%1 %2").arg(number).arg(name) : name;
        QAction *action = m_menu->addAction(label);
        action->setToolTip(shown);
        action->setStatusTip(shown);
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
