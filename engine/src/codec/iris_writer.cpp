#include "codec/iris_writer.h"

#include <cmath>
#include <cstring>
#include <limits>

namespace iris::ife {

namespace {

// Little-endian appends to a byte vector whose first byte lies at file offset `base`.
class Out {
public:
    Out(std::vector<uint8_t>& b, uint64_t base) : b_(b), base_(base) {}
    uint64_t offset() const { return base_ + b_.size(); }
    void put(uint64_t v, int bytes) {
        for (int i = 0; i < bytes; ++i) b_.push_back(uint8_t(v >> (8 * i)));
    }
    void u8(uint8_t v) { b_.push_back(v); }
    void u16(uint16_t v) { put(v, 2); }
    void u32(uint32_t v) { put(v, 4); }
    void u64(uint64_t v) { put(v, 8); }
    void f32(float f) {
        uint32_t bits;
        std::memcpy(&bits, &f, 4);
        put(bits, 4);
    }
    void bytes(const void* p, size_t n) {
        const auto* c = static_cast<const uint8_t*>(p);
        b_.insert(b_.end(), c, c + n);
    }
    // VALIDATION (the block's own offset) and RECOVERY; returns the block's offset.
    uint64_t blockStart(Tag tag) {
        const uint64_t at = offset();
        u64(at);
        u16(uint16_t(kRecoveryBase | tag));
        return at;
    }
    uint64_t arrayStart(Tag tag, uint16_t stride, uint32_t count) {
        const uint64_t at = blockStart(tag);
        u16(stride);
        u32(count);
        return at;
    }

private:
    std::vector<uint8_t>& b_;
    uint64_t base_;
};

Result invalid(const std::string& what) { return Result(Status::InvalidArgument, "Cannot write the .iris file: " + what); }

} // namespace

Expected<Trailer> buildTrailer(uint64_t base, const WriteInfo& info, const std::vector<PackedTile>& tiles) {
    if (info.layers.empty() || info.layers.size() > size_t(kMaxLayers)) {
        return invalid(std::to_string(info.layers.size()) + " layers (1 to " + std::to_string(kMaxLayers) + ")");
    }
    uint64_t tileCount = 0;
    for (size_t i = 0; i < info.layers.size(); ++i) {
        const WriteLayer& l = info.layers[i];
        if (l.xTiles == 0 || l.yTiles == 0) return invalid("layer " + std::to_string(i) + " has no tiles");
        if (!std::isfinite(l.scale) || !(l.scale > 0) || (i > 0 && !(l.scale > info.layers[i - 1].scale))) {
            return invalid("the layer scales must be positive and strictly increase");
        }
        tileCount += uint64_t(l.xTiles) * l.yTiles;
    }
    if (tileCount != tiles.size() || tileCount > std::numeric_limits<uint32_t>::max()) {
        return invalid(std::to_string(tiles.size()) + " tiles for layers of " + std::to_string(tileCount));
    }
    uint64_t attributeBytes = 0;
    for (const auto& [k, v] : info.attributes) {
        if (k.empty() || k.size() > 0xFFFF || v.size() > std::numeric_limits<uint32_t>::max()) {
            return invalid("attribute '" + k.substr(0, 64) + "' has a key or value of a size the format cannot hold");
        }
        attributeBytes += k.size() + v.size();
    }
    if (attributeBytes > std::numeric_limits<uint32_t>::max() ||
        info.attributes.size() > std::numeric_limits<uint32_t>::max()) {
        return invalid("the attributes exceed 4 GiB");
    }
    for (const WriteImage& img : info.images) {
        if (img.title.size() > 0xFFFF || img.bytes.size() > std::numeric_limits<uint32_t>::max()) {
            return invalid("associated image '" + img.title.substr(0, 64) + "' is too large for the format");
        }
    }
    if (info.icc.size() > std::numeric_limits<uint32_t>::max()) return invalid("the ICC profile exceeds 4 GiB");

    Trailer t;
    size_t reserve = kArrayHeader + tiles.size() * kTileEntry + kArrayHeader + info.layers.size() * kLayerEntry +
                     kTileTableSize10 + kMetadataSize10 + kByteArrayHeader + info.icc.size() + kArrayHeader +
                     kArrayHeader + info.attributes.size() * kAttributeSizeEntry + kByteArrayHeader + attributeBytes +
                     kAttributesSize;
    for (const WriteImage& img : info.images) reserve += kImageBytesHeader + img.title.size() + img.bytes.size() + kImageEntry;
    t.bytes.reserve(reserve);
    Out o(t.bytes, base);

    // TILE_OFFSETS: (u40 offset, u24 size) per tile.
    const uint64_t tileOffsets = o.arrayStart(TILE_OFFSETS, kTileEntry, uint32_t(tiles.size()));
    for (PackedTile p : tiles) o.u64(p);

    // LAYER_EXTENTS
    const uint64_t layerExtents = o.arrayStart(LAYER_EXTENTS, kLayerEntry, uint32_t(info.layers.size()));
    for (const WriteLayer& l : info.layers) {
        o.u32(l.xTiles);
        o.u32(l.yTiles);
        o.f32(l.scale);
    }

    // TILE_TABLE
    t.tileTable = o.blockStart(TILE_TABLE);
    o.u8(info.tileEncoding);
    o.u8(info.pixelFormat);
    o.u64(kNullOffset); // CIPHER: tiles are not encrypted
    o.u64(tileOffsets);
    o.u64(layerExtents);
    o.u32(info.xExtent);
    o.u32(info.yExtent);

    // METADATA: its offsets are known only once the blocks after it are placed, so it is
    // reserved here and filled at the end.
    t.metadata = o.offset();
    const size_t metadataAt = t.bytes.size();
    t.bytes.resize(t.bytes.size() + kMetadataSize10);

    uint64_t icc = kNullOffset;
    if (!info.icc.empty()) {
        icc = o.blockStart(ICC_PROFILE);
        o.u32(uint32_t(info.icc.size()));
        o.bytes(info.icc.data(), info.icc.size());
    }

    uint64_t images = kNullOffset;
    if (!info.images.empty()) {
        std::vector<uint64_t> at;
        for (const WriteImage& img : info.images) {
            at.push_back(o.blockStart(IMAGE_BYTES));
            o.u16(uint16_t(img.title.size()));
            o.u32(uint32_t(img.bytes.size()));
            o.bytes(img.title.data(), img.title.size());
            o.bytes(img.bytes.data(), img.bytes.size());
        }
        images = o.arrayStart(IMAGES, kImageEntry, uint32_t(info.images.size()));
        for (size_t i = 0; i < info.images.size(); ++i) {
            const WriteImage& img = info.images[i];
            o.u64(at[i]);
            o.u32(img.width);
            o.u32(img.height);
            o.u8(img.encoding);
            o.u8(img.format);
            o.u16(0); // ORIENTATION: 0° (f16)
        }
    }

    uint64_t attributes = kNullOffset;
    if (!info.attributes.empty()) {
        const uint64_t sizes = o.arrayStart(ATTRIBUTE_SIZES, kAttributeSizeEntry, uint32_t(info.attributes.size()));
        for (const auto& [k, v] : info.attributes) {
            o.u16(uint16_t(k.size()));
            o.u32(uint32_t(v.size()));
        }
        const uint64_t bytes = o.blockStart(ATTRIBUTE_BYTES);
        o.u32(uint32_t(attributeBytes));
        for (const auto& [k, v] : info.attributes) {
            o.bytes(k.data(), k.size());
            o.bytes(v.data(), v.size());
        }
        attributes = o.blockStart(ATTRIBUTES);
        o.u8(kMetadataI2S); // version 1.0: free text is I2S with VERSION 0
        o.u16(0);
        o.u64(sizes);
        o.u64(bytes);
    }

    // Now the METADATA block in its reserved place.
    std::vector<uint8_t> md;
    Out m(md, t.metadata);
    m.blockStart(METADATA);
    m.u16(info.codecMajor);
    m.u16(info.codecMinor);
    m.u16(info.codecBuild);
    m.u64(attributes);
    m.u64(images);
    m.u64(icc);
    m.u64(kNullOffset); // ANNOTATIONS
    m.f32(info.micronsPerPixel);
    m.f32(info.magnification);
    std::memcpy(t.bytes.data() + metadataAt, md.data(), kMetadataSize10);
    return t;
}

std::array<uint8_t, kHeaderSize> fileHeader(uint64_t fileSize, uint64_t tileTable, uint64_t metadata) {
    std::vector<uint8_t> b;
    Out o(b, 0);
    o.u32(kMagic);
    o.u16(uint16_t(kRecoveryBase | FILE_HEADER));
    o.u64(fileSize);
    o.u16(1); // EXTENSION_MAJOR
    o.u16(0); // EXTENSION_MINOR
    o.u32(0); // FILE_REVISION
    o.u64(tileTable);
    o.u64(metadata);
    std::array<uint8_t, kHeaderSize> h{};
    std::memcpy(h.data(), b.data(), kHeaderSize);
    return h;
}

} // namespace iris::ife
