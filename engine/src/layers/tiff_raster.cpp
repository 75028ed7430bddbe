// TIFF → a map (libtiff over the bytes in memory): one image or a pyramid of IFDs and SubIFDs,
// strips or tiles, any compression libtiff decodes. Tiles and strips are converted into the
// level as they are read, so nothing larger than one tile or strip is held besides the level.
#include <sys/stat.h>
#include <tiffio.h>

#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <limits>
#include <mutex>
#include <type_traits>

#include "layers/raster_readers.h"
#include "layers/streamed_raster.h"

namespace iris::layers_detail {

namespace {

constexpr int kMaxDirectories = 64;               // IFDs and SubIFDs looked at
constexpr uint64_t kMaxChunkBytes = 256ull << 20; // one decoded tile or strip

struct Mem {
    const uint8_t* data;
    uint64_t size;
    uint64_t pos = 0;
};

// libtiff's first error message of an operation (cleared by the caller before each).
struct Sink {
    std::string error;
};

tmsize_t readProc(thandle_t th, void* buf, tmsize_t n) {
    auto* m = static_cast<Mem*>(th);
    if (n <= 0 || m->pos >= m->size) return 0;
    const uint64_t k = std::min<uint64_t>(uint64_t(n), m->size - m->pos);
    std::memcpy(buf, m->data + m->pos, size_t(k));
    m->pos += k;
    return tmsize_t(k);
}
tmsize_t writeProc(thandle_t, void*, tmsize_t) {
    return 0;
}
toff_t seekProc(thandle_t th, toff_t off, int whence) {
    auto* m = static_cast<Mem*>(th);
    switch (whence) {
    case SEEK_SET: m->pos = off; break;
    case SEEK_CUR: m->pos += off; break;
    case SEEK_END: m->pos = m->size + off; break;
    default: return toff_t(-1);
    }
    return m->pos;
}
int closeProc(thandle_t) {
    return 0;
}
toff_t sizeProc(thandle_t th) {
    return static_cast<Mem*>(th)->size;
}
int mapProc(thandle_t, void**, toff_t*) {
    return 0;
}
void unmapProc(thandle_t, void*, toff_t) {}

int onError(TIFF*, void* user, const char* module, const char* fmt, va_list ap) {
    auto* m = static_cast<Sink*>(user);
    if (m->error.empty()) {
        char buf[512];
        std::vsnprintf(buf, sizeof buf, fmt, ap);
        m->error = (module && *module) ? std::string(module) + ": " + buf : std::string(buf);
    }
    return 1;
}
int onWarning(TIFF*, void*, const char*, const char*, va_list) {
    return 1;
}

struct TiffCloser {
    TIFF* tif;
    ~TiffCloser() {
        if (tif) TIFFClose(tif);
    }
};

// Where a directory is: the n-th of the main chain, or a SubIFD at an offset.
struct Location {
    bool sub;
    tdir_t index;
    toff_t offset;
};

// One directory's layout, as far as a map needs it.
struct Dir {
    uint32_t width = 0, height = 0;
    uint16_t spp = 1, bps = 1, format = SAMPLEFORMAT_UINT, photometric = 0, planar = PLANARCONFIG_CONTIG;
    uint32_t subfileType = 0;
    bool associatedAlpha = false;
    RasterKind kind = RasterKind::Scalar;
    Sample sample{};
    int pixelBytes = 0;  // of the decoded data
    int channels = 1;    // kept per pixel: 1, 3 or 4
    std::string problem; // why it cannot be a level
};

std::string describe(const Dir& d) {
    return "photometric " + std::to_string(d.photometric) + ", " + std::to_string(d.spp) + " sample(s) of " +
           std::to_string(d.bps) + " bits, sample format " + std::to_string(d.format);
}

Dir readDir(TIFF* tif, bool asLabels) {
    Dir d;
    TIFFGetField(tif, TIFFTAG_IMAGEWIDTH, &d.width);
    TIFFGetField(tif, TIFFTAG_IMAGELENGTH, &d.height);
    TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLESPERPIXEL, &d.spp);
    TIFFGetFieldDefaulted(tif, TIFFTAG_BITSPERSAMPLE, &d.bps);
    TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLEFORMAT, &d.format);
    TIFFGetFieldDefaulted(tif, TIFFTAG_PLANARCONFIG, &d.planar);
    TIFFGetFieldDefaulted(tif, TIFFTAG_SUBFILETYPE, &d.subfileType);
    if (!TIFFGetField(tif, TIFFTAG_PHOTOMETRIC, &d.photometric))
        d.photometric = d.spp >= 3 ? PHOTOMETRIC_RGB : PHOTOMETRIC_MINISBLACK;
    uint16_t compression = COMPRESSION_NONE;
    TIFFGetFieldDefaulted(tif, TIFFTAG_COMPRESSION, &compression);
    if (d.photometric == PHOTOMETRIC_YCBCR && compression == COMPRESSION_JPEG) {
        TIFFSetField(tif, TIFFTAG_JPEGCOLORMODE, JPEGCOLORMODE_RGB); // libjpeg converts to RGB
        d.photometric = PHOTOMETRIC_RGB;
    }
    if (d.spp == 4) {
        uint16_t count = 0, *types = nullptr;
        if (TIFFGetField(tif, TIFFTAG_EXTRASAMPLES, &count, &types) && count >= 1 && types)
            d.associatedAlpha = types[0] == EXTRASAMPLE_ASSOCALPHA;
    }
    if (d.planar != PLANARCONFIG_CONTIG && d.spp > 1) {
        d.problem = "planar (separate) samples; write the samples interleaved";
        return d;
    }
    const bool grey = d.photometric == PHOTOMETRIC_MINISBLACK && d.spp == 1;
    const bool palette = d.photometric == PHOTOMETRIC_PALETTE && d.spp == 1 && (d.bps == 8 || d.bps == 16);
    if (grey || (palette && asLabels)) {
        const bool isFloat = d.format == SAMPLEFORMAT_IEEEFP;
        const bool isInt = d.format == SAMPLEFORMAT_UINT || d.format == SAMPLEFORMAT_INT;
        const bool sizeOk = isFloat ? (d.bps == 32 || d.bps == 64 || d.bps == 16) : (d.bps == 8 || d.bps == 16 || d.bps == 32);
        if (!(isFloat || isInt) || !sizeOk) {
            d.problem = "a single-channel image of " + describe(d) +
                        " (8/16/32-bit integers and 16/32/64-bit floats are read)";
            return d;
        }
        if (asLabels && isFloat) {
            d.problem = "a label map needs integer samples, not floating point";
            return d;
        }
        d.kind = asLabels ? RasterKind::Label : RasterKind::Scalar;
        d.sample = {isFloat ? SampleKind::Float : d.format == SAMPLEFORMAT_INT ? SampleKind::Int : SampleKind::Uint,
                    d.bps / 8, false};
        d.pixelBytes = d.bps / 8;
        return d;
    }
    if (palette) {
        d.kind = RasterKind::Rgba;
        d.sample = {SampleKind::Uint, d.bps / 8, false};
        d.pixelBytes = d.bps / 8;
        return d;
    }
    if (d.photometric == PHOTOMETRIC_RGB && (d.spp == 3 || d.spp == 4) && d.bps == 8 &&
        d.format == SAMPLEFORMAT_UINT) {
        if (asLabels) {
            d.problem = "a label map must be single-channel, not RGB";
            return d;
        }
        d.kind = RasterKind::Rgba;
        d.channels = d.spp;
        d.pixelBytes = d.spp;
        return d;
    }
    d.problem = "an image of " + describe(d) +
                " (single-channel numbers, 8-bit RGB or RGBA, or a palette are read)";
    return d;
}

// One row of `cols` numbers of type T in this machine's byte order to a Scalar or Label row, as
// storeValueTo would store them, with their range added to `range`; false (and `range`
// untouched) where a value is refused, for the caller to name it through storeValueTo. The
// load's inner loop: a sample through Sample and a Result a pixel took most of a large map's
// load (measured in LAYERS.md).
template <class T>
bool convertRow(RasterKind kind, const uint8_t* p, uint8_t* out, uint32_t cols, ValueRange* range) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (uint32_t c = 0; c < cols; ++c) {
        T t;
        std::memcpy(&t, p + size_t(c) * sizeof(T), sizeof(T));
        const double v = double(t);
        if (kind == RasterKind::Label) {
            if constexpr (std::is_floating_point_v<T>) {
                return false; // refused (floating-point labels never get here)
            } else {
                if constexpr (std::numeric_limits<T>::min() < 0 || sizeof(T) > 2)
                    if (!(v >= 0 && v <= 65535)) return false;
                const uint16_t id = uint16_t(t);
                std::memcpy(out + size_t(c) * 2, &id, 2);
            }
        } else {
            if constexpr (std::is_floating_point_v<T>) {
                if (v != v) { // NaN: stored, not ranged
                    const float f = float(v);
                    std::memcpy(out + size_t(c) * 4, &f, 4);
                    continue;
                }
                if (!(std::fabs(v) <= double(std::numeric_limits<float>::max()))) return false;
            }
            const float f = float(v);
            std::memcpy(out + size_t(c) * 4, &f, 4);
        }
        lo = v < lo ? v : lo;
        hi = v > hi ? v : hi;
    }
    if (range && lo <= hi) range->add(lo), range->add(hi);
    return true;
}

// convertRow for d's samples, or false where there is none (swapped bytes, half floats, 64-bit
// integers) or a value is refused.
bool convertRowFast(const Dir& d, const uint8_t* p, uint8_t* out, uint32_t cols, ValueRange* range) {
    if (d.sample.swap) return false;
    switch (d.sample.kind) {
    case SampleKind::Uint:
        if (d.sample.size == 1) return convertRow<uint8_t>(d.kind, p, out, cols, range);
        if (d.sample.size == 2) return convertRow<uint16_t>(d.kind, p, out, cols, range);
        if (d.sample.size == 4) return convertRow<uint32_t>(d.kind, p, out, cols, range);
        return false;
    case SampleKind::Int:
        if (d.sample.size == 1) return convertRow<int8_t>(d.kind, p, out, cols, range);
        if (d.sample.size == 2) return convertRow<int16_t>(d.kind, p, out, cols, range);
        if (d.sample.size == 4) return convertRow<int32_t>(d.kind, p, out, cols, range);
        return false;
    case SampleKind::Float:
        if (d.sample.size == 4) return convertRow<float>(d.kind, p, out, cols, range);
        if (d.sample.size == 8) return convertRow<double>(d.kind, p, out, cols, range);
        return false;
    case SampleKind::Bool: return false;
    }
    return false;
}

// Converts decoded pixels (one tile or strip) into the map's kind: `cols` × `rows` pixels of
// `src` (rows `stride` bytes apart) to `dst` (rows `dstStride` pixels apart); (x0, y0) is where
// they lie in the level, to name a bad value. Scalar and Label values are added to `range`.
Result convert(const Dir& d, const uint16_t* const* palette, uint8_t* dst, size_t dstStride, const uint8_t* src,
               size_t stride, uint32_t x0, uint32_t y0, uint32_t cols, uint32_t rows, const std::string& name,
               ValueRange* range = nullptr) {
    const size_t bpp = size_t(bytesPerPixelOf(d.kind));
    for (uint32_t r = 0; r < rows; ++r) {
        const uint8_t* p = src + size_t(r) * stride;
        const uint64_t y = uint64_t(y0) + r;
        if (d.kind != RasterKind::Rgba && convertRowFast(d, p, dst + size_t(r) * dstStride * bpp, cols, range))
            continue;
        for (uint32_t c = 0; c < cols; ++c, p += d.pixelBytes) {
            const uint64_t x = uint64_t(x0) + c;
            uint8_t* out = dst + (size_t(r) * dstStride + c) * bpp;
            if (d.kind != RasterKind::Rgba) {
                const double v = d.sample(p);
                if (Result e = storeValueTo(d.kind, out, x, y, v, name); !e) return e;
                if (range && v == v) range->add(v);
                continue;
            }
            if (palette) {
                const size_t i = size_t(d.sample(p));
                for (int k = 0; k < 3; ++k) out[k] = uint8_t(palette[k][i] >> 8);
                out[3] = 255;
            } else if (d.channels == 3) {
                out[0] = p[0], out[1] = p[1], out[2] = p[2], out[3] = 255;
            } else if (d.associatedAlpha) {
                const unsigned a = p[3];
                for (int k = 0; k < 3; ++k) out[k] = a ? uint8_t(std::min(255u, (p[k] * 255u + a / 2) / a)) : 0;
                out[3] = uint8_t(a);
            } else {
                std::memcpy(out, p, 4);
            }
        }
    }
    return {};
}

uint8_t* levelData(RasterKind k, RasterLevel& l) {
    switch (k) {
    case RasterKind::Scalar: return reinterpret_cast<uint8_t*>(l.scalar.data());
    case RasterKind::Label: return reinterpret_cast<uint8_t*>(l.label.data());
    case RasterKind::Rgba: return l.rgba.data();
    }
    return nullptr;
}

// The pixel of (x, y) in a level's data of `width` pixels a row.
uint8_t* at(RasterKind k, uint8_t* data, uint32_t width, uint32_t x, uint32_t y) {
    return data + (size_t(y) * width + x) * size_t(bytesPerPixelOf(k));
}

// Reads the current directory's pixels into `l` (sized by the caller).
Result readPixels(TIFF* tif, const Dir& d, RasterLevel& l, Sink& mem, const std::string& name) {
    auto libtiffError = [&](const std::string& what) {
        return fail(Status::CorruptData, name, what + (mem.error.empty() ? std::string() : ": " + mem.error));
    };
    uint16_t* palette[3] = {nullptr, nullptr, nullptr};
    const bool usePalette = d.kind == RasterKind::Rgba && d.photometric == PHOTOMETRIC_PALETTE;
    if (usePalette && !TIFFGetField(tif, TIFFTAG_COLORMAP, &palette[0], &palette[1], &palette[2]))
        return libtiffError("a palette image without a colour map");
    const uint16_t* const* pal = usePalette ? palette : nullptr;
    const size_t rowBytes = size_t(d.width) * size_t(d.pixelBytes);
    if (uint64_t(TIFFScanlineSize64(tif)) != rowBytes)
        return libtiffError("libtiff's rows of " + std::to_string(TIFFScanlineSize64(tif)) + " bytes, " +
                            std::to_string(rowBytes) + " expected");
    if (TIFFIsTiled(tif)) {
        uint32_t tw = 0, th = 0;
        TIFFGetField(tif, TIFFTAG_TILEWIDTH, &tw);
        TIFFGetField(tif, TIFFTAG_TILELENGTH, &th);
        const uint64_t tileBytes = uint64_t(tw) * th * uint64_t(d.pixelBytes);
        if (tw == 0 || th == 0 || tileBytes > kMaxChunkBytes || uint64_t(TIFFTileSize64(tif)) != tileBytes)
            return fail(Status::CorruptData, name,
                        "tiles of " + std::to_string(tw) + "x" + std::to_string(th) + " pixels (" +
                            std::to_string(TIFFTileSize64(tif)) + " bytes) do not fit the image's layout or the limit");
        std::vector<uint8_t> buf(static_cast<size_t>(tileBytes));
        for (uint32_t y = 0; y < d.height; y += th)
            for (uint32_t x = 0; x < d.width; x += tw) {
                if (TIFFReadEncodedTile(tif, TIFFComputeTile(tif, x, y, 0, 0), buf.data(), tmsize_t(tileBytes)) < 0)
                    return libtiffError("the tile at (" + std::to_string(x) + ", " + std::to_string(y) +
                                        ") does not decode");
                if (Result r = convert(d, pal, at(d.kind, levelData(d.kind, l), d.width, x, y), d.width, buf.data(),
                                       size_t(tw) * d.pixelBytes, x, y, std::min(tw, d.width - x),
                                       std::min(th, d.height - y), name);
                    !r)
                    return r;
            }
        return {};
    }
    uint32_t rps = d.height;
    TIFFGetFieldDefaulted(tif, TIFFTAG_ROWSPERSTRIP, &rps);
    if (rps == 0 || rps > d.height) rps = d.height;
    const uint64_t stripBytes = uint64_t(rps) * rowBytes;
    if (stripBytes > kMaxChunkBytes)
        return fail(Status::UnsupportedFormat, name,
                    "strips of " + std::to_string(stripBytes) + " bytes (the limit is " + std::to_string(kMaxChunkBytes) +
                        "; write smaller strips or tiles)");
    std::vector<uint8_t> buf(static_cast<size_t>(stripBytes));
    for (uint32_t y = 0; y < d.height; y += rps) {
        const uint32_t rows = std::min(rps, d.height - y);
        if (TIFFReadEncodedStrip(tif, TIFFComputeStrip(tif, y, 0), buf.data(), tmsize_t(uint64_t(rows) * rowBytes)) < 0)
            return libtiffError("the strip at row " + std::to_string(y) + " does not decode");
        if (Result r = convert(d, pal, at(d.kind, levelData(d.kind, l), d.width, 0, y), d.width, buf.data(), rowBytes,
                               0, y, d.width, rows, name);
            !r)
            return r;
    }
    return {};
}

// The levels of an open TIFF: every directory in file order (each IFD of the main chain followed
// by its SubIFDs), the first image and then each one smaller than the last level taken, of the
// same kind and not a mask. Errors name the file; `used` counts the decoded bytes of them all.
struct LevelDir {
    Location at;
    Dir dir;
    bool tiled = false; // the storage, filled in for a streamed load
    uint32_t tileW = 0, tileH = 0, rowsPerStrip = 0;
};

Expected<std::vector<LevelDir>> listLevels(TIFF* tif, Sink& sink, const std::string& name,
                                           const RasterLoadOptions& options) {
    std::vector<Location> where;
    for (tdir_t i = 0; int(where.size()) < kMaxDirectories; ++i) {
        if (i > 0 && !TIFFReadDirectory(tif)) break;
        where.push_back({false, i, 0});
        uint16_t count = 0;
        toff_t* offsets = nullptr;
        if (TIFFGetField(tif, TIFFTAG_SUBIFD, &count, &offsets) && offsets) {
            const std::vector<toff_t> subs(offsets, offsets + std::min<int>(count, kMaxDirectories));
            for (toff_t off : subs)
                if (int(where.size()) < kMaxDirectories) where.push_back({true, 0, off});
        }
    }
    std::vector<LevelDir> levels;
    for (const Location& at : where) {
        sink.error.clear();
        const bool selected = at.sub ? TIFFSetSubDirectory(tif, at.offset) : TIFFSetDirectory(tif, at.index);
        if (!selected) {
            if (levels.empty()) return fail(Status::CorruptData, name, "the first image's directory: " + sink.error);
            continue; // a broken SubIFD of a reduced level: not a level
        }
        const Dir d = readDir(tif, options.asLabels);
        if (levels.empty()) {
            if (!d.problem.empty()) return fail(Status::UnsupportedFormat, name, d.problem);
        } else {
            const Dir& prev = levels.back().dir;
            const bool smaller = d.width <= prev.width && d.height <= prev.height &&
                                 (d.width < prev.width || d.height < prev.height);
            if (!d.problem.empty() || d.kind != levels.front().dir.kind || !smaller || d.width == 0 || d.height == 0 ||
                (d.subfileType & FILETYPE_MASK))
                continue; // a thumbnail of another kind, a mask, a label image: not a level
        }
        levels.push_back({at, d});
    }
    return levels;
}

bool select(TIFF* tif, const Location& at) {
    return at.sub ? TIFFSetSubDirectory(tif, at.offset) : TIFFSetDirectory(tif, at.index);
}

std::string levelName(const std::string& name, size_t level) {
    return level == 0 ? name : name + ": level " + std::to_string(level);
}

// Opens a TIFF file by path for reading, libtiff's messages going to `sink`.
TIFF* openFile(const std::string& path, Sink& sink) {
    TIFFOpenOptions* opts = TIFFOpenOptionsAlloc();
    if (!opts) return nullptr;
    TIFFOpenOptionsSetMaxSingleMemAlloc(opts, tmsize_t(kMaxChunkBytes));
    TIFFOpenOptionsSetErrorHandlerExtR(opts, &onError, &sink);
    TIFFOpenOptionsSetWarningHandlerExtR(opts, &onWarning, &sink);
    TIFF* tif = TIFFOpenExt(path.c_str(), "rm", opts);
    TIFFOpenOptionsFree(opts);
    return tif;
}

// A TIFF level left in its file: read a tile (or strip) at a time on its own libtiff handle, the
// decoded blocks converted to the map's kind and kept in the BlockedSource's cache. Every block
// it produces is checked as the whole-file reader checks it, and its values go into the range.
class TiffLevelSource final : public BlockedSource {
public:
    static Expected<std::shared_ptr<TiffLevelSource>> open(const std::string& path, const LevelDir& level,
                                                          const std::string& name) {
        auto src = std::shared_ptr<TiffLevelSource>(new TiffLevelSource(level, name));
        src->tif_ = openFile(path, src->sink_);
        if (!src->tif_) return fail(Status::IoError, name, "cannot open it again: " + src->sink_.error);
        if (!select(src->tif_, level.at)) return fail(Status::CorruptData, name, "its directory: " + src->sink_.error);
        const Dir& d = level.dir;
        if (d.kind == RasterKind::Rgba && d.photometric == PHOTOMETRIC_PALETTE) {
            uint16_t* pal[3] = {nullptr, nullptr, nullptr};
            if (!TIFFGetField(src->tif_, TIFFTAG_COLORMAP, &pal[0], &pal[1], &pal[2]))
                return fail(Status::CorruptData, name, "a palette image without a colour map");
            for (int k = 0; k < 3; ++k) src->palette_[k] = pal[k];
        }
        if (uint64_t(TIFFScanlineSize64(src->tif_)) != uint64_t(d.width) * uint64_t(d.pixelBytes))
            return fail(Status::CorruptData, name, "libtiff's rows do not fit the image's layout");
        if (level.tiled && uint64_t(TIFFTileSize64(src->tif_)) != src->blockBytes_)
            return fail(Status::CorruptData, name,
                        "tiles of " + std::to_string(src->tw_) + "x" + std::to_string(src->th_) + " pixels (" +
                            std::to_string(TIFFTileSize64(src->tif_)) + " bytes) do not fit the image's layout");
        if (src->blockBytes_ > kMaxChunkBytes || src->blockBytes_ == 0)
            return fail(Status::UnsupportedFormat, name,
                        "tiles or strips of " + std::to_string(src->blockBytes_) + " bytes (the limit is " +
                            std::to_string(kMaxChunkBytes) + "; write smaller strips or tiles)");
        return src;
    }
    ~TiffLevelSource() override {
        if (tif_) TIFFClose(tif_);
    }
    ValueRange range() const {
        std::lock_guard lock(rangeMutex_);
        return range_;
    }

protected:
    Result produce(int32_t bx, int32_t by, uint8_t* out) const override {
        const Dir& d = level_.dir;
        const uint32_t x = uint32_t(bx) * tw_, y = uint32_t(by) * th_;
        const uint32_t cols = std::min(tw_, d.width - x), rows = std::min(th_, d.height - y);
        buf_.resize(size_t(blockBytes_));
        sink_.error.clear();
        const auto broken = [&](const char* what) {
            return fail(Status::CorruptData, name_,
                        std::string(what) + " at (" + std::to_string(x) + ", " + std::to_string(y) +
                            ") does not decode" + (sink_.error.empty() ? "" : ": " + sink_.error));
        };
        if (tiled_) {
            if (TIFFReadEncodedTile(tif_, TIFFComputeTile(tif_, x, y, 0, 0), buf_.data(), tmsize_t(blockBytes_)) < 0)
                return broken("the tile");
        } else if (TIFFReadEncodedStrip(tif_, TIFFComputeStrip(tif_, y, 0), buf_.data(),
                                        tmsize_t(uint64_t(rows) * d.width * uint64_t(d.pixelBytes))) < 0) {
            return broken("the strip");
        }
        ValueRange r;
        const bool pal = palette_[0] != nullptr;
        if (Result e = convert(d, pal ? palette_ : nullptr, out, tw_, buf_.data(), size_t(tw_) * d.pixelBytes, x, y,
                               cols, rows, name_, &r);
            !e)
            return e;
        std::lock_guard lock(rangeMutex_);
        range_.add(r);
        return {};
    }

private:
    TiffLevelSource(const LevelDir& level, const std::string& name)
        : BlockedSource(level.dir.kind, int32_t(level.dir.width), int32_t(level.dir.height), blockW(level),
                        blockH(level), cacheBytes(level)),
          level_(level), name_(name) {
        tw_ = uint32_t(blockW(level)), th_ = uint32_t(blockH(level));
        tiled_ = level.tiled;
        blockBytes_ = uint64_t(tw_) * th_ * uint64_t(level.dir.pixelBytes);
    }
    // An eighth of the level, from 4 to 64 MiB: a view's chunks and their neighbours, not the level.
    static size_t cacheBytes(const LevelDir& l) {
        const uint64_t level = uint64_t(l.dir.width) * l.dir.height * uint64_t(bytesPerPixelOf(l.dir.kind));
        return size_t(std::clamp<uint64_t>(level / 8, uint64_t(4) << 20, uint64_t(64) << 20));
    }
    static int32_t blockW(const LevelDir& l) { return int32_t(l.tiled ? l.tileW : l.dir.width); }
    static int32_t blockH(const LevelDir& l) { return int32_t(l.tiled ? l.tileH : l.rowsPerStrip); }

    LevelDir level_;
    std::string name_;
    TIFF* tif_ = nullptr;
    mutable Sink sink_;
    const uint16_t* palette_[3] = {nullptr, nullptr, nullptr};
    uint32_t tw_ = 0, th_ = 0;
    bool tiled_ = false;
    uint64_t blockBytes_ = 0;
    mutable std::vector<uint8_t> buf_;
    mutable std::mutex rangeMutex_;
    mutable ValueRange range_;
};

} // namespace

Expected<RasterMap> readTiffRaster(std::span<const uint8_t> bytes, const std::string& name,
                                   const RasterLoadOptions& options) {
    Mem mem{bytes.data(), bytes.size()};
    Sink sink;
    TIFFOpenOptions* opts = TIFFOpenOptionsAlloc();
    if (!opts) return fail(Status::OutOfMemory, name, "libtiff cannot start");
    TIFFOpenOptionsSetMaxSingleMemAlloc(opts, tmsize_t(kMaxChunkBytes));
    TIFFOpenOptionsSetErrorHandlerExtR(opts, &onError, &sink);
    TIFFOpenOptionsSetWarningHandlerExtR(opts, &onWarning, &sink);
    TiffCloser closer{TIFFClientOpenExt(name.c_str(), "rm", &mem, &readProc, &writeProc, &seekProc, &closeProc,
                                        &sizeProc, &mapProc, &unmapProc, opts)};
    TIFFOpenOptionsFree(opts);
    TIFF* tif = closer.tif;
    if (!tif) return fail(Status::CorruptData, name, "not a readable TIFF" + (sink.error.empty() ? "" : ": " + sink.error));
    auto levels = listLevels(tif, sink, name, options);
    if (!levels) return levels.error();

    const Limits limits = Limits::of(options);
    RasterMap map;
    map.kind = levels->front().dir.kind;
    uint64_t used = 0;
    for (const LevelDir& ld : *levels) {
        const Dir& d = ld.dir;
        sink.error.clear();
        if (!select(tif, ld.at)) return fail(Status::CorruptData, levelName(name, map.levels.size()), sink.error);
        const int bpp = bytesPerPixelOf(map.kind);
        if (Result r = checkLevelSize(d.width, d.height, bpp, used, limits, name); !r) return r;
        used += uint64_t(d.width) * d.height * uint64_t(bpp);
        RasterLevel l;
        l.width = int32_t(d.width), l.height = int32_t(d.height);
        const size_t n = size_t(d.width) * d.height;
        if (map.kind == RasterKind::Scalar) l.scalar.assign(n, 0.0f);
        else if (map.kind == RasterKind::Label) l.label.assign(n, 0);
        else l.rgba.assign(4 * n, 0);
        if (Result r = readPixels(tif, d, l, sink, levelName(name, map.levels.size())); !r) return r;
        map.levels.push_back(std::move(l));
    }
    if (Result r = finishMap(map, name, options.title); !r) return r;
    return map;
}

std::optional<Expected<RasterMap>> streamTiffRaster(const std::string& path, const RasterLoadOptions& options) {
    const std::string& name = path;
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return std::nullopt; // the reader says why
    Sink sink;
    TiffCloser closer{openFile(path, sink)};
    TIFF* tif = closer.tif;
    if (!tif) return std::nullopt; // the whole-file reader says why
    auto levels = listLevels(tif, sink, name, options);
    if (!levels) return std::nullopt;
    const RasterKind kind = levels->front().dir.kind;
    const uint64_t bpp = uint64_t(bytesPerPixelOf(kind));
    uint64_t total = 0;
    for (LevelDir& ld : *levels) {
        total += uint64_t(ld.dir.width) * ld.dir.height * bpp;
        if (!select(tif, ld.at)) return std::nullopt;
        ld.tiled = TIFFIsTiled(tif);
        if (ld.tiled) {
            TIFFGetField(tif, TIFFTAG_TILEWIDTH, &ld.tileW);
            TIFFGetField(tif, TIFFTAG_TILELENGTH, &ld.tileH);
        } else {
            ld.rowsPerStrip = ld.dir.height;
            TIFFGetFieldDefaulted(tif, TIFFTAG_ROWSPERSTRIP, &ld.rowsPerStrip);
            if (ld.rowsPerStrip == 0 || ld.rowsPerStrip > ld.dir.height) ld.rowsPerStrip = ld.dir.height;
        }
    }
    if (total <= options.streamAbove) return std::nullopt;

    const Limits limits = Limits::of(options);
    const uint64_t held = std::min(kHeldLevelBytes, std::max<uint64_t>(options.streamAbove / 8, 1));
    RasterMap map;
    map.kind = kind;
    uint64_t decoded = 0, resident = 0;
    std::vector<std::shared_ptr<TiffLevelSource>> sources;
    for (const LevelDir& ld : *levels) {
        const Dir& d = ld.dir;
        const std::string lname = levelName(name, map.levels.size());
        const uint64_t bytes = uint64_t(d.width) * d.height * bpp;
        if (Result r = checkLevelSize(d.width, d.height, int(bpp), 0, Limits{limits.maxSide, kMaxStreamedRasterBytes},
                                      name);
            !r)
            return Expected<RasterMap>(r);
        if (decoded + bytes > kMaxStreamedRasterBytes)
            return Expected<RasterMap>(fail(Status::UnsupportedFormat, name,
                                            "its levels need " + std::to_string(decoded + bytes) +
                                                " bytes decoded, over the limit of " +
                                                std::to_string(kMaxStreamedRasterBytes) + " for a streamed map"));
        decoded += bytes;
        RasterLevel l;
        l.width = int32_t(d.width), l.height = int32_t(d.height);
        if (bytes <= held) {
            // Small enough to hold: read now, counted against the held limit.
            if (Result r = checkLevelSize(d.width, d.height, int(bpp), resident, limits, name); !r)
                return Expected<RasterMap>(r);
            resident += bytes;
            sink.error.clear();
            if (!select(tif, ld.at)) return Expected<RasterMap>(fail(Status::CorruptData, lname, sink.error));
            const size_t n = size_t(d.width) * d.height;
            if (kind == RasterKind::Scalar) l.scalar.assign(n, 0.0f);
            else if (kind == RasterKind::Label) l.label.assign(n, 0);
            else l.rgba.assign(4 * n, 0);
            if (Result r = readPixels(tif, d, l, sink, lname); !r) return Expected<RasterMap>(r);
        } else {
            auto src = TiffLevelSource::open(path, ld, lname);
            if (!src) return Expected<RasterMap>(src.error());
            sources.push_back(*src);
            l.source = *src;
        }
        map.levels.push_back(std::move(l));
    }
    // Coarser levels down to 512 a side where the file stops above them (reading the finest
    // streamed level once, which also checks it); then every block no read has checked yet.
    if (Result r = extendPyramid(map, 512, held); !r) return Expected<RasterMap>(r);
    for (const auto& s : sources)
        if (Result r = s->produceAll(); !r) return Expected<RasterMap>(r);
    if (Result r = finishMap(map, name, options.title); !r) return Expected<RasterMap>(r);
    if (kind != RasterKind::Rgba) {
        ValueRange range;
        if (!std::isnan(map.minValue)) range.add(map.minValue), range.add(map.maxValue);
        for (const auto& s : sources) range.add(s->range());
        if (!range.empty()) map.minValue = range.lo, map.maxValue = range.hi;
    }
    return Expected<RasterMap>(std::move(map));
}

} // namespace iris::layers_detail
