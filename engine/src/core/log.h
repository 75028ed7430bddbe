// Engine-internal logging: formats a line and hands it to the host's callback (or stderr
// when the host gave none and the level is Warning or worse). Thread-safe.
#pragma once

#include <cstdio>
#include <string>

#include "iris/types.h"

namespace iris {

class Log {
public:
    explicit Log(LogCallback cb = {}) : cb_(std::move(cb)) {}
    void write(LogLevel level, const std::string& line) const;
    void debug(const std::string& s) const { write(LogLevel::Debug, s); }
    void info(const std::string& s) const { write(LogLevel::Info, s); }
    void warn(const std::string& s) const { write(LogLevel::Warning, s); }
    void error(const std::string& s) const { write(LogLevel::Error, s); }

private:
    LogCallback cb_;
};

} // namespace iris
