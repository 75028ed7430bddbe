// Writes the seed corpus of fuzz_raster_map into OUT_DIR (CTest's fuzz.raster_map.seeds, before
// the replay): small map files of every format and layout the loaders read, written with the
// same writers as unit.layers (tests/layers/raster_writers.h), and a text colour map.
//
//   fuzz_raster_seeds OUT_DIR
//
// PNG: 8- and 16-bit grey, 4-bit grey, palette with tRNS, RGB, 16-bit RGBA, grey+alpha, an
// interlaced one. TIFF: float32 strips with NaN, deflated float32 tiles, uint16 label tiles,
// int8, float64, RGB, premultiplied RGBA, palette; pyramids as SubIFDs, as a BigTIFF IFD chain,
// and one mixed with a thumbnail and a mask. .npy: versions 1.0, 2.0 and 3.0, every dtype the
// reader takes in both byte orders, Fortran order, NaN.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "raster_writers.h"

namespace rw = raster_writers;

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: %s OUT_DIR\n", argv[0]);
        return 2;
    }
    const std::string dir = argv[1];
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    bool ok = true;
    auto path = [&](const std::string& f) { return dir + "/" + f; };
    auto ramp = [](size_t n, int mul) {
        std::vector<uint8_t> v(n);
        for (size_t i = 0; i < n; ++i) v[i] = uint8_t(i * mul);
        return v;
    };

    // --- PNG ---
    ok &= rw::writePng(path("grey8.png"), {12, 10, PNG_COLOR_TYPE_GRAY, 8, false, ramp(120, 2)});
    ok &= rw::writePng(path("grey16.png"), {6, 5, PNG_COLOR_TYPE_GRAY, 16, false, ramp(60, 37)});
    ok &= rw::writePng(path("grey4-interlaced.png"), {9, 9, PNG_COLOR_TYPE_GRAY, 4, true, ramp(45, 17)});
    rw::Png pal{8, 4, PNG_COLOR_TYPE_PALETTE, 8, false, ramp(32, 1)};
    for (int i = 0; i < 32; ++i) pal.palette.push_back({uint8_t(i * 8), uint8_t(255 - i * 8), 7});
    pal.trnsAlpha = {0, 64, 128};
    ok &= rw::writePng(path("palette.png"), pal);
    ok &= rw::writePng(path("rgb.png"), {5, 4, PNG_COLOR_TYPE_RGB, 8, false, ramp(60, 5)});
    ok &= rw::writePng(path("rgba16.png"), {3, 3, PNG_COLOR_TYPE_RGBA, 16, false, ramp(72, 11)});
    ok &= rw::writePng(path("grey-alpha.png"), {4, 4, PNG_COLOR_TYPE_GRAY_ALPHA, 8, false, ramp(32, 9)});
    ok &= rw::writePng(path("lut-strip.png"), {256, 1, PNG_COLOR_TYPE_RGB, 8, false, ramp(768, 1)});

    // --- TIFF ---
    using TI = rw::TiffImage;
    std::vector<float> f(24 * 20);
    for (size_t i = 0; i < f.size(); ++i) f[i] = std::sin(float(i) * 0.1f);
    f[5] = NAN;
    TI fs{24, 20, 1, 32, SAMPLEFORMAT_IEEEFP};
    fs.data = rw::rawBytes(f);
    ok &= rw::writeTiff(path("f32-strips.tif"), {fs});
    TI ft = fs;
    ft.tile = 16, ft.compression = COMPRESSION_ADOBE_DEFLATE;
    ok &= rw::writeTiff(path("f32-tiles-deflate.tif"), {ft});
    TI lab{20, 18, 1, 16};
    lab.tile = 16;
    std::vector<uint16_t> ids(20 * 18);
    for (size_t i = 0; i < ids.size(); ++i) ids[i] = uint16_t(i % 6);
    lab.data = rw::rawBytes(ids);
    ok &= rw::writeTiff(path("u16-label-tiles.tif"), {lab});
    TI i8{4, 4, 1, 8, SAMPLEFORMAT_INT};
    i8.data = ramp(16, 29);
    ok &= rw::writeTiff(path("i8.tif"), {i8});
    TI f64{3, 3, 1, 64, SAMPLEFORMAT_IEEEFP};
    f64.data = rw::rawBytes(std::vector<double>{0, 0.5, 1, 1.5, 2, 2.5, 3, -1, 1e10});
    ok &= rw::writeTiff(path("f64.tif"), {f64});
    TI rgb{6, 5, 3, 8, SAMPLEFORMAT_UINT, PHOTOMETRIC_RGB};
    rgb.data = ramp(90, 3);
    ok &= rw::writeTiff(path("rgb.tif"), {rgb});
    TI rgba{4, 4, 4, 8, SAMPLEFORMAT_UINT, PHOTOMETRIC_RGB, EXTRASAMPLE_ASSOCALPHA};
    rgba.data = ramp(64, 3);
    ok &= rw::writeTiff(path("rgba-premultiplied.tif"), {rgba});
    TI palette{4, 2, 1, 8, SAMPLEFORMAT_UINT, PHOTOMETRIC_PALETTE};
    palette.colormap.assign(3 * 256, 0x4000);
    palette.data = ramp(8, 1);
    ok &= rw::writeTiff(path("palette.tif"), {palette});
    const auto level = rw::floatLevel;
    const std::vector<TI> pyramid = {level(33, 20, 1), level(17, 10, 2), level(8, 5, 3)};
    ok &= rw::writeTiff(path("pyramid-subifd.tif"), pyramid, true);
    ok &= rw::writeTiff(path("pyramid-chain-bigtiff.tif"), pyramid, false, true);
    TI mask = level(10, 6, 9);
    mask.subfileType = FILETYPE_REDUCEDIMAGE | FILETYPE_MASK;
    ok &= rw::writeTiff(path("pyramid-mixed.tif"), {level(32, 20, 1), rgb, mask, level(16, 10, 2)});

    // --- .npy ---
    const std::vector<std::pair<std::string, std::vector<uint8_t>>> dtypes = {
        {"<f4", rw::rawBytes(std::vector<float>{0, 0.25f, NAN, 1, 2, 3})},
        {">f4", rw::rawBytes(std::vector<float>{0, 0.25f, NAN, 1, 2, 3}, true)},
        {"<f8", rw::rawBytes(std::vector<double>{0, 0.25, 1, 1, 2, -3})},
        {">f8", rw::rawBytes(std::vector<double>{0, 0.25, 1, 1, 2, -3}, true)},
        {"<f2", rw::rawBytes(std::vector<uint16_t>{0, 0x3c00, 0x7e00, 0x4000, 0x0001, 0xb800})},
        {"|u1", {0, 1, 2, 3, 4, 255}},
        {"|i1", {0, 1, 2, 3, 4, 0x80}},
        {"|b1", {0, 1, 1, 0, 1, 0}},
        {"<u2", rw::rawBytes(std::vector<uint16_t>{0, 1, 2, 3, 4, 65535})},
        {">i2", rw::rawBytes(std::vector<int16_t>{0, 1, 2, 3, 4, -2}, true)},
        {"<i4", rw::rawBytes(std::vector<int32_t>{0, 1, 2, 3, 4, 70000})},
        {"<u4", rw::rawBytes(std::vector<uint32_t>{0, 1, 2, 3, 4, 5})},
        {"<i8", rw::rawBytes(std::vector<int64_t>{0, 1, 2, 3, 4, -5})},
        {">u8", rw::rawBytes(std::vector<uint64_t>{0, 1, 2, 3, 4, 5}, true)},
    };
    for (int version = 1; version <= 3; ++version)
        for (const auto& [descr, data] : dtypes) {
            std::string stem = descr.substr(1) + (descr[0] == '>' ? "-be" : "");
            ok &= rw::writeBytes(path("v" + std::to_string(version) + "-" + stem + ".npy"),
                                 rw::npyBytes(descr, version == 2, "(2, 3)", data, version));
        }

    // --- a text colour map ---
    std::string lut = "# r g b a\n";
    for (int i = 0; i < 256; ++i) lut += std::to_string(i) + " " + std::to_string(255 - i) + " 9 255\n";
    ok &= rw::writeBytes(path("lut.txt"), std::vector<uint8_t>(lut.begin(), lut.end()));

    const auto count = std::distance(std::filesystem::directory_iterator(dir), std::filesystem::directory_iterator());
    std::printf("fuzz_raster_seeds: %ld seed(s) in %s\n", long(count), dir.c_str());
    if (!ok) std::fprintf(stderr, "fuzz_raster_seeds: a writer failed\n");
    return ok ? 0 : 1;
}
