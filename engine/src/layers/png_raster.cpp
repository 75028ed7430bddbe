// PNG → a map, through libpng's full API (the simplified png_image API converts grey through
// a gamma curve, which would change the values of a data map).
//
// libpng reports errors by longjmp: every call that can fail runs inside readInfo or readRows,
// C-style functions that hold no object with a destructor, so the jump skips nothing; the C++
// around them owns the buffers and destroys the libpng structures (PngHandle).
#include <png.h>

#include <csetjmp>
#include <cstdio>
#include <cstring>

#include "layers/raster_readers.h"

namespace iris::layers_detail {

namespace {

struct Source {
    const uint8_t* data;
    size_t size;
    size_t pos;
    char error[256];
};

void readData(png_structp png, png_bytep out, size_t n) {
    auto* s = static_cast<Source*>(png_get_io_ptr(png));
    if (n > s->size - s->pos) png_error(png, "the file ends early (truncated)");
    std::memcpy(out, s->data + s->pos, n);
    s->pos += n;
}

void onError(png_structp png, png_const_charp message) {
    auto* s = static_cast<Source*>(png_get_error_ptr(png));
    if (s->error[0] == 0) std::snprintf(s->error, sizeof s->error, "%s", message);
    png_longjmp(png, 1);
}

void onWarning(png_structp, png_const_charp) {}

struct PngHandle {
    png_structp png = nullptr;
    png_infop info = nullptr;
    ~PngHandle() { png_destroy_read_struct(&png, info ? &info : nullptr, nullptr); }
};

struct Header {
    png_uint_32 width, height;
    int bitDepth, colorType, interlace;
    bool trns;
};

int readInfo(png_structp png, png_infop info, Header* h) {
    if (setjmp(png_jmpbuf(png))) return 1;
    png_read_info(png, info);
    png_get_IHDR(png, info, &h->width, &h->height, &h->bitDepth, &h->colorType, &h->interlace, nullptr, nullptr);
    h->trns = png_get_valid(png, info, PNG_INFO_tRNS) != 0;
    return 0;
}

// What the rows become: Scalar/Label one channel of `bytes` (1 or 2, native order), or RGBA8.
enum class Out { Grey, Rgba };

int setTransforms(png_structp png, png_infop info, const Header* h, Out out, bool scaleLowBits, size_t* rowBytes) {
    if (setjmp(png_jmpbuf(png))) return 1;
    if (out == Out::Grey) {
        if (h->bitDepth < 8) {
            if (scaleLowBits) png_set_expand_gray_1_2_4_to_8(png);
            else png_set_packing(png); // values (and palette indices) as they are
        }
        if (h->bitDepth == 16 && std::endian::native == std::endian::little) png_set_swap(png);
    } else {
        if (h->colorType == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
        if (h->trns) png_set_tRNS_to_alpha(png);
        if (h->bitDepth == 16) png_set_scale_16(png);
        if (h->bitDepth < 8 && !(h->colorType & PNG_COLOR_MASK_PALETTE)) png_set_expand_gray_1_2_4_to_8(png);
        if (!(h->colorType & PNG_COLOR_MASK_COLOR)) png_set_gray_to_rgb(png);
        if (!(h->colorType & PNG_COLOR_MASK_ALPHA) && !h->trns) png_set_filler(png, 0xff, PNG_FILLER_AFTER);
    }
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    *rowBytes = png_get_rowbytes(png, info);
    return 0;
}

int readRows(png_structp png, png_bytepp rows) {
    if (setjmp(png_jmpbuf(png))) return 1;
    png_read_image(png, rows);
    return 0;
}

} // namespace

Expected<RasterMap> readPngRaster(std::span<const uint8_t> bytes, const std::string& name,
                                  const RasterLoadOptions& options) {
    Source src{bytes.data(), bytes.size(), 0, {0}};
    PngHandle h;
    h.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &src, &onError, &onWarning);
    if (h.png) h.info = png_create_info_struct(h.png);
    if (!h.png || !h.info) return fail(Status::OutOfMemory, name, "libpng cannot start");
    png_set_read_fn(h.png, &src, &readData);
    // Ancillary chunks (iCCP, zTXt, …) are not used: no allocation for them beyond this.
    png_set_chunk_malloc_max(h.png, 1u << 20);
    png_set_user_limits(h.png, 0x7fffffff, 0x7fffffff); // our own limits below, with our message
    auto libpngError = [&](const char* stage) {
        return fail(Status::CorruptData, name,
                    std::string("PNG ") + stage + ": " + (src.error[0] ? src.error : "libpng failed"));
    };
    Header hd{};
    if (readInfo(h.png, h.info, &hd)) return libpngError("header");

    const bool grey = hd.colorType == PNG_COLOR_TYPE_GRAY;
    const bool palette = hd.colorType == PNG_COLOR_TYPE_PALETTE;
    RasterMap map;
    Out out;
    if (options.asLabels) {
        if (!grey && !palette)
            return fail(Status::UnsupportedFormat, name,
                        "a label map must be a single-channel (grey or palette) PNG, not colour or with alpha");
        map.kind = RasterKind::Label;
        out = Out::Grey;
    } else {
        map.kind = grey ? RasterKind::Scalar : RasterKind::Rgba;
        out = grey ? Out::Grey : Out::Rgba;
    }
    const Limits limits = Limits::of(options);
    if (Result r = checkLevelSize(hd.width, hd.height, map.kind == RasterKind::Label ? 2 : 4, 0, limits, name); !r)
        return r;
    size_t rowBytes = 0;
    if (setTransforms(h.png, h.info, &hd, out, !options.asLabels, &rowBytes)) return libpngError("transforms");
    const size_t sampleBytes = out == Out::Rgba ? 4 : (hd.bitDepth == 16 ? 2 : 1);
    if (rowBytes != size_t(hd.width) * sampleBytes)
        return fail(Status::CorruptData, name,
                    "libpng's rows of " + std::to_string(rowBytes) + " bytes, " +
                        std::to_string(size_t(hd.width) * sampleBytes) + " expected");

    RasterLevel l;
    l.width = int32_t(hd.width), l.height = int32_t(hd.height);
    std::vector<uint8_t> raw;
    if (out == Out::Rgba) l.rgba.resize(rowBytes * hd.height);
    else raw.resize(rowBytes * hd.height);
    uint8_t* base = out == Out::Rgba ? l.rgba.data() : raw.data();
    std::vector<png_bytep> rows(hd.height);
    for (size_t y = 0; y < hd.height; ++y) rows[y] = base + y * rowBytes;
    if (readRows(h.png, rows.data())) return libpngError("data");

    const size_t n = size_t(hd.width) * hd.height;
    if (out == Out::Grey) {
        auto value = [&](size_t i) -> uint16_t {
            if (sampleBytes == 1) return raw[i];
            uint16_t v;
            std::memcpy(&v, &raw[2 * i], 2);
            return v;
        };
        if (map.kind == RasterKind::Label) {
            l.label.resize(n);
            for (size_t i = 0; i < n; ++i) l.label[i] = value(i);
        } else {
            l.scalar.resize(n);
            for (size_t i = 0; i < n; ++i) l.scalar[i] = float(value(i));
        }
    }
    map.levels.push_back(std::move(l));
    if (Result r = finishMap(map, name, options.title); !r) return r;
    return map;
}

} // namespace iris::layers_detail
