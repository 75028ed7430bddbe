#include "slide/openslide_source.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <openslide.h>
#include <tiffio.h>

namespace iris {

namespace {

constexpr int64_t kMaxDimension = int64_t(1) << 29; // 536,870,912 px: far beyond any scanner

double propertyDouble(openslide_t* osr, const char* name) {
    const char* v = openslide_get_property_value(osr, name);
    if (!v || !*v) return 0;
    char* end = nullptr;
    const double d = std::strtod(v, &end);
    return (end != v && std::isfinite(d) && d > 0) ? d : 0;
}

// OpenSlide hands out premultiplied ARGB in native-endian uint32; the engine's tiles are
// premultiplied RGBA bytes (the atlas blends premultiplied, so straight alpha is never needed).
inline void argbToRgbaPremultiplied(const uint32_t* src, uint8_t* dst, size_t n) {
    for (size_t i = 0; i < n; ++i) {
        const uint32_t p = src[i];
        dst[4 * i + 0] = uint8_t(p >> 16);
        dst[4 * i + 1] = uint8_t(p >> 8);
        dst[4 * i + 2] = uint8_t(p);
        dst[4 * i + 3] = uint8_t(p >> 24);
    }
}

} // namespace

bool OpenSlideSource::detect(const std::string&) {
    return true; // the universal reader: open() decides and explains
}

namespace {

// Hostile TIFFs that crash OpenSlide 3.4.1 while it opens them, refused here with libtiff
// (without its memory map) before OpenSlide sees the file. Not a TIFF (other vendors' formats):
// nothing to check.
//  - A tile's bytes are read into a buffer of the size TILEBYTECOUNTS states (g_slice_alloc),
//    and GLib aborts the process when that cannot be had: a hostile count of a few gigabytes
//    kills the host (the fuzzer found one, 2995479730 bytes). Every tile of every tiled
//    directory must lie inside the file.
//  - The Aperio reader marks a level's empty tiles (byte count 0) missing and propagates each
//    to the next tiled directory, dividing its column by round(tiles across / next level's
//    tiles across), and its row likewise: a next level more than twice as many tiles across or
//    down makes that 0, an integer division by zero (SIGFPE; the fuzzer found it). A pyramid's
//    next level is never bigger, so such a file is refused as corrupt whatever its vendor.
//  - Every tile OpenSlide reads (and, for an Aperio JPEG 2000 file, tile 0 while it opens) is
//    decoded into one g_slice_alloc of tile width x height x 4 bytes: 16 GiB for a stated
//    65536 x 65536 tile, and GLib aborts when it fails. Tiles longer than kMaxFileTileSide a
//    side are refused as unsupported (the TIFF tile reader refuses them too).
Result checkTiffForOpenSlide(const std::string& path, const std::string& name) {
    std::error_code ec;
    const uint64_t fileSize = std::filesystem::file_size(path, ec);
    if (ec) return {};
    TIFFErrorHandler oldError = TIFFSetErrorHandler(nullptr), oldWarning = TIFFSetWarningHandler(nullptr);
    TIFF* tif = TIFFOpen(path.c_str(), "rm");
    TIFFSetErrorHandler(oldError);
    TIFFSetWarningHandler(oldWarning);
    if (!tif) return {}; // not a TIFF: OpenSlide decides
    struct TiledDir {
        tdir_t dir = 0;
        uint64_t across = 0, down = 0;
        bool emptyTiles = false;
    };
    std::vector<TiledDir> tiled;
    const auto checkDirectory = [&](tdir_t dir) -> Result {
        if (!TIFFIsTiled(tif)) return {};
        TiledDir td;
        td.dir = dir;
        uint32_t w = 0, h = 0, tw = 0, th = 0;
        TIFFGetField(tif, TIFFTAG_IMAGEWIDTH, &w);
        TIFFGetField(tif, TIFFTAG_IMAGELENGTH, &h);
        TIFFGetField(tif, TIFFTAG_TILEWIDTH, &tw);
        TIFFGetField(tif, TIFFTAG_TILELENGTH, &th);
        if (tw > kMaxFileTileSide || th > kMaxFileTileSide) {
            return Result(Status::UnsupportedFormat,
                          "Cannot open '" + name + "': TIFF directory " + std::to_string(dir) + " has tiles of " +
                              std::to_string(tw) + "x" + std::to_string(th) + " pixels, more than the " +
                              std::to_string(kMaxFileTileSide) + " a side Iris View reads");
        }
        if (tw && th) {
            td.across = (uint64_t(w) + tw - 1) / tw;
            td.down = (uint64_t(h) + th - 1) / th;
        }
        tiled.push_back(td); // a level to OpenSlide, even one it then refuses
        uint64_t* counts = nullptr;
        uint64_t* offsets = nullptr;
        if (!TIFFGetField(tif, TIFFTAG_TILEBYTECOUNTS, &counts) || !TIFFGetField(tif, TIFFTAG_TILEOFFSETS, &offsets) ||
            !counts || !offsets)
            return {}; // OpenSlide refuses such a directory itself
        const uint32_t tiles = TIFFNumberOfTiles(tif);
        for (uint32_t t = 0; t < tiles; ++t) {
            if (counts[t] > fileSize || offsets[t] > fileSize - counts[t]) {
                return Result(Status::CorruptData, "Cannot open '" + name + "': tile " + std::to_string(t) +
                                                      " of TIFF directory " + std::to_string(dir) + " claims " +
                                                      std::to_string(counts[t]) + " bytes at byte " +
                                                      std::to_string(offsets[t]) + ", past the end of the file (" +
                                                      std::to_string(fileSize) + " bytes)");
            }
            if (counts[t] == 0) tiled.back().emptyTiles = true;
        }
        return {};
    };
    Result out;
    tdir_t dir = 0;
    do {
        out = checkDirectory(dir++);
    } while (out.ok() && TIFFReadDirectory(tif));
    TIFFClose(tif);
    for (size_t i = 0; out.ok() && i + 1 < tiled.size(); ++i) {
        const TiledDir& a = tiled[i];
        const TiledDir& b = tiled[i + 1];
        if (a.emptyTiles && (b.across > 2 * a.across || b.down > 2 * a.down)) {
            out = Result(Status::CorruptData,
                         "Cannot open '" + name + "': TIFF directory " + std::to_string(a.dir) + " (" +
                             std::to_string(a.across) + "x" + std::to_string(a.down) +
                             " tiles) has empty tiles and the next tiled directory, " + std::to_string(b.dir) + ", has " +
                             std::to_string(b.across) + "x" + std::to_string(b.down) +
                             " tiles: a pyramid whose next level is bigger is corrupt");
        }
    }
    return out;
}

} // namespace

std::string OpenSlideSource::vendorOf(const std::string& path) {
    const char* vendor = openslide_detect_vendor(path.c_str());
    return vendor ? vendor : "";
}

Expected<std::unique_ptr<SlideSource>> OpenSlideSource::open(const std::string& path) {
    const std::string name = std::filesystem::path(path).filename().string();
    // TIFF-based formats (Aperio, generic TIFF, Hamamatsu NDPI, Philips, Ventana, Leica, Trestle)
    // are found by their contents: they are opened through the pinned name, so that tiles are
    // read from this file even after it is deleted or replaced. Formats found by their names
    // (MIRAX's .mrxs with its folder, Hamamatsu's .vms) keep the path.
    auto pinned = std::make_unique<PinnedFile>(path);
    if (!pinned->isTiff()) pinned.reset();
    const std::string opened = pinned ? pinned->name() : path;
    if (Result r = checkTiffForOpenSlide(opened, name); !r.ok()) return r;
    const char* vendor = openslide_detect_vendor(opened.c_str());
    openslide_t* osr = openslide_open(opened.c_str());
    if (!osr) {
        return Result(Status::UnsupportedFormat,
                      "Cannot open '" + name + "': not a slide format OpenSlide " +
                          openslide_get_version() + " recognises");
    }
    if (const char* err = openslide_get_error(osr)) {
        std::string msg = "Cannot open '" + name + "'";
        if (vendor) msg += std::string(" (") + vendor + ")";
        msg += ": " + std::string(err);
        openslide_close(osr);
        return Result(Status::CorruptData, msg);
    }
    SlideInfo info;
    info.path = path;
    const char* v = openslide_get_property_value(osr, OPENSLIDE_PROPERTY_NAME_VENDOR);
    info.vendor = v ? v : (vendor ? vendor : "unknown");
    const int32_t levels = openslide_get_level_count(osr);
    if (levels <= 0) {
        openslide_close(osr);
        return Result(Status::CorruptData, "Cannot open '" + name + "': the slide has no pyramid levels");
    }
    std::vector<int32_t> osLevels; // OpenSlide's index of each level kept
    for (int32_t l = 0; l < levels; ++l) {
        LevelInfo li;
        openslide_get_level_dimensions(osr, l, &li.width, &li.height);
        li.downsample = openslide_get_level_downsample(osr, l);
        if (li.width <= 0 || li.height <= 0 || li.width > kMaxDimension || li.height > kMaxDimension ||
            !(li.downsample >= 1.0) || !std::isfinite(li.downsample)) {
            openslide_close(osr);
            return Result(Status::CorruptData,
                          "Cannot open '" + name + "': level " + std::to_string(l) + " has impossible dimensions " +
                              std::to_string(li.width) + "x" + std::to_string(li.height));
        }
        if (l > 0 && li.downsample <= info.levels.back().downsample) {
            // Levels must get coarser: one that is not is left out, and the levels after it
            // keep their own OpenSlide index for reading (osLevels_).
            continue;
        }
        fillTileGrid(li);
        info.levels.push_back(li);
        osLevels.push_back(l);
    }
    info.width = info.levels[0].width;
    info.height = info.levels[0].height;
    info.mppX = propertyDouble(osr, OPENSLIDE_PROPERTY_NAME_MPP_X);
    info.mppY = propertyDouble(osr, OPENSLIDE_PROPERTY_NAME_MPP_Y);
    if (info.mppX == 0 || info.mppY == 0) {
        // OpenSlide 3.4.1 derives no mpp for generic TIFF; the TIFF resolution tags carry it
        // when they are in pixels per centimetre. Only a microscope-like value (0.05–20 µm per
        // pixel) is believed: a 72-dpi default (≈ 353 µm) is no scan resolution.
        const char* unit = openslide_get_property_value(osr, "tiff.ResolutionUnit");
        if (unit && std::string(unit) == "centimeter") {
            const double rx = propertyDouble(osr, "tiff.XResolution");
            const double ry = propertyDouble(osr, "tiff.YResolution");
            const double mx = rx > 0 ? 10000.0 / rx : 0, my = ry > 0 ? 10000.0 / ry : 0;
            if (mx >= 0.05 && mx <= 20 && my >= 0.05 && my <= 20) {
                info.mppX = mx;
                info.mppY = my;
            }
        }
    }
    info.objectivePower = propertyDouble(osr, OPENSLIDE_PROPERTY_NAME_OBJECTIVE_POWER);
    if (const char* const* names = openslide_get_property_names(osr)) {
        for (; *names; ++names) {
            const char* val = openslide_get_property_value(osr, *names);
            info.properties.emplace_back(*names, val ? val : "");
        }
    }
    std::sort(info.properties.begin(), info.properties.end());
    if (const char* const* names = openslide_get_associated_image_names(osr)) {
        for (; *names; ++names) info.associatedImages.emplace_back(*names);
    }
    fillLevelPhysics(info);
    return std::unique_ptr<SlideSource>(new OpenSlideSource(osr, std::move(info), std::move(osLevels), std::move(pinned)));
}

OpenSlideSource::~OpenSlideSource() {
    openslide_close(osr_);
}

Result OpenSlideSource::checkError(const char* what) const {
    if (const char* err = openslide_get_error(osr_)) {
        return Result(Status::CorruptData, std::string(what) + " failed in '" +
                                               std::filesystem::path(info_.path).filename().string() + "': " + err);
    }
    return {};
}

Result OpenSlideSource::readTile(int level, int64_t tx, int64_t ty, uint8_t* dst) {
    if (level < 0 || size_t(level) >= info_.levels.size()) return Result(Status::InvalidArgument, "no such level");
    const LevelInfo& li = info_.levels[size_t(level)];
    if (tx < 0 || ty < 0 || tx >= li.tilesX || ty >= li.tilesY) return Result(Status::InvalidArgument, "no such tile");
    const int w = int(std::min<int64_t>(kTileSize, li.width - tx * kTileSize));
    const int h = int(std::min<int64_t>(kTileSize, li.height - ty * kTileSize));
    // OpenSlide addresses every level in level-0 coordinates.
    const int64_t x0 = std::llround(double(tx * kTileSize) * li.downsample);
    const int64_t y0 = std::llround(double(ty * kTileSize) * li.downsample);
    thread_local std::vector<uint32_t> argb;
    argb.resize(size_t(w) * size_t(h));
    openslide_read_region(osr_, argb.data(), x0, y0, osLevels_[size_t(level)], w, h);
    if (Result r = checkError("Reading a tile"); !r.ok()) return r;
    for (int y = 0; y < h; ++y) {
        argbToRgbaPremultiplied(argb.data() + size_t(y) * size_t(w), dst + size_t(y) * kTileSize * 4, size_t(w));
    }
    padTileEdges(dst, w, h);
    return {};
}

Expected<Image> OpenSlideSource::readAssociatedImage(const std::string& name) {
    if (std::find(info_.associatedImages.begin(), info_.associatedImages.end(), name) == info_.associatedImages.end()) {
        return Result(Status::InvalidArgument, "The slide has no associated image '" + name + "'");
    }
    std::lock_guard lock(associatedMutex_);
    int64_t w = 0, h = 0;
    openslide_get_associated_image_dimensions(osr_, name.c_str(), &w, &h);
    // Checked before the allocation: a file stating a 60000×60000 label would otherwise ask for
    // 14 GiB (found by tests/fuzz, regressions/tiff_reader/openslide-associated-image-14gib.fuzz).
    const std::string size = std::to_string(w) + "x" + std::to_string(h);
    const std::string where = "Associated image '" + name + "' of '" + std::filesystem::path(info_.path).filename().string() + "'";
    if (w <= 0 || h <= 0 || w > 65536 || h > 65536)
        return Result(Status::CorruptData, where + " has impossible dimensions " + size);
    if (uint64_t(w) * uint64_t(h) > kMaxAssociatedPixels)
        return Result(Status::CorruptData, where + " is too large: " + size + ", more than 64 megapixels");
    std::vector<uint32_t> argb(size_t(w) * size_t(h));
    openslide_read_associated_image(osr_, name.c_str(), argb.data());
    if (Result r = checkError(("Reading associated image '" + name + "'").c_str()); !r.ok()) return r;
    Image img;
    img.width = uint32_t(w);
    img.height = uint32_t(h);
    img.rgba.resize(argb.size() * 4);
    for (size_t i = 0; i < argb.size(); ++i) {
        const uint32_t p = argb[i];
        const uint32_t a = p >> 24;
        uint32_t r = (p >> 16) & 255, g = (p >> 8) & 255, b = p & 255;
        if (a != 0 && a != 255) { // un-premultiply for the host's straight-alpha image
            r = std::min<uint32_t>(255, (r * 255 + a / 2) / a);
            g = std::min<uint32_t>(255, (g * 255 + a / 2) / a);
            b = std::min<uint32_t>(255, (b * 255 + a / 2) / a);
        }
        img.rgba[4 * i + 0] = uint8_t(r);
        img.rgba[4 * i + 1] = uint8_t(g);
        img.rgba[4 * i + 2] = uint8_t(b);
        img.rgba[4 * i + 3] = uint8_t(a);
    }
    return img;
}

} // namespace iris
