// libFuzzer target for the .iris reader (engine/src/slide/iris_file.cpp), see README.md.
//
// Each input is a whole file held in memory, as IrisFileSource holds its mapping. It goes
// through what opening and showing an .iris slide does:
//   ife::parse()                the whole structure, validated;
//   ife::slideInfo()            what IrisFileSource::open() builds: levels, properties
//                               (attributes), associated image names, the ICC profile;
//   ife::readTileCoefficients() the same tile as a coefficient record (the GPU's share of the
//                               decode): a header the buffer thread takes and packed blocks
//                               whose values lie within it, or an error
//   ife::readTile()             IrisFileSource::readTile(): tileStream + JPEG decode into a
//                               256×256 RGBA buffer + edge padding, for a bounded number of
//                               tiles, and requests outside the grid;
//   ife::readAssociatedImage()  IrisFileSource::readAssociatedImage(): JPEG / PNG decode.
// Besides the sanitizers, it checks what parse() promises the rest of the engine (every
// stream inside the buffer, the engine's tile grid equal to the file's, …) and that a
// stream that failed to decode leaves the thread's JPEG decoder usable, and aborts when a
// promise is broken.
//
// Mutations that change the length of a file first break its FILE_SIZE field; so that they
// still reach the blocks behind the header, an input whose FILE_SIZE is wrong is also read
// a second time with FILE_SIZE set to its length.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <unordered_set>
#include <vector>

#include <turbojpeg.h>

#include "fuzz_signals.h"
#include "slide/iris_file.h"
#include "slide/jpeg_coefficients.h"
#include "slide/jpeg_decode.h"

namespace {

using namespace iris;

const std::string kName = "fuzz.iris";
constexpr int kMaxTileReads = 12;                 // tile decodes per input (a JPEG decode is the slow part)
constexpr size_t kMaxImageReads = 4;              // associated images decoded per input
constexpr uint64_t kMaxImagePixels = 1ull << 22;  // 16 MiB of RGBA (the engine allows 2^28 pixels)

bool verbose() {
    static const bool v = std::getenv("IRIS_FUZZ_VERBOSE") != nullptr;
    return v;
}

[[noreturn]] void broken(const char* what, int line) {
    std::fprintf(stderr, "fuzz_iris_reader.cpp:%d: broken promise: %s\n", line, what);
    std::abort();
}
#define PROMISE(cond)                           \
    do {                                        \
        if (!(cond)) broken(#cond, __LINE__);   \
    } while (0)

// Set when a tile or image of this input failed to decode.
bool g_decodeFailed = false;

// A valid 16×16 JPEG, made once.
const std::vector<uint8_t>& referenceJpeg() {
    static const std::vector<uint8_t> jpeg = [] {
        std::vector<uint8_t> px(16 * 16 * 3);
        for (size_t i = 0; i < px.size(); ++i) px[i] = uint8_t(i * 7);
        tjhandle tj = tjInitCompress();
        unsigned char* out = nullptr;
        unsigned long size = 0;
        if (!tj || tjCompress2(tj, px.data(), 16, 0, 16, TJPF_RGB, &out, &size, TJSAMP_420, 75, 0) != 0) std::abort();
        std::vector<uint8_t> v(out, out + size);
        tjFree(out);
        tjDestroy(tj);
        return v;
    }();
    return jpeg;
}

// Loader threads decode tile after tile with one decompressor each: a stream that failed
// must not make the next, valid one fail.
void checkDecoderUsable() {
    const std::vector<uint8_t>& jpeg = referenceJpeg();
    std::vector<uint8_t> px(16 * 16 * 4);
    const Result r = decodeJpegRgba(jpeg.data(), jpeg.size(), 16, 16, px.data(), 16 * 4);
    if (!r.ok()) std::fprintf(stderr, "a valid JPEG after a failed one: %s\n", r.message().c_str());
    PROMISE(r.ok());
}

bool isReadError(const Result& r) {
    return r.status() == Status::CorruptData || r.status() == Status::UnsupportedFormat;
}

uint64_t loadLE(const uint8_t* p, int bytes) {
    uint64_t v = 0;
    for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | p[i];
    return v;
}

// What parse() promises about a layout it returns for `size` bytes.
void checkLayout(const uint8_t* data, uint64_t size, const ife::Layout& L) {
    PROMISE(!L.layers.empty() && L.layers.size() <= size_t(ife::kMaxLayers));
    PROMISE(L.major == 1);
    PROMISE(L.tileLength == 256);
    PROMISE(L.encoding == ife::kEncodingJpeg || L.encoding == ife::kEncodingAvif);
    PROMISE(L.tileStride >= 8);
    PROMISE(L.tileEntries <= size && L.tileCount <= (size - L.tileEntries) / L.tileStride);
    uint64_t firstTile = 0;
    for (size_t i = 0; i < L.layers.size(); ++i) {
        const ife::Layer& l = L.layers[i];
        PROMISE(l.xTiles > 0 && l.yTiles > 0);
        PROMISE(l.firstTile == firstTile);
        firstTile += uint64_t(l.xTiles) * l.yTiles;
        // The true size lies inside the tile grid: no tile of the grid is empty, none is missing.
        PROMISE(l.width > int64_t(l.xTiles - 1) * 256 && l.width <= int64_t(l.xTiles) * 256);
        PROMISE(l.height > int64_t(l.yTiles - 1) * 256 && l.height <= int64_t(l.yTiles) * 256);
        PROMISE(l.downsample >= 1);
        if (i > 0) PROMISE(l.scale > L.layers[i - 1].scale);
        for (uint32_t y = 0; y < l.yTiles; ++y) {
            for (uint32_t x = 0; x < l.xTiles; ++x) {
                const ife::TileStream s = ife::tileStream(data, L, i, x, y);
                PROMISE(s.size == 0 || (s.offset <= size && s.size <= size - s.offset));
            }
        }
    }
    PROMISE(firstTile == L.tileCount);
    PROMISE(L.width == L.layers.back().width && L.height == L.layers.back().height);
    std::unordered_set<std::string> names;
    for (const ife::AssociatedImage& img : L.images) {
        PROMISE(img.offset <= size && img.size <= size - img.offset);
        PROMISE(!img.name.empty());
        PROMISE(names.insert(img.name).second);
    }
    if (L.hasIcc) PROMISE(L.iccOffset <= size && L.iccSize <= size - L.iccOffset);
    for (const auto& kv : L.attributes) PROMISE(!kv.first.empty());
}

// What IrisFileSource::open() hands to the engine.
void checkInfo(const ife::Layout& L, const SlideInfo& info) {
    PROMISE(info.levels.size() == L.layers.size());
    for (size_t level = 0; level < info.levels.size(); ++level) {
        const LevelInfo& li = info.levels[level];
        const ife::Layer& l = L.layers[L.layers.size() - 1 - level];
        // The engine asks for the tiles of its own grid; readTile() checks against the file's.
        PROMISE(li.tilesX == int64_t(l.xTiles) && li.tilesY == int64_t(l.yTiles));
        PROMISE(li.width == l.width && li.height == l.height);
    }
    PROMISE(info.levels.front().downsample == 1.0);
    PROMISE(info.width == L.width && info.height == L.height);
    PROMISE(info.iccProfile.size() == (L.hasIcc ? L.iccSize : 0));
    PROMISE(info.associatedImages.size() == L.images.size());
    for (size_t i = 1; i < info.properties.size(); ++i) {
        PROMISE(info.properties[i - 1].first < info.properties[i].first); // sorted, unique
    }
}

void readTiles(const uint8_t* data, const ife::Layout& L, const SlideInfo& info) {
    // One tile and a guard band: libjpeg-turbo is not instrumented, so ASan would not see
    // it write past the tile; the band does.
    constexpr size_t kGuard = 4096;
    std::vector<uint8_t> buffer(kTileBytes + kGuard, 0xA5);
    uint8_t* const tile = buffer.data();
    auto guardIntact = [&] {
        return std::all_of(buffer.begin() + kTileBytes, buffer.end(), [](uint8_t b) { return b == 0xA5; });
    };
    int reads = 0;
    // Coarsest level first (the fewest tiles), each row-major, until the budget is spent.
    for (int level = int(info.levels.size()) - 1; level >= 0 && reads < kMaxTileReads; --level) {
        const LevelInfo& li = info.levels[size_t(level)];
        for (int64_t ty = 0; ty < li.tilesY && reads < kMaxTileReads; ++ty) {
            for (int64_t tx = 0; tx < li.tilesX && reads < kMaxTileReads; ++tx, ++reads) {
                const Result r = ife::readTile(data, L, kName, level, tx, ty, tile);
                PROMISE(r.ok() || isReadError(r));
                if (r.status() == Status::CorruptData) g_decodeFailed = true;
                PROMISE(guardIntact());
                if (verbose() && !r.ok()) std::fprintf(stderr, "  %s\n", r.message().c_str());
                // The same tile as a coefficient record (the GPU's share of the decode): a record
                // the buffer thread takes, with the level's valid part, or an error.
                if (ife::readTileCoefficients(ife::Bytes{data, -1, kName}, L, level, tx, ty, tile).ok()) {
                    JpegCoefficients h;
                    uint32_t vw = 0, vh = 0;
                    PROMISE(jpegrecord::header(tile, h, vw, vh));
                    PROMISE(jpegblocks::valid(reinterpret_cast<const uint32_t*>(tile) + jpegrecord::kBlocksWord, h.blockCount(), h.packedWords));
                    PROMISE(int64_t(vw) == std::min<int64_t>(kTileSize, li.width - tx * kTileSize));
                    PROMISE(int64_t(vh) == std::min<int64_t>(kTileSize, li.height - ty * kTileSize));
                }
                PROMISE(guardIntact());
            }
        }
    }
    // Requests outside the grid are refused before anything is read.
    const int levels = int(info.levels.size());
    const LevelInfo& finest = info.levels.front();
    PROMISE(ife::readTile(data, L, kName, -1, 0, 0, tile).status() == Status::InvalidArgument);
    PROMISE(ife::readTile(data, L, kName, levels, 0, 0, tile).status() == Status::InvalidArgument);
    PROMISE(ife::readTile(data, L, kName, 0, finest.tilesX, 0, tile).status() == Status::InvalidArgument);
    PROMISE(ife::readTile(data, L, kName, 0, 0, finest.tilesY, tile).status() == Status::InvalidArgument);
    PROMISE(ife::readTile(data, L, kName, 0, -1, 0, tile).status() == Status::InvalidArgument);
}

void readImages(const uint8_t* data, const ife::Layout& L, const SlideInfo& info) {
    for (size_t i = 0; i < std::min(kMaxImageReads, info.associatedImages.size()); ++i) {
        const std::string& name = info.associatedImages[i];
        Expected<Image> img = ife::readAssociatedImage(data, L, kName, name, kMaxImagePixels);
        if (img) {
            PROMISE(img->width > 0 && img->height > 0);
            PROMISE(uint64_t(img->width) * img->height <= kMaxImagePixels);
            PROMISE(img->rgba.size() == size_t(img->width) * img->height * 4);
        } else {
            PROMISE(isReadError(img.error()));
            if (img.error().status() == Status::CorruptData) g_decodeFailed = true;
            if (verbose()) std::fprintf(stderr, "  %s\n", img.error().message().c_str());
        }
    }
    const std::string missing = "no such image \x7f";
    if (std::find(info.associatedImages.begin(), info.associatedImages.end(), missing) == info.associatedImages.end()) {
        PROMISE(ife::readAssociatedImage(data, L, kName, missing, kMaxImagePixels).error().status() ==
                Status::InvalidArgument);
    }
}

void readFile(const uint8_t* data, uint64_t size) {
    Expected<ife::Layout> layout = ife::parse(data, size, kName);
    if (!layout) {
        const Result& e = layout.error();
        PROMISE(isReadError(e));
        PROMISE(e.message().rfind("Cannot open '" + kName + "': ", 0) == 0);
        if (verbose()) std::fprintf(stderr, "%s\n", e.message().c_str());
        return;
    }
    const ife::Layout& L = *layout;
    checkLayout(data, size, L);
    const SlideInfo info = ife::slideInfo(data, L, kName);
    checkInfo(L, info);
    if (verbose()) {
        std::fprintf(stderr, "parsed: v%u.%u, %zu layers, %lldx%lld, %llu tiles, %zu attributes, %zu images, ICC %u bytes\n",
                     unsigned(L.major), unsigned(L.minor), L.layers.size(), (long long)L.width, (long long)L.height,
                     (unsigned long long)L.tileCount, L.attributes.size(), L.images.size(),
                     L.hasIcc ? unsigned(L.iccSize) : 0u);
    }
    readTiles(data, L, info);
    readImages(data, L, info);
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    g_decodeFailed = false;
    readFile(data, size);
    if (size >= 14 && std::memcmp(data, "sirI", 4) == 0 && loadLE(data + 6, 8) != size) {
        std::vector<uint8_t> fixed(data, data + size); // exactly `size` bytes, as the input
        for (int i = 0; i < 8; ++i) fixed[6 + size_t(i)] = uint8_t(uint64_t(size) >> (8 * i));
        readFile(fixed.data(), size);
    }
    if (g_decodeFailed) checkDecoderUsable();
    return 0;
}
