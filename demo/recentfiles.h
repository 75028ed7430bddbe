// Iris View demo — the File › Open Recent menu, kept in QSettings.
#pragma once

#include <QtCore/QObject>
#include <QtCore/QStringList>

QT_BEGIN_NAMESPACE
class QMenu;
QT_END_NAMESPACE

class RecentFiles : public QObject {
    Q_OBJECT
public:
    static constexpr int kMaxEntries = 10;

    // Fills menu (rebuilt each time it is about to show).
    explicit RecentFiles(QMenu *menu, QObject *parent = nullptr);

    QStringList files() const;
    void add(const QString &path);
    void remove(const QString &path);
    void clear();

Q_SIGNALS:
    void openRequested(const QString &path);

private:
    void rebuild();
    void store(const QStringList &files);

    QMenu *m_menu;
};
