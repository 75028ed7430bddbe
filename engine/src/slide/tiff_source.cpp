#include "slide/tiff_source.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include <tiffio.h>

#include "slide/jp2k_decode.h"
#include "slide/jpeg_coefficients.h"
#include "slide/jpeg_frame_decode.h"
#include "slide/openslide_source.h"

namespace iris {

namespace {

constexpr uint16_t kAperioJp2kYCbCr = 33003;
constexpr uint16_t kAperioJp2kRgb = 33005;
constexpr uint64_t kMaxFileTilePixels = uint64_t(1) << 24;   // 16 Mpx: 64 MiB decoded
constexpr uint64_t kMaxRawTileBytes = uint64_t(64) << 20;    // a compressed tile
constexpr size_t kCacheBudgetBytes = size_t(32) << 20;       // decoded file tiles kept
constexpr int kMaxDirectories = 4096;

// LibTiff: TIFFRGBAImage, as OpenSlide 3.4.1 reads a tile. JpegYCbCr / JpegRgb: a JPEG tile read
// raw, its directory's JPEGTables put in front, and decoded by libjpeg-turbo straight into the
// tile's RGBA (decodeJpegFrameRgba) — the same decode libtiff's JPEG codec makes under
// TIFFRGBAImage (islow DCT, fancy upsampling; YCbCr converted to RGB for photometric YCbCr,
// the components taken as they are for photometric RGB), without its per-tile codec set-up,
// its scanline copies and its packing into ABGR words (issue 20: the tile decode was twice the
// decode floor's). A tile it cannot decode is read through TIFFRGBAImage as before.
enum class Decoder { LibTiff, JpegYCbCr, JpegRgb, Jp2kYCbCr, Jp2kRgb };

// What one TIFF directory says about itself.
struct DirInfo {
    tdir_t index = 0;
    bool tiled = false;
    uint32_t width = 0, height = 0, tileW = 0, tileH = 0;
    uint16_t compression = 0, photometric = 0, spp = 0, bps = 0, planar = 0, orientation = 0, sampleFormat = 0;
    uint16_t extraSamples = 0;
    uint32_t tileCount = 0;
    std::vector<uint8_t> jpegTables; // JPEGTables (JPEG compression), "" when absent
};

std::string fileNameOf(const std::string& path) {
    return std::filesystem::path(path).filename().string();
}

} // namespace

struct TiffTileSource::Level {
    tdir_t dir = 0;
    uint32_t width = 0, height = 0, tileW = 0, tileH = 0;
    uint32_t across = 0, down = 0;
    Decoder decoder = Decoder::LibTiff;
    std::vector<uint8_t> jpegTables; // the directory's JPEGTables without their EOI (Jpeg decoders)
};

struct TiffTileSource::DecodedTile {
    uint32_t width = 0, height = 0; // the part of the file tile inside the level
    std::vector<uint8_t> rgba;      // width × height, RGBA8, opaque
};

// One libtiff handle over the shared descriptor, with its own file position and the first
// error libtiff reported through it since lastError was last cleared.
struct TiffTileSource::Handle {
    int fd = -1;
    uint64_t size = 0;
    uint64_t pos = 0;
    TIFF* tif = nullptr;
    tdir_t dir = 0;
    std::string lastError;

    Handle() = default;
    Handle(const Handle&) = delete;
    Handle& operator=(const Handle&) = delete;
    ~Handle() {
        if (tif) TIFFClose(tif);
    }
};

namespace {

using Handle = TiffTileSource::Handle;

tmsize_t readProc(thandle_t th, void* buf, tmsize_t n) {
    auto* h = static_cast<Handle*>(th);
    if (n < 0) return -1;
    size_t done = 0;
    auto* out = static_cast<uint8_t*>(buf);
    while (done < size_t(n)) {
        if (h->pos + done >= h->size) break;
        const ssize_t r = ::pread(h->fd, out + done, size_t(n) - done, off_t(h->pos + done));
        if (r < 0) {
            if (errno == EINTR) continue;
            return -1;
        }
        if (r == 0) break;
        done += size_t(r);
    }
    h->pos += done;
    return tmsize_t(done);
}

tmsize_t writeProc(thandle_t, void*, tmsize_t) {
    return 0; // read-only
}

toff_t seekProc(thandle_t th, toff_t off, int whence) {
    auto* h = static_cast<Handle*>(th);
    switch (whence) {
    case SEEK_SET: h->pos = off; break;
    case SEEK_CUR: h->pos += off; break;
    case SEEK_END: h->pos = h->size + off; break;
    default: return toff_t(-1);
    }
    return h->pos;
}

int closeProc(thandle_t) {
    return 0; // the descriptor belongs to the source
}

toff_t sizeProc(thandle_t th) {
    return static_cast<Handle*>(th)->size;
}

int mapProc(thandle_t, void**, toff_t*) {
    return 0; // no memory mapping: a file truncated under us must not raise SIGBUS
}

void unmapProc(thandle_t, void*, toff_t) {}

int errorHandler(TIFF*, void* user, const char* module, const char* fmt, va_list ap) {
    auto* h = static_cast<Handle*>(user);
    if (h && h->lastError.empty()) {
        char buf[512];
        std::vsnprintf(buf, sizeof buf, fmt, ap);
        h->lastError = (module && *module) ? std::string(module) + ": " + buf : std::string(buf);
    }
    return 1; // handled: nothing on stderr
}

int warningHandler(TIFF*, void*, const char*, const char*, va_list) {
    return 1; // libtiff's warnings (unknown tags, …) are not errors, and OpenSlide ignores them too
}

std::unique_ptr<Handle> openHandle(int fd, uint64_t size, const std::string& name, std::string* error) {
    auto h = std::make_unique<Handle>();
    h->fd = fd;
    h->size = size;
    TIFFOpenOptions* opts = TIFFOpenOptionsAlloc();
    if (!opts) {
        *error = "out of memory";
        return nullptr;
    }
    TIFFOpenOptionsSetMaxSingleMemAlloc(opts, tmsize_t(256) << 20);
    TIFFOpenOptionsSetErrorHandlerExtR(opts, &errorHandler, h.get());
    TIFFOpenOptionsSetWarningHandlerExtR(opts, &warningHandler, h.get());
    // "m": no mmap (mapProc refuses anyway). Everything else is libtiff's default.
    h->tif = TIFFClientOpenExt(name.c_str(), "rm", h.get(), &readProc, &writeProc, &seekProc, &closeProc, &sizeProc,
                               &mapProc, &unmapProc, opts);
    TIFFOpenOptionsFree(opts);
    if (!h->tif) {
        *error = h->lastError.empty() ? std::string("libtiff cannot open it") : h->lastError;
        return nullptr;
    }
    h->dir = TIFFCurrentDirectory(h->tif);
    return h;
}

DirInfo readDirInfo(TIFF* tif, tdir_t index) {
    DirInfo d;
    d.index = index;
    d.tiled = TIFFIsTiled(tif) != 0;
    TIFFGetField(tif, TIFFTAG_IMAGEWIDTH, &d.width);
    TIFFGetField(tif, TIFFTAG_IMAGELENGTH, &d.height);
    if (d.tiled) {
        TIFFGetField(tif, TIFFTAG_TILEWIDTH, &d.tileW);
        TIFFGetField(tif, TIFFTAG_TILELENGTH, &d.tileH);
        d.tileCount = TIFFNumberOfTiles(tif);
    }
    TIFFGetFieldDefaulted(tif, TIFFTAG_COMPRESSION, &d.compression);
    if (!TIFFGetField(tif, TIFFTAG_PHOTOMETRIC, &d.photometric)) d.photometric = 0xffff;
    TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLESPERPIXEL, &d.spp);
    TIFFGetFieldDefaulted(tif, TIFFTAG_BITSPERSAMPLE, &d.bps);
    TIFFGetFieldDefaulted(tif, TIFFTAG_PLANARCONFIG, &d.planar);
    TIFFGetFieldDefaulted(tif, TIFFTAG_ORIENTATION, &d.orientation);
    TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLEFORMAT, &d.sampleFormat);
    uint16_t* extra = nullptr;
    if (!TIFFGetField(tif, TIFFTAG_EXTRASAMPLES, &d.extraSamples, &extra)) d.extraSamples = 0;
    if (d.compression == COMPRESSION_JPEG) {
        uint32_t count = 0;
        const uint8_t* tables = nullptr;
        if (TIFFGetField(tif, TIFFTAG_JPEGTABLES, &count, &tables) && tables && count > 0 && count < (1u << 20))
            d.jpegTables.assign(tables, tables + count);
    }
    return d;
}

// Whether this reader decodes the directory exactly as OpenSlide 3.4.1 does; if not, why not.
bool decodable(const DirInfo& d, Decoder* decoder, std::string* why) {
    if (!d.tiled) {
        *why = "not tiled";
        return false;
    }
    if (d.tileW == 0 || d.tileH == 0 || d.tileW > kMaxFileTileSide || d.tileH > kMaxFileTileSide ||
        uint64_t(d.tileW) * d.tileH > kMaxFileTilePixels) {
        *why = "tile size " + std::to_string(d.tileW) + "x" + std::to_string(d.tileH);
        return false;
    }
    const uint64_t across = (uint64_t(d.width) + d.tileW - 1) / d.tileW;
    const uint64_t down = (uint64_t(d.height) + d.tileH - 1) / d.tileH;
    if (d.width == 0 || d.height == 0 || across * down > UINT32_MAX || d.tileCount != across * down) {
        *why = "tile count " + std::to_string(d.tileCount) + " does not fit " + std::to_string(d.width) + "x" +
               std::to_string(d.height);
        return false;
    }
    if (d.bps != 8 || d.sampleFormat != SAMPLEFORMAT_UINT || d.extraSamples != 0 || d.orientation != ORIENTATION_TOPLEFT) {
        *why = "pixel layout (bits " + std::to_string(d.bps) + ", extra samples " + std::to_string(d.extraSamples) +
               ", orientation " + std::to_string(d.orientation) + ")";
        return false;
    }
    if (d.compression == kAperioJp2kYCbCr || d.compression == kAperioJp2kRgb) {
        if (d.spp != 3) {
            *why = "JPEG 2000 with " + std::to_string(d.spp) + " samples";
            return false;
        }
        *decoder = d.compression == kAperioJp2kYCbCr ? Decoder::Jp2kYCbCr : Decoder::Jp2kRgb;
        return true;
    }
    switch (d.compression) {
    case COMPRESSION_NONE:
    case COMPRESSION_LZW:
    case COMPRESSION_JPEG:
    case COMPRESSION_ADOBE_DEFLATE:
    case COMPRESSION_DEFLATE:
    case COMPRESSION_PACKBITS:
    case COMPRESSION_ZSTD:
    case COMPRESSION_WEBP:
        break;
    default:
        *why = "compression " + std::to_string(d.compression);
        return false;
    }
    if (!TIFFIsCODECConfigured(d.compression)) {
        *why = "compression " + std::to_string(d.compression) + " not built into libtiff";
        return false;
    }
    const bool grey = d.spp == 1 && d.photometric == PHOTOMETRIC_MINISBLACK;
    const bool rgb = d.spp == 3 && d.planar == PLANARCONFIG_CONTIG &&
                     (d.photometric == PHOTOMETRIC_RGB ||
                      (d.photometric == PHOTOMETRIC_YCBCR && d.compression == COMPRESSION_JPEG));
    if (!grey && !rgb) {
        *why = std::to_string(d.spp) + " samples, photometric " + std::to_string(d.photometric);
        return false;
    }
    *decoder = Decoder::LibTiff;
    // The direct JPEG decode: three 8-bit samples, interleaved, tables (if any) a whole
    // tables-only stream (SOI … EOI).
    const std::vector<uint8_t>& t = d.jpegTables;
    const bool tablesOk = t.empty() || (t.size() >= 4 && t[0] == 0xFF && t[1] == 0xD8 && t[t.size() - 2] == 0xFF &&
                                        t[t.size() - 1] == 0xD9);
    if (d.compression == COMPRESSION_JPEG && rgb && tablesOk)
        *decoder = d.photometric == PHOTOMETRIC_YCBCR ? Decoder::JpegYCbCr : Decoder::JpegRgb;
    return true;
}

Result notMine(const std::string& name, const std::string& why) {
    return Result(Status::UnsupportedFormat, "'" + name + "' is not for the TIFF tile reader: " + why);
}

// OpenSlide 3.4.1 decodes tile 0 of the first directory when it opens an Aperio JPEG 2000 slide,
// with a decoder that reads past the end of a component whose size does not fit its
// subsampling, or divides by zero (checkJp2kForOpenSlide, jp2k_decode.h). Found by
// tests/fuzz (regressions/tiff_reader/openslide-jp2k-first-tile-overread.fuzz): a file whose
// first tile is such a codestream is refused before OpenSlide sees it. It is no valid slide
// either, so the refusal is CorruptData, which the format table does not pass on to OpenSlide.
// `h` is at the first directory. Tiles that cannot be read are OpenSlide's to report.
Result checkFirstJp2kTile(Handle& h, const std::string& name) {
    TIFF* tif = h.tif;
    uint16_t compression = 0;
    TIFFGetFieldDefaulted(tif, TIFFTAG_COMPRESSION, &compression);
    if (!TIFFIsTiled(tif) || (compression != kAperioJp2kYCbCr && compression != kAperioJp2kRgb)) return {};
    const char* description = nullptr;
    if (!TIFFGetField(tif, TIFFTAG_IMAGEDESCRIPTION, &description) || !description ||
        std::strncmp(description, "Aperio", 6) != 0) {
        return {}; // OpenSlide's aperio reader takes only these; generic-tiff refuses 33003/33005
    }
    uint32_t tileW = 0, tileH = 0;
    TIFFGetField(tif, TIFFTAG_TILEWIDTH, &tileW);
    TIFFGetField(tif, TIFFTAG_TILELENGTH, &tileH);
    int errorFlag = 0;
    const uint64_t bytes = TIFFGetStrileByteCountWithErr(tif, 0, &errorFlag);
    if (errorFlag || bytes == 0 || bytes > h.size || tileW == 0 || tileH == 0 || tileW > kMaxFileTileSide ||
        tileH > kMaxFileTileSide) {
        return {};
    }
    if (bytes > kMaxRawTileBytes) {
        return Result(Status::CorruptData, "Cannot open '" + name + "': its first JPEG 2000 tile claims " +
                                               std::to_string(bytes) + " bytes");
    }
    std::vector<uint8_t> raw(static_cast<size_t>(bytes));
    if (TIFFReadRawTile(tif, 0, raw.data(), tmsize_t(bytes)) != tmsize_t(bytes)) return {};
    h.lastError.clear();
    if (Result r = checkJp2kForOpenSlide(raw.data(), raw.size(), int(tileW), int(tileH)); !r.ok()) {
        return Result(Status::CorruptData,
                      "Cannot open '" + name + "': its first JPEG 2000 tile is unusable (" + r.message() + ")");
    }
    return {};
}

} // namespace

bool TiffTileSource::detect(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return false;
    uint8_t m[4] = {};
    const ssize_t n = ::pread(fd, m, 4, 0);
    ::close(fd);
    if (n != 4) return false;
    const bool le = m[0] == 'I' && m[1] == 'I' && (m[2] == 42 || m[2] == 43) && m[3] == 0;
    const bool be = m[0] == 'M' && m[1] == 'M' && m[2] == 0 && (m[3] == 42 || m[3] == 43);
    return le || be;
}

Expected<std::unique_ptr<SlideSource>> TiffTileSource::tryOpen(const std::string& path) {
    const std::string name = fileNameOf(path);
    if (!detect(path)) return notMine(name, "not a TIFF file");

    // libtiff first: the file must pass checkFirstJp2kTile before OpenSlide opens it.
    std::unique_ptr<TiffTileSource> src(new TiffTileSource());
    src->fileName_ = name;
    src->fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (src->fd_ < 0) return notMine(name, std::strerror(errno));
    struct stat st {};
    if (::fstat(src->fd_, &st) != 0 || st.st_size <= 0) return notMine(name, "cannot stat the file");
    src->fileSize_ = uint64_t(st.st_size);
    std::string err;
    auto probe = openHandle(src->fd_, src->fileSize_, name, &err);
    if (!probe) return notMine(name, "libtiff: " + err);
    if (Result r = checkFirstJp2kTile(*probe, name); !r.ok()) return r;

    // Aperio and generic TIFF only: OpenSlide names the vendor from the tags first, so that a
    // Hamamatsu, Philips, Ventana, Leica or Trestle TIFF goes on to the OpenSlide reader without
    // being opened whole here only to learn its vendor (an NDPI open validates every level's
    // JPEG header and may start a restart-marker scan).
    auto meta = OpenSlideSource::openAs(path, {"aperio", "generic-tiff"});
    if (!meta.ok()) {
        // OpenSlide's own verdict: "not a slide" lets the next reader try; anything else
        // (a recognised but broken file) is the answer, with OpenSlide's message.
        if (meta.error().status() == Status::UnsupportedFormat) return notMine(name, meta.error().message());
        return meta.error();
    }
    const SlideInfo& info = (*meta)->info();
    if (info.vendor != "aperio" && info.vendor != "generic-tiff") return notMine(name, "vendor " + info.vendor);

    std::vector<DirInfo> dirs;
    for (int i = 0; i < kMaxDirectories; ++i) {
        dirs.push_back(readDirInfo(probe->tif, TIFFCurrentDirectory(probe->tif)));
        if (!TIFFReadDirectory(probe->tif)) break;
    }

    // Each level is the first unused tiled directory of the level's dimensions (Aperio's and
    // generic TIFF's levels are their tiled directories, in order; thumbnail, label and macro
    // are stripped or of other sizes).
    std::vector<bool> used(dirs.size(), false);
    for (size_t l = 0; l < info.levels.size(); ++l) {
        const LevelInfo& li = info.levels[l];
        size_t found = dirs.size();
        for (size_t d = 0; d < dirs.size(); ++d) {
            if (!used[d] && dirs[d].tiled && int64_t(dirs[d].width) == li.width && int64_t(dirs[d].height) == li.height) {
                found = d;
                break;
            }
        }
        if (found == dirs.size()) {
            return notMine(name, "no tiled directory of " + std::to_string(li.width) + "x" + std::to_string(li.height) +
                                     " for level " + std::to_string(l));
        }
        used[found] = true;
        const DirInfo& d = dirs[found];
        Level lv;
        std::string why;
        if (!decodable(d, &lv.decoder, &why)) {
            return notMine(name, "level " + std::to_string(l) + " (directory " + std::to_string(d.index) + "): " + why);
        }
        lv.dir = d.index;
        if (lv.decoder == Decoder::JpegYCbCr || lv.decoder == Decoder::JpegRgb)
            lv.jpegTables.assign(d.jpegTables.begin(), d.jpegTables.end() - (d.jpegTables.empty() ? 0 : 2));
        lv.width = d.width;
        lv.height = d.height;
        lv.tileW = d.tileW;
        lv.tileH = d.tileH;
        lv.across = (d.width + d.tileW - 1) / d.tileW;
        lv.down = (d.height + d.tileH - 1) / d.tileH;
        src->levels_.push_back(lv);
    }
    if (src->levels_.empty()) return notMine(name, "no levels");
    src->info_ = info;
    {
        // The colour profile of the full-resolution image (TIFFTAG_ICCPROFILE, 34675).
        uint32_t iccSize = 0;
        void* icc = nullptr;
        if (TIFFSetDirectory(probe->tif, src->levels_[0].dir) &&
            TIFFGetField(probe->tif, TIFFTAG_ICCPROFILE, &iccSize, &icc) && icc && iccSize > 0) {
            const auto* b = static_cast<const uint8_t*>(icc);
            src->info_.iccProfile.assign(b, b + iccSize);
        }
    }
    src->pool_.resize(src->levels_.size());
    // Keep the probe: it becomes the first pooled handle of the level it can reach first.
    if (TIFFSetDirectory(probe->tif, src->levels_[0].dir)) {
        probe->dir = src->levels_[0].dir;
        probe->lastError.clear();
        src->pool_[0].push_back(std::move(probe));
    }
    src->meta_ = std::move(*meta);
    return std::unique_ptr<SlideSource>(std::move(src));
}

TiffTileSource::~TiffTileSource() {
    pool_.clear(); // closes every TIFF before the descriptor they read through
    if (fd_ >= 0) ::close(fd_);
}

const SlideInfo& TiffTileSource::info() const {
    return info_;
}

Expected<Image> TiffTileSource::readAssociatedImage(const std::string& name) {
    return meta_->readAssociatedImage(name);
}

std::unique_ptr<TiffTileSource::Handle> TiffTileSource::acquire(size_t level, Result* error) {
    {
        std::lock_guard lock(poolMutex_);
        auto& idle = pool_[level];
        if (!idle.empty()) {
            auto h = std::move(idle.back());
            idle.pop_back();
            return h;
        }
    }
    std::string err;
    auto h = openHandle(fd_, fileSize_, fileName_, &err);
    if (!h) {
        *error = Result(Status::IoError, "Cannot reopen '" + fileName_ + "' with libtiff: " + err);
        return nullptr;
    }
    if (!TIFFSetDirectory(h->tif, levels_[level].dir)) {
        *error = Result(Status::CorruptData, "Cannot read TIFF directory " + std::to_string(levels_[level].dir) +
                                                 " of '" + fileName_ + "': " + h->lastError);
        return nullptr;
    }
    h->dir = levels_[level].dir;
    h->lastError.clear();
    return h;
}

void TiffTileSource::release(size_t level, std::unique_ptr<Handle> handle) {
    std::lock_guard lock(poolMutex_);
    pool_[level].push_back(std::move(handle));
}

// A JPEG tile's whole stream for libjpeg: the tables (SOI, DQT, DHT…, no EOI), then the tile's
// own stream after its SOI; a tile with its own tables reads the same, its tables replacing
// ours. In this thread's buffer, valid until its next call. False when the tile cannot be read.
bool TiffTileSource::jpegTileStream(Handle& hd, const Level& L, uint32_t tileIndex, const uint8_t** data, size_t* size) {
    int errorFlag = 0;
    const uint64_t bytes = TIFFGetStrileByteCountWithErr(hd.tif, tileIndex, &errorFlag);
    if (errorFlag || bytes < 4 || bytes > kMaxRawTileBytes || bytes > fileSize_) return false;
    thread_local std::vector<uint8_t> stream;
    const size_t head = L.jpegTables.empty() ? 0 : L.jpegTables.size();
    stream.resize(head + size_t(bytes));
    if (head > 0) std::memcpy(stream.data(), L.jpegTables.data(), head); // no tables: data() may be null
    uint8_t* raw = stream.data() + head;
    if (TIFFReadRawTile(hd.tif, tileIndex, raw, tmsize_t(bytes)) != tmsize_t(bytes) || !hd.lastError.empty()) return false;
    if (raw[0] != 0xFF || raw[1] != 0xD8) return false;
    *data = stream.data();
    *size = stream.size();
    if (head > 0) {
        std::memmove(raw, raw + 2, size_t(bytes) - 2); // drop the tile's SOI: the tables' opens the stream
        *size -= 2;
    }
    return true;
}

bool TiffTileSource::decodeJpegTile(Handle& hd, const Level& L, uint32_t tileIndex, uint32_t w, uint32_t h, uint8_t* dst,
                                    size_t pitch) {
    const uint8_t* data = nullptr;
    size_t size = 0;
    if (!jpegTileStream(hd, L, tileIndex, &data, &size)) return false;
    const JpegColour colour = L.decoder == Decoder::JpegYCbCr ? JpegColour::YCbCr : JpegColour::Rgb;
    if (w == L.tileW && h == L.tileH)
        return decodeJpegFrameRgba(data, size, int(L.tileW), int(L.tileH), colour, dst, pitch).ok();
    thread_local std::vector<uint8_t> full; // an edge tile: the file tile is whole, the level ends inside it
    full.resize(size_t(L.tileW) * L.tileH * 4);
    if (!decodeJpegFrameRgba(data, size, int(L.tileW), int(L.tileH), colour, full.data(), size_t(L.tileW) * 4).ok())
        return false;
    for (uint32_t y = 0; y < h; ++y) std::memcpy(dst + size_t(y) * pitch, full.data() + size_t(y) * L.tileW * 4, size_t(w) * 4);
    return true;
}

Expected<std::shared_ptr<const TiffTileSource::DecodedTile>> TiffTileSource::fileTile(size_t level, uint32_t col,
                                                                                     uint32_t row) {
    const Level& L = levels_[level];
    const uint32_t tileIndex = row * L.across + col; // < 2^32: checked at open
    const uint64_t key = (uint64_t(level) << 32) | tileIndex;
    {
        std::lock_guard lock(cacheMutex_);
        if (auto it = cacheIndex_.find(key); it != cacheIndex_.end()) {
            lru_.splice(lru_.begin(), lru_, it->second);
            return it->second->second;
        }
    }

    const uint32_t x0 = col * L.tileW, y0 = row * L.tileH;
    const uint32_t w = std::min(L.tileW, L.width - x0), h = std::min(L.tileH, L.height - y0);
    auto tile = std::make_shared<DecodedTile>();
    tile->width = w;
    tile->height = h;
    tile->rgba.resize(size_t(w) * h * 4);

    Result error;
    std::unique_ptr<Handle> hd = acquire(level, &error);
    if (!hd) return error;
    hd->lastError.clear();
    const auto fail = [&](const std::string& why) {
        return Result(Status::CorruptData, "Cannot decode tile (" + std::to_string(col) + ", " + std::to_string(row) +
                                               ") of TIFF directory " + std::to_string(L.dir) + " in '" + fileName_ +
                                               "': " + why);
    };

    bool decoded = false;
    if (L.decoder == Decoder::JpegYCbCr || L.decoder == Decoder::JpegRgb) decoded = decodeJpegTile(*hd, L, tileIndex, w, h, tile->rgba.data(), size_t(w) * 4);
    if (decoded) {
        // done
    } else if (L.decoder == Decoder::LibTiff || L.decoder == Decoder::JpegYCbCr || L.decoder == Decoder::JpegRgb) {
        hd->lastError.clear();
        // As OpenSlide 3.4.1 reads a tile (TIFFRGBAImage, top-left orientation), except that the
        // raster is clipped to the image: a raster wider than the image makes libtiff "adapt"
        // the width and scramble the rows (SOURCES.md's warning about 3.4.1 on small levels).
        char emsg[1024] = {0};
        TIFFRGBAImage img;
        if (!TIFFRGBAImageOK(hd->tif, emsg) || !TIFFRGBAImageBegin(&img, hd->tif, 1, emsg)) {
            return fail(hd->lastError.empty() ? std::string(emsg) : hd->lastError); // handle dropped
        }
        img.req_orientation = ORIENTATION_TOPLEFT;
        img.col_offset = x0;
        img.row_offset = y0;
        thread_local std::vector<uint32_t> raster;
        raster.resize(size_t(w) * h);
        const int ok = TIFFRGBAImageGet(&img, raster.data(), w, h);
        TIFFRGBAImageEnd(&img);
        if (!ok || !hd->lastError.empty()) {
            return fail(hd->lastError.empty() ? std::string("TIFFRGBAImageGet failed") : hd->lastError);
        }
        // TIFFRGBAImage packs A·B·G·R from the high byte down: RGBA bytes on a little-endian CPU.
        if constexpr (std::endian::native == std::endian::little) {
            std::memcpy(tile->rgba.data(), raster.data(), tile->rgba.size());
        } else {
            for (size_t i = 0; i < raster.size(); ++i) {
                const uint32_t p = raster[i];
                tile->rgba[4 * i + 0] = uint8_t(TIFFGetR(p));
                tile->rgba[4 * i + 1] = uint8_t(TIFFGetG(p));
                tile->rgba[4 * i + 2] = uint8_t(TIFFGetB(p));
                tile->rgba[4 * i + 3] = uint8_t(TIFFGetA(p));
            }
        }
    } else {
        int errorFlag = 0;
        const uint64_t bytes = TIFFGetStrileByteCountWithErr(hd->tif, tileIndex, &errorFlag);
        if (errorFlag || bytes == 0 || bytes > kMaxRawTileBytes || bytes > fileSize_) {
            return fail("impossible compressed size " + std::to_string(bytes));
        }
        thread_local std::vector<uint8_t> raw;
        raw.resize(size_t(bytes));
        const tmsize_t got = TIFFReadRawTile(hd->tif, tileIndex, raw.data(), tmsize_t(bytes));
        if (got != tmsize_t(bytes)) {
            return fail(hd->lastError.empty() ? std::string("short read") : hd->lastError);
        }
        const Jp2kColour colour = L.decoder == Decoder::Jp2kYCbCr ? Jp2kColour::YCbCr : Jp2kColour::Rgb;
        Result r;
        if (w == L.tileW && h == L.tileH) {
            r = decodeJp2kRgba(raw.data(), raw.size(), int(L.tileW), int(L.tileH), colour, tile->rgba.data(),
                               size_t(w) * 4);
        } else {
            thread_local std::vector<uint8_t> full;
            full.resize(size_t(L.tileW) * L.tileH * 4);
            r = decodeJp2kRgba(raw.data(), raw.size(), int(L.tileW), int(L.tileH), colour, full.data(),
                               size_t(L.tileW) * 4);
            if (r.ok()) {
                for (uint32_t y = 0; y < h; ++y) {
                    std::memcpy(tile->rgba.data() + size_t(y) * w * 4, full.data() + size_t(y) * L.tileW * 4,
                                size_t(w) * 4);
                }
            }
        }
        if (!r.ok()) {
            release(level, std::move(hd)); // the handle itself is fine: only the codestream was bad
            return fail(r.message());
        }
    }
    release(level, std::move(hd));

    std::shared_ptr<const DecodedTile> out = std::move(tile);
    std::lock_guard lock(cacheMutex_);
    if (auto it = cacheIndex_.find(key); it != cacheIndex_.end()) return it->second->second; // raced: keep one
    lru_.emplace_front(key, out);
    cacheIndex_[key] = lru_.begin();
    cacheBytes_ += out->rgba.size();
    while (cacheBytes_ > kCacheBudgetBytes && lru_.size() > 1) {
        cacheBytes_ -= lru_.back().second->rgba.size();
        cacheIndex_.erase(lru_.back().first);
        lru_.pop_back();
    }
    return out;
}

bool TiffTileSource::readsCoefficients(int level) const {
    if (level < 0 || size_t(level) >= levels_.size()) return false;
    const Level& L = levels_[size_t(level)];
    return (L.decoder == Decoder::JpegYCbCr || L.decoder == Decoder::JpegRgb) && L.tileW == uint32_t(kTileSize) &&
           L.tileH == uint32_t(kTileSize);
}

Result TiffTileSource::readTileCoefficients(int level, int64_t tx, int64_t ty, uint8_t* dst) {
    if (!readsCoefficients(level)) return Result(Status::UnsupportedFormat, "not a level of 256x256 JPEG tiles");
    const LevelInfo& li = info().levels[size_t(level)];
    if (tx < 0 || ty < 0 || tx >= li.tilesX || ty >= li.tilesY) return Result(Status::InvalidArgument, "no such tile");
    const Level& L = levels_[size_t(level)];
    // The file's tile grid is the engine's (readsCoefficients): file tile (tx, ty) is this tile.
    const int w = int(std::min<int64_t>(kTileSize, li.width - tx * kTileSize));
    const int h = int(std::min<int64_t>(kTileSize, li.height - ty * kTileSize));
    Result error;
    std::unique_ptr<Handle> hd = acquire(size_t(level), &error);
    if (!hd) return error;
    hd->lastError.clear();
    const uint8_t* data = nullptr;
    size_t size = 0;
    Result r = Result(Status::CorruptData, "the tile's JPEG stream cannot be read");
    if (jpegTileStream(*hd, L, uint32_t(ty) * L.across + uint32_t(tx), &data, &size))
        r = jpegrecord::write(data, size, kTileSize, kTileSize,
                              L.decoder == Decoder::JpegYCbCr ? JpegColour::YCbCr : JpegColour::Rgb, w, h, dst);
    hd->lastError.clear();
    release(size_t(level), std::move(hd));
    return r;
}

Result TiffTileSource::readTile(int level, int64_t tx, int64_t ty, uint8_t* dst) {
    const SlideInfo& inf = info();
    if (level < 0 || size_t(level) >= inf.levels.size()) return Result(Status::InvalidArgument, "no such level");
    const LevelInfo& li = inf.levels[size_t(level)];
    if (tx < 0 || ty < 0 || tx >= li.tilesX || ty >= li.tilesY) return Result(Status::InvalidArgument, "no such tile");
    const Level& L = levels_[size_t(level)];
    const int64_t x0 = tx * kTileSize, y0 = ty * kTileSize;
    const int w = int(std::min<int64_t>(kTileSize, li.width - x0));
    const int h = int(std::min<int64_t>(kTileSize, li.height - y0));
    if ((L.decoder == Decoder::JpegYCbCr || L.decoder == Decoder::JpegRgb) && L.tileW == uint32_t(kTileSize) &&
        L.tileH == uint32_t(kTileSize)) {
        // The file's tile grid is the engine's: file tile (tx, ty) is this tile and no other
        // engine tile needs it, so it is decoded straight into dst, past the file-tile cache and
        // its copy (issue 20). A tile that does not decode so takes the way below.
        Result error;
        if (std::unique_ptr<Handle> hd = acquire(size_t(level), &error)) {
            hd->lastError.clear();
            const bool ok = decodeJpegTile(*hd, L, uint32_t(ty) * L.across + uint32_t(tx), uint32_t(w), uint32_t(h), dst,
                                           size_t(kTileSize) * 4);
            hd->lastError.clear();
            release(size_t(level), std::move(hd));
            if (ok) {
                padTileEdges(dst, w, h);
                return {};
            }
        }
    }
    const uint32_t col0 = uint32_t(x0 / L.tileW), col1 = uint32_t((x0 + w - 1) / L.tileW);
    const uint32_t row0 = uint32_t(y0 / L.tileH), row1 = uint32_t((y0 + h - 1) / L.tileH);
    for (uint32_t row = row0; row <= row1; ++row) {
        for (uint32_t col = col0; col <= col1; ++col) {
            auto t = fileTile(size_t(level), col, row);
            if (!t.ok()) return t.error();
            const DecodedTile& ft = **t;
            // The overlap of file tile (col, row) and the engine tile, in level pixels.
            const int64_t fx = int64_t(col) * L.tileW, fy = int64_t(row) * L.tileH;
            const int64_t ax = std::max(fx, x0), bx = std::min(fx + ft.width, x0 + w);
            const int64_t ay = std::max(fy, y0), by = std::min(fy + ft.height, y0 + h);
            if (ax >= bx || ay >= by) continue;
            const size_t n = size_t(bx - ax) * 4;
            for (int64_t y = ay; y < by; ++y) {
                const uint8_t* s = ft.rgba.data() + (size_t(y - fy) * ft.width + size_t(ax - fx)) * 4;
                uint8_t* d = dst + (size_t(y - y0) * kTileSize + size_t(ax - x0)) * 4;
                std::memcpy(d, s, n);
            }
        }
    }
    padTileEdges(dst, w, h);
    return {};
}

} // namespace iris
