// libjpeg's error handling for the engine's own uses of its API (slide/jpeg_frame_decode.cpp,
// slide/jpeg_coefficients.cpp): errors and warnings (corrupt entropy data, a premature end)
// alike jump back to the caller's setjmp with libjpeg's message, so that a stream libjpeg had
// to guess at is refused rather than shown as if it were right. The caller keeps no C++ object
// with a destructor between its setjmp and the end (longjmp would skip it).
#pragma once

#include <csetjmp>

#include <jpeglib.h>

namespace iris::libjpeg {

struct Errors {
    jpeg_error_mgr pub;
    std::jmp_buf jump;
    char message[JMSG_LENGTH_MAX];
};

[[noreturn]] inline void errorExit(j_common_ptr cinfo) {
    auto* err = reinterpret_cast<Errors*>(cinfo->err);
    (*cinfo->err->format_message)(cinfo, err->message);
    std::longjmp(err->jump, 1);
}

inline void emitMessage(j_common_ptr cinfo, int level) {
    if (level < 0) errorExit(cinfo); // a warning: stop
}

// Points cinfo's error handling at `err`.
inline void install(jpeg_decompress_struct& cinfo, Errors& err) {
    cinfo.err = jpeg_std_error(&err.pub);
    err.pub.error_exit = errorExit;
    err.pub.emit_message = emitMessage;
}

} // namespace iris::libjpeg
