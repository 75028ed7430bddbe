// Iris View demo — one slide of View › Compare…: a header (the slide's name, its
// magnification, a link toggle, open and close buttons) over an IrisSlideView.
#pragma once

#include <QtWidgets/QWidget>

QT_BEGIN_NAMESPACE
class QLabel;
class QToolButton;
QT_END_NAMESPACE
class IrisSlideView;

class ComparePane : public QWidget {
    Q_OBJECT
public:
    explicit ComparePane(QWidget *parent = nullptr);

    IrisSlideView *view() const { return m_view; }
    QToolButton *linkButton() const { return m_link; }
    QToolButton *closeButton() const { return m_close; }

    // Opens the slide once the view is on screen (the view then fits it at once; one opened
    // before would fit itself again when first shown). Emits opened() or failed().
    void openWhenShown(const QString &path);
    QString pendingPath() const { return m_pending; }

    void setLinked(bool linked);
    // The pane the menu's actions act on: its header is highlighted.
    void setCurrent(bool current);

Q_SIGNALS:
    void opened(const QString &path);
    void failed(const QString &path, const QString &message);
    void linkToggled(bool linked);
    void openRequested();
    void closeRequested();
    void activated(); // the pointer moved over it, or it was clicked

protected:
    bool eventFilter(QObject *watched, QEvent *event) override;

private:
    void openNow();
    void updateHeader();

    IrisSlideView *m_view;
    QWidget *m_header;
    QLabel *m_title;
    QLabel *m_magnification;
    QToolButton *m_link;
    QToolButton *m_open;
    QToolButton *m_close;
    QString m_pending;
    bool m_current = false;
};
