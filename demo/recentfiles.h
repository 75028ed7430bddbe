// Iris View demo — the File › Open Recent menu, kept in QSettings, and how each of those
// slides was last turned and flipped (restored when it is opened again).
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

    // A slide's turn (degrees clockwise) and flips, as IrisSlideView states them.
    struct Orientation {
        double rotation = 0;
        bool flippedHorizontally = false;
        bool flippedVertically = false;

        bool isDefault() const { return rotation == 0 && !flippedHorizontally && !flippedVertically; }
        friend bool operator==(const Orientation &, const Orientation &) = default;
    };

    // Fills menu (rebuilt each time it is about to show).
    explicit RecentFiles(QMenu *menu, QObject *parent = nullptr);

    // Entries are absolute paths of local slides, or DICOMweb series URLs kept exactly as
    // opened (http(s)://…; never with user:password@, which the entry drops: credentials are
    // never written to the list).
    static bool isUrl(const QString &path);
    static QString entryFor(const QString &path);

    QStringList files() const;
    void add(const QString &path);
    void remove(const QString &path);
    void clear();

    // The orientation remembered for a slide of the list (the default for any other).
    Orientation orientation(const QString &path) const;
    // Remembered while the slide is in the list; the default is not stored.
    void setOrientation(const QString &path, const Orientation &orientation);

Q_SIGNALS:
    void openRequested(const QString &path);

private:
    void rebuild();
    void store(const QStringList &files);

    QMenu *m_menu;
};
