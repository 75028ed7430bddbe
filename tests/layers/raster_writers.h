// Writers of small map files for the layer tests (tst_layers.cpp) and the fuzz seeds
// (tests/fuzz/fuzz_raster_seeds.cpp): PNG through libpng, TIFF through libtiff, .npy by hand.
// Header-only; each returns false (and the writer's message on stderr) on failure.
#pragma once

#include <png.h>
#include <tiffio.h>

#include <algorithm>
#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace raster_writers {

// A PNG of `colorType` (PNG_COLOR_TYPE_*) and `bitDepth`, rows packed as libpng wants them
// (16-bit samples big-endian), optional palette and tRNS, Adam7 when `interlace`.
struct Png {
    uint32_t width = 0, height = 0;
    int colorType = PNG_COLOR_TYPE_GRAY;
    int bitDepth = 8;
    bool interlace = false;
    std::vector<uint8_t> rows; // height × rowbytes
    std::vector<png_color> palette;
    std::vector<uint8_t> trnsAlpha; // palette alphas
    bool trnsGray = false;
    uint16_t trnsGrayValue = 0;
};

inline bool writePng(const std::string& path, const Png& p) {
    FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return false;
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png_create_info_struct(png);
    std::vector<png_bytep> rowPtrs(p.height);
    const size_t rowBytes = p.height ? p.rows.size() / p.height : 0;
    for (uint32_t y = 0; y < p.height; ++y) rowPtrs[y] = const_cast<png_bytep>(p.rows.data() + y * rowBytes);
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        std::fclose(f);
        return false;
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, p.width, p.height, p.bitDepth, p.colorType,
                 p.interlace ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    if (!p.palette.empty()) png_set_PLTE(png, info, p.palette.data(), int(p.palette.size()));
    if (!p.trnsAlpha.empty()) png_set_tRNS(png, info, p.trnsAlpha.data(), int(p.trnsAlpha.size()), nullptr);
    if (p.trnsGray) {
        png_color_16 c{};
        c.gray = p.trnsGrayValue;
        png_set_tRNS(png, info, nullptr, 0, &c);
    }
    png_write_info(png, info);
    png_write_image(png, rowPtrs.data());
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    return std::fclose(f) == 0;
}

// One TIFF image: `data` holds width × height pixels of `spp` samples of `bps` bits, native
// byte order, contiguous.
struct TiffImage {
    uint32_t width = 0, height = 0;
    uint16_t spp = 1, bps = 8, format = SAMPLEFORMAT_UINT, photometric = PHOTOMETRIC_MINISBLACK;
    uint16_t extraSample = EXTRASAMPLE_UNASSALPHA; // for spp 4
    uint32_t tile = 0;          // 0: strips; else square tiles of this size (a multiple of 16)
    uint32_t rowsPerStrip = 3;  // strips
    uint16_t compression = COMPRESSION_NONE;
    uint32_t subfileType = 0;
    std::vector<uint16_t> colormap; // 3 × 2^bps for a palette image
    std::vector<uint8_t> data;
};

inline bool writeTiffDir(TIFF* tif, const TiffImage& im) {
    TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, im.width);
    TIFFSetField(tif, TIFFTAG_IMAGELENGTH, im.height);
    TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, im.spp);
    TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, im.bps);
    TIFFSetField(tif, TIFFTAG_SAMPLEFORMAT, im.format);
    TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, im.photometric);
    TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
    TIFFSetField(tif, TIFFTAG_COMPRESSION, im.compression);
    if (im.subfileType) TIFFSetField(tif, TIFFTAG_SUBFILETYPE, im.subfileType);
    if (im.spp == 4) {
        uint16_t extra = im.extraSample;
        TIFFSetField(tif, TIFFTAG_EXTRASAMPLES, 1, &extra);
    }
    if (!im.colormap.empty()) {
        const size_t n = im.colormap.size() / 3;
        TIFFSetField(tif, TIFFTAG_COLORMAP, im.colormap.data(), im.colormap.data() + n, im.colormap.data() + 2 * n);
    }
    const size_t px = size_t(im.spp) * im.bps / 8;
    if (im.tile) {
        TIFFSetField(tif, TIFFTAG_TILEWIDTH, im.tile);
        TIFFSetField(tif, TIFFTAG_TILELENGTH, im.tile);
        std::vector<uint8_t> buf(size_t(im.tile) * im.tile * px);
        for (uint32_t ty = 0; ty < im.height; ty += im.tile)
            for (uint32_t tx = 0; tx < im.width; tx += im.tile) {
                std::fill(buf.begin(), buf.end(), 0);
                for (uint32_t y = ty; y < std::min(im.height, ty + im.tile); ++y)
                    std::memcpy(&buf[(size_t(y - ty) * im.tile) * px], &im.data[(size_t(y) * im.width + tx) * px],
                                std::min(im.tile, im.width - tx) * px);
                if (TIFFWriteTile(tif, buf.data(), tx, ty, 0, 0) < 0) return false;
            }
    } else {
        TIFFSetField(tif, TIFFTAG_ROWSPERSTRIP, im.rowsPerStrip);
        for (uint32_t y = 0; y < im.height; ++y)
            if (TIFFWriteScanline(tif, const_cast<uint8_t*>(&im.data[size_t(y) * im.width * px]), y, 0) < 0) return false;
    }
    return true;
}

template <class T>
std::vector<uint8_t> rawBytes(const std::vector<T>& v, bool swap = false);

// A float32 image of w × h pixels all `value`, in 16-pixel tiles: a pyramid level.
inline TiffImage floatLevel(uint32_t w, uint32_t h, float value) {
    TiffImage im{w, h, 1, 32, SAMPLEFORMAT_IEEEFP};
    im.tile = 16;
    im.data = rawBytes(std::vector<float>(size_t(w) * h, value));
    return im;
}

// Writes `images` as a chain of IFDs or, with `subIfds`, the first with the others as its SubIFDs.
inline bool writeTiff(const std::string& path, const std::vector<TiffImage>& images, bool subIfds = false,
                      bool bigTiff = false) {
    TIFF* tif = TIFFOpen(path.c_str(), bigTiff ? "w8" : "w");
    if (!tif) return false;
    bool ok = true;
    for (size_t i = 0; i < images.size() && ok; ++i) {
        if (subIfds && i == 0 && images.size() > 1) {
            std::vector<toff_t> offsets(images.size() - 1, 0);
            TIFFSetField(tif, TIFFTAG_SUBIFD, uint16_t(offsets.size()), offsets.data());
        }
        ok = writeTiffDir(tif, images[i]) && TIFFWriteDirectory(tif);
    }
    TIFFClose(tif);
    return ok;
}

// A .npy file: version major.0, `descr`, `fortran`, `shape` as Python writes it ("(3, 2)"),
// then `data` as given. The header is padded to a multiple of 64 bytes, as numpy does.
inline std::vector<uint8_t> npyBytes(const std::string& descr, bool fortran, const std::string& shape,
                                     const std::vector<uint8_t>& data, int major = 1) {
    std::string dict = "{'descr': '" + descr + "', 'fortran_order': " + (fortran ? "True" : "False") +
                       ", 'shape': " + shape + ", }";
    const size_t pre = major == 1 ? 10 : 12;
    while ((pre + dict.size() + 1) % 64) dict += ' ';
    dict += '\n';
    std::vector<uint8_t> out = {0x93, 'N', 'U', 'M', 'P', 'Y', uint8_t(major), 0};
    const size_t n = dict.size();
    out.push_back(uint8_t(n & 0xff));
    out.push_back(uint8_t(n >> 8));
    if (major > 1) out.push_back(uint8_t(n >> 16)), out.push_back(uint8_t(n >> 24));
    out.insert(out.end(), dict.begin(), dict.end());
    out.insert(out.end(), data.begin(), data.end());
    return out;
}

inline bool writeBytes(const std::string& path, const std::vector<uint8_t>& bytes) {
    std::ofstream f(path, std::ios::binary);
    f.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    return bool(f);
}

template <class T>
std::vector<uint8_t> rawBytes(const std::vector<T>& v, bool swap) {
    std::vector<uint8_t> out(v.size() * sizeof(T));
    std::memcpy(out.data(), v.data(), out.size());
    if (swap)
        for (size_t i = 0; i < v.size(); ++i) std::reverse(out.begin() + i * sizeof(T), out.begin() + (i + 1) * sizeof(T));
    return out;
}

inline std::vector<uint8_t> readBytes(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    return std::vector<uint8_t>(std::istreambuf_iterator<char>(f), {});
}

} // namespace raster_writers
