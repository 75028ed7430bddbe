#include "slide/jp2k_decode.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <memory>

#include <openjpeg.h>

namespace iris {

namespace {

// OpenSlide's YCbCr → RGB tables (its make-tables.c): R and B chroma rounded to integers; the
// G chroma as two 16.16 fixed-point precursors whose sum is shifted right by 16, one of them
// carrying the +0.5 of the rounding. Built with the same double expressions, in the same order,
// so that every entry is identical to OpenSlide 3.4.1's compiled tables.
struct YCbCrTables {
    std::array<int16_t, 256> rCr{};
    std::array<int32_t, 256> gCb{};
    std::array<int32_t, 256> gCr{};
    std::array<int16_t, 256> bCb{};
    YCbCrTables() {
        for (int i = 0; i < 256; ++i) {
            rCr[size_t(i)] = int16_t(std::round(1.402 * (i - 128)));
            gCb[size_t(i)] = int32_t(std::round((1 << 16) * (0.5 - 0.34414 * (i - 128))));
            gCr[size_t(i)] = int32_t(std::round((1 << 16) * -0.71414 * (i - 128)));
            bCb[size_t(i)] = int16_t(std::round(1.772 * (i - 128)));
        }
    }
};

const YCbCrTables& tables() {
    static const YCbCrTables t;
    return t;
}

inline uint8_t clamp8(int v) {
    return uint8_t(std::clamp(v, 0, 255));
}

struct CodecDeleter {
    void operator()(opj_codec_t* c) const { opj_destroy_codec(c); }
};
struct StreamDeleter {
    void operator()(opj_stream_t* s) const { opj_stream_destroy(s); }
};
struct ImageDeleter {
    void operator()(opj_image_t* i) const { opj_image_destroy(i); }
};

struct Buffer {
    const uint8_t* data;
    OPJ_SIZE_T size;
    OPJ_SIZE_T offset;
};

OPJ_SIZE_T readCallback(void* buf, OPJ_SIZE_T count, void* user) {
    auto* b = static_cast<Buffer*>(user);
    count = std::min(count, b->size - b->offset);
    if (count == 0) return OPJ_SIZE_T(-1);
    std::memcpy(buf, b->data + b->offset, count);
    b->offset += count;
    return count;
}

OPJ_OFF_T skipCallback(OPJ_OFF_T count, void* user) {
    auto* b = static_cast<Buffer*>(user);
    const OPJ_OFF_T orig = OPJ_OFF_T(b->offset);
    const OPJ_OFF_T target = std::clamp<OPJ_OFF_T>(orig + count, 0, OPJ_OFF_T(b->size));
    b->offset = OPJ_SIZE_T(target);
    if (count != 0 && target == orig) return -1;
    return target - orig;
}

OPJ_BOOL seekCallback(OPJ_OFF_T offset, void* user) {
    auto* b = static_cast<Buffer*>(user);
    if (offset < 0 || OPJ_SIZE_T(offset) > b->size) return OPJ_FALSE;
    b->offset = OPJ_SIZE_T(offset);
    return OPJ_TRUE;
}

void errorCallback(const char* msg, void* user) {
    auto* s = static_cast<std::string*>(user);
    if (s->empty() && msg) {
        *s = msg;
        while (!s->empty() && (s->back() == '\n' || s->back() == '\r' || s->back() == ' ')) s->pop_back();
    }
}

void quietCallback(const char*, void*) {}

// A codestream whose header has been read: the decoder, its stream and the image it describes.
struct Codestream {
    Buffer buf{};
    std::string err;
    std::unique_ptr<opj_stream_t, StreamDeleter> stream;
    std::unique_ptr<opj_codec_t, CodecDeleter> codec;
    std::unique_ptr<opj_image_t, ImageDeleter> image;
};

// Most J2K tiles one codestream may have. Scanners write one per TIFF tile or DICOM frame;
// OpenJPEG allocates a coding-parameter record (kilobytes) per tile as it reads the header.
constexpr uint64_t kMaxCodestreamTiles = 4096;

uint32_t be32(const uint8_t* p) {
    return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3];
}

// The image size and tiling that the SIZ marker (which follows SOC first thing in every J2K
// codestream) states, checked before OpenJPEG reads the header: it allocates for the tiles
// stated there (a 128-px-wide tile that claimed 6488192 rows in 128-row tiles took OpenJPEG
// seconds and hundreds of megabytes to refuse; found by tests/fuzz), whereas the image must be
// exactly the width × height tile that both OpenSlide and this decoder take. A codestream
// without SOC and SIZ is left for OpenJPEG to refuse.
Result checkSiz(const uint8_t* data, size_t size, int width, int height) {
    if (!data || size < 4 + 38 || data[0] != 0xFF || data[1] != 0x4F || data[2] != 0xFF || data[3] != 0x51) return {};
    const uint8_t* siz = data + 4 + 4; // past SOC, the SIZ marker, Lsiz and Rsiz
    const uint32_t x1 = be32(siz), y1 = be32(siz + 4);
    const uint32_t tileW = be32(siz + 16), tileH = be32(siz + 20), tileX0 = be32(siz + 24), tileY0 = be32(siz + 28);
    if (x1 != uint32_t(width) || y1 != uint32_t(height)) {
        return Result(Status::CorruptData, "JPEG 2000 tile is " + std::to_string(x1) + "x" + std::to_string(y1) +
                                               ", expected " + std::to_string(width) + "x" + std::to_string(height));
    }
    if (tileW == 0 || tileH == 0 || tileX0 >= x1 || tileY0 >= y1) return {}; // OpenJPEG's to refuse
    const uint64_t tiles = ((uint64_t(x1) - tileX0 + tileW - 1) / tileW) * ((uint64_t(y1) - tileY0 + tileH - 1) / tileH);
    if (tiles > kMaxCodestreamTiles) {
        return Result(Status::CorruptData, "JPEG 2000 tile is divided into " + std::to_string(tiles) +
                                               " codestream tiles (at most " + std::to_string(kMaxCodestreamTiles) +
                                               " are read)");
    }
    return {};
}

Result readHeader(const uint8_t* data, size_t size, Codestream& cs) {
    if (!data || size == 0) return Result(Status::CorruptData, "empty JPEG 2000 tile");
    cs.stream.reset(opj_stream_create(size, OPJ_TRUE));
    cs.codec.reset(opj_create_decompress(OPJ_CODEC_J2K));
    if (!cs.stream || !cs.codec) return Result(Status::OutOfMemory, "cannot create an OpenJPEG decoder");
    cs.buf = Buffer{data, size, 0};
    opj_stream_set_user_data(cs.stream.get(), &cs.buf, nullptr);
    opj_stream_set_user_data_length(cs.stream.get(), size);
    opj_stream_set_read_function(cs.stream.get(), readCallback);
    opj_stream_set_skip_function(cs.stream.get(), skipCallback);
    opj_stream_set_seek_function(cs.stream.get(), seekCallback);

    opj_dparameters_t params;
    opj_set_default_decoder_parameters(&params);
    if (!opj_setup_decoder(cs.codec.get(), &params)) return Result(Status::CorruptData, "opj_setup_decoder() failed");
    opj_set_error_handler(cs.codec.get(), errorCallback, &cs.err);
    opj_set_warning_handler(cs.codec.get(), quietCallback, nullptr);
    opj_set_info_handler(cs.codec.get(), quietCallback, nullptr);

    opj_image_t* rawImage = nullptr;
    if (!opj_read_header(cs.stream.get(), cs.codec.get(), &rawImage)) {
        opj_image_destroy(rawImage);
        return Result(Status::CorruptData,
                      "OpenJPEG error: " + (cs.err.empty() ? std::string("opj_read_header() failed") : cs.err));
    }
    cs.image.reset(rawImage);
    cs.err.clear();
    return {};
}

} // namespace

Result checkJp2kForOpenSlide(const uint8_t* data, size_t size, int width, int height) {
    if (width <= 0 || height <= 0) return Result(Status::InvalidArgument, "bad JPEG 2000 tile size");
    if (Result r = checkSiz(data, size, width, height); !r.ok()) return r;
    Codestream cs;
    if (Result r = readHeader(data, size, cs); !r.ok()) return r;
    const opj_image_t& image = *cs.image;
    if (image.numcomps < 3) {
        return Result(Status::CorruptData,
                      "JPEG 2000 tile has " + std::to_string(image.numcomps) + " components, where OpenSlide reads 3");
    }
    // OpenSlide's unpack_argb samples component c at (y / (height / h_c)) · w_c + x / (width / w_c)
    // for every x < width, y < height (its fast paths are special cases of the same index).
    for (int c = 0; c < 3; ++c) {
        const opj_image_comp_t& comp = image.comps[c];
        const uint64_t subX = comp.w ? uint64_t(width) / comp.w : 0, subY = comp.h ? uint64_t(height) / comp.h : 0;
        if (subX == 0 || subY == 0 || (uint64_t(width) - 1) / subX >= comp.w ||
            (uint64_t(height) - 1) / subY >= comp.h) {
            return Result(Status::CorruptData,
                          "JPEG 2000 component " + std::to_string(c) + " is " + std::to_string(comp.w) + "x" +
                              std::to_string(comp.h) + ", which OpenSlide 3.4.1 cannot sample for a " +
                              std::to_string(width) + "x" + std::to_string(height) + " tile without reading past it");
        }
    }
    return {};
}

Result decodeJp2kRgba(const uint8_t* data, size_t size, int width, int height, Jp2kColour colour, uint8_t* dst,
                      size_t pitch) {
    if (!data || size == 0) return Result(Status::CorruptData, "empty JPEG 2000 tile");
    if (width <= 0 || height <= 0) return Result(Status::InvalidArgument, "bad JPEG 2000 tile size");
    if (Result r = checkSiz(data, size, width, height); !r.ok()) return r;
    Codestream cs;
    if (Result r = readHeader(data, size, cs); !r.ok()) return r;
    opj_image_t* const image = cs.image.get();
    std::string& err = cs.err;
    if (image->x0 != 0 || image->y0 != 0 || image->x1 != OPJ_UINT32(width) || image->y1 != OPJ_UINT32(height)) {
        return Result(Status::CorruptData, "JPEG 2000 tile is " + std::to_string(image->x1) + "x" +
                                               std::to_string(image->y1) + ", expected " + std::to_string(width) +
                                               "x" + std::to_string(height));
    }
    if (image->numcomps != 3) {
        return Result(Status::CorruptData,
                      "JPEG 2000 tile has " + std::to_string(image->numcomps) + " components, expected 3");
    }
    // Component sizes are checked before decoding: OpenSlide derives each component's
    // subsampling as width / component width, which must be at least 1.
    for (int c = 0; c < 3; ++c) {
        const opj_image_comp_t& comp = image->comps[c];
        if (comp.w == 0 || comp.h == 0 || comp.w > OPJ_UINT32(width) || comp.h > OPJ_UINT32(height)) {
            return Result(Status::CorruptData, "JPEG 2000 tile has a component of impossible size");
        }
    }
    if (!opj_decode(cs.codec.get(), cs.stream.get(), image)) { // no opj_end_decompress: OpenSlide does not ask for it
        return Result(Status::CorruptData, "OpenJPEG error: " + (err.empty() ? std::string("opj_decode() failed") : err));
    }
    for (int c = 0; c < 3; ++c) {
        const opj_image_comp_t& comp = image->comps[c];
        if (!comp.data || comp.w == 0 || comp.h == 0 || comp.w > OPJ_UINT32(width) || comp.h > OPJ_UINT32(height)) {
            return Result(Status::CorruptData, "JPEG 2000 tile decoded to no data");
        }
    }

    // OpenSlide's unpack_argb: component c of pixel (x, y) is data[(y / subY) · w_c + x / subX]
    // with subX = width / w_c (integer division), truncated to 8 bits. The index is clamped into
    // the component only for malformed sizes that OpenSlide would read past (never for a valid file).
    struct Plane {
        const OPJ_INT32* data;
        uint32_t w, h, subX, subY;
    };
    Plane planes[3];
    for (int c = 0; c < 3; ++c) {
        const opj_image_comp_t& comp = image->comps[c];
        planes[c] = {comp.data, comp.w, comp.h, uint32_t(width) / comp.w, uint32_t(height) / comp.h};
    }
    const auto sample = [&](const Plane& p, uint32_t x, uint32_t y) -> uint8_t {
        const uint32_t cx = std::min(x / p.subX, p.w - 1);
        const uint32_t cy = std::min(y / p.subY, p.h - 1);
        return uint8_t(p.data[size_t(cy) * p.w + cx]);
    };
    const YCbCrTables& t = tables();
    for (uint32_t y = 0; y < uint32_t(height); ++y) {
        uint8_t* row = dst + size_t(y) * pitch;
        for (uint32_t x = 0; x < uint32_t(width); ++x) {
            const uint8_t c0 = sample(planes[0], x, y);
            const uint8_t c1 = sample(planes[1], x, y);
            const uint8_t c2 = sample(planes[2], x, y);
            uint8_t* px = row + size_t(x) * 4;
            if (colour == Jp2kColour::YCbCr) {
                const int16_t rChroma = t.rCr[c2];
                const int16_t gChroma = int16_t((t.gCb[c1] + t.gCr[c2]) >> 16);
                const int16_t bChroma = t.bCb[c1];
                px[0] = clamp8(int(c0) + rChroma);
                px[1] = clamp8(int(c0) + gChroma);
                px[2] = clamp8(int(c0) + bChroma);
            } else {
                px[0] = c0;
                px[1] = c1;
                px[2] = c2;
            }
            px[3] = 255;
        }
    }
    return {};
}

} // namespace iris
