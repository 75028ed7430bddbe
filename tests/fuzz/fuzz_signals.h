// What every fuzz target installs before the first input: a SIGTRAP that becomes an abort.
// Header-only; each target includes it (directly, or through fuzz_support.h or
// fuzz_annotations.h) from its one source file, which gets this file's LLVMFuzzerInitialize.
//
// GLib ends the process on g_error() and on a failed g_assert in a non-test build with
// G_BREAKPOINT (an int3, so SIGTRAP), and OpenSlide and the libraries beneath it use GLib.
// libFuzzer handles SIGSEGV, SIGBUS, SIGABRT, SIGILL and SIGFPE (writing the input as
// crash-<sha1>) but not SIGTRAP, and neither does ASan by default: the process would die by
// the signal and the input would be lost. The handler writes one line with write(2) and calls
// abort(), both async-signal-safe; SIGABRT is not blocked while it runs, so libFuzzer's
// -handle_abrt handler (on by default) writes the crash input, its stack and the final stats.
#pragma once

#include <signal.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>

namespace fuzz_signals {

inline void trapToAbort(int) {
    static const char msg[] = "SIGTRAP (GLib's g_error or G_BREAKPOINT, e.g. inside OpenSlide): aborting so that "
                              "libFuzzer keeps the input\n";
    ssize_t ignored = ::write(STDERR_FILENO, msg, sizeof msg - 1);
    (void)ignored;
    std::abort();
}

inline void installTrapToAbort() {
    struct sigaction sa = {};
    sa.sa_handler = trapToAbort;
    sigemptyset(&sa.sa_mask); // SIGABRT stays deliverable inside the handler
    sa.sa_flags = 0;
    if (sigaction(SIGTRAP, &sa, nullptr) != 0) {
        std::perror("sigaction(SIGTRAP)");
        std::abort();
    }
}

} // namespace fuzz_signals

// libFuzzer calls it once, before any input (also when it only replays files).
extern "C" int LLVMFuzzerInitialize(int*, char***) {
    fuzz_signals::installTrapToAbort();
    return 0;
}
