// Writes the seed corpora of the fuzz targets other than fuzz_iris_reader (make-seeds.sh runs
// it once per target):
//
//   fuzz_seeds tiff    OUT_DIR            TIFF and SVS files (libtiff), sound and broken
//   fuzz_seeds jp2k    OUT_DIR [SLIDE…]   J2K codestreams (OpenJPEG), and the JPEG 2000 tiles
//                                         of the given Aperio slides
//   fuzz_seeds icc     OUT_DIR [SLIDE…]   ICC profiles (LittleCMS), and the profiles embedded in
//                                         the given TIFF/SVS slides and DICOM files
//   fuzz_seeds pyramid OUT_DIR            broken-source descriptions for fuzz_pyramid
//   fuzz_seeds dicom   OUT_DIR            DICOM WSI files (DCMTK), and series of several
//
// Each writes small files: a fuzzer mutates a small file faster and reaches its structure
// sooner than a big one's pixel data. What each corpus holds is listed where it is written.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <lcms2.h>
#include <openjpeg.h>
#include <tiffio.h>
#include <turbojpeg.h>

#include <dcmtk/config/osconfig.h> // first, as DCMTK asks

#include <dcmtk/dcmdata/dcdatset.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcitem.h>
#include <dcmtk/dcmdata/dcpixel.h>
#include <dcmtk/dcmdata/dcpixseq.h>
#include <dcmtk/dcmdata/dcpxitem.h>
#include <dcmtk/dcmdata/dcuid.h>
#include <dcmtk/oflog/oflog.h>

namespace {

using Bytes = std::vector<uint8_t>;

[[noreturn]] void die(const std::string& what) {
    std::fprintf(stderr, "fuzz_seeds: %s\n", what.c_str());
    std::exit(1);
}

std::string g_out;
int g_count = 0;

void save(const std::string& name, const Bytes& b) {
    std::ofstream f(g_out + "/" + name, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
    if (!f) die("cannot write " + g_out + "/" + name);
    ++g_count;
}

Bytes load(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    if (!f) die("cannot read " + path);
    return Bytes(std::istreambuf_iterator<char>(f), {});
}

// Gradients and a checkerboard: tiles that are neither empty nor big, whatever the codec.
uint8_t pattern(uint32_t x, uint32_t y, uint32_t c) {
    x /= 4; // runs of four: the lossless codecs compress them well
    return uint8_t((x * (4 + c) + y * (3 - c) + (((x / 4) ^ (y / 16)) & 1) * 40 + c * 70) & 0xff);
}

// ------------------------------------------------------------------------------------------
// JPEG (TurboJPEG) and JPEG 2000 (OpenJPEG) streams
// ------------------------------------------------------------------------------------------

Bytes jpeg(int w, int h, int quality, int subsamp, bool grey = false) {
    Bytes px(size_t(w) * h * (grey ? 1 : 3));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < (grey ? 1 : 3); ++c) px[(size_t(y) * w + x) * (grey ? 1 : 3) + c] = pattern(x, y, c);
    tjhandle tj = tjInitCompress();
    unsigned char* out = nullptr;
    unsigned long size = 0;
    if (!tj || tjCompress2(tj, px.data(), w, 0, h, grey ? TJPF_GRAY : TJPF_RGB, &out, &size,
                           grey ? TJSAMP_GRAY : subsamp, quality, 0) != 0)
        die("TurboJPEG cannot compress");
    Bytes v(out, out + size);
    tjFree(out);
    tjDestroy(tj);
    return v;
}

struct J2kOptions {
    uint32_t w = 64, h = 64;
    int comps = 3;
    int precision = 8;
    bool sign = false;
    uint32_t dx = 1, dy = 1; // subsampling of components 1 and 2
    bool lossless = true;
    int resolutions = 3;
    bool mct = false;
    OPJ_PROG_ORDER order = OPJ_LRCP;
    uint32_t tileW = 0, tileH = 0; // 0: one tile
    int layers = 1;
    bool sop = false, eph = false;
    int cblk = 64;
};

Bytes j2k(const J2kOptions& o) {
    std::vector<opj_image_cmptparm_t> cp(size_t(o.comps));
    for (int c = 0; c < o.comps; ++c) {
        std::memset(&cp[size_t(c)], 0, sizeof(opj_image_cmptparm_t));
        const bool sub = c > 0 && c < 3;
        cp[size_t(c)].dx = sub ? o.dx : 1;
        cp[size_t(c)].dy = sub ? o.dy : 1;
        cp[size_t(c)].w = (o.w + cp[size_t(c)].dx - 1) / cp[size_t(c)].dx;
        cp[size_t(c)].h = (o.h + cp[size_t(c)].dy - 1) / cp[size_t(c)].dy;
        cp[size_t(c)].prec = OPJ_UINT32(o.precision);
        cp[size_t(c)].sgnd = o.sign ? 1 : 0;
    }
    opj_image_t* img =
        opj_image_create(OPJ_UINT32(o.comps), cp.data(), o.comps >= 3 ? OPJ_CLRSPC_SRGB : OPJ_CLRSPC_GRAY);
    if (!img) die("opj_image_create");
    img->x0 = img->y0 = 0;
    img->x1 = o.w;
    img->y1 = o.h;
    for (int c = 0; c < o.comps; ++c) {
        const opj_image_comp_t& comp = img->comps[c];
        const int maxv = (1 << o.precision) - 1;
        for (uint32_t y = 0; y < comp.h; ++y)
            for (uint32_t x = 0; x < comp.w; ++x) {
                int v = pattern(x, y, uint32_t(c)) * maxv / 255;
                if (o.sign) v -= (maxv + 1) / 2;
                comp.data[y * comp.w + x] = v;
            }
    }
    opj_cparameters_t p;
    opj_set_default_encoder_parameters(&p);
    p.tcp_numlayers = o.layers;
    for (int l = 0; l < o.layers; ++l) p.tcp_rates[l] = o.lossless ? 0 : float(40 >> l);
    p.cp_disto_alloc = 1;
    p.irreversible = o.lossless ? 0 : 1;
    p.numresolution = o.resolutions;
    p.tcp_mct = o.mct ? 1 : 0;
    p.prog_order = o.order;
    p.cblockw_init = p.cblockh_init = o.cblk;
    if (o.tileW) {
        p.tile_size_on = OPJ_TRUE;
        p.cp_tdx = int(o.tileW);
        p.cp_tdy = int(o.tileH);
    }
    if (o.sop) p.csty |= 0x02;
    if (o.eph) p.csty |= 0x04;
    opj_codec_t* codec = opj_create_compress(OPJ_CODEC_J2K);
    if (!codec || !opj_setup_encoder(codec, &p, img)) die("opj_setup_encoder");
    struct Sink {
        Bytes b;
        size_t pos = 0;
    } sink;
    opj_stream_t* s = opj_stream_default_create(OPJ_FALSE);
    opj_stream_set_user_data(s, &sink, nullptr);
    opj_stream_set_write_function(s, [](void* buf, OPJ_SIZE_T n, void* u) -> OPJ_SIZE_T {
        auto* k = static_cast<Sink*>(u);
        if (k->b.size() < k->pos + n) k->b.resize(k->pos + n);
        std::memcpy(k->b.data() + k->pos, buf, n);
        k->pos += n;
        return n;
    });
    opj_stream_set_skip_function(s, [](OPJ_OFF_T n, void* u) -> OPJ_OFF_T {
        auto* k = static_cast<Sink*>(u);
        k->pos += size_t(n);
        if (k->b.size() < k->pos) k->b.resize(k->pos);
        return n;
    });
    opj_stream_set_seek_function(s, [](OPJ_OFF_T n, void* u) -> OPJ_BOOL {
        static_cast<Sink*>(u)->pos = size_t(n);
        return OPJ_TRUE;
    });
    if (!opj_start_compress(codec, img, s) || !opj_encode(codec, s) || !opj_end_compress(codec, s))
        die("OpenJPEG cannot encode");
    opj_stream_destroy(s);
    opj_destroy_codec(codec);
    opj_image_destroy(img);
    return sink.b;
}

// ------------------------------------------------------------------------------------------
// TIFF
// ------------------------------------------------------------------------------------------

constexpr uint16_t kAperioJp2kYCbCr = 33003, kAperioJp2kRgb = 33005;

struct Dir {
    uint32_t w = 0, h = 0;
    uint32_t tileW = 256, tileH = 256; // 0: stripped
    uint16_t compression = COMPRESSION_NONE;
    uint16_t photometric = PHOTOMETRIC_RGB;
    uint16_t spp = 3, bps = 8, planar = PLANARCONFIG_CONTIG, orientation = ORIENTATION_TOPLEFT;
    int quality = 40;
    bool ycbcr = false; // JPEG in YCbCr (libtiff converts from RGB)
    std::string description;
    Bytes icc;
    // Raw tiles, written as they are (JPEG 2000 codestreams, JPEG of the wrong size); empty:
    // libtiff encodes the pattern.
    std::function<Bytes(uint32_t col, uint32_t row)> rawTile;
};

void writeTiff(const std::string& name, const std::vector<Dir>& dirs, bool bigtiff = false) {
    const std::string path = g_out + "/" + name;
    TIFF* t = TIFFOpen(path.c_str(), bigtiff ? "w8" : "w");
    if (!t) die("libtiff cannot create " + path);
    for (const Dir& d : dirs) {
        TIFFSetField(t, TIFFTAG_IMAGEWIDTH, d.w);
        TIFFSetField(t, TIFFTAG_IMAGELENGTH, d.h);
        TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, d.spp);
        TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, d.bps);
        TIFFSetField(t, TIFFTAG_PLANARCONFIG, d.planar);
        TIFFSetField(t, TIFFTAG_ORIENTATION, d.orientation);
        TIFFSetField(t, TIFFTAG_COMPRESSION, d.compression);
        TIFFSetField(t, TIFFTAG_PHOTOMETRIC, d.photometric);
        if (d.spp == 4 && d.photometric == PHOTOMETRIC_RGB) {
            const uint16_t extra = EXTRASAMPLE_UNASSALPHA;
            TIFFSetField(t, TIFFTAG_EXTRASAMPLES, 1, &extra);
        }
        if (d.compression == COMPRESSION_JPEG) {
            TIFFSetField(t, TIFFTAG_JPEGQUALITY, d.quality);
            if (d.ycbcr) {
                TIFFSetField(t, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_YCBCR);
                TIFFSetField(t, TIFFTAG_YCBCRSUBSAMPLING, 2, 2);
                TIFFSetField(t, TIFFTAG_JPEGCOLORMODE, JPEGCOLORMODE_RGB);
            }
        }
        if (d.photometric == PHOTOMETRIC_PALETTE) {
            std::vector<uint16_t> r(256), g(256), b(256);
            for (int i = 0; i < 256; ++i) {
                r[size_t(i)] = uint16_t(i * 257);
                g[size_t(i)] = uint16_t((255 - i) * 257);
                b[size_t(i)] = uint16_t((i * 7 & 255) * 257);
            }
            TIFFSetField(t, TIFFTAG_COLORMAP, r.data(), g.data(), b.data());
        }
        if (!d.description.empty()) TIFFSetField(t, TIFFTAG_IMAGEDESCRIPTION, d.description.c_str());
        if (!d.icc.empty()) TIFFSetField(t, TIFFTAG_ICCPROFILE, uint32_t(d.icc.size()), d.icc.data());
        const uint32_t bytesPerSample = d.bps / 8;
        const uint32_t sampleBytes = d.planar == PLANARCONFIG_CONTIG ? d.spp * bytesPerSample : bytesPerSample;
        const auto fill = [&](Bytes& buf, uint32_t x0, uint32_t y0, uint32_t w, uint32_t h, uint32_t plane) {
            buf.assign(size_t(w) * h * sampleBytes, 0);
            for (uint32_t y = 0; y < h; ++y)
                for (uint32_t x = 0; x < w; ++x)
                    for (uint32_t s = 0; s < sampleBytes; ++s) {
                        const uint32_t c = d.planar == PLANARCONFIG_CONTIG ? s / bytesPerSample : plane;
                        buf[(size_t(y) * w + x) * sampleBytes + s] = pattern(x0 + x, y0 + y, c);
                    }
        };
        Bytes buf;
        if (d.tileW) {
            TIFFSetField(t, TIFFTAG_TILEWIDTH, d.tileW);
            TIFFSetField(t, TIFFTAG_TILELENGTH, d.tileH);
            const uint32_t planes = d.planar == PLANARCONFIG_CONTIG ? 1 : d.spp;
            for (uint32_t p = 0; p < planes; ++p)
                for (uint32_t y = 0; y < d.h; y += d.tileH)
                    for (uint32_t x = 0; x < d.w; x += d.tileW) {
                        if (d.rawTile) {
                            const Bytes raw = d.rawTile(x / d.tileW, y / d.tileH);
                            const ttile_t tile = TIFFComputeTile(t, x, y, 0, uint16_t(p));
                            if (TIFFWriteRawTile(t, tile, const_cast<uint8_t*>(raw.data()), tmsize_t(raw.size())) < 0)
                                die("TIFFWriteRawTile " + path);
                        } else {
                            fill(buf, x, y, d.tileW, d.tileH, p);
                            if (TIFFWriteTile(t, buf.data(), x, y, 0, uint16_t(p)) < 0) die("TIFFWriteTile " + path);
                        }
                    }
        } else {
            const uint32_t rows = std::min<uint32_t>(d.h, 16);
            TIFFSetField(t, TIFFTAG_ROWSPERSTRIP, rows);
            for (uint32_t y = 0; y < d.h; y += rows) {
                const uint32_t n = std::min(rows, d.h - y);
                fill(buf, 0, y, d.w, n, 0);
                if (TIFFWriteEncodedStrip(t, TIFFComputeStrip(t, y, 0), buf.data(), tmsize_t(buf.size())) < 0)
                    die("TIFFWriteEncodedStrip " + path);
            }
        }
        if (!TIFFWriteDirectory(t)) die("TIFFWriteDirectory " + path);
    }
    TIFFClose(t);
    ++g_count;
}

// Edits a classic little-endian TIFF in place, for the defects libtiff will not write.
struct TiffPatch {
    Bytes b;
    uint32_t r32(size_t at) const { return b[at] | b[at + 1] << 8 | b[at + 2] << 16 | uint32_t(b[at + 3]) << 24; }
    uint16_t r16(size_t at) const { return uint16_t(b[at] | b[at + 1] << 8); }
    void w32(size_t at, uint32_t v) {
        for (int i = 0; i < 4; ++i) b[at + size_t(i)] = uint8_t(v >> (8 * i));
    }
    void w16(size_t at, uint16_t v) {
        b[at] = uint8_t(v);
        b[at + 1] = uint8_t(v >> 8);
    }
    std::vector<uint32_t> ifds() const {
        std::vector<uint32_t> out;
        for (uint32_t off = r32(4); off && off + 2 <= b.size() && out.size() < 64; off = r32(off + 2 + 12 * r16(off)))
            out.push_back(off);
        return out;
    }
    // The entry of `tag` in directory `dir`.
    size_t entry(size_t dir, uint16_t tag) const {
        const uint32_t ifd = ifds().at(dir);
        for (uint16_t i = 0; i < r16(ifd); ++i)
            if (r16(ifd + 2 + 12u * i) == tag) return ifd + 2 + 12u * i;
        die("no tag " + std::to_string(tag) + " in directory " + std::to_string(dir));
    }
    // Sets a one-value SHORT or LONG entry.
    void set(size_t dir, uint16_t tag, uint32_t v) {
        const size_t e = entry(dir, tag);
        if (r16(e + 2) == TIFF_SHORT)
            w16(e + 8, uint16_t(v));
        else
            w32(e + 8, v);
    }
    // Element i of a LONG array entry (tile offsets, byte counts).
    void setElement(size_t dir, uint16_t tag, uint32_t i, uint32_t v) {
        const size_t e = entry(dir, tag);
        const uint32_t count = r32(e + 4);
        w32(count == 1 ? e + 8 : r32(e + 8) + 4u * i, v);
    }
    void setCount(size_t dir, uint16_t tag, uint32_t count) { w32(entry(dir, tag) + 4, count); }
    void setNext(size_t dir, uint32_t next) {
        const uint32_t ifd = ifds().at(dir);
        w32(ifd + 2 + 12u * r16(ifd), next);
    }
};

void patchTiff(const std::string& from, const std::string& to, const std::function<void(TiffPatch&)>& edit) {
    TiffPatch p{load(g_out + "/" + from)};
    edit(p);
    save(to, p.b);
}

const char* kAperioDesc = "Aperio Image Library v10.0.51\r\n520x300 [0,0 520x300] (256x256) JPEG/RGB Q=30|AppMag = "
                          "20|StripeWidth = 1000|ScanScope ID = SS1234|MPP = 0.4990|Date = 09/24/24";

void tiffSeeds() {
    // Generic tiled TIFF pyramids: each compression the reader decodes, partial edge tiles.
    const uint16_t codecs[] = {COMPRESSION_NONE, COMPRESSION_ADOBE_DEFLATE, COMPRESSION_LZW, COMPRESSION_PACKBITS,
                               COMPRESSION_ZSTD, COMPRESSION_WEBP,          COMPRESSION_JPEG};
    for (uint16_t c : codecs) {
        if (!TIFFIsCODECConfigured(c)) continue;
        std::vector<Dir> dirs;
        for (uint32_t s = 0; s < 3; ++s) {
            Dir d;
            d.w = 150 >> s;
            d.h = 100 >> s;
            d.tileW = d.tileH = 48;
            d.compression = c;
            d.ycbcr = c == COMPRESSION_JPEG;
            d.quality = 30;
            dirs.push_back(d);
        }
        writeTiff("generic-" + std::to_string(c) + ".tiff", dirs);
    }
    // Aperio SVS, JPEG (YCbCr 4:2:0, tables in JPEGTables): level 0, thumbnail (stripped), level
    // 1, label and macro.
    {
        Dir l0{.w = 520,
               .h = 300,
               .compression = COMPRESSION_JPEG,
               .quality = 30,
               .ycbcr = true,
               .description = kAperioDesc};
        Dir thumb{.w = 130,
                  .h = 75,
                  .tileW = 0,
                  .compression = COMPRESSION_JPEG,
                  .quality = 30,
                  .ycbcr = true,
                  .description = "Aperio Image Library v10.0.51\r\n520x300 -> 130x75 - |AppMag = 20|MPP = 0.4990"};
        Dir l1{.w = 130,
               .h = 75,
               .compression = COMPRESSION_JPEG,
               .quality = 30,
               .ycbcr = true,
               .description = "Aperio Image Library v10.0.51\r\n520x300 -> 130x75 - |AppMag = 20|MPP = 0.4990"};
        Dir label{.w = 40,
                  .h = 40,
                  .tileW = 0,
                  .compression = COMPRESSION_LZW,
                  .description = "Aperio Image Library v10.0.51\nlabel 40x40"};
        Dir macro{.w = 80,
                  .h = 30,
                  .tileW = 0,
                  .compression = COMPRESSION_JPEG,
                  .quality = 30,
                  .description = "Aperio Image Library v10.0.51\nmacro 80x30"};
        writeTiff("aperio-jpeg.svs", {l0, thumb, l1, label, macro});
        // Aperio's 240-px tiles, 4:4:4, an ICC profile (LittleCMS's sRGB).
        cmsHPROFILE srgb = cmsCreate_sRGBProfile();
        cmsUInt32Number n = 0;
        cmsSaveProfileToMem(srgb, nullptr, &n);
        Bytes icc(n);
        cmsSaveProfileToMem(srgb, icc.data(), &n);
        cmsCloseProfile(srgb);
        Dir l0b = l0;
        l0b.tileW = l0b.tileH = 240;
        l0b.ycbcr = false;
        l0b.icc = icc;
        writeTiff("aperio-240-icc.svs", {l0b, thumb});
        // BigTIFF.
        writeTiff("aperio-bigtiff.svs", {l0, thumb, l1}, true);
    }
    // Aperio JPEG 2000: 33003 (YCbCr components, no MCT) and 33005 (RGB, with MCT).
    for (uint16_t c : {kAperioJp2kYCbCr, kAperioJp2kRgb}) {
        std::vector<Dir> dirs;
        for (uint32_t s = 0; s < 2; ++s) {
            Dir d{.w = 300u >> (2 * s),
                  .h = 200u >> (2 * s),
                  .tileW = 128,
                  .tileH = 128,
                  .compression = c,
                  .description = s == 0 ? kAperioDesc : "Aperio Image Library v10.0.51\r\n300x200 -> 75x50"};
            d.rawTile = [c](uint32_t, uint32_t) {
                return j2k({.w = 128, .h = 128, .lossless = false, .resolutions = 4, .mct = c == kAperioJp2kRgb});
            };
            dirs.push_back(d);
            if (s == 0) dirs.push_back(Dir{.w = 75, .h = 50, .tileW = 0, .compression = COMPRESSION_NONE});
        }
        writeTiff("aperio-jp2k-" + std::to_string(c) + ".svs", dirs);
        // A codestream of the wrong size in one tile, subsampled chroma in another.
        dirs[0].rawTile = [c](uint32_t col, uint32_t) {
            if (col == 1) return j2k({.w = 96, .h = 128});
            if (col == 2) return j2k({.w = 128, .h = 128, .dx = 2, .dy = 2, .mct = false});
            return j2k({.w = 128, .h = 128, .mct = c == kAperioJp2kRgb});
        };
        writeTiff("aperio-jp2k-" + std::to_string(c) + "-odd-tiles.svs", dirs);
    }
    // Pixel layouts the reader leaves to OpenSlide or refuses: greyscale (JPEG and Deflate),
    // CMYK, 16-bit, palette, planar RGB, RGBA, another orientation, stripped.
    const auto single = [](Dir d) {
        d.w = d.w ? d.w : 90;
        d.h = d.h ? d.h : 70;
        d.tileW = d.tileH = 64;
        return d;
    };
    writeTiff("grey-jpeg.tiff",
              {single({.compression = COMPRESSION_JPEG, .photometric = PHOTOMETRIC_MINISBLACK, .spp = 1})});
    writeTiff("grey-deflate.tiff",
              {single({.compression = COMPRESSION_ADOBE_DEFLATE, .photometric = PHOTOMETRIC_MINISBLACK, .spp = 1})});
    writeTiff("cmyk.tiff", {single({.compression = COMPRESSION_LZW, .photometric = PHOTOMETRIC_SEPARATED, .spp = 4})});
    writeTiff("rgb16.tiff", {single({.compression = COMPRESSION_NONE, .bps = 16})});
    writeTiff("palette.tiff",
              {single({.compression = COMPRESSION_PACKBITS, .photometric = PHOTOMETRIC_PALETTE, .spp = 1})});
    writeTiff("planar.tiff", {single({.compression = COMPRESSION_NONE, .planar = PLANARCONFIG_SEPARATE})});
    writeTiff("rgba.tiff", {single({.compression = COMPRESSION_ADOBE_DEFLATE, .spp = 4})});
    writeTiff("orientation.tiff", {single({.compression = COMPRESSION_NONE, .orientation = ORIENTATION_BOTRIGHT})});
    writeTiff("stripped.tiff", {Dir{.w = 64, .h = 48, .tileW = 0}});
    // Tiles larger than the image; tiny tiles; a non-square tile.
    writeTiff("tile-larger.tiff",
              {Dir{.w = 2, .h = 1, .tileW = 32, .tileH = 32, .compression = COMPRESSION_ADOBE_DEFLATE}});
    writeTiff("tile-16.tiff", {Dir{.w = 40, .h = 33, .tileW = 16, .tileH = 16, .compression = COMPRESSION_LZW}});
    writeTiff("tile-wide.tiff", {Dir{.w = 520, .h = 20, .tileW = 512, .tileH = 16, .compression = COMPRESSION_LZW}});
    // JPEG tiles that decode to another size than the tile's.
    writeTiff("jpeg-wrong-size.tiff", {Dir{.w = 256,
                                           .h = 128,
                                           .tileW = 128,
                                           .tileH = 128,
                                           .compression = COMPRESSION_JPEG,
                                           .rawTile = [](uint32_t col, uint32_t) {
                                               return col == 0 ? jpeg(64, 128, 50, TJSAMP_420)
                                                               : jpeg(128, 128, 50, TJSAMP_444);
                                           }}});

    // Broken structure, patched into the files above.
    patchTiff("aperio-jpeg.svs", "loop-self.svs", [](TiffPatch& p) { p.setNext(0, p.ifds()[0]); });
    patchTiff("aperio-jpeg.svs", "loop-back.svs", [](TiffPatch& p) { p.setNext(4, p.ifds()[1]); });
    patchTiff("generic-8.tiff", "loop-generic.tiff", [](TiffPatch& p) { p.setNext(2, p.ifds()[0]); });
    patchTiff("generic-8.tiff", "next-past-end.tiff", [](TiffPatch& p) { p.setNext(0, uint32_t(p.b.size() + 4096)); });
    patchTiff("aperio-jpeg.svs", "tile-offset-past-end.svs", [](TiffPatch& p) {
        p.setElement(0, TIFFTAG_TILEOFFSETS, 1, uint32_t(p.b.size() + 100));
        p.setElement(0, TIFFTAG_TILEBYTECOUNTS, 2, 0xfffffff0u);
    });
    patchTiff("generic-1.tiff", "tile-offset-past-end.tiff",
              [](TiffPatch& p) { p.setElement(0, TIFFTAG_TILEOFFSETS, 0, uint32_t(p.b.size() - 10)); });
    patchTiff("aperio-jpeg.svs", "absurd-width.svs", [](TiffPatch& p) { p.set(0, TIFFTAG_IMAGEWIDTH, 0x7fffffff); });
    patchTiff("aperio-jpeg.svs", "absurd-label.svs", [](TiffPatch& p) {
        p.set(3, TIFFTAG_IMAGEWIDTH, 60000);
        p.set(3, TIFFTAG_IMAGELENGTH, 60000);
    });
    patchTiff("generic-8.tiff", "zero-height.tiff", [](TiffPatch& p) { p.set(1, TIFFTAG_IMAGELENGTH, 0); });
    patchTiff("generic-8.tiff", "tile-zero.tiff", [](TiffPatch& p) { p.set(0, TIFFTAG_TILEWIDTH, 0); });
    patchTiff("generic-8.tiff", "tile-huge.tiff", [](TiffPatch& p) {
        p.set(0, TIFFTAG_TILEWIDTH, 65536);
        p.set(0, TIFFTAG_TILELENGTH, 65536);
    });
    patchTiff("generic-1.tiff", "tile-not-16.tiff", [](TiffPatch& p) { p.set(0, TIFFTAG_TILEWIDTH, 100); });
    patchTiff("aperio-jpeg.svs", "jpegtables-truncated.svs",
              [](TiffPatch& p) { p.setCount(0, TIFFTAG_JPEGTABLES, 20); });
    patchTiff("aperio-jpeg.svs", "jpeg-photometric-rgb.svs",
              [](TiffPatch& p) { p.set(0, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_RGB); });
    patchTiff("aperio-jpeg.svs", "bps-16.svs", [](TiffPatch& p) { p.set(2, TIFFTAG_BITSPERSAMPLE, 16); });
    patchTiff("generic-1.tiff", "spp-2.tiff", [](TiffPatch& p) { p.set(0, TIFFTAG_SAMPLESPERPIXEL, 2); });
    patchTiff("aperio-jp2k-33003.svs", "jp2k-bytecount-zero.svs",
              [](TiffPatch& p) { p.setElement(0, TIFFTAG_TILEBYTECOUNTS, 0, 0); });
    patchTiff("aperio-jp2k-33005.svs", "jp2k-compression-33004.svs",
              [](TiffPatch& p) { p.set(0, TIFFTAG_COMPRESSION, 33004); });
}

// Writes the raw JPEG 2000 tiles (at most `limit`) of each 33003/33005 directory of `path`.
void extractJp2kTiles(const std::string& path, size_t limit) {
    TIFFSetErrorHandler(nullptr); // the shared slides include broken ones on purpose
    TIFFSetWarningHandler(nullptr);
    TIFF* t = TIFFOpen(path.c_str(), "rm");
    if (!t) return;
    const std::string base =
        std::string(std::strrchr(path.c_str(), '/') ? std::strrchr(path.c_str(), '/') + 1 : path.c_str());
    size_t n = 0;
    do {
        uint16_t c = 0;
        TIFFGetFieldDefaulted(t, TIFFTAG_COMPRESSION, &c);
        if (!TIFFIsTiled(t) || (c != kAperioJp2kYCbCr && c != kAperioJp2kRgb)) continue;
        const ttile_t tiles = TIFFNumberOfTiles(t);
        for (ttile_t i = 0; i < tiles && n < limit; i += std::max<ttile_t>(1, tiles / 3)) {
            const uint64_t size = TIFFGetStrileByteCount(t, i);
            if (size == 0 || size > (1u << 20)) continue;
            Bytes raw(size);
            if (TIFFReadRawTile(t, i, raw.data(), tmsize_t(size)) != tmsize_t(size)) continue;
            save("tile-" + base + "-" + std::to_string(TIFFCurrentDirectory(t)) + "-" + std::to_string(i) + ".j2k",
                 raw);
            ++n;
        }
    } while (TIFFReadDirectory(t));
    TIFFClose(t);
}

void jp2kSeeds(const std::vector<std::string>& slides) {
    save("rgb-64-lossless.j2k", j2k({}));
    save("rgb-64-lossy-mct.j2k", j2k({.lossless = false, .mct = true}));
    save("ycc-240.j2k", j2k({.w = 240, .h = 240, .lossless = false, .resolutions = 5}));
    save("one-pixel.j2k", j2k({.w = 1, .h = 1, .resolutions = 1}));
    save("odd-33x17.j2k", j2k({.w = 33, .h = 17, .resolutions = 2}));
    save("subsampled-420.j2k", j2k({.w = 64, .h = 48, .dx = 2, .dy = 2}));
    save("subsampled-422.j2k", j2k({.w = 50, .h = 20, .dx = 2, .dy = 1, .lossless = false}));
    save("tiled-4.j2k", j2k({.w = 96, .h = 96, .tileW = 48, .tileH = 48}));
    save("precision-12.j2k", j2k({.w = 32, .h = 32, .precision = 12}));
    save("precision-16-signed.j2k", j2k({.w = 32, .h = 32, .precision = 16, .sign = true}));
    save("precision-4.j2k", j2k({.w = 32, .h = 32, .precision = 4}));
    save("grey.j2k", j2k({.w = 32, .h = 32, .comps = 1}));
    save("rgba.j2k", j2k({.w = 32, .h = 32, .comps = 4}));
    save("layers-rpcl-sop-eph.j2k",
         j2k({.w = 64, .h = 64, .lossless = false, .order = OPJ_RPCL, .layers = 3, .sop = true, .eph = true}));
    save("pcrl-cblk-16.j2k", j2k({.w = 64, .h = 64, .order = OPJ_PCRL, .cblk = 16}));
    save("cprl-resolutions-6.j2k", j2k({.w = 128, .h = 128, .lossless = false, .resolutions = 6, .order = OPJ_CPRL}));
    for (const std::string& s : slides) extractJp2kTiles(s, 4);
}

// ------------------------------------------------------------------------------------------
// ICC profiles
// ------------------------------------------------------------------------------------------

Bytes profileBytes(cmsHPROFILE p) {
    if (!p) die("LittleCMS could not make a profile");
    cmsUInt32Number n = 0;
    if (!cmsSaveProfileToMem(p, nullptr, &n)) die("cmsSaveProfileToMem");
    Bytes b(n);
    if (!cmsSaveProfileToMem(p, b.data(), &n)) die("cmsSaveProfileToMem");
    cmsCloseProfile(p);
    return b;
}

void describe(cmsHPROFILE p, const char* text) {
    cmsMLU* mlu = cmsMLUalloc(nullptr, 2);
    cmsMLUsetASCII(mlu, "en", "US", text);
    cmsMLUsetASCII(mlu, "de", "DE", "deutsch");
    cmsWriteTag(p, cmsSigProfileDescriptionTag, mlu);
    cmsMLUfree(mlu);
}

cmsHPROFILE matrixShaper(cmsToneCurve* curve, const cmsCIExyY& white, const cmsCIExyYTRIPLE& primaries) {
    cmsToneCurve* curves[3] = {curve, curve, curve};
    cmsHPROFILE p = cmsCreateRGBProfile(&white, &primaries, curves);
    cmsFreeToneCurve(curve);
    return p;
}

// The profiles embedded in a TIFF/SVS (tag 34675, every directory) or a DICOM file (0028,2000
// at the top level and in the Optical Path Sequence).
void extractProfiles(const std::string& path) {
    const std::string base = std::strrchr(path.c_str(), '/') ? std::strrchr(path.c_str(), '/') + 1 : path;
    TIFFSetErrorHandler(nullptr);
    TIFFSetWarningHandler(nullptr);
    if (TIFF* t = TIFFOpen(path.c_str(), "rm")) {
        int dir = 0;
        do {
            uint32_t n = 0;
            void* icc = nullptr;
            if (TIFFGetField(t, TIFFTAG_ICCPROFILE, &n, &icc) && icc && n)
                save("embedded-" + base + "-" + std::to_string(dir) + ".icc",
                     Bytes(static_cast<uint8_t*>(icc), static_cast<uint8_t*>(icc) + n));
            ++dir;
        } while (TIFFReadDirectory(t));
        TIFFClose(t);
        return;
    }
    OFLog::getLogger("dcmtk.dcmdata").setLogLevel(OFLogger::FATAL_LOG_LEVEL); // broken files on purpose
    DcmFileFormat ff;
    if (ff.loadFile(OFFilename(path.c_str())).bad()) return;
    const Uint8* bytes = nullptr;
    unsigned long n = 0;
    DcmItem* path0 = nullptr;
    if (ff.getDataset()->findAndGetSequenceItem(DCM_OpticalPathSequence, path0, 0).good() && path0 &&
        path0->findAndGetUint8Array(DCM_ICCProfile, bytes, &n).good() && bytes && n)
        save("embedded-" + base + ".icc", Bytes(bytes, bytes + n));
    else if (ff.getDataset()->findAndGetUint8Array(DCM_ICCProfile, bytes, &n).good() && bytes && n)
        save("embedded-" + base + ".icc", Bytes(bytes, bytes + n));
}

void iccSeeds(const std::vector<std::string>& slides) {
    const cmsCIExyY d65 = {0.3127, 0.3290, 1.0};
    const cmsCIExyY d50 = {0.3457, 0.3585, 1.0};
    const cmsCIExyYTRIPLE srgbPrim = {{0.64, 0.33, 1}, {0.30, 0.60, 1}, {0.15, 0.06, 1}};
    const cmsCIExyYTRIPLE widePrim = {{0.7347, 0.2653, 1}, {0.1152, 0.8264, 1}, {0.1566, 0.0177, 1}};

    {
        cmsHPROFILE p = cmsCreate_sRGBProfile();
        describe(p, "sRGB v4 from LittleCMS");
        save("srgb-v4.icc", profileBytes(p));
    }
    {
        cmsHPROFILE p = cmsCreate_sRGBProfile();
        cmsSetProfileVersion(p, 2.1);
        save("srgb-v2.icc", profileBytes(p));
    }
    save("gamma22-adobe-like.icc", profileBytes(matrixShaper(cmsBuildGamma(nullptr, 2.2), d65,
                                                             {{0.64, 0.33, 1}, {0.21, 0.71, 1}, {0.15, 0.06, 1}})));
    {
        // Strong curves: a parametric type 4 (sRGB-like with an odd knee), and a tabulated
        // 4096-entry S-curve, on wide-gamut primaries.
        const double params[] = {3.0, 0.8, 0.2, 0.3, 0.2};
        save("parametric-type4-wide.icc",
             profileBytes(matrixShaper(cmsBuildParametricToneCurve(nullptr, 4, params), d50, widePrim)));
        std::vector<cmsUInt16Number> table(4096);
        for (size_t i = 0; i < table.size(); ++i) {
            const double x = double(i) / 4095.0;
            table[i] = cmsUInt16Number(65535.0 * (x * x * (3 - 2 * x)));
        }
        cmsHPROFILE p = matrixShaper(cmsBuildTabulatedToneCurve16(nullptr, 4096, table.data()), d65, srgbPrim);
        describe(p,
                 "S-curve \x01\x7f control characters and a long text that goes on and on and on and on and "
                 "on and on and on and on and on and on and on and on and on and on and on and on and on and on and "
                 "on and on and on and on and on and on and on and on and on and on and on and on and on and on end");
        save("tabulated-s-curve.icc", profileBytes(p));
    }
    {
        // A LUT-based RGB profile: AToB0 and BToA0 pipelines with a 9-point CLUT.
        cmsHPROFILE p = cmsCreateProfilePlaceholder(nullptr);
        cmsSetProfileVersion(p, 2.1);
        cmsSetDeviceClass(p, cmsSigDisplayClass);
        cmsSetColorSpace(p, cmsSigRgbData);
        cmsSetPCS(p, cmsSigLabData);
        cmsHPROFILE srgb = cmsCreate_sRGBProfile();
        cmsHPROFILE lab = cmsCreateLab4Profile(nullptr);
        cmsHTRANSFORM toLab = cmsCreateTransform(srgb, TYPE_RGB_16, lab, TYPE_Lab_16, INTENT_PERCEPTUAL, 0);
        cmsHTRANSFORM fromLab = cmsCreateTransform(lab, TYPE_Lab_16, srgb, TYPE_RGB_16, INTENT_PERCEPTUAL, 0);
        const auto clutPipe = [](cmsHTRANSFORM xf, cmsUInt32Number in, cmsUInt32Number out) {
            cmsPipeline* pipe = cmsPipelineAlloc(nullptr, in, out);
            cmsStage* clut = cmsStageAllocCLut16bit(nullptr, 9, in, out, nullptr);
            cmsStageSampleCLut16bit(
                clut,
                [](const cmsUInt16Number inV[], cmsUInt16Number outV[], void* cargo) -> cmsInt32Number {
                    cmsDoTransform(static_cast<cmsHTRANSFORM>(cargo), inV, outV, 1);
                    return 1;
                },
                xf, 0);
            cmsPipelineInsertStage(pipe, cmsAT_END, clut);
            return pipe;
        };
        cmsPipeline* a2b = clutPipe(toLab, 3, 3);
        cmsPipeline* b2a = clutPipe(fromLab, 3, 3);
        cmsWriteTag(p, cmsSigAToB0Tag, a2b);
        cmsWriteTag(p, cmsSigBToA0Tag, b2a);
        cmsWriteTag(p, cmsSigMediaWhitePointTag, cmsD50_XYZ());
        describe(p, "CLUT RGB");
        cmsPipelineFree(a2b);
        cmsPipelineFree(b2a);
        cmsDeleteTransform(toLab);
        cmsDeleteTransform(fromLab);
        cmsCloseProfile(lab);
        cmsCloseProfile(srgb);
        save("clut-rgb-v2.icc", profileBytes(p));
    }
    // Profiles the engine refuses: not RGB, or a class that cannot be one end of a transform.
    save("lab-v4.icc", profileBytes(cmsCreateLab4Profile(nullptr)));
    save("lab-v2.icc", profileBytes(cmsCreateLab2Profile(nullptr)));
    save("xyz.icc", profileBytes(cmsCreateXYZProfile()));
    {
        cmsToneCurve* g = cmsBuildGamma(nullptr, 1.8);
        save("grey-gamma18.icc", profileBytes(cmsCreateGrayProfile(cmsD50_xyY(), g)));
        cmsFreeToneCurve(g);
    }
    save("abstract-bchsw.icc", profileBytes(cmsCreateBCHSWabstractProfile(9, 0.9, 1.1, 10, 1.2, 5000, 6500)));
    save("null.icc", profileBytes(cmsCreateNULLProfile()));
    {
        cmsHPROFILE a = cmsCreate_sRGBProfile();
        cmsHPROFILE b = matrixShaper(cmsBuildGamma(nullptr, 2.2), d65, widePrim);
        cmsHTRANSFORM xf = cmsCreateTransform(a, TYPE_RGB_8, b, TYPE_RGB_8, INTENT_PERCEPTUAL, 0);
        save("devicelink-rgb.icc", profileBytes(cmsTransform2DeviceLink(xf, 4.3, 0)));
        cmsDeleteTransform(xf);
        cmsCloseProfile(a);
        cmsCloseProfile(b);
    }
    for (const std::string& s : slides) extractProfiles(s);
}

// ------------------------------------------------------------------------------------------
// Pyramid descriptions: fuzz_pyramid reads its input with FuzzedDataProvider, so any bytes
// describe some source; these are a few of every length class.
// ------------------------------------------------------------------------------------------

void pyramidSeeds() {
    std::mt19937 rng(20240914);
    for (int i = 0; i < 24; ++i) {
        Bytes b(size_t(8 + 6 * i));
        for (uint8_t& v : b) v = uint8_t(rng());
        save("random-" + std::to_string(i) + ".bin", b);
    }
}

// ------------------------------------------------------------------------------------------
// DICOM
// ------------------------------------------------------------------------------------------

enum class Frames { Jpeg, Jp2k, NativeRgb, NativePlanar, NativeGrey };

struct DicomSpec {
    std::string series = "1.2.826.0.1.3680043.10.1001.1";
    std::string instance = "1.2.826.0.1.3680043.10.1001.1.1";
    std::string flavour = "VOLUME";
    Frames frames = Frames::Jpeg;
    E_TransferSyntax xfer = EXS_JPEGProcess1;
    uint32_t totalW = 300, totalH = 200, frameW = 128, frameH = 128;
    bool sparse = false;     // TILED_SPARSE with a Plane Position per frame (one position left empty)
    bool offsetTable = true; // Basic Offset Table (encapsulated)
    size_t fragmentKb = 0;   // split frames into fragments of this many KiB (0: one fragment a frame)
    Bytes icc;
    uint16_t concatenation = 0;              // In-concatenation number (0: none), of 2
    uint32_t firstFrame = 0, frameCount = 0; // the frames this file holds (count 0: all)
};

Bytes frameBytes(const DicomSpec& s, uint32_t x0, uint32_t y0) {
    switch (s.frames) {
    case Frames::Jpeg: return jpeg(int(s.frameW), int(s.frameH), 40, TJSAMP_422);
    case Frames::Jp2k: return j2k({.w = s.frameW, .h = s.frameH, .lossless = false, .resolutions = 3, .mct = true});
    case Frames::NativeRgb:
    case Frames::NativePlanar:
    case Frames::NativeGrey: break;
    }
    const bool grey = s.frames == Frames::NativeGrey, planar = s.frames == Frames::NativePlanar;
    const size_t plane = size_t(s.frameW) * s.frameH;
    Bytes b(plane * (grey ? 1 : 3));
    for (uint32_t y = 0; y < s.frameH; ++y)
        for (uint32_t x = 0; x < s.frameW; ++x)
            for (uint32_t c = 0; c < (grey ? 1u : 3u); ++c)
                b[planar ? c * plane + y * s.frameW + x : (y * s.frameW + x) * (grey ? 1 : 3) + c] =
                    pattern(x0 + x, y0 + y, c);
    return b;
}

Bytes dicomFile(const DicomSpec& s) {
    DcmFileFormat ff;
    DcmDataset* ds = ff.getDataset();
    const bool native =
        s.frames == Frames::NativeRgb || s.frames == Frames::NativePlanar || s.frames == Frames::NativeGrey;
    const bool grey = s.frames == Frames::NativeGrey;
    const uint32_t across = (s.totalW + s.frameW - 1) / s.frameW, down = (s.totalH + s.frameH - 1) / s.frameH;
    std::vector<std::pair<uint32_t, uint32_t>> origins; // each frame's top-left
    for (uint32_t r = 0; r < down; ++r)
        for (uint32_t c = 0; c < across; ++c) origins.emplace_back(c * s.frameW, r * s.frameH);
    if (s.sparse) origins.erase(origins.begin() + 1); // a missing frame: background
    if (s.frameCount) origins = {origins.begin() + s.firstFrame, origins.begin() + s.firstFrame + s.frameCount};
    const uint32_t frames = uint32_t(origins.size());
    ds->putAndInsertString(DCM_SOPClassUID, "1.2.840.10008.5.1.4.1.1.77.1.6");
    ds->putAndInsertString(DCM_SOPInstanceUID, s.instance.c_str());
    ds->putAndInsertString(DCM_StudyInstanceUID, "1.2.826.0.1.3680043.10.1001");
    ds->putAndInsertString(DCM_SeriesInstanceUID, s.series.c_str());
    ds->putAndInsertString(DCM_Modality, "SM");
    ds->putAndInsertString(DCM_Manufacturer, "Iris View fuzz seeds");
    ds->putAndInsertString(DCM_ImageType, ("DERIVED\\PRIMARY\\" + s.flavour + "\\NONE").c_str());
    ds->putAndInsertUint16(DCM_Rows, uint16_t(s.frameH));
    ds->putAndInsertUint16(DCM_Columns, uint16_t(s.frameW));
    ds->putAndInsertUint16(DCM_SamplesPerPixel, grey ? 1 : 3);
    ds->putAndInsertString(DCM_PhotometricInterpretation, grey                       ? "MONOCHROME2"
                                                          : s.frames == Frames::Jpeg ? "YBR_FULL_422"
                                                                                     : "RGB");
    if (!grey) ds->putAndInsertUint16(DCM_PlanarConfiguration, s.frames == Frames::NativePlanar ? 1 : 0);
    ds->putAndInsertUint16(DCM_BitsAllocated, 8);
    ds->putAndInsertUint16(DCM_BitsStored, 8);
    ds->putAndInsertUint16(DCM_HighBit, 7);
    ds->putAndInsertUint16(DCM_PixelRepresentation, 0);
    ds->putAndInsertString(DCM_NumberOfFrames, std::to_string(frames).c_str());
    ds->putAndInsertUint32(DCM_TotalPixelMatrixColumns, s.totalW);
    ds->putAndInsertUint32(DCM_TotalPixelMatrixRows, s.totalH);
    ds->putAndInsertString(DCM_DimensionOrganizationType, s.sparse ? "TILED_SPARSE" : "TILED_FULL");
    if (s.concatenation) {
        ds->putAndInsertString(DCM_ConcatenationUID, "1.2.826.0.1.3680043.10.1001.9");
        ds->putAndInsertUint16(DCM_InConcatenationNumber, s.concatenation);
        ds->putAndInsertUint16(DCM_InConcatenationTotalNumber, 2);
        ds->putAndInsertUint32(DCM_ConcatenationFrameOffsetNumber, s.firstFrame);
    }
    {
        DcmItem* shared = nullptr;
        ds->findOrCreateSequenceItem(DCM_SharedFunctionalGroupsSequence, shared, 0);
        DcmItem* measures = nullptr;
        shared->findOrCreateSequenceItem(DCM_PixelMeasuresSequence, measures, 0);
        measures->putAndInsertString(DCM_PixelSpacing, "0.000499\\0.000501");
        DcmItem* path = nullptr;
        ds->findOrCreateSequenceItem(DCM_OpticalPathSequence, path, 0);
        path->putAndInsertString(DCM_ObjectiveLensPower, "20");
        if (!s.icc.empty()) path->putAndInsertUint8Array(DCM_ICCProfile, s.icc.data(), s.icc.size());
        DcmItem* specimen = nullptr;
        ds->findOrCreateSequenceItem(DCM_SpecimenDescriptionSequence, specimen, 0);
        specimen->putAndInsertString(DCM_SpecimenIdentifier, "FUZZ-1");
    }
    if (s.sparse) {
        for (uint32_t f = 0; f < frames; ++f) {
            DcmItem* item = nullptr;
            ds->findOrCreateSequenceItem(DCM_PerFrameFunctionalGroupsSequence, item, long(f));
            DcmItem* pos = nullptr;
            item->findOrCreateSequenceItem(DCM_PlanePositionSlideSequence, pos, 0);
            pos->putAndInsertSint32(DCM_ColumnPositionInTotalImagePixelMatrix, Sint32(origins[f].first + 1));
            pos->putAndInsertSint32(DCM_RowPositionInTotalImagePixelMatrix, Sint32(origins[f].second + 1));
        }
    }
    if (native) {
        Bytes all;
        for (const auto& [x, y] : origins) {
            const Bytes f = frameBytes(s, x, y);
            all.insert(all.end(), f.begin(), f.end());
        }
        ds->putAndInsertUint8Array(DCM_PixelData, all.data(), all.size());
    } else {
        auto* seq = new DcmPixelSequence(DCM_PixelSequenceTag);
        auto* bot = new DcmPixelItem(DCM_PixelItemTag);
        seq->insert(bot);
        DcmOffsetList offsets;
        for (const auto& [x, y] : origins) {
            Bytes f = frameBytes(s, x, y);
            if (f.size() & 1) f.push_back(0);
            if (seq->storeCompressedFrame(offsets, f.data(), Uint32(f.size()), Uint32(s.fragmentKb)).bad())
                die("DCMTK cannot store a frame");
        }
        if (s.offsetTable) bot->createOffsetTable(offsets);
        auto* pd = new DcmPixelData(DCM_PixelData);
        pd->putOriginalRepresentation(s.xfer, nullptr, seq);
        ds->insert(pd, true);
    }
    const std::string tmp = g_out + "/.dicom.tmp";
    if (ff.saveFile(OFFilename(tmp.c_str()), s.xfer).bad()) die("DCMTK cannot write " + tmp);
    Bytes b = load(tmp);
    std::remove(tmp.c_str());
    return b;
}

// Several files as one input of fuzz_dicom_file: its series marker, then the files, each after
// the separator (fuzz_dicom_file.cpp reads it back).
Bytes series(const std::vector<Bytes>& files) {
    static const std::string kMarker = "IRIS-FUZZ-DICOM-SERIES\n", kSeparator = "\n--iris-fuzz-next-file--\n";
    Bytes b(kMarker.begin(), kMarker.end());
    for (size_t i = 0; i < files.size(); ++i) {
        if (i) b.insert(b.end(), kSeparator.begin(), kSeparator.end());
        b.insert(b.end(), files[i].begin(), files[i].end());
    }
    return b;
}

void dicomSeeds() {
    cmsHPROFILE srgb = cmsCreate_sRGBProfile();
    const Bytes icc = profileBytes(srgb);
    save("jpeg-tiled-full.dcm", dicomFile({.icc = icc}));
    save("jpeg-256.dcm", dicomFile({.totalW = 400, .totalH = 260, .frameW = 256, .frameH = 256}));
    save("jpeg-sparse.dcm", dicomFile({.sparse = true}));
    save("jpeg-no-offset-table-fragments.dcm", dicomFile({.offsetTable = false, .fragmentKb = 1}));
    save("jp2k.dcm", dicomFile({.frames = Frames::Jp2k, .xfer = EXS_JPEG2000, .frameW = 96, .frameH = 64}));
    save("native-rgb-explicit.dcm", dicomFile({.frames = Frames::NativeRgb,
                                               .xfer = EXS_LittleEndianExplicit,
                                               .totalW = 100,
                                               .totalH = 70,
                                               .frameW = 64,
                                               .frameH = 64}));
    save("native-planar-implicit.dcm", dicomFile({.frames = Frames::NativePlanar,
                                                  .xfer = EXS_LittleEndianImplicit,
                                                  .totalW = 80,
                                                  .totalH = 40,
                                                  .frameW = 32,
                                                  .frameH = 32}));
    save("native-grey-sparse.dcm", dicomFile({.frames = Frames::NativeGrey,
                                              .xfer = EXS_LittleEndianExplicit,
                                              .totalW = 96,
                                              .totalH = 96,
                                              .frameW = 32,
                                              .frameH = 48,
                                              .sparse = true}));
    save("label-only.dcm", dicomFile({.flavour = "LABEL", .totalW = 100, .totalH = 60, .frameW = 100, .frameH = 60}));
    // Series: two levels, a label and a thumbnail; a level split over a concatenation of two files.
    const auto part = [](int i) { return "1.2.826.0.1.3680043.10.1001.1." + std::to_string(10 + i); };
    save("series-levels-label.bin",
         series({dicomFile({.instance = part(1), .totalW = 512, .totalH = 300}),
                 dicomFile({.instance = part(2), .totalW = 128, .totalH = 75, .frameW = 128, .frameH = 128}),
                 dicomFile(
                     {.instance = part(3), .flavour = "LABEL", .totalW = 64, .totalH = 40, .frameW = 64, .frameH = 40}),
                 dicomFile({.instance = part(4),
                            .flavour = "THUMBNAIL",
                            .frames = Frames::NativeRgb,
                            .xfer = EXS_LittleEndianExplicit,
                            .totalW = 64,
                            .totalH = 37,
                            .frameW = 64,
                            .frameH = 37})}));
    save("series-odd-shapes.bin",
         series({dicomFile({.instance = part(5), .totalW = 100, .totalH = 100, .frameW = 100, .frameH = 100}),
                 dicomFile({.instance = part(6), .totalW = 999, .totalH = 1, .frameW = 256, .frameH = 1}),
                 dicomFile({.instance = part(7), .totalW = 30, .totalH = 30, .frameW = 30, .frameH = 30})}));
    save("series-concatenation.bin",
         series({dicomFile({.instance = part(8), .totalW = 256, .totalH = 128, .concatenation = 1, .frameCount = 1}),
                 dicomFile({.instance = part(9),
                            .totalW = 256,
                            .totalH = 128,
                            .concatenation = 2,
                            .firstFrame = 1,
                            .frameCount = 1})}));
}

} // namespace

int main(int argc, char** argv) {
    if (argc < 3) {
        std::fprintf(stderr, "usage: fuzz_seeds tiff|jp2k|icc|pyramid|dicom OUT_DIR [SLIDE…]\n");
        return 2;
    }
    const std::string what = argv[1];
    g_out = argv[2];
    const std::vector<std::string> slides(argv + 3, argv + argc);
    if (what == "tiff")
        tiffSeeds();
    else if (what == "jp2k")
        jp2kSeeds(slides);
    else if (what == "icc")
        iccSeeds(slides);
    else if (what == "pyramid")
        pyramidSeeds();
    else if (what == "dicom")
        dicomSeeds();
    else
        die("unknown corpus '" + what + "'");
    std::printf("fuzz_seeds: %d %s seed(s) in %s\n", g_count, what.c_str(), g_out.c_str());
    return 0;
}
