// libFuzzer target for the direct TIFF/SVS reader (engine/src/slide/tiff_source.cpp, with
// jp2k_decode.cpp and the libtiff codecs behind it), see README.md.
//
// Each input is one whole file. TiffTileSource::tryOpen takes a path, because its metadata
// comes from OpenSlide (which opens paths only); so the input is written to a file in a
// scratch folder first (tmpfs where there is one) and opened as the format table opens it.
// Then, as showing the slide does: SlideInfo, a bounded walk of tiles on every level
// (coarsest first; first, middle and bottom-right edge tile), requests outside the grid, and
// every associated image.
//
// Besides the sanitizers it checks what the reader promises the engine and aborts when a
// promise is broken:
//   * open either succeeds or fails with UnsupportedFormat ("not mine": the next reader
//     tries) or CorruptData, and the message names the file;
//   * the SlideInfo is a pyramid the engine can use (levels of positive size, the engine's
//     tile grid, downsamples from 1 increasing, sorted unique properties) of vendor aperio or
//     generic-tiff;
//   * a tile that reads is opaque and fills the whole tile (the buffer is pre-filled with a
//     pattern whose alpha is not 255), with the edge rule of SlideSource::readTile past the
//     level's edge, and nothing is written past the tile (a guard band: libtiff, libjpeg and
//     OpenJPEG are not instrumented); reading it again gives the same pixels (the decoded
//     file-tile cache);
//   * a tile that does not read fails with CorruptData or IoError naming the file;
//   * an associated image is w × h RGBA of positive size, or an error naming the file;
//   * a level that offers coefficient records (the GPU's share of the decode) gives, for its
//     first and last tiles, a record whose header the buffer thread takes (jpegrecord::header:
//     sizes within a tile, components' blocks adding up, the valid part the level's) and whose
//     packed blocks' values all lie within it (jpegblocks::valid), or an error; nothing is
//     written past the tile buffer.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include <openslide.h>

#include "fuzz_support.h"
#include "slide/jpeg_coefficients.h"
#include "slide/tiff_source.h"

namespace {

using namespace iris;

constexpr const char* kName = "fuzz.svs";
constexpr size_t kMaxTileReads = 16; // per input: a 16-Mpx file tile takes a while to decode

const fuzz::ScratchDir& scratch() {
    static const fuzz::ScratchDir dir;
    return dir;
}

bool namesFile(const Result& r) { return fuzz::contains(r.message(), std::string("'") + kName + "'"); }

void readTiles(SlideSource& src) {
    fuzz::readTileSample(src, kMaxTileReads, [](const Result& r) { return (r.status() == Status::CorruptData || r.status() == Status::IoError) && namesFile(r); });
}

void readRecords(SlideSource& src) {
    const SlideInfo& info = src.info();
    size_t reads = 0;
    for (int level = int(info.levels.size()) - 1; level >= 0 && reads < 6; --level) {
        if (!src.readsCoefficients(level)) continue;
        const LevelInfo& li = info.levels[size_t(level)];
        const std::pair<int64_t, int64_t> tiles[2] = {{0, 0}, {li.tilesX - 1, li.tilesY - 1}};
        for (const auto& [tx, ty] : tiles) {
            std::vector<uint8_t> buf(size_t(kTileBytes) + 4096, 0xA5);
            const Result r = src.readTileCoefficients(level, tx, ty, buf.data());
            ++reads;
            for (size_t i = size_t(kTileBytes); i < buf.size(); ++i) PROMISE(buf[i] == 0xA5);
            if (!r.ok()) continue;
            JpegCoefficients h;
            uint32_t vw = 0, vh = 0;
            PROMISE(jpegrecord::header(buf.data(), h, vw, vh));
            PROMISE(jpegblocks::valid(reinterpret_cast<const uint32_t*>(buf.data()) + jpegrecord::kBlocksWord, h.blockCount(), h.packedWords));
            PROMISE(int64_t(vw) == std::min<int64_t>(kTileSize, li.width - tx * kTileSize));
            PROMISE(int64_t(vh) == std::min<int64_t>(kTileSize, li.height - ty * kTileSize));
        }
    }
}

// The size OpenSlide states for an associated image (0 × 0 when it cannot say).
std::pair<int64_t, int64_t> associatedSize(const std::string& path, const std::string& name) {
    int64_t w = 0, h = 0;
    if (openslide_t* osr = openslide_open(path.c_str())) {
        openslide_get_associated_image_dimensions(osr, name.c_str(), &w, &h);
        openslide_close(osr);
    }
    return {w, h};
}

void readImages(SlideSource& src, const std::string& path) {
    for (const std::string& name : src.info().associatedImages) {
        // An associated image past the readers' bound (kMaxAssociatedPixels) is refused before
        // anything is allocated for it (OpenSlideSource once allocated up to 16 GiB:
        // regressions/openslide-associated-image-14gib.fuzz), and the refusal names the file.
        const auto [w, h] = associatedSize(path, name);
        const bool huge = uint64_t(std::max<int64_t>(w, 0)) * uint64_t(std::max<int64_t>(h, 0)) > kMaxAssociatedPixels;
        Expected<Image> img = src.readAssociatedImage(name);
        if (huge) PROMISE(!img && img.error().status() == Status::CorruptData);
        if (img) {
            PROMISE(img->width > 0 && img->height > 0);
            PROMISE(img->rgba.size() == size_t(img->width) * img->height * 4);
        } else {
            if (fuzz::verbose() || !namesFile(img.error())) fuzz::note(name.c_str(), img.error());
            PROMISE(img.error().status() == Status::CorruptData);
            PROMISE(namesFile(img.error()));
        }
    }
    PROMISE(src.readAssociatedImage("no such image").error().status() == Status::InvalidArgument);
}

void readInput(const uint8_t* data, size_t size) {
    const std::string path = scratch().write(kName, data, size);
    if (!TiffTileSource::detect(path)) return; // the format table asks this reader only then

    auto opened = TiffTileSource::tryOpen(path);
    if (!opened) {
        const Result& e = opened.error();
        if (fuzz::verbose()) fuzz::note("open", e);
        if (!(e.status() == Status::UnsupportedFormat || e.status() == Status::CorruptData) || !namesFile(e))
            fuzz::note("open", e);
        PROMISE(e.status() == Status::UnsupportedFormat || e.status() == Status::CorruptData);
        PROMISE(namesFile(e));
        return;
    }
    SlideSource& src = **opened;
    const SlideInfo& info = src.info();
    fuzz::checkSlideInfo(info);
    PROMISE(info.vendor == "aperio" || info.vendor == "generic-tiff");
    PROMISE(info.levels.front().downsample == 1.0);
    PROMISE(info.iccProfile.size() < size);
    if (fuzz::verbose()) {
        std::fprintf(stderr, "opened: %s, %zu levels, %lldx%lld, %zu images, ICC %zu bytes\n", info.vendor.c_str(),
                     info.levels.size(), (long long)info.width, (long long)info.height, info.associatedImages.size(),
                     info.iccProfile.size());
    }
    readTiles(src);
    readRecords(src);
    readImages(src, path);
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0) return 0; // the format table opens no empty file
    readInput(data, size);
    return 0;
}
