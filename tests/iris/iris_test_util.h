// Helpers shared by the .iris suites (tst_iris_reader, tst_iris_roundtrip): where the test
// data and the output go, raw byte access to an .iris file by the spec's field offsets (the
// tests' own reading, independent of the engine's parser), PSNR, and one rendered frame.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <turbojpeg.h>

#include <iris/engine.h>

namespace iris_test {

namespace fs = std::filesystem;

// ---- locations ------------------------------------------------------------------------

// testdata/slides (IRIS_TESTDATA, else IRIS_TESTDATA_DEFAULT), when it holds `sub`.
inline std::optional<fs::path> slidesDir(const char* sub = "iris") {
    for (const char* var : {"IRIS_TESTDATA", "IRIS_TESTDATA_DEFAULT"}) {
        const char* v = std::getenv(var);
        if (!v || !*v) continue;
        std::error_code ec;
        const fs::path p = fs::path(v) / "slides";
        if (fs::is_directory(p / sub, ec)) return p;
    }
    return std::nullopt;
}

// testdata/slides/iris: the reference encoders' files.
inline std::optional<fs::path> irisDir() {
    if (auto s = slidesDir("iris")) return *s / "iris";
    return std::nullopt;
}
inline fs::path fixture(const char* name) { return irisDir().value_or(fs::path()) / name; }
inline fs::path sourceSlide(const char* name) { return irisDir().value_or(fs::path()).parent_path() / "aperio" / name; }

// $IRIS_TEST_OUT/sub (created), where a suite writes its files.
inline fs::path outDir(const char* sub = "iris") {
    const char* v = std::getenv("IRIS_TEST_OUT");
    fs::path p = (v && *v) ? fs::path(v) : fs::temp_directory_path() / "iris-test-out";
    p /= sub;
    std::error_code ec;
    fs::create_directories(p, ec);
    return p;
}

// ---- bytes ----------------------------------------------------------------------------

using Bytes = std::vector<uint8_t>;

inline Bytes readAll(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return Bytes(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Written under a temporary name and renamed, so that a file the engine still has mapped is
// never truncated under it.
inline bool writeAll(const fs::path& p, const Bytes& b) {
    const fs::path tmp = p.string() + ".tmp";
    {
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        out.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
        if (!out) return false;
    }
    std::error_code ec;
    fs::rename(tmp, p, ec);
    return !ec;
}

inline uint64_t get(const Bytes& b, uint64_t off, int n) {
    uint64_t v = 0;
    for (int i = n - 1; i >= 0; --i) v = (v << 8) | b.at(off + uint64_t(i));
    return v;
}

inline void put(Bytes& b, uint64_t off, uint64_t v, int n) {
    for (int i = 0; i < n; ++i) b.at(off + uint64_t(i)) = uint8_t(v >> (8 * i));
}

inline float getF32(const Bytes& b, uint64_t off) {
    const uint32_t u = uint32_t(get(b, off, 4));
    float f;
    std::memcpy(&f, &u, 4);
    return f;
}

inline void putF32(Bytes& b, uint64_t off, float f) {
    uint32_t u;
    std::memcpy(&u, &f, 4);
    put(b, off, u, 4);
}

inline void append(Bytes& b, uint64_t v, int n) {
    for (int i = 0; i < n; ++i) b.push_back(uint8_t(v >> (8 * i)));
}

constexpr uint64_t kNull = ~0ull;

// The tests' own reading of the block locations (field offsets from the spec's table).
struct Ife {
    Bytes b;
    uint64_t u(uint64_t off, int n) const { return get(b, off, n); }
    uint64_t tileTable() const { return u(22, 8); }
    uint64_t metadata() const { return u(30, 8); }
    uint64_t layerExtents() const { return u(tileTable() + 28, 8); }
    uint32_t layerCount() const { return uint32_t(u(layerExtents() + 12, 4)); }
    uint64_t layer(uint32_t i) const { return layerExtents() + 16 + i * u(layerExtents() + 10, 2); }
    uint64_t tileOffsets() const { return u(tileTable() + 20, 8); }
    uint64_t tileCount() const { return u(tileOffsets() + 12, 4); }
    uint64_t tileEntry(uint64_t i) const { return tileOffsets() + 16 + i * u(tileOffsets() + 10, 2); }
    uint64_t tileOffset(uint64_t i) const { return u(tileEntry(i), 5); }
    uint64_t tileSize(uint64_t i) const { return u(tileEntry(i) + 5, 3); }
    uint64_t attributes() const { return u(metadata() + 16, 8); }
    uint64_t attributeSizes() const { return u(attributes() + 13, 8); }
    uint64_t attributeBytes() const { return u(attributes() + 21, 8); }
    uint64_t images() const { return u(metadata() + 24, 8); }
    uint32_t imageCount() const { return images() == kNull ? 0 : uint32_t(u(images() + 12, 4)); }
    uint64_t imageEntry(uint32_t i) const { return images() + 16 + i * u(images() + 10, 2); }
    uint64_t icc() const { return u(metadata() + 32, 8); }
    void fixFileSize() { put(b, 6, b.size(), 8); }

    // The attributes as stored, in order.
    std::vector<std::pair<std::string, std::string>> attributeList() const {
        std::vector<std::pair<std::string, std::string>> out;
        if (attributes() == kNull) return out;
        const uint64_t sizes = attributeSizes();
        const uint16_t stride = uint16_t(u(sizes + 10, 2));
        const uint32_t count = uint32_t(u(sizes + 12, 4));
        uint64_t at = attributeBytes() + 14;
        for (uint32_t i = 0; i < count; ++i) {
            const uint64_t e = sizes + 16 + uint64_t(i) * stride;
            const uint64_t k = u(e, 2), v = u(e + 2, 4);
            out.emplace_back(std::string(b.begin() + long(at), b.begin() + long(at + k)),
                             std::string(b.begin() + long(at + k), b.begin() + long(at + k + v)));
            at += k + v;
        }
        return out;
    }

    // Copies an array block to the end of the file with entries `grow` bytes longer (the
    // new bytes hold 0xA5, standing for fields of a later version) and returns its offset.
    uint64_t appendWiderArray(uint64_t at, int grow) {
        const uint16_t stride = uint16_t(u(at + 10, 2));
        const uint32_t count = uint32_t(u(at + 12, 4));
        const uint16_t tag = uint16_t(u(at + 8, 2));
        const uint64_t off = b.size();
        append(b, off, 8);
        append(b, tag, 2);
        append(b, uint64_t(stride + grow), 2);
        append(b, count, 4);
        for (uint32_t i = 0; i < count; ++i) {
            const uint64_t e = at + 16 + uint64_t(i) * stride;
            for (uint16_t k = 0; k < stride; ++k) b.push_back(b[e + k]);
            for (int k = 0; k < grow; ++k) b.push_back(0xA5);
        }
        return off;
    }
};

// ---- images ---------------------------------------------------------------------------

// PSNR of RGB over the pixels where `where(x, y)` holds; +inf when identical, NaN when none.
inline double psnr(const iris::Image& a, const iris::Image& b, const std::function<bool(uint32_t, uint32_t)>& where,
                   uint64_t* compared = nullptr) {
    if (a.width != b.width || a.height != b.height) return std::numeric_limits<double>::quiet_NaN();
    double se = 0;
    uint64_t n = 0;
    for (uint32_t y = 0; y < a.height; ++y) {
        for (uint32_t x = 0; x < a.width; ++x) {
            if (where && !where(x, y)) continue;
            const size_t i = (size_t(y) * a.width + x) * 4;
            for (int c = 0; c < 3; ++c) {
                const double d = double(a.rgba[i + size_t(c)]) - double(b.rgba[i + size_t(c)]);
                se += d * d;
            }
            ++n;
        }
    }
    if (compared) *compared = n;
    if (n == 0) return std::numeric_limits<double>::quiet_NaN();
    const double mse = se / double(3 * n);
    return mse == 0 ? std::numeric_limits<double>::infinity() : 10.0 * std::log10(255.0 * 255.0 / mse);
}

// PSNR (over `where`) of the reference after a JPEG round trip with the given settings
// (TurboJPEG; quality 90 4:2:2 are the reference encoder's): what the codec alone costs on
// this content. NaN when TurboJPEG fails.
inline double honestPsnr(const iris::Image& ref, const std::function<bool(uint32_t, uint32_t)>& where,
                         int quality = 90, int subsamp = TJSAMP_422) {
    tjhandle c = tjInitCompress();
    tjhandle d = tjInitDecompress();
    unsigned char* jpeg = nullptr;
    unsigned long size = 0;
    iris::Image out = ref;
    double p = std::numeric_limits<double>::quiet_NaN();
    if (c && d &&
        tjCompress2(c, ref.rgba.data(), int(ref.width), 0, int(ref.height), TJPF_RGBA, &jpeg, &size, subsamp, quality,
                    0) == 0 &&
        tjDecompress2(d, jpeg, size, out.rgba.data(), int(ref.width), 0, int(ref.height), TJPF_RGBA, 0) == 0) {
        p = psnr(out, ref, where);
    }
    tjFree(jpeg);
    if (c) tjDestroy(c);
    if (d) tjDestroy(d);
    return p;
}

inline std::string describe(const iris::Result& r) {
    return std::string(iris::statusName(r.status())) + ": " + r.message();
}

// Sets the view whose top-left target pixel covers level-0 (x0, y0) and waits for its
// complete frame; the frame must be of the target's size and show exactly that view.
inline std::optional<iris::Frame> renderAt(iris::Engine& e, double x0, double y0, double ds, uint32_t w, uint32_t h,
                                           std::chrono::milliseconds timeout, std::string* why) {
    iris::View v;
    v.centerX = x0 + w * 0.5 * ds;
    v.centerY = y0 + h * 0.5 * ds;
    v.downsample = ds;
    e.setView(v);
    if (const iris::Result r = e.waitForFrame(timeout); !r.ok()) {
        *why = "waitForFrame: " + describe(r);
        return std::nullopt;
    }
    auto f = e.readFrame();
    if (!f) {
        *why = "readFrame: " + describe(f.error());
        return std::nullopt;
    }
    if (f->image.width != w || f->image.height != h || !f->complete) {
        *why = "the frame is incomplete or of the wrong size";
        return std::nullopt;
    }
    if (std::abs(f->view.centerX - v.centerX) > 1e-6 || std::abs(f->view.centerY - v.centerY) > 1e-6 ||
        std::abs(f->view.downsample - ds) > 1e-9) {
        *why = "the frame shows another view";
        return std::nullopt;
    }
    return std::move(f.value());
}

} // namespace iris_test
