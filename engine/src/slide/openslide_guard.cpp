#include "slide/openslide_guard.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string_view>
#include <vector>

#include <openslide.h>
#include <pugixml.hpp>
#include <tiffio.h>

#include "slide/slide_source.h"

namespace iris {

namespace {

// The most tiles one Ventana scan area may state: 2^27, some 134 million (a slide has thousands;
// OpenSlide allocates a pointer and a record for each).
constexpr int64_t kMaxVentanaAreaTiles = int64_t(1) << 27;

// Every TIFF's directories, whatever its vendor (tif at its first directory):
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
Result checkTiffLayout(TIFF* tif, uint64_t fileSize, const std::string& name) {
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

// An element's name without its namespace prefix.
std::string_view localName(const pugi::xml_node& n) {
    const std::string_view name = n.name();
    const size_t colon = name.find(':');
    return colon == std::string_view::npos ? name : name.substr(colon + 1);
}

pugi::xml_node child(const pugi::xml_node& n, std::string_view local) {
    for (pugi::xml_node c = n.first_child(); c; c = c.next_sibling())
        if (c.type() == pugi::node_element && localName(c) == local) return c;
    return {};
}

// The text of the element at `path` (local names) below n, as XPath's text() sees it: empty when
// the element or its text is missing.
std::string textAt(pugi::xml_node n, std::initializer_list<std::string_view> path) {
    for (std::string_view p : path) {
        n = child(n, p);
        if (!n) return {};
    }
    return n.child_value();
}

// A whole decimal integer, as OpenSlide's attribute parser takes it (g_ascii_strtoll, all of
// the text, saturated on overflow). Nothing for text OpenSlide refuses itself.
std::optional<int64_t> parseInt(const char* s) {
    if (!s || !*s) return std::nullopt;
    char* end = nullptr;
    const long long v = std::strtoll(s, &end, 10);
    if (*end != 0) return std::nullopt;
    return int64_t(v);
}

pugi::xml_document parseXml(const char* data, size_t size) {
    pugi::xml_document doc;
    doc.load_buffer(data, size, pugi::parse_default, pugi::encoding_utf8);
    return doc;
}

// Ventana BIF (OpenSlide 3.4.1's ventana reader; Debian's deb12u1 patch refuses counts <= 0):
//  - each scanned area (EncodeInfo's ImageInfo with AOIScanned != 0, in the level-0 XMLPacket)
//    gets g_new(tile*, NumCols * NumRows): a huge product aborts in GLib, and one that wraps
//    in 64 bits to a small count is then indexed far outside it (SIGSEGV);
//  - a level's downsample is level 0's "mag=" over its own: a magnification of 0 or below
//    gives a downsample under 1 and a subtile count of 0 that reads divide by (SIGFPE).
// Every directory's XMLPacket and ImageDescription is looked at: a superset of OpenSlide's.
Result checkVentana(TIFF* tif, const std::string& name) {
    const auto refuse = [&](const std::string& why) {
        return Result(Status::CorruptData, "Cannot open '" + name + "' (Ventana): " + why);
    };
    int dirs = 0;
    do {
        uint32_t count = 0;
        const void* data = nullptr;
        if (TIFFGetField(tif, TIFFTAG_XMLPACKET, &count, &data) && data && count) {
            const pugi::xml_document doc = parseXml(static_cast<const char*>(data), count);
            for (pugi::xpath_node x : doc.select_nodes("//*[local-name()='ImageInfo']")) {
                const pugi::xml_node info = x.node();
                const auto scanned = parseInt(info.attribute("AOIScanned").as_string(nullptr));
                if (!scanned || *scanned == 0) continue;
                const auto cols = parseInt(info.attribute("NumCols").as_string(nullptr));
                const auto rows = parseInt(info.attribute("NumRows").as_string(nullptr));
                if (!cols || !rows) continue; // OpenSlide refuses the file itself
                if (*cols < 1 || *rows < 1 || *cols > kMaxVentanaAreaTiles || *rows > kMaxVentanaAreaTiles ||
                    *cols * *rows > kMaxVentanaAreaTiles) {
                    return refuse("a scan area states " + std::to_string(*cols) + " x " + std::to_string(*rows) +
                                  " tiles");
                }
            }
        }
        const char* desc = nullptr;
        if (TIFFGetField(tif, TIFFTAG_IMAGEDESCRIPTION, &desc) && desc && std::strstr(desc, "level=")) {
            // OpenSlide splits the description at spaces into key=value pairs.
            const std::string_view d = desc;
            size_t at = 0;
            while (at <= d.size()) {
                const size_t end = std::min(d.find(' ', at), d.size());
                const std::string_view pair = d.substr(at, end - at);
                if (pair.substr(0, 4) == "mag=") {
                    const std::string value(pair.substr(4));
                    char* stop = nullptr;
                    const double mag = std::strtod(value.c_str(), &stop);
                    if (!value.empty() && *stop == 0 && !(std::isfinite(mag) && mag > 0))
                        return refuse("a level states magnification " + value);
                }
                at = end + 1;
            }
        }
    } while (++dirs < 4096 && TIFFReadDirectory(tif));
    return {};
}

// Leica SCN (OpenSlide 3.4.1's leica reader, the XML in the first ImageDescription). For each
// brightfield image of the collection it compares the objective text of main images with
// strcmp, NULL when the element is missing (SIGSEGV), and takes the last of the image's
// z-plane-0 dimensions, reading before an empty array when there is none (SIGSEGV).
Result checkLeica(TIFF* tif, const std::string& name) {
    const char* desc = nullptr;
    if (!TIFFGetField(tif, TIFFTAG_IMAGEDESCRIPTION, &desc) || !desc) return {};
    const pugi::xml_document doc = parseXml(desc, std::strlen(desc));
    const pugi::xml_node collection = child(doc.document_element(), "collection");
    if (!collection) return {};
    const auto collW = parseInt(collection.attribute("sizeX").as_string(nullptr));
    const auto collH = parseInt(collection.attribute("sizeY").as_string(nullptr));
    int index = 0;
    for (pugi::xml_node image = collection.first_child(); image; image = image.next_sibling()) {
        if (image.type() != pugi::node_element || localName(image) != "image") continue;
        const int n = index++;
        if (textAt(image, {"scanSettings", "illuminationSettings", "illuminationSource"}) != "brightfield") continue;
        int planeZero = 0;
        for (pugi::xml_node dim = child(image, "pixels").first_child(); dim; dim = dim.next_sibling()) {
            if (dim.type() != pugi::node_element || localName(dim) != "dimension") continue;
            const pugi::xml_attribute z = dim.attribute("z");
            if (!z || std::string_view(z.value()) == "0") ++planeZero;
        }
        const auto refuse = [&](const std::string& why) {
            return Result(Status::CorruptData,
                          "Cannot open '" + name + "' (Leica): image " + std::to_string(n) + " " + why);
        };
        if (planeZero == 0) return refuse("has no dimension in z-plane 0");
        const pugi::xml_node view = child(image, "view");
        const auto x = parseInt(view.attribute("offsetX").as_string(nullptr));
        const auto y = parseInt(view.attribute("offsetY").as_string(nullptr));
        const auto w = parseInt(view.attribute("sizeX").as_string(nullptr));
        const auto h = parseInt(view.attribute("sizeY").as_string(nullptr));
        const bool macro = x == int64_t(0) && y == int64_t(0) && w && h && w == collW && h == collH;
        if (!macro && textAt(image, {"scanSettings", "objectiveSettings", "objective"}).empty())
            return refuse("states no objective");
    }
    return {};
}

// An NDPI level's JPEG header, as OpenSlide's find_bitstream_start and libjpeg see it: the
// restart interval, the MCU size, and where the entropy-coded data starts.
struct NdpiJpeg {
    uint64_t headerEnd = 0; // file offset just past the SOS segment
    uint32_t restartInterval = 0;
    uint32_t mcuW = 8, mcuH = 8;
};

// Walks the markers from `start` to SOS. Nothing when they are not markers (OpenSlide refuses
// the file itself); headerEnd past `limit` when the header runs past it.
std::optional<NdpiJpeg> readNdpiJpegHeader(std::FILE* f, uint64_t start, uint64_t limit) {
    NdpiJpeg j;
    uint32_t hMax = 1, vMax = 1;
    uint64_t pos = start;
    for (int markers = 0; markers < 1024; ++markers) {
        if (pos > limit) {
            j.headerEnd = pos;
            return j;
        }
        uint8_t m[4];
        if (fseeko(f, off_t(pos), SEEK_SET) != 0 || std::fread(m, 1, 2, f) != 2 || m[0] != 0xFF) return std::nullopt;
        if (m[1] == 0xD8) { // SOI: no segment
            pos += 2;
            continue;
        }
        if (std::fread(m + 2, 1, 2, f) != 2) return std::nullopt;
        const uint32_t len = uint32_t(m[2]) << 8 | m[3];
        if (len < 2) return std::nullopt;
        std::vector<uint8_t> seg(len - 2);
        if (!seg.empty() && std::fread(seg.data(), 1, seg.size(), f) != seg.size()) {
            j.headerEnd = pos + 2 + len; // a segment past the end of the file
            return j;
        }
        const uint8_t marker = m[1];
        const bool sof = (marker >= 0xC0 && marker <= 0xC3) || (marker >= 0xC5 && marker <= 0xC7) ||
                         (marker >= 0xC9 && marker <= 0xCB) || (marker >= 0xCD && marker <= 0xCF);
        if (sof && seg.size() >= 6) {
            const size_t comps = seg[5];
            for (size_t c = 0; c < comps && 6 + 3 * c + 1 < seg.size(); ++c) {
                hMax = std::max<uint32_t>(hMax, seg[6 + 3 * c + 1] >> 4);
                vMax = std::max<uint32_t>(vMax, seg[6 + 3 * c + 1] & 15);
            }
        } else if (marker == 0xDD && seg.size() >= 2) {
            j.restartInterval = uint32_t(seg[0]) << 8 | seg[1];
        } else if (marker == 0xDA) {
            const bool interleaved = !seg.empty() && seg[0] > 1; // libjpeg's comps_in_scan > 1
            j.mcuW = interleaved ? 8 * std::max<uint32_t>(hMax, 1) : 8;
            j.mcuH = interleaved ? 8 * std::max<uint32_t>(vMax, 1) : 8;
            j.headerEnd = pos + 2 + len;
            return j;
        }
        pos += 2 + len;
    }
    return std::nullopt;
}

// OpenSlide's fix for NDPI files over 4 GiB, whose 32-bit offsets lose their high bits: they
// are taken from the directory's own offset (openslide-decode-tifflike.c, fix_offset_ndpi).
uint64_t fixNdpiOffset(uint64_t dirOffset, uint64_t offset) {
    uint64_t result = (dirOffset & ~uint64_t(UINT32_MAX)) | (offset & UINT32_MAX);
    if (result >= dirOffset) result = std::min(result - UINT32_MAX - 1, result);
    return result;
}

// One NDPI directory's fields that OpenSlide's ndpi reader reads (first values; nothing when
// absent or unreadable).
struct NdpiDirectory {
    int index = 0;
    std::optional<double> width, height, sourceLens, focalPlane, stripOffset, stripBytes;
    std::optional<double> mcuStartMost; // the largest MCU start (tag 65426)
};

// The directories of an NDPI file as OpenSlide's own TIFF parser (tifflike) reads them, not
// libtiff, which refuses some (a level 0 pixels wide) that tifflike takes: a classic TIFF whose
// next-directory offsets are 64-bit, and whose other offsets get fixNdpiOffset.
std::vector<NdpiDirectory> readNdpiDirectories(std::FILE* f) {
    std::vector<NdpiDirectory> out;
    uint8_t head[8];
    if (fseeko(f, 0, SEEK_SET) != 0 || std::fread(head, 1, 8, f) != 8) return out;
    const bool be = head[0] == 'M';
    const auto u = [&](const uint8_t* p, int n) {
        uint64_t v = 0;
        for (int i = 0; i < n; ++i) v |= uint64_t(p[be ? n - 1 - i : i]) << (8 * i);
        return v;
    };
    if (u(head + 2, 2) != 42) return out;
    uint64_t dirOffset = u(head + 4, 4);
    std::vector<uint64_t> seen;
    while (dirOffset != 0 && out.size() < 4096 && std::find(seen.begin(), seen.end(), dirOffset) == seen.end()) {
        seen.push_back(dirOffset);
        uint8_t cnt[2];
        if (fseeko(f, off_t(dirOffset), SEEK_SET) != 0 || std::fread(cnt, 1, 2, f) != 2) break;
        const size_t entries = size_t(u(cnt, 2));
        std::vector<uint8_t> raw(entries * 12 + 8);
        if (std::fread(raw.data(), 1, raw.size(), f) != raw.size()) break;
        NdpiDirectory d;
        d.index = int(out.size());
        const auto values = [&](const uint8_t* e, std::optional<double>* first, std::optional<double>* most) {
            const uint64_t type = u(e + 2, 2), count = u(e + 4, 4);
            static constexpr int kSize[] = {0, 1, 1, 2, 4, 8, 1, 1, 2, 4, 8, 4, 8, 4, 0, 0, 8, 8, 8};
            const int size = type < std::size(kSize) ? kSize[type] : 0;
            if (size == 0 || count == 0 || count > (uint64_t(1) << 24)) return;
            std::vector<uint8_t> bytes(size_t(count) * size_t(size));
            if (bytes.size() <= 4) {
                std::memcpy(bytes.data(), e + 8, bytes.size());
            } else {
                const uint64_t at = fixNdpiOffset(dirOffset, u(e + 8, 4));
                const off_t resume = ftello(f);
                const bool ok = fseeko(f, off_t(at), SEEK_SET) == 0 && std::fread(bytes.data(), 1, bytes.size(), f) == bytes.size();
                fseeko(f, resume, SEEK_SET);
                if (!ok) return;
            }
            for (uint64_t i = 0; i < count; ++i) {
                const uint8_t* p = bytes.data() + i * size_t(size);
                double v = 0;
                switch (type) {
                case 6: v = double(int8_t(p[0])); break;
                case 8: v = double(int16_t(u(p, 2))); break;
                case 9: v = double(int32_t(u(p, 4))); break;
                case 11: { const uint32_t b = uint32_t(u(p, 4)); float x; std::memcpy(&x, &b, 4); v = x; break; }
                case 12: { const uint64_t b = u(p, 8); double x; std::memcpy(&x, &b, 8); v = x; break; }
                case 17: v = double(int64_t(u(p, 8))); break;
                default: v = double(u(p, size)); break;
                }
                if (i == 0 && first) *first = v;
                if (most) *most = std::max(most->value_or(v), v);
                if (!most) break;
            }
        };
        for (size_t i = 0; i < entries; ++i) {
            const uint8_t* e = raw.data() + i * 12;
            switch (u(e, 2)) {
            case TIFFTAG_IMAGEWIDTH: values(e, &d.width, nullptr); break;
            case TIFFTAG_IMAGELENGTH: values(e, &d.height, nullptr); break;
            case TIFFTAG_STRIPOFFSETS: values(e, &d.stripOffset, nullptr); break;
            case TIFFTAG_STRIPBYTECOUNTS: values(e, &d.stripBytes, nullptr); break;
            case 65421: values(e, &d.sourceLens, nullptr); break;
            case 65424: values(e, &d.focalPlane, nullptr); break;
            case 65426: values(e, nullptr, &d.mcuStartMost); break;
            default: break;
            }
        }
        if (d.stripOffset) d.stripOffset = double(fixNdpiOffset(dirOffset, uint64_t(*d.stripOffset)));
        out.push_back(d);
        dirOffset = u(raw.data() + entries * 12, 8);
    }
    return out;
}

// Hamamatsu NDPI (OpenSlide 3.4.1's ndpi reader). Each level (source lens > 0, focal plane 0)
// is one JPEG in one strip; OpenSlide walks its header and then:
//  - divides the level's width and height by the tile size (the whole level when the JPEG has
//    no restart markers): a level of 0 pixels is a division by zero (SIGFPE);
//  - counts tiles in 32 bits and allocates them with g_new: a product past 2^31 aborts in GLib;
//  - decodes a level without restart markers as one tile of w * h * 4 bytes counted in 32
//    bits: past 2^31 the buffer is too small (SIGSEGV);
//  - scans for restart markers from the end of the header up to the strip's end: a strip
//    shorter than its header (or an MCU start past the strip) overflows a stack buffer, which
//    glibc's fortify check aborts.
Result checkNdpi(const std::string& path, const std::string& name) {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) return {};
    Result out;
    for (const NdpiDirectory& d : readNdpiDirectories(f)) {
        if (!d.sourceLens || !(*d.sourceLens > 0) || !d.focalPlane || *d.focalPlane != 0) continue; // not a level
        if (!d.width || !d.height || !d.stripOffset || !d.stripBytes) continue; // OpenSlide refuses it itself
        const std::string where = "directory " + std::to_string(d.index);
        const auto refuse = [&](const std::string& why) {
            return Result(Status::CorruptData, "Cannot open '" + name + "' (Hamamatsu NDPI): " + where + " " + why);
        };
        const uint64_t w = uint64_t(std::max(0.0, *d.width)), h = uint64_t(std::max(0.0, *d.height));
        if (w == 0 || h == 0) {
            out = refuse("is a level of " + std::to_string(w) + "x" + std::to_string(h) + " pixels");
            break;
        }
        const uint64_t start = uint64_t(*d.stripOffset), bytes = uint64_t(*d.stripBytes);
        const std::optional<NdpiJpeg> jpeg = readNdpiJpegHeader(f, start, start + bytes);
        if (!jpeg) continue; // not a JPEG: OpenSlide refuses it itself
        if (jpeg->headerEnd > start + bytes) {
            out = refuse("has a JPEG header longer than its strip (" + std::to_string(bytes) + " bytes)");
            break;
        }
        if (d.mcuStartMost && *d.mcuStartMost > double(bytes)) {
            out = refuse("has an MCU start past its strip");
            break;
        }
        if (jpeg->restartInterval == 0) {
            if (w * h * 4 > uint64_t(INT32_MAX)) {
                out = refuse("is one JPEG of " + std::to_string(w) + "x" + std::to_string(h) +
                             " pixels without restart markers, more than OpenSlide can decode");
                break;
            }
            continue;
        }
        const uint64_t tileW = uint64_t(jpeg->mcuW) * jpeg->restartInterval, tileH = jpeg->mcuH;
        const uint64_t tiles = (w / tileW) * (h / tileH);
        if (tiles > uint64_t(1) << 27) {
            out = refuse("is " + std::to_string(tiles) + " tiles of " + std::to_string(tileW) + "x" +
                         std::to_string(tileH));
            break;
        }
    }
    std::fclose(f);
    return out;
}

} // namespace

Result checkFileForOpenSlide(const std::string& path, const std::string& name, const char** vendor) {
    *vendor = nullptr;
    std::error_code ec;
    const uint64_t fileSize = std::filesystem::file_size(path, ec);
    if (ec) {
        *vendor = openslide_detect_vendor(path.c_str());
        return {};
    }
    TIFFErrorHandler oldError = TIFFSetErrorHandler(nullptr), oldWarning = TIFFSetWarningHandler(nullptr);
    TIFF* tif = TIFFOpen(path.c_str(), "rm");
    TIFFSetErrorHandler(oldError);
    TIFFSetWarningHandler(oldWarning);
    // The layout first: OpenSlide's vendor detection parses the file's directories itself, and
    // asks for what a hostile one states (it copes when that fails, but the asking is better
    // not made).
    Result out = tif ? checkTiffLayout(tif, fileSize, name) : Result();
    if (out.ok()) {
        *vendor = openslide_detect_vendor(path.c_str());
        const std::string_view named = *vendor ? *vendor : "";
        // NDPI's fields are read as OpenSlide reads them, whether libtiff can open the file or not.
        if (named == "hamamatsu")
            out = checkNdpi(path, name);
        else if (tif && (named == "ventana" || named == "leica") && TIFFSetDirectory(tif, 0))
            out = named == "ventana" ? checkVentana(tif, name) : checkLeica(tif, name);
    }
    if (tif) TIFFClose(tif);
    return out;
}

} // namespace iris
