#include "slide/jpeg_coefficients.h"

#include <csetjmp>
#include <cstdio>
#include <algorithm>
#include <cstring>
#include <new>
#include <string>

#include <jpeglib.h>

#include "slide/libjpeg_errors.h"

namespace iris {

namespace {

using ErrorManager = libjpeg::Errors;

enum Outcome { Read = 0, Corrupt = 1, Unsupported = 2 };

// Where the blocks go: the result's vector (dst null), or the caller's memory.
struct Sink {
    JpegCoefficients* out;
    int16_t* dst;
    size_t capacity;
};

int16_t* blocksFor(Sink* sink, size_t values) {
    if (sink->dst) return values <= sink->capacity ? sink->dst : nullptr;
    try {
        sink->out->blocks.resize(values);
    } catch (const std::bad_alloc&) {
        return nullptr;
    }
    return sink->out->blocks.data();
}

// The part between setjmp and the end: no C++ object with a destructor lives in this frame
// (longjmp would skip it). The blocks' vector is the caller's; blocksFor sizes it and turns a
// failed allocation into a null pointer, so no exception crosses the jump either.
int read(jpeg_decompress_struct* cinfo, ErrorManager* err, const uint8_t* data, size_t size, int width, int height,
         JpegColour colour, Sink* sink) {
    JpegCoefficients* out = sink->out;
    if (setjmp(err->jump)) return Corrupt;
    jpeg_create_decompress(cinfo);
    jpeg_mem_src(cinfo, data, static_cast<unsigned long>(size));
    if (jpeg_read_header(cinfo, TRUE) != JPEG_HEADER_OK) {
        std::snprintf(err->message, sizeof err->message, "no JPEG image in the stream");
        return Corrupt;
    }
    if (int(cinfo->image_width) != width || int(cinfo->image_height) != height) {
        std::snprintf(err->message, sizeof err->message, "the JPEG is %ux%u pixels, expected %dx%d",
                      unsigned(cinfo->image_width), unsigned(cinfo->image_height), width, height);
        return Corrupt;
    }
    if (cinfo->data_precision != 8) {
        std::snprintf(err->message, sizeof err->message, "%d-bit samples", cinfo->data_precision);
        return Unsupported;
    }
    const int n = cinfo->num_components;
    if (n != 1 && n != 3) {
        std::snprintf(err->message, sizeof err->message, "%d components", n);
        return Unsupported;
    }
    if (colour != JpegColour::Auto && n != 3) {
        std::snprintf(err->message, sizeof err->message, "the JPEG has %d components, expected 3", n);
        return Corrupt;
    }
    J_COLOR_SPACE space = cinfo->jpeg_color_space;
    if (colour == JpegColour::YCbCr) space = JCS_YCbCr;
    if (colour == JpegColour::Rgb) space = JCS_RGB;
    if (n == 1) {
        out->transform = JpegCoefficients::Transform::Grey;
    } else if (space == JCS_YCbCr) {
        out->transform = JpegCoefficients::Transform::YCbCr;
    } else if (space == JCS_RGB) {
        out->transform = JpegCoefficients::Transform::Rgb;
    } else {
        std::snprintf(err->message, sizeof err->message, "colour space %d", int(space));
        return Unsupported;
    }
    const jpeg_component_info* c = cinfo->comp_info;
    if (n == 3) {
        const bool chroma11 = c[1].h_samp_factor == 1 && c[1].v_samp_factor == 1 && c[2].h_samp_factor == 1 &&
                              c[2].v_samp_factor == 1;
        const int h = c[0].h_samp_factor, v = c[0].v_samp_factor;
        // 4:4:4, 4:2:2 and 4:2:0; libjpeg's fancy upsampling (the one the GPU repeats) needs a
        // downsampled row of more than two samples.
        const bool layout = chroma11 && ((h == 1 && v == 1) || (h == 2 && v == 1) || (h == 2 && v == 2));
        if (!layout || (h == 2 && (cinfo->image_width + 1) / 2 <= 2)) {
            std::snprintf(err->message, sizeof err->message, "sampling %dx%d,%dx%d,%dx%d", h, v, c[1].h_samp_factor,
                          c[1].v_samp_factor, c[2].h_samp_factor, c[2].v_samp_factor);
            return Unsupported;
        }
        out->hMax = uint32_t(h);
        out->vMax = uint32_t(v);
    }
    if (sink->dst) {
        // Blocks a component has (libjpeg's width_in_blocks × height_in_blocks, from the frame
        // header): a stream whose blocks will not fit the caller's room is refused before the
        // entropy decode, so that the caller's fallback does not pay for two decodes.
        int hMax = 1, vMax = 1;
        for (int ci = 0; ci < n; ++ci) {
            hMax = std::max(hMax, c[ci].h_samp_factor);
            vMax = std::max(vMax, c[ci].v_samp_factor);
        }
        size_t predicted = 0;
        for (int ci = 0; ci < n; ++ci) {
            const size_t wide = (size_t(cinfo->image_width) * c[ci].h_samp_factor + size_t(hMax) * 8 - 1) / (size_t(hMax) * 8);
            const size_t high = (size_t(cinfo->image_height) * c[ci].v_samp_factor + size_t(vMax) * 8 - 1) / (size_t(vMax) * 8);
            predicted += wide * high;
        }
        if (predicted * 64 > sink->capacity) {
            std::snprintf(err->message, sizeof err->message, "no room for %zu blocks", predicted);
            return Unsupported;
        }
    }
    jvirt_barray_ptr* arrays = jpeg_read_coefficients(cinfo);
    size_t total = 0;
    for (int ci = 0; ci < n; ++ci) {
        if (!c[ci].quant_table) {
            std::snprintf(err->message, sizeof err->message, "component %d has no quantisation table", ci);
            return Corrupt;
        }
        out->comp[ci].blocksWide = c[ci].width_in_blocks;
        out->comp[ci].blocksHigh = c[ci].height_in_blocks;
        out->comp[ci].firstBlock = uint32_t(total);
        for (int k = 0; k < 64; ++k) out->comp[ci].quant[k] = c[ci].quant_table->quantval[k];
        total += size_t(c[ci].width_in_blocks) * c[ci].height_in_blocks;
    }
    if (total > (1u << 26)) {
        std::snprintf(err->message, sizeof err->message, "%zu blocks", total);
        return Corrupt;
    }
    out->blocksTotal = uint32_t(total);
    int16_t* dst = blocksFor(sink, total * 64);
    if (!dst) {
        std::snprintf(err->message, sizeof err->message, "no room for %zu blocks", total);
        return sink->dst ? Unsupported : Corrupt; // the caller's room is too small; or no memory
    }
    for (int ci = 0; ci < n; ++ci) {
        const JDIMENSION wide = c[ci].width_in_blocks;
        for (JDIMENSION row = 0; row < c[ci].height_in_blocks; ++row) {
            JBLOCKARRAY line = (*cinfo->mem->access_virt_barray)(reinterpret_cast<j_common_ptr>(cinfo), arrays[ci],
                                                                 row, 1, FALSE);
            static_assert(sizeof(JCOEF) == sizeof(int16_t));
            std::memcpy(dst, line[0], size_t(wide) * sizeof(JBLOCK));
            dst += size_t(wide) * 64;
        }
    }
    jpeg_finish_decompress(cinfo);
    return Read;
}

} // namespace

Expected<JpegCoefficients> readJpegCoefficients(const uint8_t* data, size_t size, int width, int height,
                                                JpegColour colour) {
    return readJpegCoefficients(data, size, width, height, colour, nullptr, 0);
}

Expected<JpegCoefficients> readJpegCoefficients(const uint8_t* data, size_t size, int width, int height,
                                                JpegColour colour, int16_t* dst, size_t capacity) {
    if (!data || size == 0) return Result(Status::CorruptData, "the JPEG stream is empty");
    if (size > 0xffffffffu) return Result(Status::CorruptData, "the JPEG stream is too large");
    if (width <= 0 || height <= 0) return Result(Status::InvalidArgument, "bad size for the JPEG read");
    JpegCoefficients out;
    out.width = uint32_t(width);
    out.height = uint32_t(height);
    jpeg_decompress_struct cinfo{};
    ErrorManager err{};
    libjpeg::install(cinfo, err);
    Sink sink{&out, dst, capacity};
    const int outcome = read(&cinfo, &err, data, size, width, height, colour, &sink);
    if (outcome == Read) out.components = uint32_t(cinfo.num_components);
    jpeg_destroy_decompress(&cinfo);
    if (outcome == Corrupt) return Result(Status::CorruptData, std::string("the JPEG data is corrupt (") + err.message + ")");
    if (outcome == Unsupported)
        return Result(Status::UnsupportedFormat, std::string("the GPU JPEG path does not take ") + err.message);
    return out;
}

namespace jpegrecord {

Result write(const uint8_t* data, size_t size, int width, int height, JpegColour colour, int validWidth, int validHeight,
             uint8_t* record) {
    auto* words = reinterpret_cast<uint32_t*>(record);
    static_assert(sizeof(int16_t) * 2 == sizeof(uint32_t));
    Expected<JpegCoefficients> c = readJpegCoefficients(data, size, width, height, colour,
                                                        reinterpret_cast<int16_t*>(words + kBlocksWord), size_t(kMaxBlocks) * 64);
    if (!c) return c.error(); // too many blocks for a record: UnsupportedFormat, a layout the path does not take
    std::memset(words, 0, size_t(kBlocksWord) * 4);
    words[0] = kMagic;
    words[1] = c->width;
    words[2] = c->height;
    words[3] = uint32_t(std::clamp(validWidth, 1, width));
    words[4] = uint32_t(std::clamp(validHeight, 1, height));
    words[5] = uint32_t(c->transform);
    words[6] = c->hMax;
    words[7] = c->vMax;
    words[8] = c->components;
    words[9] = c->blockCount();
    for (uint32_t i = 0; i < c->components; ++i) {
        words[10 + 3 * i] = c->comp[i].blocksWide;
        words[11 + 3 * i] = c->comp[i].blocksHigh;
        words[12 + 3 * i] = c->comp[i].firstBlock;
        for (int q = 0; q < 64; ++q) words[kQuantWord + 64 * i + q] = c->comp[i].quant[q];
    }
    return {};
}

bool header(const uint8_t* record, JpegCoefficients& out, uint32_t& validWidth, uint32_t& validHeight) {
    uint32_t w[kHeaderWords];
    std::memcpy(w, record, sizeof w);
    if (w[0] != kMagic || w[1] == 0 || w[2] == 0 || w[1] > uint32_t(kTileSize) || w[2] > uint32_t(kTileSize) || (w[8] != 1 && w[8] != 3) ||
        w[9] > kMaxBlocks || w[5] > 2)
        return false;
    out = JpegCoefficients{};
    out.width = w[1];
    out.height = w[2];
    validWidth = w[3];
    validHeight = w[4];
    out.transform = JpegCoefficients::Transform(w[5]);
    out.hMax = w[6];
    out.vMax = w[7];
    out.components = w[8];
    out.blocksTotal = w[9];
    // What the shaders index by must hold together: each component's blocks follow the
    // previous one's, within a 256×256 tile's 32×32 blocks, adding up to the total.
    if (out.hMax < 1 || out.hMax > 2 || out.vMax < 1 || out.vMax > 2 || validWidth < 1 || validWidth > out.width ||
        validHeight < 1 || validHeight > out.height)
        return false;
    uint32_t next = 0;
    for (uint32_t i = 0; i < out.components; ++i) {
        JpegCoefficients::Component& c = out.comp[i];
        c.blocksWide = w[10 + 3 * i];
        c.blocksHigh = w[11 + 3 * i];
        c.firstBlock = w[12 + 3 * i];
        if (c.firstBlock != next || c.blocksWide == 0 || c.blocksHigh == 0 || c.blocksWide > 32 || c.blocksHigh > 32 ||
            c.blocksWide * 8 * (i == 0 ? 1 : out.hMax) < out.width || c.blocksHigh * 8 * (i == 0 ? 1 : out.vMax) < out.height)
            return false;
        next += c.blocksWide * c.blocksHigh;
    }
    return next == out.blocksTotal;
}

} // namespace jpegrecord

} // namespace iris
