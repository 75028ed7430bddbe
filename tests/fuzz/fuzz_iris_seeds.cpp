// Writes small valid .iris files for fuzz_iris_reader's seed corpus:
//
//   fuzz_iris_seeds OUT_DIR
//
// iris-encode writes what an encoder writes; these files hold what it does not: every
// optional block of the format (ICC profile, annotations with groups, clinical metadata),
// PNG and JPEG associated images with clashing and empty titles, NULL tiles, two entries
// sharing a stream, entries longer than 1.0's (a newer minor version), both readings of
// X/Y_EXTENT, progressive, greyscale and 4:4:4 JPEG tiles, AVIF tiles; and a sound
// structure around streams that cannot be decoded (wrong size, truncated, headers claiming
// huge images), and an encrypted file. Layout from shared/formats/iris-file-extension.md;
// each file is checked by opening it with the reader (ife::parse, then every tile and
// image) before it is written.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <png.h>
#include <turbojpeg.h>
#include <zlib.h>

#include "slide/iris_file.h"

namespace {

using Bytes = std::vector<uint8_t>;

enum Tag : uint16_t {
    FILE_HEADER = 1, TILE_TABLE, CIPHER, METADATA, ATTRIBUTES, LAYER_EXTENTS, TILE_OFFSETS, ATTRIBUTE_SIZES,
    ATTRIBUTE_BYTES, IMAGES, IMAGE_BYTES, ICC_PROFILE, ANNOTATIONS, ANNOTATION_BYTES, ANNOTATION_GROUP_SIZES,
    ANNOTATION_GROUP_BYTES, CLINICAL_METADATA,
};
constexpr uint64_t kNull = 0xFFFFFFFFFFFFFFFFull;

[[noreturn]] void die(const std::string& what) {
    std::fprintf(stderr, "fuzz_iris_seeds: %s\n", what.c_str());
    std::exit(1);
}

struct Writer {
    Bytes b;
    uint64_t pos() const { return b.size(); }
    void put(uint64_t v, int n) {
        for (int i = 0; i < n; ++i) b.push_back(uint8_t(v >> (8 * i)));
    }
    void patch(uint64_t at, uint64_t v, int n) {
        for (int i = 0; i < n; ++i) b[at + size_t(i)] = uint8_t(v >> (8 * i));
    }
    void f32(float f) {
        uint32_t u;
        std::memcpy(&u, &f, 4);
        put(u, 4);
    }
    void bytes(const Bytes& v) { b.insert(b.end(), v.begin(), v.end()); }
    void str(const std::string& s) { b.insert(b.end(), s.begin(), s.end()); }
    void zeros(size_t n) { b.insert(b.end(), n, 0); }
    // VALIDATION and RECOVERY of a block starting here.
    uint64_t block(Tag tag) {
        const uint64_t at = pos();
        put(at, 8);
        put(0x5500u | tag, 2);
        return at;
    }
    uint64_t array(Tag tag, uint16_t stride, uint32_t count) {
        const uint64_t at = block(tag);
        put(stride, 2);
        put(count, 4);
        return at;
    }
    uint64_t byteArray(Tag tag, const Bytes& v) {
        const uint64_t at = block(tag);
        put(v.size(), 4);
        bytes(v);
        return at;
    }
};

// ---- images ------------------------------------------------------------------------------

// Seed 0: gradients (AC coefficients everywhere); others: flat 32-pixel squares, which
// compress to a few hundred bytes and keep the files small.
Bytes rgbPattern(int w, int h, int seed) {
    Bytes px(size_t(w) * h * 3);
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            uint8_t* p = &px[(size_t(y) * w + x) * 3];
            const bool on = ((x / 32 + y / 32 + seed) & 1) != 0;
            p[0] = seed == 0 ? uint8_t(x * 255 / std::max(1, w - 1)) : uint8_t(on ? 230 : 30 * seed);
            p[1] = seed == 0 ? uint8_t(y * 255 / std::max(1, h - 1)) : uint8_t(on ? 180 : 60);
            p[2] = uint8_t(on ? 200 : 40 + 20 * seed);
        }
    }
    return px;
}

Bytes jpeg(int w, int h, int seed, int subsamp, int quality, int flags = 0) {
    tjhandle tj = tjInitCompress();
    if (!tj) die("tjInitCompress failed");
    const Bytes px = rgbPattern(w, h, seed);
    unsigned char* out = nullptr;
    unsigned long size = 0;
    if (tjCompress2(tj, px.data(), w, 0, h, TJPF_RGB, &out, &size, subsamp, quality, flags) != 0) {
        die(std::string("tjCompress2: ") + tjGetErrorStr2(tj));
    }
    Bytes v(out, out + size);
    tjFree(out);
    tjDestroy(tj);
    return v;
}

Bytes pngImage(int w, int h, int seed) {
    png_image img;
    std::memset(&img, 0, sizeof img);
    img.version = PNG_IMAGE_VERSION;
    img.width = uint32_t(w);
    img.height = uint32_t(h);
    img.format = PNG_FORMAT_RGB;
    const Bytes px = rgbPattern(w, h, seed);
    png_alloc_size_t size = 0;
    if (!png_image_write_to_memory(&img, nullptr, &size, 0, px.data(), 0, nullptr)) die("PNG size");
    Bytes v(size);
    if (!png_image_write_to_memory(&img, v.data(), &size, 0, px.data(), 0, nullptr)) die("PNG write");
    v.resize(size);
    return v;
}

// A JPEG whose SOF claims width × height (its data stays the small image's).
Bytes claimJpegSize(Bytes v, uint16_t width, uint16_t height) {
    for (size_t i = 2; i + 9 < v.size(); ++i) {
        if (v[i] == 0xFF && (v[i + 1] == 0xC0 || v[i + 1] == 0xC2)) {
            v[i + 5] = uint8_t(height >> 8);
            v[i + 6] = uint8_t(height);
            v[i + 7] = uint8_t(width >> 8);
            v[i + 8] = uint8_t(width);
            return v;
        }
    }
    die("no SOF marker");
}

// A PNG whose IHDR claims width × height, with its CRC made right again.
Bytes claimPngSize(Bytes v, uint32_t width, uint32_t height) {
    if (v.size() < 33 || std::memcmp(&v[12], "IHDR", 4) != 0) die("no IHDR");
    for (int i = 0; i < 4; ++i) {
        v[16 + size_t(i)] = uint8_t(width >> (24 - 8 * i));
        v[20 + size_t(i)] = uint8_t(height >> (24 - 8 * i));
    }
    const uLong crc = crc32(0, &v[12], 17);
    for (int i = 0; i < 4; ++i) v[29 + size_t(i)] = uint8_t(crc >> (24 - 8 * i));
    return v;
}

// ---- files -------------------------------------------------------------------------------

struct LayerSpec {
    uint32_t xTiles, yTiles;
    float scale;
};

struct AssociatedSpec {
    std::string title;
    uint8_t encoding; // 1 PNG, 2 JPEG (3 AVIF and others: a few bytes, never decoded)
    int width, height;
    uint16_t orientation = 0; // f16
    bool huge = false;        // its header claims 8192 × 8192 pixels
};

struct FileSpec {
    std::string name;
    uint16_t minor = 1;
    uint8_t encoding = iris::ife::kEncodingJpeg;
    uint32_t xExtent = 0, yExtent = 0;
    std::vector<LayerSpec> layers; // lowest resolution first
    int subsamp = TJSAMP_420;
    int quality = 10;
    int jpegFlags = 0;
    bool nullTile = false;     // the last tile has no data
    bool sharedStream = false; // the first two tiles share one stream
    uint16_t extra = 0;        // bytes appended to every array entry (a newer minor version)
    std::vector<std::pair<std::string, std::string>> attributes;
    uint8_t attributeFormat = 3;
    uint16_t attributeStride = 7; // 1.0 files may have 6 (no KIND)
    std::vector<AssociatedSpec> images;
    Bytes icc;
    int annotations = 0; // with a group of them
    bool clinical = false;
    bool cipher = false;     // encrypted: parse() refuses it (UnsupportedFormat)
    bool badStreams = false; // tiles 0-3 and the images fail to decode (not parse); the rest must decode
};

Bytes write(const FileSpec& s) {
    Writer w;
    // FILE_HEADER (38 bytes): offsets and FILE_SIZE patched at the end.
    w.put(0x49726973, 4);
    w.put(0x5500u | FILE_HEADER, 2);
    w.put(0, 8);
    w.put(1, 2);
    w.put(s.minor, 2);
    w.put(7, 4); // FILE_REVISION
    w.put(0, 8);
    w.put(0, 8);

    // Tile streams, then their table.
    uint64_t tileCount = 0;
    for (const LayerSpec& l : s.layers) tileCount += uint64_t(l.xTiles) * l.yTiles;
    std::vector<std::pair<uint64_t, uint32_t>> streams;
    for (uint64_t i = 0; i < tileCount; ++i) {
        if (s.nullTile && i + 1 == tileCount) {
            streams.emplace_back(0xFFFFFFFFFFull, 0);
            continue;
        }
        if (s.sharedStream && i == 1) {
            streams.push_back(streams[0]);
            continue;
        }
        Bytes t;
        if (s.encoding == iris::ife::kEncodingAvif) {
            t = {0, 0, 0, 0x1c, 'f', 't', 'y', 'p', 'a', 'v', 'i', 'f'}; // never decoded
        } else if (s.badStreams && i == 0) {
            t = jpeg(128, 128, 1, s.subsamp, s.quality); // not 256 × 256
        } else if (s.badStreams && i == 1) {
            t = jpeg(256, 256, 0, s.subsamp, s.quality);
            t.resize(t.size() / 2); // premature end of data
        } else if (s.badStreams && i == 2) {
            t = {0xFF, 0xD8, 0xFF, 0xE0, 0, 2, 0xFF, 0xD9}; // no frame
        } else if (s.badStreams && i == 3) {
            t = {0xFF, 0xD8, 0xFF, 0xDA, 0, 8, 1, 1, 0, 0, 0x3F, 0}; // SOS before SOF: a header error
        } else {
            t = jpeg(256, 256, int(i % 5), s.subsamp, s.quality, s.jpegFlags);
        }
        streams.emplace_back(w.pos(), uint32_t(t.size()));
        w.bytes(t);
    }
    const uint64_t extents = w.array(LAYER_EXTENTS, uint16_t(12 + s.extra), uint32_t(s.layers.size()));
    for (const LayerSpec& l : s.layers) {
        w.put(l.xTiles, 4);
        w.put(l.yTiles, 4);
        w.f32(l.scale);
        w.zeros(s.extra);
    }
    const uint64_t offsets = w.array(TILE_OFFSETS, uint16_t(8 + s.extra), uint32_t(tileCount));
    for (const auto& [off, size] : streams) {
        w.put(off, 5);
        w.put(size, 3);
        w.zeros(s.extra);
    }
    const uint64_t cipher = s.cipher ? w.block(CIPHER) : kNull;
    const uint64_t table = w.block(TILE_TABLE);
    w.put(s.encoding, 1);
    w.put(2, 1); // R8G8B8
    w.put(cipher, 8);
    w.put(offsets, 8);
    w.put(extents, 8);
    w.put(s.xExtent, 4);
    w.put(s.yExtent, 4);
    if (s.minor >= 1) w.put(256, 2);

    // ATTRIBUTES: entries KEY_SIZE, VALUE_SIZE, then KIND where the stride has room.
    uint64_t attributes = kNull;
    if (!s.attributes.empty()) {
        const uint64_t sizes = w.array(ATTRIBUTE_SIZES, s.attributeStride, uint32_t(s.attributes.size()));
        Bytes all;
        for (const auto& [k, v] : s.attributes) {
            w.put(k.size(), 2);
            w.put(v.size(), 4);
            w.zeros(s.attributeStride - 6u); // KIND 0: STRING
            all.insert(all.end(), k.begin(), k.end());
            all.insert(all.end(), v.begin(), v.end());
        }
        const uint64_t bytes = w.byteArray(ATTRIBUTE_BYTES, all);
        attributes = w.block(ATTRIBUTES);
        w.put(s.attributeFormat, 1);
        w.put(s.attributeFormat == 1 ? 0 : 1, 2);
        w.put(sizes, 8);
        w.put(bytes, 8);
    }

    // IMAGES
    uint64_t images = kNull;
    if (!s.images.empty()) {
        std::vector<uint64_t> at;
        for (size_t i = 0; i < s.images.size(); ++i) {
            const AssociatedSpec& a = s.images[i];
            Bytes data;
            if (a.encoding == iris::ife::kImagePng) {
                data = pngImage(a.width, a.height, int(i));
                if (a.huge) data = claimPngSize(data, 8192, 8192);
            } else if (a.encoding == iris::ife::kImageJpeg) {
                data = jpeg(a.width, a.height, int(i), TJSAMP_420, 30);
                if (a.huge) data = claimJpegSize(data, 8192, 8192);
            } else {
                data = {0, 0, 0, 0x1c, 'f', 't', 'y', 'p', 'a', 'v', 'i', 'f'};
            }
            at.push_back(w.block(IMAGE_BYTES));
            w.put(a.title.size(), 2);
            w.put(data.size(), 4);
            w.str(a.title);
            w.bytes(data);
        }
        images = w.array(IMAGES, uint16_t(20 + s.extra), uint32_t(s.images.size()));
        for (size_t i = 0; i < s.images.size(); ++i) {
            const AssociatedSpec& a = s.images[i];
            w.put(at[i], 8);
            w.put(uint32_t(a.width), 4);
            w.put(uint32_t(a.height), 4);
            w.put(a.encoding, 1);
            w.put(2, 1);
            w.put(a.orientation, 2);
            w.zeros(s.extra);
        }
    }

    const uint64_t icc = s.icc.empty() ? kNull : w.byteArray(ICC_PROFILE, s.icc);

    // ANNOTATIONS: TEXT annotations in one group.
    uint64_t annotations = kNull;
    if (s.annotations > 0) {
        std::vector<uint64_t> at;
        for (int i = 0; i < s.annotations; ++i) {
            const std::string text = "note " + std::to_string(i);
            at.push_back(w.byteArray(ANNOTATION_BYTES, Bytes(text.begin(), text.end())));
        }
        const uint64_t groupSizes = w.array(ANNOTATION_GROUP_SIZES, 6, 1);
        const std::string group = "group";
        w.put(group.size(), 2);
        w.put(uint32_t(s.annotations), 4);
        Bytes groupBytes(group.begin(), group.end());
        for (int i = 0; i < s.annotations; ++i) {
            for (int k = 0; k < 3; ++k) groupBytes.push_back(uint8_t(i >> (8 * k))); // member IDs (u24)
        }
        const uint64_t groupAt = w.byteArray(ANNOTATION_GROUP_BYTES, groupBytes);
        annotations = w.array(ANNOTATIONS, uint16_t(39 + s.extra), uint32_t(s.annotations));
        w.put(groupSizes, 8);
        w.put(groupAt, 8);
        for (int i = 0; i < s.annotations; ++i) {
            w.put(uint32_t(i), 3);
            w.put(at[size_t(i)], 8);
            w.put(4, 1); // TEXT
            for (float f : {10.0f * i, 20.0f, 64.0f, 32.0f}) w.f32(f);
            w.put(64, 4);
            w.put(32, 4);
            w.put(i == 0 ? 0xFFFFFF : 0, 3); // PARENT_ID
            w.zeros(s.extra);
        }
    }

    uint64_t clinical = kNull;
    if (s.clinical && s.minor >= 1) {
        const std::string msg = "MSH|^~\\&|IRIS|LAB|||20240101||ORU^R01|1|P|2.5";
        clinical = w.block(CLINICAL_METADATA);
        w.put(msg.size(), 4);
        w.put(1, 1); // HL7_V2
        w.str(msg);
    }

    const uint64_t metadata = w.block(METADATA);
    w.put(1, 2);
    w.put(2, 2);
    w.put(3, 2);
    w.put(attributes, 8);
    w.put(images, 8);
    w.put(icc, 8);
    w.put(annotations, 8);
    w.f32(0.499f);
    w.f32(1.25f);
    if (s.minor >= 1) {
        w.put(clinical, 8);
        w.f32(s.clinical ? 2.5f : 0.0f);
    }

    w.patch(6, w.pos(), 8);
    w.patch(22, table, 8);
    w.patch(30, metadata, 8);
    return w.b;
}

// The reader must open the file and decode every tile and image (AVIF refused per tile),
// or refuse it as the spec says.
void check(const FileSpec& s, const Bytes& b) {
    using namespace iris;
    Expected<ife::Layout> L = ife::parse(b.data(), b.size(), s.name);
    if (s.cipher) {
        if (L || L.error().status() != Status::UnsupportedFormat) die(s.name + ": an encrypted file was not refused");
        return;
    }
    if (!L) die(s.name + ": " + L.error().message());
    const SlideInfo info = ife::slideInfo(b.data(), *L, s.name);
    Bytes tile(kTileBytes);
    for (int level = 0; level < int(info.levels.size()); ++level) {
        for (int64_t ty = 0; ty < info.levels[size_t(level)].tilesY; ++ty) {
            for (int64_t tx = 0; tx < info.levels[size_t(level)].tilesX; ++tx) {
                const Result r = ife::readTile(b.data(), *L, s.name, level, tx, ty, tile.data());
                const bool avif = s.encoding == ife::kEncodingAvif;
                // (In a bad-streams file the good tiles come after the bad ones: a decode error
                // must not stick to the thread's decompressor.)
                const bool bad = s.badStreams && level == 0 && ty * info.levels[0].tilesX + tx < 4;
                if (bad ? r.ok() : avif ? r.status() != Status::UnsupportedFormat : !r.ok()) {
                    die(s.name + ": tile (" + std::to_string(tx) + ", " + std::to_string(ty) + ") of level " +
                        std::to_string(level) + ": " + (r.ok() ? std::string("decoded") : r.message()));
                }
            }
        }
    }
    for (const std::string& name : info.associatedImages) {
        Expected<Image> img = ife::readAssociatedImage(b.data(), *L, s.name, name, 1u << 20);
        if (!img && !s.badStreams) die(s.name + ": " + img.error().message());
    }
}

std::vector<FileSpec> specs() {
    std::vector<FileSpec> v;
    {
        // Everything 1.1 has: 3 layers (extents per the schema: the finest layer's), every
        // optional block, a NULL tile, a shared stream.
        FileSpec s;
        s.name = "gen-v1.1-full.iris";
        s.layers = {{1, 1, 1}, {2, 1, 2}, {3, 2, 4}};
        s.xExtent = 600;
        s.yExtent = 400;
        s.nullTile = true;
        s.sharedStream = true;
        s.attributes = {{"aperio.MPP", "0.499"}, {"openslide.vendor", "synthetic"}, {"empty", ""},
                        {"iris.version", "shadowed"}};
        s.images = {{"label", 2, 48, 24, 0x55A0}, {"thumbnail", 1, 24, 16, 0}, {"label", 1, 8, 8, 0x59A0},
                    {"", 2, 16, 16, 0x5C38}};
        s.icc = Bytes(48, 0x42);
        s.annotations = 2;
        s.clinical = true;
        v.push_back(s);
    }
    {
        // The reference encoder's way: 1.0, X/Y_EXTENT of the lowest layer, a non-integer
        // scale, 4:2:2 tiles, I2S attributes of VERSION 0 (free text) with 6-byte entries.
        FileSpec s;
        s.name = "gen-v1.0-lowest-extent.iris";
        s.minor = 0;
        s.layers = {{1, 1, 1}, {2, 1, 2.0005f}};
        s.xExtent = 150;
        s.yExtent = 100;
        s.subsamp = TJSAMP_422;
        s.quality = 20;
        s.attributeFormat = 1;
        s.attributeStride = 6;
        s.attributes = {{"tiff.ImageDescription", "Aperio Image Library"}};
        s.images = {{"macro", 2, 64, 16, 0}};
        v.push_back(s);
    }
    {
        // A newer minor version: every array entry 5 bytes longer; progressive 4:4:4 tiles.
        FileSpec s;
        s.name = "gen-v1.3-longer-entries.iris";
        s.minor = 3;
        s.layers = {{1, 1, 1}, {2, 2, 2}};
        s.xExtent = 300;
        s.yExtent = 290;
        s.extra = 5;
        s.subsamp = TJSAMP_444;
        s.jpegFlags = TJFLAG_PROGRESSIVE;
        s.images = {{"thumbnail", 1, 12, 12, 0}};
        s.annotations = 1;
        s.icc = Bytes{0, 1, 2, 3};
        s.clinical = true;
        v.push_back(s);
    }
    {
        // One pixel, greyscale tile, no metadata blocks at all.
        FileSpec s;
        s.name = "gen-v1.1-1x1-gray.iris";
        s.layers = {{1, 1, 1}};
        s.xExtent = 1;
        s.yExtent = 1;
        s.subsamp = TJSAMP_GRAY;
        v.push_back(s);
    }
    {
        // AVIF tiles: opened, each tile refused.
        FileSpec s;
        s.name = "gen-v1.1-avif.iris";
        s.encoding = iris::ife::kEncodingAvif;
        s.layers = {{2, 1, 1}};
        s.xExtent = 400;
        s.yExtent = 200;
        s.attributes = {{"k", "v"}};
        v.push_back(s);
    }
    {
        // Structurally sound, but tiles and images that cannot be decoded: a 128 × 128
        // tile, a truncated one, one without a frame, one whose header is broken, then two
        // good ones; images claiming 8192 × 8192 pixels, AVIF and an unknown encoding.
        FileSpec s;
        s.name = "gen-v1.1-bad-streams.iris";
        s.layers = {{3, 2, 1}};
        s.xExtent = 700;
        s.yExtent = 300;
        s.badStreams = true;
        s.images = {{"label", 2, 32, 16, 0, true}, {"macro", 1, 16, 16, 0, true}, {"avif", 3, 8, 8}, {"odd", 7, 8, 8}};
        v.push_back(s);
    }
    {
        // Encrypted tiles (a CIPHER block): refused.
        FileSpec s;
        s.name = "gen-v1.1-cipher.iris";
        s.layers = {{1, 1, 1}};
        s.xExtent = 100;
        s.yExtent = 100;
        s.cipher = true;
        v.push_back(s);
    }
    return v;
}

} // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: %s OUT_DIR\n", argv[0]);
        return 2;
    }
    for (const FileSpec& s : specs()) {
        const Bytes b = write(s);
        check(s, b);
        const std::string path = std::string(argv[1]) + "/" + s.name;
        std::ofstream out(path, std::ios::binary);
        out.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
        if (!out) die("cannot write " + path);
    }
    return 0;
}
