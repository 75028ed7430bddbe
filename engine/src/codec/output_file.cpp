#include "codec/output_file.h"

#include <cerrno>
#include <cstring>
#include <filesystem>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace iris {

namespace {

namespace fs = std::filesystem;

constexpr size_t kBufferBytes = size_t(8) << 20; // one write() per 8 MiB of tiles

std::string why(int err) {
    switch (err) {
    case ENOSPC:
    case EDQUOT: return "disk full";
    case EACCES:
    case EPERM: return "no permission";
    case EROFS: return "read-only file system";
    case EFBIG: return "file too large for the file system";
    default: return std::strerror(err);
    }
}

} // namespace

Expected<std::unique_ptr<OutputFile>> OutputFile::create(const std::string& path) {
    if (path.empty()) return Result(Status::InvalidArgument, "No output path given");
    std::error_code ec;
    const fs::path p(path);
    if (fs::is_directory(p, ec)) {
        return Result(Status::NotAFile, "Cannot write '" + path + "': it is a folder; give a file name ending in .iris");
    }
    fs::path folder = p.parent_path();
    if (folder.empty()) folder = ".";
    const auto st = fs::status(folder, ec);
    if (ec || !fs::exists(st)) {
        return Result(Status::NotFound, "Cannot write '" + path + "': the folder '" + folder.string() + "' does not exist");
    }
    if (!fs::is_directory(st)) {
        return Result(Status::NotAFile, "Cannot write '" + path + "': '" + folder.string() + "' is not a folder");
    }
    // Exclusive creation never follows a planted link or clobbers another run's file.
    const std::string base = path + ".partial-" + std::to_string(::getpid());
    for (int n = 0; n < 100; ++n) {
        const std::string temp = n == 0 ? base : base + "-" + std::to_string(n);
        const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0) return std::unique_ptr<OutputFile>(new OutputFile(path, temp, folder.string(), fd));
        const int err = errno;
        if (err == EEXIST) continue;
        if (err == EACCES || err == EPERM || err == EROFS) {
            return Result(Status::IoError, "Cannot write '" + path + "': " + why(err) + " to create files in '" +
                                               folder.string() + "'");
        }
        return Result(Status::IoError, "Cannot write '" + path + "': cannot create '" + temp + "' (" + why(err) + ")");
    }
    return Result(Status::IoError, "Cannot write '" + path + "': temporary files '" + base + "-*' are in the way");
}

OutputFile::OutputFile(std::string path, std::string temp, std::string folder, int fd)
    : path_(std::move(path)), temp_(std::move(temp)), folder_(std::move(folder)), fd_(fd) {
    buffer_.reserve(kBufferBytes);
}

OutputFile::~OutputFile() {
    if (fd_ >= 0) ::close(fd_);
    if (!committed_) ::unlink(temp_.c_str());
}

Result OutputFile::failure(const char* what, int err) const {
    return Result(Status::IoError, "Cannot write '" + path_ + "': " + why(err) + " (" + what + " '" + temp_ + "')");
}

Result OutputFile::writeAll(const uint8_t* p, size_t n, uint64_t offset) {
    while (n > 0) {
        const ssize_t w = ::pwrite(fd_, p, n, off_t(offset));
        if (w < 0) {
            if (errno == EINTR) continue;
            return failure("writing", errno);
        }
        if (w == 0) return failure("writing", ENOSPC);
        p += w;
        n -= size_t(w);
        offset += uint64_t(w);
    }
    return {};
}

Result OutputFile::flush() {
    if (buffer_.empty()) return {};
    if (Result r = writeAll(buffer_.data(), buffer_.size(), flushed_); !r.ok()) return r;
    flushed_ += buffer_.size();
    buffer_.clear();
    return {};
}

Result OutputFile::append(const void* data, size_t size) {
    const auto* p = static_cast<const uint8_t*>(data);
    if (buffer_.size() + size > kBufferBytes) {
        if (Result r = flush(); !r.ok()) return r;
    }
    if (size >= kBufferBytes) {
        if (Result r = writeAll(p, size, flushed_); !r.ok()) return r;
        flushed_ += size;
    } else {
        buffer_.insert(buffer_.end(), p, p + size);
    }
    size_ += size;
    return {};
}

Result OutputFile::writeAt(uint64_t offset, const void* data, size_t size) {
    if (offset + size > size_) return Result(Status::InvalidArgument, "writeAt past the end of the output");
    if (Result r = flush(); !r.ok()) return r;
    return writeAll(static_cast<const uint8_t*>(data), size, offset);
}

Result OutputFile::commit() {
    if (Result r = flush(); !r.ok()) return r;
    if (::fsync(fd_) != 0) return failure("flushing", errno);
    const int fd = fd_;
    fd_ = -1;
    if (::close(fd) != 0) return failure("closing", errno);
    if (::rename(temp_.c_str(), path_.c_str()) != 0) {
        const int err = errno;
        return Result(Status::IoError, "Cannot write '" + path_ + "': cannot rename '" + temp_ + "' to it (" + why(err) + ")");
    }
    committed_ = true;
    // The rename is durable once the folder is synced (best effort: not every file system
    // lets a folder be opened for it).
    const int dir = ::open(folder_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dir >= 0) {
        (void)::fsync(dir);
        ::close(dir);
    }
    return {};
}

} // namespace iris
