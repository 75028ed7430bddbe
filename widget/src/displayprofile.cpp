#include "displayprofile_p.h"

#include <cstdlib>
#include <memory>

#include <QtCore/QCoreApplication>
#include <QtCore/QPointer>
#include <QtGui/QGuiApplication>
#include <QtGui/QScreen>
#include <QtGui/qguiapplication_platform.h>

#include <xcb/xcb.h>

#include "logging_p.h"

namespace IrisWidget {

namespace {

constexpr quint32 kMaxProfileBytes = 64u << 20;
const char kPropertyPrefix[] = "_ICC_PROFILE";

xcb_connection_t *x11Connection()
{
    auto *x11 = qGuiApp ? qGuiApp->nativeInterface<QNativeInterface::QX11Application>() : nullptr;
    return x11 ? x11->connection() : nullptr;
}

QByteArray propertyName(int screenIndex)
{
    QByteArray name(kPropertyPrefix);
    if (screenIndex > 0)
        name += '_' + QByteArray::number(screenIndex);
    return name;
}

struct FreeDeleter
{
    void operator()(void *p) const { std::free(p); }
};
template<typename T>
using XcbReply = std::unique_ptr<T, FreeDeleter>;

xcb_atom_t existingAtom(xcb_connection_t *c, const QByteArray &name)
{
    // only_if_exists: a property nobody ever set needs no atom of ours.
    XcbReply<xcb_intern_atom_reply_t> reply(
        xcb_intern_atom_reply(c, xcb_intern_atom(c, 1, uint16_t(name.size()), name.constData()), nullptr));
    return reply ? reply->atom : xcb_atom_t(XCB_ATOM_NONE);
}

xcb_window_t rootWindow(xcb_connection_t *c)
{
    const xcb_screen_t *root = xcb_setup_roots_iterator(xcb_get_setup(c)).data;
    return root ? root->root : xcb_window_t(XCB_WINDOW_NONE);
}

} // namespace

QByteArray screenIccProfile(const QScreen *screen)
{
    xcb_connection_t *c = x11Connection();
    if (!c || !screen)
        return {};
    const int index = std::max<int>(0, int(QGuiApplication::screens().indexOf(const_cast<QScreen *>(screen))));
    const QByteArray name = propertyName(index);
    const xcb_atom_t atom = existingAtom(c, name);
    if (atom == XCB_ATOM_NONE)
        return {};
    const xcb_window_t root = rootWindow(c);
    if (root == XCB_WINDOW_NONE)
        return {};
    // Lengths are in 32-bit units; one request reads the whole property up to the limit.
    XcbReply<xcb_get_property_reply_t> reply(xcb_get_property_reply(
        c, xcb_get_property(c, 0, root, atom, XCB_GET_PROPERTY_TYPE_ANY, 0, kMaxProfileBytes / 4), nullptr));
    if (!reply || reply->format != 8)
        return {};
    if (reply->bytes_after > 0) {
        qCWarning(lcIrisWidget).noquote() << name << "holds more than 64 MiB; it is not used as the display profile";
        return {};
    }
    const int length = xcb_get_property_value_length(reply.get());
    return QByteArray(static_cast<const char *>(xcb_get_property_value(reply.get())), length);
}

DisplayProfileWatcher *DisplayProfileWatcher::instance()
{
    // Parented to the application: it goes when the application does, and a new
    // application (tests make several) gets a new one.
    static QPointer<DisplayProfileWatcher> watcher;
    if (!watcher && QCoreApplication::instance())
        watcher = new DisplayProfileWatcher;
    return watcher;
}

DisplayProfileWatcher::DisplayProfileWatcher()
    : QObject(QCoreApplication::instance())
{
    xcb_connection_t *c = x11Connection();
    if (!c)
        return;
    // The properties of the first kMaxScreens screens, interned once (all requests sent
    // before the first reply is read), so that an event is matched without a round trip.
    constexpr int kMaxScreens = 16;
    xcb_intern_atom_cookie_t cookies[kMaxScreens];
    for (int i = 0; i < kMaxScreens; ++i) {
        const QByteArray name = propertyName(i);
        cookies[i] = xcb_intern_atom(c, 0, uint16_t(name.size()), name.constData());
    }
    for (int i = 0; i < kMaxScreens; ++i) {
        XcbReply<xcb_intern_atom_reply_t> reply(xcb_intern_atom_reply(c, cookies[i], nullptr));
        if (reply)
            m_atoms.insert(reply->atom);
    }
    QCoreApplication::instance()->installNativeEventFilter(this);
}

bool DisplayProfileWatcher::nativeEventFilter(const QByteArray &eventType, void *message, qintptr *)
{
    if (eventType != "xcb_generic_event_t")
        return false;
    const auto *event = static_cast<const xcb_generic_event_t *>(message);
    if ((event->response_type & 0x7f) != XCB_PROPERTY_NOTIFY)
        return false;
    const auto *notify = static_cast<const xcb_property_notify_event_t *>(message);
    xcb_connection_t *c = x11Connection();
    if (!c)
        return false;
    if (notify->window != rootWindow(c) || !m_atoms.contains(notify->atom))
        return false;
    qCDebug(lcIrisWidget) << "a display profile property of the root window changed";
    Q_EMIT changed();
    return false; // Qt handles the event as well
}

} // namespace IrisWidget
