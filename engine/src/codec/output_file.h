// The encoder's output: a temporary file beside the final name, written through a large
// buffer, flushed to disk and renamed into place by commit(). Destroyed without commit() (an
// error, a cancel, an exception) it removes the temporary file, so no partial file is left
// and nothing ever appears under the final name.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "iris/types.h"

namespace iris {

class OutputFile {
public:
    // Checks the path (not a folder, its folder exists) and creates "PATH.partial-PID"
    // exclusively. NotFound / NotAFile / IoError ("no permission", "read-only file system",
    // "disk full") name the path.
    static Expected<std::unique_ptr<OutputFile>> create(const std::string& path);
    ~OutputFile();
    OutputFile(const OutputFile&) = delete;
    OutputFile& operator=(const OutputFile&) = delete;

    // Appends through the buffer (large writes go straight to the file).
    Result append(const void* data, size_t size);
    // Bytes appended so far: the file offset of the next append.
    uint64_t size() const { return size_; }
    // Writes at an offset already appended (flushes the buffer first).
    Result writeAt(uint64_t offset, const void* data, size_t size);
    // Flushes, fsyncs, closes and renames the temporary file to the final name, then fsyncs
    // the folder. After success the destructor leaves the file alone.
    Result commit();

    const std::string& path() const { return path_; }
    const std::string& tempPath() const { return temp_; }

private:
    OutputFile(std::string path, std::string temp, std::string folder, int fd);
    Result flush();
    Result writeAll(const uint8_t* p, size_t n, uint64_t offset);
    Result failure(const char* what, int err) const;

    std::string path_, temp_, folder_;
    int fd_ = -1;
    bool committed_ = false;
    uint64_t size_ = 0;          // bytes appended
    uint64_t flushed_ = 0;       // bytes in the file
    std::vector<uint8_t> buffer_;
};

} // namespace iris
