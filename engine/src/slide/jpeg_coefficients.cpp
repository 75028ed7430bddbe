#include "slide/jpeg_coefficients.h"

#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <new>
#include <string>

#include <jpeglib.h>

namespace iris {

namespace {

// As in jpeg_frame_decode.cpp: errors and warnings jump back to the read's setjmp, so a tile
// libjpeg had to guess at is refused rather than reconstructed from guesses.
struct ErrorManager {
    jpeg_error_mgr pub;
    std::jmp_buf jump;
    char message[JMSG_LENGTH_MAX];
};

[[noreturn]] void errorExit(j_common_ptr cinfo) {
    auto* err = reinterpret_cast<ErrorManager*>(cinfo->err);
    (*cinfo->err->format_message)(cinfo, err->message);
    std::longjmp(err->jump, 1);
}

void emitMessage(j_common_ptr cinfo, int level) {
    if (level < 0) errorExit(cinfo);
}

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
        return Corrupt;
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
    cinfo.err = jpeg_std_error(&err.pub);
    err.pub.error_exit = errorExit;
    err.pub.emit_message = emitMessage;
    Sink sink{&out, dst, capacity};
    const int outcome = read(&cinfo, &err, data, size, width, height, colour, &sink);
    if (outcome == Read) out.components = uint32_t(cinfo.num_components);
    jpeg_destroy_decompress(&cinfo);
    if (outcome == Corrupt) return Result(Status::CorruptData, std::string("the JPEG data is corrupt (") + err.message + ")");
    if (outcome == Unsupported)
        return Result(Status::UnsupportedFormat, std::string("the GPU JPEG path does not take ") + err.message);
    return out;
}

} // namespace iris
