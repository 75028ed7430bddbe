// loadRasterMap: reads the file whole (bounded), then hands it to the reader its first bytes
// name — PNG, TIFF or NumPy .npy — never guessing from the extension.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "layers/raster_readers.h"
#include "layers/streamed_raster.h"

namespace iris {

using namespace layers_detail;

namespace layers_detail {

bool isPng(std::span<const uint8_t> b) {
    static constexpr uint8_t kMagic[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    return b.size() >= 8 && std::memcmp(b.data(), kMagic, 8) == 0;
}

bool isTiff(std::span<const uint8_t> b) {
    if (b.size() < 4) return false;
    const bool le = b[0] == 'I' && b[1] == 'I', be = b[0] == 'M' && b[1] == 'M';
    const unsigned v = le ? unsigned(b[2] | b[3] << 8) : unsigned(b[2] << 8 | b[3]);
    return (le || be) && (v == 42 || v == 43); // classic TIFF, BigTIFF
}

bool isNpy(std::span<const uint8_t> b) {
    return b.size() >= 6 && std::memcmp(b.data(), "\x93NUMPY", 6) == 0;
}

Expected<std::vector<uint8_t>> readWholeFile(const std::string& path, uint64_t maxBytes) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
        const int e = errno;
        return fail(e == ENOENT ? Status::NotFound : Status::IoError, path, std::strerror(e));
    }
    struct Closer {
        int fd;
        ~Closer() { ::close(fd); }
    } closer{fd};
    struct stat st {};
    if (::fstat(fd, &st) != 0) return fail(Status::IoError, path, std::strerror(errno));
    if (!S_ISREG(st.st_mode)) return fail(Status::NotAFile, path, "not a regular file");
    if (uint64_t(st.st_size) > maxBytes)
        return fail(Status::UnsupportedFormat, path,
                    "the file has " + std::to_string(st.st_size) + " bytes, more than a map of the limits can need (" +
                        std::to_string(maxBytes) + ")");
    std::vector<uint8_t> bytes(size_t(st.st_size));
    size_t done = 0;
    while (done < bytes.size()) {
        const ssize_t n = ::read(fd, bytes.data() + done, bytes.size() - done);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) return fail(Status::IoError, path, std::strerror(errno));
        if (n == 0) break; // shrank while read: the readers see a truncated file
        done += size_t(n);
    }
    bytes.resize(done);
    return bytes;
}

} // namespace layers_detail

Expected<RasterMap> loadRasterMapFromMemory(std::span<const uint8_t> bytes, const std::string& name,
                                            const RasterLoadOptions& options) {
    if (isPng(bytes)) return readPngRaster(bytes, name, options);
    if (isTiff(bytes)) return readTiffRaster(bytes, name, options);
    if (isNpy(bytes)) return readNpyRaster(bytes, name, options);
    if (bytes.empty()) return fail(Status::CorruptData, name, "the file is empty");
    return fail(Status::UnsupportedFormat, name, "not a PNG, TIFF or NumPy .npy file (by its first bytes)");
}

Expected<RasterMap> loadRasterMap(const std::string& path, const RasterLoadOptions& options) {
    // The largest file a map within the limits can come from: an .npy of 8-byte values of
    // every pixel (twice the decoded float32 bytes), plus headers. Compressed formats are
    // smaller; a larger file is refused before it is read.
    // A TIFF over options.streamAbove decoded is streamed: its large levels stay in the file.
    if (auto streamed = streamTiffRaster(path, options)) return std::move(*streamed);
    const uint64_t maxFile = 2 * Limits::of(options).maxBytes + (1u << 20);
    auto bytes = readWholeFile(path, maxFile);
    if (!bytes) return bytes.error();
    return loadRasterMapFromMemory(*bytes, path, options);
}

} // namespace iris
