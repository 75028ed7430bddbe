#include "slide/iris_file.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <unordered_set>

#include <fcntl.h>
#include <png.h>
#include <sys/stat.h>
#include <unistd.h>

#include "slide/jpeg_coefficients.h"
#include "slide/jpeg_decode.h"

namespace iris {

namespace ife {

namespace {

// ---- names for messages ----------------------------------------------------------------

const char* tagName(unsigned code) {
    static const char* const names[] = {
        nullptr,         "FILE_HEADER", "TILE_TABLE",  "CIPHER",           "METADATA",
        "ATTRIBUTES",    "LAYER_EXTENTS", "TILE_OFFSETS", "ATTRIBUTE_SIZES", "ATTRIBUTE_BYTES",
        "IMAGES",        "IMAGE_BYTES", "ICC_PROFILE", "ANNOTATIONS",      "ANNOTATION_BYTES",
        "ANNOTATION_GROUP_SIZES", "ANNOTATION_GROUP_BYTES", "CLINICAL_METADATA",
    };
    return code < std::size(names) ? names[code] : nullptr;
}

// The engine addresses at most 2^21 tiles a side (view_model.h), 2^29 pixels.
constexpr uint32_t kMaxTilesPerSide = 1u << 21;
// Bounds on what a file can make the reader hold in memory (real slides have a handful of
// associated images and at most thousands of attributes).
constexpr uint32_t kMaxImages = 1024;
constexpr uint32_t kMaxAttributes = 1u << 20;

// ---- little-endian loads (callers check bounds first) ---------------------------------

inline uint64_t loadLE(const uint8_t* p, int bytes) {
    uint64_t v = 0;
    for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | p[i];
    return v;
}

inline float loadF32(const uint8_t* p) {
    const uint32_t bits = uint32_t(loadLE(p, 4));
    float f;
    std::memcpy(&f, &bits, 4);
    return f;
}

float halfToFloat(uint16_t h) {
    const int exp = (h >> 10) & 0x1F;
    const int man = h & 0x3FF;
    float v;
    if (exp == 0) {
        v = std::ldexp(float(man), -24);
    } else if (exp == 31) {
        v = man ? std::numeric_limits<float>::quiet_NaN() : std::numeric_limits<float>::infinity();
    } else {
        v = std::ldexp(float(man + 1024), exp - 25);
    }
    return (h & 0x8000) ? -v : v;
}

// ---- text, locale-independent ----------------------------------------------------------

std::string num(uint64_t v) { return std::to_string(v); }

std::string hex16(uint16_t v) {
    static const char digits[] = "0123456789ABCDEF";
    std::string s = "0x";
    for (int shift = 12; shift >= 0; shift -= 4) s += digits[(v >> shift) & 0xF];
    return s;
}

std::string fmt(float v) {
    char buf[64];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    return r.ec == std::errc() ? std::string(buf, r.ptr) : std::string("?");
}

// ---- the validating reader ------------------------------------------------------------

class Parser {
public:
    Parser(const ByteSource& source, const std::string& name) : s_(source), n_(source.size()), name_(name) {}

    // [off, off + len) lies inside the file, without overflow.
    bool fits(uint64_t off, uint64_t len) const { return off <= n_ && len <= n_ - off; }

    uint8_t u8(uint64_t off) const { return uint8_t(le(off, 1)); }
    uint16_t u16(uint64_t off) const { return uint16_t(le(off, 2)); }
    uint32_t u24(uint64_t off) const { return uint32_t(le(off, 3)); }
    uint32_t u32(uint64_t off) const { return uint32_t(le(off, 4)); }
    uint64_t u40(uint64_t off) const { return le(off, 5); }
    uint64_t u64(uint64_t off) const { return le(off, 8); }
    float f32(uint64_t off) const {
        uint8_t b[4];
        s_.read(off, b, 4);
        return loadF32(b);
    }
    std::string str(uint64_t off, uint64_t len) const {
        std::string out(size_t(len), '\0');
        s_.read(off, out.data(), size_t(len));
        return out;
    }
    uint64_t size() const { return n_; }

    Result corrupt(const std::string& what) const {
        return Result(Status::CorruptData, "Cannot open '" + name_ + "': " + what);
    }
    Result unsupported(const std::string& what) const {
        return Result(Status::UnsupportedFormat, "Cannot open '" + name_ + "': " + what);
    }

    // A block of at least `size` bytes at `off`, referenced by `ref`: inside the file, its
    // VALIDATION equal to its own offset, its RECOVERY tag the one of `tag`.
    Result block(uint64_t off, uint64_t size, Tag tag, const std::string& ref) const {
        const std::string what = std::string("the ") + tagName(tag) + " block";
        if (off == kNullOffset) return corrupt(what + " is missing (" + ref + " is NULL_OFFSET)");
        if (!fits(off, size)) {
            return corrupt(ref + " points to byte " + num(off) + ", past the end of the file (" + num(n_) +
                           " bytes): " + what + " (" + num(size) + " bytes) does not fit");
        }
        const uint64_t validation = u64(off);
        if (validation != off) {
            return corrupt(what + " at byte " + num(off) + " (from " + ref + ") fails validation: its VALIDATION field is " +
                           num(validation) + ", not its own offset " + num(off));
        }
        const uint16_t recovery = u16(off + 8);
        const uint16_t expected = uint16_t(kRecoveryBase | tag);
        if (recovery != expected) {
            const char* found = (recovery & 0xFF00) == kRecoveryBase ? tagName(recovery & 0xFF) : nullptr;
            return corrupt("the block at byte " + num(off) + " (from " + ref + ") has recovery tag " + hex16(recovery) +
                           (found ? std::string(" (") + found + ")" : std::string(" (no block type)")) + ", expected " +
                           hex16(expected) + " for " + tagName(tag));
        }
        return {};
    }

    struct Array {
        uint64_t entries = 0; // offset of entry 0
        uint16_t stride = 0;
        uint32_t count = 0;
    };
    // An array block: header, then COUNT entries of STRIDE bytes, all inside the file.
    Result array(uint64_t off, uint64_t header, uint16_t minStride, Tag tag, const std::string& ref, Array* out) const {
        if (Result r = block(off, header, tag, ref); !r.ok()) return r;
        out->stride = u16(off + 10);
        out->count = u32(off + 12);
        out->entries = off + header;
        if (out->stride < minStride) {
            return corrupt(std::string("the ") + tagName(tag) + " array at byte " + num(off) + " has STRIDE " +
                           num(out->stride) + ", less than the " + num(minStride) + " bytes of an entry");
        }
        const uint64_t bytes = uint64_t(out->stride) * out->count; // < 2^48: no overflow
        if (!fits(out->entries, bytes)) {
            return corrupt(std::string("the ") + tagName(tag) + " array at byte " + num(off) + " (" + num(out->count) +
                           " entries of STRIDE " + num(out->stride) + " bytes) runs past the end of the file (" +
                           num(n_) + " bytes)");
        }
        return {};
    }

    // A byte-array block: header, then COUNT bytes, all inside the file.
    Result byteArray(uint64_t off, uint64_t header, Tag tag, const std::string& ref, uint64_t* bytes,
                     uint32_t* count) const {
        if (Result r = block(off, header, tag, ref); !r.ok()) return r;
        *count = u32(off + 10);
        *bytes = off + header;
        if (!fits(*bytes, *count)) {
            return corrupt(std::string("the ") + tagName(tag) + " block at byte " + num(off) + " (" + num(*count) +
                           " bytes) runs past the end of the file (" + num(n_) + " bytes)");
        }
        return {};
    }

private:
    uint64_t le(uint64_t off, int bytes) const {
        uint8_t b[8];
        s_.read(off, b, size_t(bytes));
        return loadLE(b, bytes);
    }
    const ByteSource& s_;
    uint64_t n_;
    const std::string& name_;
};

Result parseLayers(const Parser& p, uint64_t off, Layout& out) {
    Parser::Array a;
    if (Result r = p.array(off, kArrayHeader, kLayerEntry, LAYER_EXTENTS, "TILE_TABLE.LAYER_EXTENTS_OFFSET", &a); !r.ok())
        return r;
    if (a.count == 0) return p.corrupt("LAYER_EXTENTS lists no layers");
    if (a.count > uint32_t(kMaxLayers)) {
        return p.unsupported("LAYER_EXTENTS lists " + num(a.count) + " layers; at most " + num(kMaxLayers) +
                             " are supported");
    }
    uint64_t firstTile = 0;
    for (uint32_t i = 0; i < a.count; ++i) {
        const uint64_t e = a.entries + uint64_t(i) * a.stride;
        Layer l;
        l.xTiles = p.u32(e);
        l.yTiles = p.u32(e + 4);
        l.scale = p.f32(e + 8);
        const std::string layer = "layer " + num(i);
        if (l.xTiles == 0 || l.yTiles == 0) {
            return p.corrupt(layer + " is " + num(l.xTiles) + "x" + num(l.yTiles) +
                             " tiles: X_TILES and Y_TILES must be at least 1");
        }
        if (l.xTiles > kMaxTilesPerSide || l.yTiles > kMaxTilesPerSide) {
            return p.corrupt(layer + " is " + num(l.xTiles) + "x" + num(l.yTiles) + " tiles (" +
                             num(uint64_t(l.xTiles) * l.yTiles) + " tiles), beyond any slide: at most " +
                             num(kMaxTilesPerSide) + " tiles a side are supported");
        }
        if (!std::isfinite(l.scale) || !(l.scale > 0)) {
            return p.corrupt(layer + " has SCALE " + fmt(l.scale) + "; a scale must be a positive finite number");
        }
        if (i > 0 && !(l.scale > out.layers.back().scale)) {
            return p.corrupt("layer scales must strictly increase from layer 0 (the lowest resolution), but " + layer +
                             " has SCALE " + fmt(l.scale) + " after " + fmt(out.layers.back().scale));
        }
        l.firstTile = firstTile;
        firstTile += uint64_t(l.xTiles) * l.yTiles; // ≤ 64 · 2^42: no overflow
        out.layers.push_back(l);
    }
    out.tileCount = firstTile;
    return {};
}

Result parseTiles(const Parser& p, uint64_t off, uint64_t fileSize, Layout& out) {
    Parser::Array a;
    if (Result r = p.array(off, kArrayHeader, kTileEntry, TILE_OFFSETS, "TILE_TABLE.TILE_OFFSETS_OFFSET", &a); !r.ok())
        return r;
    if (a.count != out.tileCount) {
        return p.corrupt("TILE_OFFSETS holds " + num(a.count) + " entries but the layer extents need " +
                         num(out.tileCount) + " tiles");
    }
    out.tileEntries = a.entries;
    out.tileStride = a.stride;
    size_t layer = 0;
    for (uint64_t i = 0; i < out.tileCount; ++i) {
        while (i >= out.layers[layer].firstTile + uint64_t(out.layers[layer].xTiles) * out.layers[layer].yTiles) ++layer;
        const uint64_t e = a.entries + i * a.stride;
        const uint64_t offset = p.u40(e);
        const uint32_t size = p.u24(e + 5);
        if (offset == kNullTile) continue;
        if (offset + size > fileSize) { // offset < 2^40, size < 2^24: no overflow
            const Layer& l = out.layers[layer];
            const uint64_t k = i - l.firstTile;
            return p.corrupt("tile " + num(i) + " (layer " + num(layer) + ", x " + num(k % l.xTiles) + ", y " +
                             num(k / l.xTiles) + ") lies past the end of the file: bytes " + num(offset) + " to " +
                             num(offset + size) + " of a " + num(fileSize) + "-byte file");
        }
    }
    return {};
}

// Rounds a pixel size; -1 when it is not a sane number of pixels.
int64_t roundPixels(double v) {
    return (std::isfinite(v) && v >= 0 && v < 4e15) ? std::llround(v) : -1;
}

// True sizes. X_EXTENT/Y_EXTENT are the highest-resolution layer's size in the schema and
// the lowest-resolution layer's in what the reference encoder writes; whichever reading the
// tile grids allow is taken, the encoder's when both do. Every layer's size (the finest
// size divided by the layer's downsample) must then agree with its tile grid to within a
// tile, and is clamped into it so that the engine's grid is the file's.
Result deriveSizes(const Parser& p, Layout& out) {
    const int64_t tl = out.tileLength;
    auto fits = [tl](uint64_t v, uint32_t tiles) {
        return v > uint64_t(tiles - 1) * uint64_t(tl) && v <= uint64_t(tiles) * uint64_t(tl);
    };
    auto near = [tl](int64_t px, uint32_t tiles) {
        return px > 0 && std::abs((px + tl - 1) / tl - int64_t(tiles)) <= 1;
    };
    auto clampTo = [tl](int64_t v, uint32_t tiles) {
        return std::clamp<int64_t>(v, int64_t(tiles - 1) * tl + 1, int64_t(tiles) * tl);
    };
    const Layer& lo = out.layers.front();
    const Layer& hi = out.layers.back();
    const uint64_t x = out.xExtent, y = out.yExtent;
    const double hiScale = hi.scale;
    const bool multi = out.layers.size() > 1;
    const bool loFits = multi && fits(x, lo.xTiles) && fits(y, lo.yTiles);
    const bool hiFits = fits(x, hi.xTiles) && fits(y, hi.yTiles);
    int64_t loW = -1, loH = -1; // the finest size under the encoder's reading
    if (loFits) {
        loW = roundPixels(double(x) * hiScale / double(lo.scale));
        loH = roundPixels(double(y) * hiScale / double(lo.scale));
    }
    if (loFits && near(loW, hi.xTiles) && near(loH, hi.yTiles)) {
        out.extentIsLowestLayer = true;
        out.width = clampTo(loW, hi.xTiles);
        out.height = clampTo(loH, hi.yTiles);
    } else if (hiFits) {
        out.width = int64_t(x);
        out.height = int64_t(y);
    } else if (loFits) {
        return p.corrupt("the layer extents disagree: X_EXTENT x Y_EXTENT (" + num(x) + "x" + num(y) +
                         ") is the size of layer 0, whose SCALE " + fmt(lo.scale) + " and layer " +
                         num(out.layers.size() - 1) + "'s SCALE " + fmt(hi.scale) + " make layer " +
                         num(out.layers.size() - 1) + " about " + std::to_string(loW) + "x" + std::to_string(loH) +
                         " pixels, not " + num(hi.xTiles) + "x" + num(hi.yTiles) + " tiles");
    } else {
        return p.corrupt("X_EXTENT x Y_EXTENT (" + num(x) + "x" + num(y) +
                         ") fits neither the highest-resolution layer (" + num(hi.xTiles) + "x" + num(hi.yTiles) +
                         " tiles) nor the lowest-resolution layer (" + num(lo.xTiles) + "x" + num(lo.yTiles) +
                         " tiles of " + num(uint64_t(tl)) + " pixels)");
    }
    for (size_t i = 0; i < out.layers.size(); ++i) {
        Layer& l = out.layers[i];
        l.downsample = hiScale / double(l.scale);
        if (i + 1 == out.layers.size()) {
            l.width = out.width;
            l.height = out.height;
            continue;
        }
        if (i == 0 && out.extentIsLowestLayer) {
            l.width = int64_t(x);
            l.height = int64_t(y);
            continue;
        }
        const int64_t w = std::max<int64_t>(1, roundPixels(double(out.width) / l.downsample));
        const int64_t h = std::max<int64_t>(1, roundPixels(double(out.height) / l.downsample));
        if (!near(w, l.xTiles) || !near(h, l.yTiles)) {
            return p.corrupt("the layer extents disagree: layer " + num(i) + " is " + num(l.xTiles) + "x" +
                             num(l.yTiles) + " tiles, but its SCALE " + fmt(l.scale) + " makes it " +
                             std::to_string(w) + "x" + std::to_string(h) + " pixels");
        }
        l.width = clampTo(w, l.xTiles);
        l.height = clampTo(h, l.yTiles);
    }
    return {};
}

Result parseAttributes(const Parser& p, uint64_t off, Layout& out) {
    if (Result r = p.block(off, kAttributesSize, ATTRIBUTES, "METADATA.ATTRIBUTES_OFFSET"); !r.ok()) return r;
    out.hasAttributes = true;
    out.attributeFormat = p.u8(off + 10);
    out.attributeVersion = p.u16(off + 11);
    Parser::Array sizes;
    if (Result r = p.array(p.u64(off + 13), kArrayHeader, kAttributeSizeEntry, ATTRIBUTE_SIZES,
                           "ATTRIBUTES.SIZES_OFFSET", &sizes);
        !r.ok())
        return r;
    uint64_t bytesAt = 0;
    uint32_t byteCount = 0;
    if (Result r = p.byteArray(p.u64(off + 21), kByteArrayHeader, ATTRIBUTE_BYTES, "ATTRIBUTES.BYTES_OFFSET", &bytesAt,
                               &byteCount);
        !r.ok())
        return r;
    if (sizes.count > kMaxAttributes) {
        return p.unsupported("ATTRIBUTE_SIZES lists " + num(sizes.count) + " attributes; at most " +
                             num(kMaxAttributes) + " are supported");
    }
    uint64_t sum = 0; // ≤ 2^32 entries · (2^16 + 2^32): no overflow
    for (uint32_t i = 0; i < sizes.count; ++i) {
        const uint64_t e = sizes.entries + uint64_t(i) * sizes.stride;
        sum += uint64_t(p.u16(e)) + p.u32(e + 2);
    }
    if (sum != byteCount) {
        return p.corrupt("the attribute sizes add up to " + num(sum) + " bytes but ATTRIBUTE_BYTES holds " +
                         num(byteCount) + " bytes");
    }
    out.attributes.reserve(sizes.count);
    uint64_t at = bytesAt;
    for (uint32_t i = 0; i < sizes.count; ++i) {
        const uint64_t e = sizes.entries + uint64_t(i) * sizes.stride;
        const uint16_t keySize = p.u16(e);
        const uint32_t valueSize = p.u32(e + 2);
        std::string key = p.str(at, keySize);
        std::string value = p.str(at + keySize, valueSize);
        at += uint64_t(keySize) + valueSize;
        if (!key.empty()) out.attributes.emplace_back(std::move(key), std::move(value));
    }
    return {};
}

Result parseImages(const Parser& p, uint64_t off, Layout& out) {
    Parser::Array a;
    if (Result r = p.array(off, kArrayHeader, kImageEntry, IMAGES, "METADATA.IMAGES_OFFSET", &a); !r.ok()) return r;
    if (a.count > kMaxImages) {
        return p.unsupported("IMAGES lists " + num(a.count) + " associated images; at most " + num(kMaxImages) +
                             " are supported");
    }
    std::unordered_set<std::string> names;
    for (uint32_t i = 0; i < a.count; ++i) {
        const uint64_t e = a.entries + uint64_t(i) * a.stride;
        const uint64_t bo = p.u64(e);
        const std::string ref = "IMAGES entry " + num(i);
        if (Result r = p.block(bo, kImageBytesHeader, IMAGE_BYTES, ref); !r.ok()) return r;
        const uint16_t titleSize = p.u16(bo + 10);
        const uint32_t imageSize = p.u32(bo + 12);
        if (!p.fits(bo + kImageBytesHeader, uint64_t(titleSize) + imageSize)) {
            return p.corrupt("associated image " + num(i) + " (IMAGE_BYTES at byte " + num(bo) + ", " + num(titleSize) +
                             "-byte title and " + num(imageSize) + "-byte image) runs past the end of the file");
        }
        AssociatedImage img;
        img.name = p.str(bo + kImageBytesHeader, titleSize);
        img.offset = bo + kImageBytesHeader + titleSize;
        img.size = imageSize;
        img.width = p.u32(e + 8);
        img.height = p.u32(e + 12);
        img.encoding = p.u8(e + 16);
        img.format = p.u8(e + 17);
        img.orientation = halfToFloat(p.u16(e + 18));
        if (img.name.empty()) img.name = "image-" + num(i);
        // Names are how the host asks for an image: keep them unique ("label", "label-2", …).
        const std::string base = img.name;
        for (uint64_t k = 2; !names.insert(img.name).second; ++k) img.name = base + "-" + num(k);
        out.images.push_back(std::move(img));
    }
    return {};
}

Result parseAnnotations(const Parser& p, uint64_t off, Layout& out) {
    Parser::Array a;
    if (Result r = p.array(off, kAnnotationsHeader, kAnnotationEntry, ANNOTATIONS, "METADATA.ANNOTATIONS_OFFSET", &a);
        !r.ok())
        return r;
    out.hasAnnotations = true;
    out.annotationCount = a.count;
    for (uint32_t i = 0; i < a.count; ++i) {
        const uint64_t e = a.entries + uint64_t(i) * a.stride;
        uint64_t bytes = 0;
        uint32_t count = 0;
        if (Result r = p.byteArray(p.u64(e + 3), kByteArrayHeader, ANNOTATION_BYTES,
                                   "ANNOTATIONS entry " + num(i) + " BYTES_OFFSET", &bytes, &count);
            !r.ok())
            return r;
    }
    if (const uint64_t gs = p.u64(off + 16); gs != kNullOffset) {
        Parser::Array g;
        if (Result r = p.array(gs, kArrayHeader, kGroupSizeEntry, ANNOTATION_GROUP_SIZES,
                               "ANNOTATIONS.GROUP_SIZES_OFFSET", &g);
            !r.ok())
            return r;
    }
    if (const uint64_t gb = p.u64(off + 24); gb != kNullOffset) {
        uint64_t bytes = 0;
        uint32_t count = 0;
        if (Result r = p.byteArray(gb, kByteArrayHeader, ANNOTATION_GROUP_BYTES, "ANNOTATIONS.GROUP_BYTES_OFFSET",
                                   &bytes, &count);
            !r.ok())
            return r;
    }
    return {};
}

// The structure, read through `source` (a failed read gives zeros; parse() checks).
Expected<Layout> parseStructure(const ByteSource& source, const std::string& name);

} // namespace

Expected<Layout> parse(const uint8_t* data, uint64_t size, const std::string& name) {
    return parse(ByteSource::memory(data, size), name);
}

Expected<Layout> parse(const ByteSource& source, const std::string& name) {
    Expected<Layout> layout = parseStructure(source, name);
    // Whatever the structure said, bytes that could not be read (zeros instead) decide.
    if (!source.failure().ok()) return source.failure();
    return layout;
}

namespace {
constexpr uint64_t kSourceBlock = 64 * 1024;
} // namespace

ByteSource ByteSource::memory(const uint8_t* data, uint64_t size) {
    ByteSource s;
    s.data_ = data;
    s.size_ = size;
    return s;
}

ByteSource ByteSource::file(int fd, uint64_t size, std::string name) {
    ByteSource s;
    s.fd_ = fd;
    s.size_ = size;
    s.name_ = std::move(name);
    return s;
}

void ByteSource::read(uint64_t off, void* dst, size_t n) const {
    auto* out = static_cast<uint8_t*>(dst);
    if (data_) {
        std::memcpy(out, data_ + off, n);
        return;
    }
    while (n > 0) {
        const uint64_t index = off / kSourceBlock;
        auto it = blocks_.find(index);
        if (it == blocks_.end()) {
            const uint64_t start = index * kSourceBlock;
            std::vector<uint8_t> block(size_t(std::min(kSourceBlock, size_ - start)), 0);
            size_t done = 0;
            while (done < block.size()) {
                const ssize_t r = ::pread(fd_, block.data() + done, block.size() - done, off_t(start + done));
                if (r < 0 && errno == EINTR) continue;
                if (r <= 0) {
                    if (failure_.ok()) {
                        failure_ = Result(Status::IoError,
                                          "Cannot open '" + name_ + "': cannot read byte " + num(start + done) +
                                              " of its " + num(size_) + " bytes" +
                                              (r == 0 ? std::string(": the file is shorter now: it was truncated or "
                                                                    "rewritten while being opened")
                                                      : std::string(": ") + std::strerror(errno)));
                    }
                    break; // the rest of the block stays zero
                }
                done += size_t(r);
            }
            it = blocks_.emplace(index, std::move(block)).first;
        }
        const uint64_t at = off - index * kSourceBlock;
        const size_t take = size_t(std::min<uint64_t>(n, it->second.size() - at));
        std::memcpy(out, it->second.data() + at, take);
        out += take;
        off += take;
        n -= take;
    }
}

namespace {

Expected<Layout> parseStructure(const ByteSource& source, const std::string& name) {
    const uint64_t size = source.size();
    const Parser p(source, name);
    Layout out;

    // FILE_HEADER
    if (size < 4 || p.u32(0) != kMagic) {
        std::string found;
        for (uint64_t i = 0; i < std::min<uint64_t>(size, 4); ++i) {
            static const char digits[] = "0123456789abcdef";
            if (i) found += ' ';
            found += digits[p.u8(i) >> 4];
            found += digits[p.u8(i) & 15];
        }
        return p.unsupported("not an Iris file: its magic bytes are " + (found.empty() ? std::string("missing") : found) +
                             ", not 73 69 72 49 (\"sirI\")");
    }
    if (size < kHeaderSize) {
        return p.corrupt("the file is truncated: its " + num(size) + " bytes are less than the " + num(kHeaderSize) +
                         "-byte FILE_HEADER");
    }
    if (const uint16_t rec = p.u16(4); rec != (kRecoveryBase | FILE_HEADER)) {
        return p.corrupt("the FILE_HEADER's recovery tag is " + hex16(rec) + ", expected " +
                         hex16(kRecoveryBase | FILE_HEADER));
    }
    const uint64_t fileSize = p.u64(6);
    if (fileSize > size) {
        return p.corrupt("the file is truncated: FILE_SIZE says " + num(fileSize) + " bytes but only " + num(size) +
                         " are present");
    }
    if (fileSize < size) {
        return p.corrupt("FILE_SIZE says " + num(fileSize) + " bytes but the file has " + num(size) +
                         " (a damaged header, or data appended after the end)");
    }
    out.major = p.u16(14);
    out.minor = p.u16(16);
    out.revision = p.u32(18);
    if (out.major != 1) {
        return p.unsupported("it is Iris File Extension version " + num(out.major) + "." + num(out.minor) +
                             "; this reader reads version 1.x");
    }
    const bool v11 = out.minor >= 1;

    // TILE_TABLE
    const uint64_t tt = p.u64(22);
    if (Result r = p.block(tt, v11 ? kTileTableSize11 : kTileTableSize10, TILE_TABLE, "FILE_HEADER.TILE_TABLE_OFFSET");
        !r.ok())
        return r;
    out.encoding = p.u8(tt + 10);
    out.pixelFormat = p.u8(tt + 11);
    const uint64_t cipher = p.u64(tt + 12);
    const uint64_t tileOffsets = p.u64(tt + 20);
    const uint64_t layerExtents = p.u64(tt + 28);
    out.xExtent = p.u32(tt + 36);
    out.yExtent = p.u32(tt + 40);
    const uint16_t tileLength = v11 ? p.u16(tt + 44) : 0;
    out.tileLength = tileLength ? tileLength : kTileLength;
    switch (out.encoding) {
    case kEncodingJpeg:
    case kEncodingAvif: break;
    case kEncodingUndefined: return p.corrupt("TILE_TABLE.ENCODING is 0 (undefined)");
    case kEncodingIris:
        return p.unsupported("its tiles use the reserved IRIS codec (TILE_TABLE.ENCODING 1), which this reader cannot "
                             "decode");
    default: return p.unsupported("its tile encoding " + num(out.encoding) + " is unknown (1.x knows 2 JPEG and 3 AVIF)");
    }
    if (cipher != kNullOffset) {
        if (Result r = p.block(cipher, kCipherSize, CIPHER, "TILE_TABLE.CIPHER_OFFSET"); !r.ok()) return r;
        return p.unsupported("its tiles are encrypted (a CIPHER block at byte " + num(cipher) +
                             "); encrypted .iris files are not supported");
    }
    if (out.tileLength != kTileLength) {
        return p.unsupported("its TILE_LENGTH is " + num(out.tileLength) +
                             " pixels; this reader supports only 256-pixel tiles");
    }
    if (Result r = parseLayers(p, layerExtents, out); !r.ok()) return r;
    if (Result r = parseTiles(p, tileOffsets, fileSize, out); !r.ok()) return r;
    if (Result r = deriveSizes(p, out); !r.ok()) return r;

    // METADATA
    const uint64_t md = p.u64(30);
    if (Result r = p.block(md, v11 ? kMetadataSize11 : kMetadataSize10, METADATA, "FILE_HEADER.METADATA_OFFSET");
        !r.ok())
        return r;
    out.codecMajor = p.u16(md + 10);
    out.codecMinor = p.u16(md + 12);
    out.codecBuild = p.u16(md + 14);
    const uint64_t attributes = p.u64(md + 16);
    const uint64_t images = p.u64(md + 24);
    const uint64_t icc = p.u64(md + 32);
    const uint64_t annotations = p.u64(md + 40);
    out.micronsPerPixel = p.f32(md + 48);
    out.magnification = p.f32(md + 52);
    const uint64_t clinical = v11 ? p.u64(md + 56) : kNullOffset;
    out.micronsPlane = v11 ? p.f32(md + 64) : 0.0f;

    if (attributes != kNullOffset) {
        if (Result r = parseAttributes(p, attributes, out); !r.ok()) return r;
    }
    if (images != kNullOffset) {
        if (Result r = parseImages(p, images, out); !r.ok()) return r;
    }
    if (icc != kNullOffset) {
        uint64_t bytes = 0;
        if (Result r = p.byteArray(icc, kByteArrayHeader, ICC_PROFILE, "METADATA.ICC_COLOR_OFFSET", &bytes, &out.iccSize);
            !r.ok())
            return r;
        out.hasIcc = true;
        out.iccOffset = bytes;
    }
    if (annotations != kNullOffset) {
        if (Result r = parseAnnotations(p, annotations, out); !r.ok()) return r;
    }
    if (clinical != kNullOffset) {
        uint64_t bytes = 0;
        if (Result r = p.byteArray(clinical, kClinicalHeader, CLINICAL_METADATA, "METADATA.CLINICAL_OFFSET", &bytes,
                                   &out.clinicalSize);
            !r.ok())
            return r;
        out.hasClinical = true;
        out.clinicalEncoding = p.u8(clinical + 14);
    }
    return out;
}

} // namespace

TileStream tileStream(const uint8_t* data, const Layout& layout, size_t layer, uint32_t x, uint32_t y) {
    const Layer& l = layout.layers[layer];
    const uint64_t index = l.firstTile + uint64_t(y) * l.xTiles + x;
    const uint8_t* e = data + layout.tileEntries + index * layout.tileStride;
    const uint64_t offset = loadLE(e, 5);
    if (offset == kNullTile) return {};
    return TileStream{offset, uint32_t(loadLE(e + 5, 3))};
}

Expected<const uint8_t*> Bytes::at(uint64_t offset, size_t n, std::vector<uint8_t>& scratch) const {
    if (data) return data + offset; // parse() checked every offset and size against the file
    scratch.resize(n);
    size_t done = 0;
    while (done < n) {
        const ssize_t r = ::pread(fd, scratch.data() + done, n - done, off_t(offset + done));
        if (r < 0 && errno == EINTR) continue;
        if (r < 0) {
            return Result(Status::IoError, "Cannot read " + num(uint64_t(n)) + " bytes at byte " + num(offset) +
                                               " of '" + name + "': " + std::strerror(errno));
        }
        if (r == 0) {
            return Result(Status::IoError, "Cannot read " + num(uint64_t(n)) + " bytes at byte " + num(offset) +
                                               " of '" + name + "': the file ends there: it was truncated or "
                                               "rewritten while open");
        }
        done += size_t(r);
    }
    return scratch.data();
}

Expected<TileStream> tileStream(const Bytes& bytes, const Layout& layout, size_t layer, uint32_t x, uint32_t y) {
    const Layer& l = layout.layers[layer];
    const uint64_t index = l.firstTile + uint64_t(y) * l.xTiles + x;
    thread_local std::vector<uint8_t> scratch; // an entry per tile read: no allocation each time
    Expected<const uint8_t*> e = bytes.at(layout.tileEntries + index * layout.tileStride, 8, scratch);
    if (!e) return e.error();
    const uint64_t offset = loadLE(*e, 5);
    if (offset == kNullTile) return TileStream{};
    return TileStream{offset, uint32_t(loadLE(*e + 5, 3))};
}

} // namespace ife

// ---- the SlideSource ------------------------------------------------------------------

namespace {

namespace fs = std::filesystem;

// A decoded associated image may hold at most this many pixels (1 GiB of RGBA).
constexpr uint64_t kMaxImagePixels = uint64_t(1) << 28;

const char* tileEncodingName(uint8_t e) {
    switch (e) {
    case ife::kEncodingIris: return "IRIS";
    case ife::kEncodingJpeg: return "JPEG";
    case ife::kEncodingAvif: return "AVIF";
    default: return "undefined";
    }
}

const char* imageEncodingName(uint8_t e) {
    switch (e) {
    case ife::kImagePng: return "PNG";
    case ife::kImageJpeg: return "JPEG";
    case ife::kImageAvif: return "AVIF";
    default: return "undefined";
    }
}

const char* pixelFormatName(uint8_t f) {
    static const char* const names[] = {"undefined", "B8G8R8", "R8G8B8", "B8G8R8A8", "R8G8B8A8"};
    return f < std::size(names) ? names[f] : "unknown";
}

const char* metadataFormatName(uint8_t f) {
    static const char* const names[] = {"undefined", "I2S", "DICOM", "FREE_TEXT"};
    return f < std::size(names) ? names[f] : "unknown";
}

const char* clinicalEncodingName(uint8_t f) {
    static const char* const names[] = {"undefined", "HL7_V2", "FHIR_JSON", "FASTFHIR"};
    return f < std::size(names) ? names[f] : "unknown";
}

// The value a float was written as (0.499f reads back as 0.499, not 0.49900001287…).
double shortestDouble(float f) {
    char buf[64];
    const auto r = std::to_chars(buf, buf + sizeof buf, f);
    double d = f;
    if (r.ec == std::errc()) std::from_chars(buf, r.ptr, d);
    return d;
}

std::string num(uint64_t v) { return std::to_string(v); }

std::string fmtShortest(float f) {
    char buf[64];
    const auto r = std::to_chars(buf, buf + sizeof buf, f);
    return r.ec == std::errc() ? std::string(buf, r.ptr) : std::string("?");
}

SlideInfo makeInfo(const std::string& path, const ife::Layout& L) {
    SlideInfo info;
    info.path = path;
    info.vendor = "iris";
    // Engine levels: finest first.
    for (size_t i = L.layers.size(); i-- > 0;) {
        const ife::Layer& layer = L.layers[i];
        LevelInfo li;
        li.width = layer.width;
        li.height = layer.height;
        li.downsample = layer.downsample;
        fillTileGrid(li);
        info.levels.push_back(li);
    }
    info.levels.front().downsample = 1.0;
    info.width = info.levels.front().width;
    info.height = info.levels.front().height;
    const double finestScale = L.layers.back().scale;
    const double mpp = shortestDouble(L.micronsPerPixel);
    // The file holds mpp and scales as float32, so mpp at full resolution is known to float
    // precision only: give its shortest decimal at that precision (0.25, not 0.2500000037),
    // so that magnifications derived from it (10 µm / mpp = 40×) come out exact.
    if (std::isfinite(mpp) && mpp > 0) info.mppX = info.mppY = shortestDouble(float(mpp / finestScale));
    const double mag = shortestDouble(L.magnification);
    if (std::isfinite(mag) && mag > 0) info.objectivePower = shortestDouble(float(mag * finestScale));

    // Properties: the reader's own under "iris.", then the attributes as stored (the
    // reference encoder copies the source's properties, "aperio.MPP", "tiff.…", …). On a
    // clash of names the reader's own entry wins.
    auto& props = info.properties;
    props.emplace_back("iris.version", num(L.major) + "." + num(L.minor));
    props.emplace_back("iris.revision", num(L.revision));
    props.emplace_back("iris.codec-version", num(L.codecMajor) + "." + num(L.codecMinor) + "." + num(L.codecBuild));
    props.emplace_back("iris.encoding", tileEncodingName(L.encoding));
    props.emplace_back("iris.pixel-format", pixelFormatName(L.pixelFormat));
    props.emplace_back("iris.tile-length", num(L.tileLength));
    props.emplace_back("iris.extent", num(L.xExtent) + "x" + num(L.yExtent));
    props.emplace_back("iris.layer-count", num(L.layers.size()));
    for (size_t i = 0; i < L.layers.size(); ++i) {
        const std::string k = "iris.layer[" + num(i) + "].";
        props.emplace_back(k + "scale", fmtShortest(L.layers[i].scale));
        props.emplace_back(k + "tiles", num(L.layers[i].xTiles) + "x" + num(L.layers[i].yTiles));
    }
    props.emplace_back("iris.mpp", fmtShortest(L.micronsPerPixel));
    props.emplace_back("iris.magnification", fmtShortest(L.magnification));
    if (L.micronsPlane > 0) props.emplace_back("iris.microns-plane", fmtShortest(L.micronsPlane));
    if (L.hasAttributes) {
        // Version 1.0 made FREE_TEXT an alias of I2S (1); VERSION 0 marks free text.
        const bool freeText = L.attributeFormat == ife::kMetadataFreeText ||
                              (L.attributeFormat == ife::kMetadataI2S && L.attributeVersion == 0);
        props.emplace_back("iris.attributes.format", freeText ? "FREE_TEXT" : metadataFormatName(L.attributeFormat));
        props.emplace_back("iris.attributes.version", num(L.attributeVersion));
        props.emplace_back("iris.attributes.count", num(L.attributes.size()));
    }
    props.emplace_back("iris.icc-profile-bytes", num(L.hasIcc ? L.iccSize : 0));
    if (L.hasAnnotations) props.emplace_back("iris.annotation-count", num(L.annotationCount));
    if (L.hasClinical) {
        props.emplace_back("iris.clinical-metadata-bytes", num(L.clinicalSize));
        props.emplace_back("iris.clinical-metadata-encoding", clinicalEncodingName(L.clinicalEncoding));
    }
    for (const ife::AssociatedImage& img : L.images) {
        const std::string k = "iris.image[" + img.name + "].";
        props.emplace_back(k + "encoding", imageEncodingName(img.encoding));
        props.emplace_back(k + "size", num(img.width) + "x" + num(img.height));
        props.emplace_back(k + "orientation", fmtShortest(img.orientation));
        info.associatedImages.push_back(img.name);
    }
    for (const auto& kv : L.attributes) props.push_back(kv);
    // Sorted by name, first of equal names kept (the reader's own come first).
    std::stable_sort(props.begin(), props.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    props.erase(std::unique(props.begin(), props.end(), [](const auto& a, const auto& b) { return a.first == b.first; }),
                props.end());
    return info;
}

Expected<Image> decodePng(const uint8_t* data, size_t size, uint64_t maxPixels) {
    png_image png;
    std::memset(&png, 0, sizeof png);
    png.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_memory(&png, data, size)) {
        return Result(Status::CorruptData, std::string("not a valid PNG (") + png.message + ")");
    }
    if (uint64_t(png.width) * png.height > maxPixels) {
        png_image_free(&png);
        return Result(Status::CorruptData, "the PNG claims " + num(png.width) + "x" + num(png.height) + " pixels");
    }
    png.format = PNG_FORMAT_RGBA;
    Image img;
    img.width = png.width;
    img.height = png.height;
    img.rgba.resize(size_t(PNG_IMAGE_SIZE(png)));
    if (!png_image_finish_read(&png, nullptr, img.rgba.data(), 0, nullptr)) {
        return Result(Status::CorruptData, std::string("the PNG data is corrupt (") + png.message + ")");
    }
    return img;
}

// The file, open, and its size when opened: parse() reads it through a ByteSource, and the
// reader keeps it for the tile reads that follow (ife::Bytes).
struct OpenedFile {
    int fd = -1;
    uint64_t size = 0;
};

Expected<OpenedFile> openFile(const std::string& path, const std::string& name) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return Result(Status::IoError, "Cannot open '" + name + "': " + std::strerror(errno));
    struct stat st {};
    if (::fstat(fd, &st) != 0) {
        const int err = errno;
        ::close(fd);
        return Result(Status::IoError, "Cannot open '" + name + "': " + std::strerror(err));
    }
    if (!S_ISREG(st.st_mode)) {
        ::close(fd);
        return Result(Status::NotAFile, "Cannot open '" + name + "': not a regular file");
    }
    if (st.st_size <= 0) {
        ::close(fd);
        return Result(Status::UnsupportedFormat, "Cannot open '" + name + "': the file is empty");
    }
    return OpenedFile{fd, uint64_t(st.st_size)};
}

} // namespace

bool IrisFileSource::detect(const std::string& path) {
    std::string ext = fs::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (ext == ".iris") return true;
    std::ifstream in(path, std::ios::binary);
    char magic[4] = {};
    if (!in.read(magic, 4)) return false;
    return std::memcmp(magic, "sirI", 4) == 0;
}

Expected<std::unique_ptr<SlideSource>> IrisFileSource::open(const std::string& path) {
    const std::string name = fs::path(path).filename().string();
    Expected<OpenedFile> file = openFile(path, name);
    if (!file) return file.error();
    // The structure (tile table, metadata, ICC profile) is read with pread, never mapped, and
    // so are the tiles and images later (ife::Bytes): a file truncated while it is opened or
    // shown fails those reads with an IoError instead of raising SIGBUS.
    const ife::ByteSource source = ife::ByteSource::file(file->fd, file->size, name);
    Expected<ife::Layout> layout = ife::parse(source, name);
    std::optional<SlideInfo> info;
    if (layout) info = ife::slideInfo(source, *layout, path);
    if (layout && !source.failure().ok()) layout = source.failure(); // the profile's read failed
    if (!layout) {
        ::close(file->fd);
        return layout.error();
    }
    return std::unique_ptr<SlideSource>(
        new IrisFileSource(file->fd, name, std::move(layout.value()), std::move(*info)));
}

IrisFileSource::IrisFileSource(int fd, std::string fileName, ife::Layout layout, SlideInfo info)
    : fd_(fd), bytes_{nullptr, fd, fileName}, fileName_(std::move(fileName)), layout_(std::move(layout)),
      info_(std::move(info)) {}

IrisFileSource::~IrisFileSource() {
    ::close(fd_);
}

namespace ife {

SlideInfo slideInfo(const uint8_t* data, const Layout& layout, const std::string& path) {
    return slideInfo(ByteSource::memory(data, UINT64_MAX), layout, path);
}

SlideInfo slideInfo(const ByteSource& source, const Layout& layout, const std::string& path) {
    SlideInfo info = makeInfo(path, layout);
    if (layout.hasIcc && layout.iccSize > 0) {
        // parse() checked that the profile's bytes lie inside the file.
        info.iccProfile.resize(layout.iccSize);
        source.read(layout.iccOffset, info.iccProfile.data(), layout.iccSize);
    }
    fillLevelPhysics(info);
    return info;
}

Result readTile(const uint8_t* data, const Layout& layout, const std::string& name, int level, int64_t tx, int64_t ty,
                uint8_t* dst) {
    return readTile(Bytes{data, -1, name}, layout, level, tx, ty, dst);
}

namespace {
// Tile (tx, ty) of engine level `level`: its layer (the level's grid is the layer's: makeInfo),
// its stream and its valid size; what readTile and readTileCoefficients both start from.
struct LevelTile {
    size_t layer = 0;
    TileStream stream;
    int width = 0, height = 0;
};
Expected<LevelTile> levelTile(const Bytes& bytes, const Layout& layout, int level, int64_t tx, int64_t ty) {
    if (level < 0 || size_t(level) >= layout.layers.size()) return Result(Status::InvalidArgument, "no such level");
    LevelTile t;
    t.layer = layout.layers.size() - 1 - size_t(level);
    const Layer& l = layout.layers[t.layer];
    if (tx < 0 || ty < 0 || tx >= l.xTiles || ty >= l.yTiles) return Result(Status::InvalidArgument, "no such tile");
    const Expected<TileStream> stream = tileStream(bytes, layout, t.layer, uint32_t(tx), uint32_t(ty));
    if (!stream) return stream.error();
    t.stream = *stream;
    t.width = int(std::min<int64_t>(kTileSize, l.width - tx * kTileSize));
    t.height = int(std::min<int64_t>(kTileSize, l.height - ty * kTileSize));
    return t;
}
} // namespace

Result readTile(const Bytes& bytes, const Layout& layout, int level, int64_t tx, int64_t ty, uint8_t* dst) {
    const std::string& name = bytes.name;
    const Expected<LevelTile> tile = levelTile(bytes, layout, level, tx, ty);
    if (!tile) return tile.error();
    const TileStream s = tile->stream;
    if (s.size == 0) {
        std::memset(dst, 0, kTileBytes); // no data: transparent (premultiplied zero)
        return {};
    }
    auto where = [&] {
        return "tile (" + num(uint64_t(tx)) + ", " + num(uint64_t(ty)) + ") of level " + num(uint64_t(level)) +
               " (layer " + num(tile->layer) + ", " + num(s.size) + " bytes at byte " + num(s.offset) + ") of '" + name +
               "'";
    };
    if (layout.encoding == kEncodingAvif) {
        return Result(Status::UnsupportedFormat,
                      "Cannot decode " + where() + ": AVIF-encoded tiles are not supported in this build");
    }
    // One buffer per loader thread for the compressed stream (a JPEG tile: tens of KiB).
    thread_local std::vector<uint8_t> scratch;
    const Expected<const uint8_t*> data = bytes.at(s.offset, s.size, scratch);
    if (!data) return Result(data.error().status(), "Cannot read " + where() + ": " + data.error().message());
    if (Result r = decodeJpegRgba(*data, s.size, kTileSize, kTileSize, dst, size_t(kTileSize) * 4); !r.ok()) {
        return Result(r.status(), "Cannot decode " + where() + ": " + r.message());
    }
    if (tile->width < kTileSize || tile->height < kTileSize) padTileEdges(dst, tile->width, tile->height);
    return {};
}

Result readTileCoefficients(const Bytes& bytes, const Layout& layout, int level, int64_t tx, int64_t ty, uint8_t* dst) {
    if (level >= 0 && size_t(level) < layout.layers.size() && layout.encoding == kEncodingAvif)
        return Result(Status::UnsupportedFormat, "AVIF tiles");
    const Expected<LevelTile> tile = levelTile(bytes, layout, level, tx, ty);
    if (!tile) return tile.error();
    if (tile->stream.size == 0) return Result(Status::UnsupportedFormat, "a tile with no data"); // readTile: transparent
    thread_local std::vector<uint8_t> scratch;
    const Expected<const uint8_t*> data = bytes.at(tile->stream.offset, tile->stream.size, scratch);
    if (!data) return data.error();
    // As readTile's decode: the colour space the stream's markers give (TurboJPEG's guess).
    return jpegrecord::write(*data, tile->stream.size, kTileSize, kTileSize, JpegColour::Auto, tile->width, tile->height,
                             dst);
}

Expected<Image> readAssociatedImage(const uint8_t* data, const Layout& layout, const std::string& name,
                                    const std::string& image, uint64_t maxPixels) {
    return readAssociatedImage(Bytes{data, -1, name}, layout, image, maxPixels);
}

Expected<Image> readAssociatedImage(const Bytes& file, const Layout& layout, const std::string& image,
                                    uint64_t maxPixels) {
    const std::string& name = file.name;
    const auto it = std::find_if(layout.images.begin(), layout.images.end(),
                                 [&](const AssociatedImage& i) { return i.name == image; });
    if (it == layout.images.end()) {
        return Result(Status::InvalidArgument, "The slide has no associated image '" + image + "'");
    }
    std::vector<uint8_t> scratch;
    const Expected<const uint8_t*> read = file.at(it->offset, it->size, scratch);
    if (!read) {
        return Result(read.error().status(),
                      "Cannot read associated image '" + image + "' of '" + name + "': " + read.error().message());
    }
    const uint8_t* bytes = *read;
    const std::string what = "Cannot decode associated image '" + image + "' of '" + name + "': ";
    switch (it->encoding) {
    case kImageJpeg:
    case kImagePng: break;
    case kImageAvif:
        return Result(Status::UnsupportedFormat, what + "AVIF-encoded images are not supported in this build");
    default:
        return Result(Status::UnsupportedFormat, what + "its image encoding " + num(it->encoding) + " is unknown");
    }
    Expected<Image> img = it->encoding == kImageJpeg ? decodeJpegImage(bytes, it->size, maxPixels)
                                                     : decodePng(bytes, it->size, maxPixels);
    if (!img) return Result(img.error().status(), what + img.error().message());
    return img;
}

} // namespace ife

Result IrisFileSource::readTile(int level, int64_t tx, int64_t ty, uint8_t* dst) {
    return ife::readTile(bytes_, layout_, level, tx, ty, dst);
}

bool IrisFileSource::readsCoefficients(int level) const {
    return layout_.encoding != ife::kEncodingAvif && level >= 0 && size_t(level) < layout_.layers.size();
}

Result IrisFileSource::readTileCoefficients(int level, int64_t tx, int64_t ty, uint8_t* dst) {
    return ife::readTileCoefficients(bytes_, layout_, level, tx, ty, dst);
}

Expected<Image> IrisFileSource::readAssociatedImage(const std::string& name) {
    return ife::readAssociatedImage(bytes_, layout_, name, kMaxImagePixels);
}

} // namespace iris
