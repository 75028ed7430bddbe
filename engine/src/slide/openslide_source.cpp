#include "slide/openslide_source.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <openslide.h>

#include "slide/openslide_guard.h"

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

Expected<std::unique_ptr<SlideSource>> OpenSlideSource::open(const std::string& path) {
    return openAs(path, {});
}

Expected<std::unique_ptr<SlideSource>> OpenSlideSource::openAs(const std::string& path,
                                                               std::initializer_list<std::string_view> vendors) {
    const std::string name = std::filesystem::path(path).filename().string();
    // TIFF-based formats (Aperio, generic TIFF, Hamamatsu NDPI, Philips, Ventana, Leica, Trestle)
    // are found by their contents: they are opened through the pinned name, so that tiles are
    // read from this file even after it is deleted or replaced. Formats found by their names
    // (MIRAX's .mrxs with its folder, Hamamatsu's .vms) keep the path.
    auto pinned = std::make_unique<PinnedFile>(path);
    if (!pinned->isTiff()) pinned.reset();
    const std::string opened = pinned ? pinned->name() : path;
    const char* vendor = nullptr;
    if (Result r = checkFileForOpenSlide(opened, name, &vendor); !r.ok()) return r;
    const std::string_view named = vendor ? vendor : "";
    if (vendors.size() != 0 && std::find(vendors.begin(), vendors.end(), named) == vendors.end()) {
        return Result(Status::UnsupportedFormat, "Cannot open '" + name + "' here: OpenSlide names " +
                                                     (vendor ? std::string("its vendor ") + vendor : "no vendor for it"));
    }
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
