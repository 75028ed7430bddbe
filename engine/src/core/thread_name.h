// Names the calling thread, so that `top -H`, `perf`, gdb and a TSan report say which of the
// engine's threads it is ("iris-render", "iris-buffer", "iris-loader", ...). Linux keeps 15
// characters; elsewhere it does nothing.
#pragma once

#if defined(__linux__)
#include <pthread.h>
#endif

namespace iris {

inline void nameThisThread(const char* name) {
#if defined(__linux__)
    (void)pthread_setname_np(pthread_self(), name); // longer than 15 characters: left unnamed
#else
    (void)name;
#endif
}

} // namespace iris
