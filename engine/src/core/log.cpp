#include "core/log.h"

namespace iris {

void Log::write(LogLevel level, const std::string& line) const {
    if (cb_) {
        cb_(level, line);
        return;
    }
    if (level >= LogLevel::Warning) {
        std::fprintf(stderr, "iris: %s\n", line.c_str());
    }
}

} // namespace iris
