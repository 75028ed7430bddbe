// Iris View demo — the Associated Images dock: the slide's label, macro, thumbnail and any
// other image the file carries, one tab each, scaled to fit.
#pragma once

#include <QtGui/QImage>
#include <QtWidgets/QDockWidget>

QT_BEGIN_NAMESPACE
class QLabel;
class QTabWidget;
QT_END_NAMESPACE

class AssociatedImagesDock : public QDockWidget {
    Q_OBJECT
public:
    explicit AssociatedImagesDock(QWidget *parent = nullptr);

    void addImage(const QString &name, const QImage &image);
    void clear();
    int imageCount() const;

private:
    QTabWidget *m_tabs;
    QLabel *m_none;
};
