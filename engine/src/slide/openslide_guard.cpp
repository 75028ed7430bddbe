#include "slide/openslide_guard.h"

#include <cerrno>
#include <cmath>
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

// The most tiles one Ventana scan area may state: 2^27 (a 134-Mpx grid of tiles, far beyond any
// slide; OpenSlide allocates a pointer and a record for each).
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
    errno = 0;
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

} // namespace

Result checkFileForOpenSlide(const std::string& path, const std::string& name) {
    std::error_code ec;
    const uint64_t fileSize = std::filesystem::file_size(path, ec);
    if (ec) return {};
    TIFFErrorHandler oldError = TIFFSetErrorHandler(nullptr), oldWarning = TIFFSetWarningHandler(nullptr);
    TIFF* tif = TIFFOpen(path.c_str(), "rm");
    TIFFSetErrorHandler(oldError);
    TIFFSetWarningHandler(oldWarning);
    if (!tif) return {}; // not a TIFF: OpenSlide decides
    Result out = checkTiffLayout(tif, fileSize, name);
    if (out.ok()) {
        const char* v = openslide_detect_vendor(path.c_str());
        const std::string_view vendor = v ? v : "";
        if ((vendor == "ventana" || vendor == "leica") && TIFFSetDirectory(tif, 0))
            out = vendor == "ventana" ? checkVentana(tif, name) : checkLeica(tif, name);
    }
    TIFFClose(tif);
    return out;
}

} // namespace iris
