// TIFF → a map (libtiff over the bytes in memory): one image or a pyramid of IFDs and SubIFDs,
// strips or tiles, any compression libtiff decodes. Tiles and strips are converted into the
// level as they are read, so nothing larger than one tile or strip is held besides the level.
#include <tiffio.h>

#include <cstdarg>
#include <cstdio>
#include <cstring>

#include "layers/raster_readers.h"

namespace iris::layers_detail {

namespace {

constexpr int kMaxDirectories = 64;               // IFDs and SubIFDs looked at
constexpr uint64_t kMaxChunkBytes = 256ull << 20; // one decoded tile or strip

struct Mem {
    const uint8_t* data;
    uint64_t size;
    uint64_t pos = 0;
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
    auto* m = static_cast<Mem*>(user);
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

// Converts decoded pixels (one tile or strip) into the level: `cols` × `rows` pixels at (x0, y0)
// of `src`, whose rows are `stride` bytes apart.
Result convert(const Dir& d, const uint16_t* const* palette, RasterLevel& l, const uint8_t* src, size_t stride,
               uint32_t x0, uint32_t y0, uint32_t cols, uint32_t rows, const std::string& name) {
    for (uint32_t r = 0; r < rows; ++r) {
        const uint8_t* p = src + size_t(r) * stride;
        const uint64_t y = uint64_t(y0) + r;
        for (uint32_t c = 0; c < cols; ++c, p += d.pixelBytes) {
            const uint64_t x = uint64_t(x0) + c;
            if (d.kind != RasterKind::Rgba) {
                if (Result e = storeValue(d.kind, l, x, y, d.sample(p), name); !e) return e;
                continue;
            }
            uint8_t* out = &l.rgba[4 * (size_t(y) * size_t(l.width) + size_t(x))];
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

// Reads the current directory's pixels into `l` (sized by the caller).
Result readPixels(TIFF* tif, const Dir& d, RasterLevel& l, Mem& mem, const std::string& name) {
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
                if (Result r = convert(d, pal, l, buf.data(), size_t(tw) * d.pixelBytes, x, y,
                                       std::min(tw, d.width - x), std::min(th, d.height - y), name);
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
        if (Result r = convert(d, pal, l, buf.data(), rowBytes, 0, y, d.width, rows, name); !r) return r;
    }
    return {};
}

} // namespace

Expected<RasterMap> readTiffRaster(std::span<const uint8_t> bytes, const std::string& name,
                                   const RasterLoadOptions& options) {
    Mem mem{bytes.data(), bytes.size()};
    TIFFOpenOptions* opts = TIFFOpenOptionsAlloc();
    if (!opts) return fail(Status::OutOfMemory, name, "libtiff cannot start");
    TIFFOpenOptionsSetMaxSingleMemAlloc(opts, tmsize_t(kMaxChunkBytes));
    TIFFOpenOptionsSetErrorHandlerExtR(opts, &onError, &mem);
    TIFFOpenOptionsSetWarningHandlerExtR(opts, &onWarning, &mem);
    TiffCloser closer{TIFFClientOpenExt(name.c_str(), "rm", &mem, &readProc, &writeProc, &seekProc, &closeProc,
                                        &sizeProc, &mapProc, &unmapProc, opts)};
    TIFFOpenOptionsFree(opts);
    TIFF* tif = closer.tif;
    if (!tif) return fail(Status::CorruptData, name, "not a readable TIFF" + (mem.error.empty() ? "" : ": " + mem.error));

    // Every directory, in file order: each IFD of the main chain followed by its SubIFDs.
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

    const Limits limits = Limits::of(options);
    RasterMap map;
    uint64_t used = 0;
    for (const Location& at : where) {
        mem.error.clear();
        const bool selected = at.sub ? TIFFSetSubDirectory(tif, at.offset) : TIFFSetDirectory(tif, at.index);
        if (!selected) {
            if (map.levels.empty()) return fail(Status::CorruptData, name, "the first image's directory: " + mem.error);
            continue; // a broken SubIFD of a reduced level: not a level
        }
        const Dir d = readDir(tif, options.asLabels);
        if (map.levels.empty()) {
            if (!d.problem.empty()) return fail(Status::UnsupportedFormat, name, d.problem);
            map.kind = d.kind;
        } else {
            const RasterLevel& prev = map.levels.back();
            const bool smaller = d.width <= uint32_t(prev.width) && d.height <= uint32_t(prev.height) &&
                                 (d.width < uint32_t(prev.width) || d.height < uint32_t(prev.height));
            if (!d.problem.empty() || d.kind != map.kind || !smaller || d.width == 0 || d.height == 0 ||
                (d.subfileType & FILETYPE_MASK))
                continue; // a thumbnail of another kind, a mask, a label image: not a level
        }
        const int bpp = map.kind == RasterKind::Label ? 2 : 4;
        if (Result r = checkLevelSize(d.width, d.height, bpp, used, limits, name); !r) return r;
        used += uint64_t(d.width) * d.height * uint64_t(bpp);
        RasterLevel l;
        l.width = int32_t(d.width), l.height = int32_t(d.height);
        const size_t n = size_t(d.width) * d.height;
        if (map.kind == RasterKind::Scalar) l.scalar.assign(n, 0.0f);
        else if (map.kind == RasterKind::Label) l.label.assign(n, 0);
        else l.rgba.assign(4 * n, 0);
        const std::string levelName = map.levels.empty() ? name : name + ": level " + std::to_string(map.levels.size());
        if (Result r = readPixels(tif, d, l, mem, levelName); !r) return r;
        map.levels.push_back(std::move(l));
    }
    if (Result r = finishMap(map, name, options.title); !r) return r;
    return map;
}

} // namespace iris::layers_detail
