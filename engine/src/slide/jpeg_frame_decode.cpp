#include "slide/jpeg_frame_decode.h"

#include <csetjmp>
#include <cstdio>
#include <string>

#include <jpeglib.h>

#include "slide/libjpeg_errors.h"

namespace iris {

namespace {

using ErrorManager = libjpeg::Errors;

// The part of the decode between setjmp and the end, without any C++ object that needs a
// destructor (longjmp would skip it). Returns 0 on success, else a Status and the reason in
// err->message.
int decode(jpeg_decompress_struct* cinfo, ErrorManager* err, const uint8_t* data, size_t size, int width, int height,
           JpegColour colour, uint8_t* dst, size_t pitch) {
    if (setjmp(err->jump)) return 1;
    jpeg_create_decompress(cinfo);
    jpeg_mem_src(cinfo, data, static_cast<unsigned long>(size));
    if (jpeg_read_header(cinfo, TRUE) != JPEG_HEADER_OK) {
        std::snprintf(err->message, sizeof err->message, "no JPEG image in the stream");
        return 1;
    }
    if (int(cinfo->image_width) != width || int(cinfo->image_height) != height) {
        std::snprintf(err->message, sizeof err->message, "the JPEG is %ux%u pixels, expected %dx%d",
                      unsigned(cinfo->image_width), unsigned(cinfo->image_height), width, height);
        return 1;
    }
    if (colour != JpegColour::Auto) {
        if (cinfo->num_components != 3) {
            std::snprintf(err->message, sizeof err->message, "the JPEG has %d components, expected 3",
                          cinfo->num_components);
            return 1;
        }
        cinfo->jpeg_color_space = colour == JpegColour::YCbCr ? JCS_YCbCr : JCS_RGB;
    } else if (cinfo->num_components != 1 && cinfo->num_components != 3) {
        std::snprintf(err->message, sizeof err->message, "the JPEG has %d components", cinfo->num_components);
        return 1;
    }
    cinfo->out_color_space = JCS_EXT_RGBA;
    jpeg_start_decompress(cinfo);
    while (cinfo->output_scanline < cinfo->output_height) {
        JSAMPROW row = dst + size_t(cinfo->output_scanline) * pitch;
        jpeg_read_scanlines(cinfo, &row, 1);
    }
    jpeg_finish_decompress(cinfo);
    return 0;
}

} // namespace

Result decodeJpegFrameRgba(const uint8_t* data, size_t size, int width, int height, JpegColour colour, uint8_t* dst,
                           size_t pitch) {
    if (!data || size == 0) return Result(Status::CorruptData, "the JPEG stream is empty");
    if (size > 0xffffffffu) return Result(Status::CorruptData, "the JPEG stream is too large");
    if (width <= 0 || height <= 0 || pitch < size_t(width) * 4) {
        return Result(Status::InvalidArgument, "bad size or row pitch for the JPEG decode");
    }
    jpeg_decompress_struct cinfo{};
    ErrorManager err{};
    libjpeg::install(cinfo, err);
    const int failed = decode(&cinfo, &err, data, size, width, height, colour, dst, pitch);
    jpeg_destroy_decompress(&cinfo);
    if (failed) return Result(Status::CorruptData, std::string("the JPEG data is corrupt (") + err.message + ")");
    return {};
}

} // namespace iris
