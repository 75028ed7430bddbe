// Iris View widget — not API. The ICC profile of the display a view is shown on.
//
// X11 states a display's profile as a property of the root window ("ICC Profiles in X
// Specification" 0.4, which colord, DisplayCAL and the desktops' colour settings write):
// _ICC_PROFILE for the first screen, _ICC_PROFILE_n for screen n (n ≥ 1), each holding the
// profile's bytes. Where the platform states none (Wayland, offscreen, no property set) the
// profile is empty and the engine assumes sRGB. Qt 6.4 has no API for it (QScreen gets a colour
// space only in later versions, and not from X11), so it is read with xcb on Qt's connection.
//
// All on the GUI thread.
#pragma once

#include <QtCore/QAbstractNativeEventFilter>
#include <QtCore/QByteArray>
#include <QtCore/QObject>
#include <QtCore/QSet>

#include "autotest_p.h"

QT_BEGIN_NAMESPACE
class QScreen;
QT_END_NAMESPACE

namespace IrisWidget {

// The profile the platform states for `screen` (its position in QGuiApplication::screens()
// picks the property: 0 → _ICC_PROFILE, n → _ICC_PROFILE_n); empty when there is none or the
// platform is not X11. Profiles over 64 MiB are ignored (a property that large is not a
// profile). Reads the property from the X server: a round trip, not for every frame.
QByteArray screenIccProfile(const QScreen *screen);

// Tells when any screen's stated profile changes (a PropertyNotify for one of the root
// window's _ICC_PROFILE properties of the first 16 screens: Qt's xcb plugin selects property
// changes on the root window). One per
// process, created on first use; changed() is emitted on the GUI thread.
class IRIS_WIDGET_AUTOTEST_EXPORT DisplayProfileWatcher final : public QObject, public QAbstractNativeEventFilter
{
    Q_OBJECT
public:
    static DisplayProfileWatcher *instance();
    bool nativeEventFilter(const QByteArray &eventType, void *message, qintptr *result) override;

Q_SIGNALS:
    void changed();

private:
    DisplayProfileWatcher();
    QSet<quint32> m_atoms; // _ICC_PROFILE, _ICC_PROFILE_1, …
};

} // namespace IrisWidget
