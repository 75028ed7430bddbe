// engine.jpeg_gpu: the GPU half of a JPEG decode (gpu/jpeg_reconstruct.h: dequantisation, islow
// inverse DCT, fancy upsampling, YCbCr → RGB in two compute dispatches, from the coefficients
// slide/jpeg_coefficients.h reads) against libjpeg-turbo's own decode of the same stream
// (decodeJpegFrameRgba, the decode every CPU path of the engine makes): equal byte for byte.
//
// Cases:
//   synthetic      TurboJPEG-encoded pictures made to reach every corner of the arithmetic
//                  (smooth ramps, fine sinusoids, noise, saturated colours and hard edges that
//                  push the IDCT and the colour conversion into their clamps), in each layout
//                  the path takes (4:4:4, 4:2:2, 4:2:0, grey), at qualities 35, 90 and 100,
//                  baseline and progressive, at tile sizes 256, 240, 512×1024 and odd sizes
//                  whose chroma planes end mid-block;
//   mixedBatch     all of them in one batch of two dispatches: each tile's descriptor, planes
//                  and output are its own;
//   slideTiles     every JPEG tile (up to 200 a level) of the test slides (Aperio SVS, YCbCr
//                  and RGB JPEG, generic TIFF) and of the built-in sample slide, read raw with
//                  the directory's JPEGTables as the TIFF reader reads them, in batches of 32;
//   intoCallerMemory  the coefficients read packed into the caller's memory (jpegblocks),
//                  unpacked by the format's definition, equal those read into the result's
//                  own vector; rooms too small are refused;
//   records        the RAM cache's coefficient records: their header, which tiles fit a tile
//                  buffer (every layout when mostly zero; noise does not), and 4:2:0, 4:2:2,
//                  4:4:4 and grey records reconstructed with an edge tile's padding;
//   engineFrames   inside the engine: settled frames with JPEG tiles finished on the GPU equal
//                  those decoded on the CPU, from a TIFF, an SVS and .iris files (whose tiles
//                  are checked to be read as records);
//   refused        layouts the path does not take (4:1:1, 4:4:0) say UnsupportedFormat; a
//                  truncated stream, garbage and a stream of other dimensions say CorruptData.
// The Vulkan validation layer is on (where installed) and must stay silent.
// The engine's headers first: gpu/vk_util.h names a parameter `signals`, a macro of Qt's.
#include "gpu/device.h"
#include "gpu/jpeg_reconstruct.h"
#include "gpu/vk_util.h"
#include "slide/jpeg_coefficients.h"
#include "slide/iris_file.h"
#include "slide/jpeg_frame_decode.h"
#include "slide/tiff_source.h"

#include <QtTest>

#include <cstring>
#include <random>

#include <tiffio.h>
#include <turbojpeg.h>

#include "test_support.h"

using namespace iristest;
using iris::JpegCoefficients;
using iris::JpegColour;
using namespace std::chrono_literals;

namespace {

struct Stream {
    std::string name;
    std::vector<uint8_t> bytes;
    int width = 0;
    int height = 0;
    JpegColour colour = JpegColour::Auto;
};

// A picture that reaches the clamps: ramps, a fine sinusoid, noise, saturated patches and a
// hard-edged checker, all at once in different places.
std::vector<uint8_t> testPicture(int w, int h, uint32_t seed) {
    std::vector<uint8_t> rgb(size_t(w) * h * 3);
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> noise(-40, 40);
    static constexpr uint8_t kSaturated[6][3] = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {255, 255, 255}, {0, 0, 0}, {255, 0, 255}};
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            uint8_t* p = &rgb[(size_t(y) * w + x) * 3];
            const int region = ((x * 4) / std::max(w, 1) + 4 * ((y * 3) / std::max(h, 1))) % 5;
            for (int c = 0; c < 3; ++c) {
                int v = 0;
                switch (region) {
                case 0: v = (x * 255) / std::max(w - 1, 1) * (c != 1) + (y * 255) / std::max(h - 1, 1) * (c == 1); break;
                case 1: v = int(127.5 + 127.5 * std::sin(x * 1.9 + y * 0.7 + c)); break;
                case 2: v = 128 + (c - 1) * 60 + noise(rng); break;
                case 3: v = kSaturated[((x / 5) + (y / 7)) % 6][c]; break;
                default: v = ((x / 3 + y / 3) & 1) ? 255 : 0; break;
                }
                p[c] = uint8_t(std::clamp(v, 0, 255));
            }
        }
    return rgb;
}

// A picture like stained tissue at low power: smooth gradients and slow waves, whose blocks are
// mostly zero coefficients.
std::vector<uint8_t> smoothPicture(int w, int h) {
    std::vector<uint8_t> rgb(size_t(w) * h * 3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c)
                rgb[(size_t(y) * w + x) * 3 + size_t(c)] =
                    uint8_t(std::clamp(int(150 + 50 * std::sin(x * 0.05 + c) * std::cos(y * 0.04) + (x + y) / 8), 0, 255));
    return rgb;
}

// Uniform noise: every coefficient of every block non-zero at q100.
std::vector<uint8_t> noisePicture(int w, int h, uint32_t seed) {
    std::vector<uint8_t> rgb(size_t(w) * h * 3);
    std::mt19937 rng(seed);
    for (uint8_t& v : rgb) v = uint8_t(rng());
    return rgb;
}

Stream encodePicture(const std::vector<uint8_t>& rgb, int w, int h, int subsamp, int quality, bool progressive = false,
                     const char* what = "picture");

Stream encode(int w, int h, int subsamp, int quality, bool progressive, uint32_t seed) {
    return encodePicture(testPicture(w, h, seed), w, h, subsamp, quality, progressive, "");
}

Stream encodePicture(const std::vector<uint8_t>& rgb, int w, int h, int subsamp, int quality, bool progressive,
                     const char* what) {
    tjhandle tj = tjInitCompress();
    unsigned char* out = nullptr;
    unsigned long size = 0;
    const int flags = TJFLAG_ACCURATEDCT | (progressive ? TJFLAG_PROGRESSIVE : 0);
    Stream s;
    if (tj && tjCompress2(tj, rgb.data(), w, 0, h, TJPF_RGB, &out, &size, subsamp, quality, flags) == 0)
        s.bytes.assign(out, out + size);
    tjFree(out);
    if (tj) tjDestroy(tj);
    static const char* kNames[] = {"444", "422", "420", "gray", "440", "411"};
    s.name = std::string(kNames[subsamp]) + " q" + std::to_string(quality) + (progressive ? " progressive " : " ") +
             std::to_string(w) + "x" + std::to_string(h) + (*what ? std::string(" ") + what : std::string());
    s.width = w;
    s.height = h;
    return s;
}

// The JPEG tiles of a TIFF's tiled JPEG directories, as the TIFF reader reads them: the
// directory's JPEGTables (without their EOI), then the tile's stream after its SOI.
std::vector<Stream> tiffJpegTiles(const fs::path& path, uint32_t perLevel) {
    std::vector<Stream> out;
    TIFFSetWarningHandler(nullptr);
    TIFF* tif = TIFFOpen(path.c_str(), "rm");
    if (!tif) return out;
    int dir = 0;
    do {
        uint16_t compression = 0, photometric = 0, spp = 0, bps = 0;
        uint32_t tw = 0, th = 0;
        TIFFGetField(tif, TIFFTAG_COMPRESSION, &compression);
        TIFFGetField(tif, TIFFTAG_PHOTOMETRIC, &photometric);
        TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLESPERPIXEL, &spp);
        TIFFGetFieldDefaulted(tif, TIFFTAG_BITSPERSAMPLE, &bps);
        if (!TIFFIsTiled(tif) || compression != COMPRESSION_JPEG || spp != 3 || bps != 8 ||
            (photometric != PHOTOMETRIC_YCBCR && photometric != PHOTOMETRIC_RGB) || !TIFFGetField(tif, TIFFTAG_TILEWIDTH, &tw) ||
            !TIFFGetField(tif, TIFFTAG_TILELENGTH, &th)) {
            ++dir;
            continue;
        }
        std::vector<uint8_t> tables;
        uint32_t count = 0;
        void* data = nullptr;
        if (TIFFGetField(tif, TIFFTAG_JPEGTABLES, &count, &data) && data && count > 2)
            tables.assign(static_cast<uint8_t*>(data), static_cast<uint8_t*>(data) + count - 2);
        const uint32_t tiles = TIFFNumberOfTiles(tif);
        const uint32_t step = std::max<uint32_t>(1, tiles / perLevel);
        for (uint32_t t = 0; t < tiles && out.size() < size_t(perLevel) * (dir + 1); t += step) {
            const uint64_t bytes = TIFFGetStrileByteCount(tif, t);
            if (bytes < 4 || bytes > (16u << 20)) continue;
            std::vector<uint8_t> raw(bytes);
            if (TIFFReadRawTile(tif, t, raw.data(), tmsize_t(bytes)) != tmsize_t(bytes)) continue;
            Stream s;
            s.bytes = tables;
            s.bytes.insert(s.bytes.end(), raw.begin() + (tables.empty() ? 0 : 2), raw.end());
            s.width = int(tw);
            s.height = int(th);
            s.colour = photometric == PHOTOMETRIC_YCBCR ? JpegColour::YCbCr : JpegColour::Rgb;
            s.name = path.filename().string() + " dir " + std::to_string(dir) + " tile " + std::to_string(t);
            out.push_back(std::move(s));
        }
        ++dir;
    } while (TIFFReadDirectory(tif));
    TIFFClose(tif);
    return out;
}

} // namespace

class TestJpegGpu : public QObject {
    Q_OBJECT

    iris::Log log_{[](iris::LogLevel level, std::string_view line) {
        if (level >= iris::LogLevel::Warning) qWarning("%.*s", int(line.size()), line.data());
    }};
    std::unique_ptr<iris::gpu::Device> device_;
    std::unique_ptr<iris::gpu::JpegReconstruct> jpeg_;
    iris::vk::CommandPool pool_;
    VkCommandBuffer cmd_ = VK_NULL_HANDLE;
    iris::vk::Fence fence_;
    iris::vk::MappedBuffer input_, output_;
    iris::vk::Buffer planes_;
    iris::vk::Memory planesMemory_;
    VkDeviceSize planesBytes_ = 0;

    bool ensure(iris::vk::MappedBuffer& b, VkDeviceSize bytes, bool readBack) {
        if (b.size >= bytes) return true;
        return iris::vk::createMappedBuffer(device_->physical(), device_->device(), bytes,
                                            VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, readBack, b)
            .ok();
    }

    // Records and submits the two dispatches over the input, planes and output buffers, waits,
    // and makes the output visible to the host.
    bool dispatch(const iris::gpu::JpegReconstruct::Sizes& sizes, uint64_t inputWords, uint64_t outputWords) {
        if (!iris::vk::flush(device_->device(), input_).ok() || !iris::vk::flush(device_->device(), output_).ok()) return false;
        auto set = jpeg_->makeSet(input_.buffer, 0, inputWords * 4, planes_.get(), planesBytes_, output_.buffer, 0,
                                  outputWords * 4);
        if (!set) {
            QTest::qFail(describe(set.error()).c_str(), __FILE__, __LINE__);
            return false;
        }
        const VkCommandBufferBeginInfo begin{.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO, .pNext = nullptr,
                                             .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT, .pInheritanceInfo = nullptr};
        vkResetCommandBuffer(cmd_, 0);
        vkBeginCommandBuffer(cmd_, &begin);
        jpeg_->record(cmd_, *set, sizes);
        iris::vk::memoryBarrier(cmd_, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
        vkEndCommandBuffer(cmd_);
        const VkCommandBufferSubmitInfo cmdInfo = iris::vk::commandInfo(cmd_);
        VkFence fence = fence_.get();
        vkResetFences(device_->device(), 1, &fence);
        if (device_->submit(iris::gpu::Device::Role::Compute, iris::vk::submitInfo(&cmdInfo), fence) != VK_SUCCESS ||
            vkWaitForFences(device_->device(), 1, &fence, VK_TRUE, 60'000'000'000ull) != VK_SUCCESS) {
            QTest::qFail("submit or wait failed", __FILE__, __LINE__);
            return false;
        }
        jpeg_->freeSet(*set);
        return iris::vk::invalidate(device_->device(), output_).ok();
    }

    // Reconstructs `streams` in one batch; their libjpeg-turbo decodes must equal it. Returns
    // the tiles compared (streams the path refuses are counted out, and must be refusals).
    int reconstructAndCompare(const std::vector<Stream>& streams) {
        std::vector<JpegCoefficients> coefficients;
        std::vector<const Stream*> taken;
        for (const Stream& s : streams) {
            auto c = iris::readJpegCoefficients(s.bytes.data(), s.bytes.size(), s.width, s.height, s.colour);
            if (!c) {
                if (c.error().status() != iris::Status::UnsupportedFormat) {
                    QTest::qFail(("coefficients of " + s.name + ": " + describe(c.error())).c_str(), __FILE__, __LINE__);
                    return -1;
                }
                continue;
            }
            coefficients.push_back(std::move(c.value()));
            taken.push_back(&s);
        }
        if (taken.empty()) return 0;
        std::vector<const JpegCoefficients*> tiles;
        std::vector<iris::gpu::JpegReconstruct::Placement> places;
        uint64_t outputWords = 0;
        for (const JpegCoefficients& c : coefficients) {
            tiles.push_back(&c);
            places.push_back({.outputWord = uint32_t(outputWords), .outputPitch = c.width});
            outputWords += uint64_t(c.width) * c.height;
        }
        const auto sizes = iris::gpu::JpegReconstruct::measure(tiles);
        if (!ensure(input_, sizes.inputWords * 4, false) || !ensure(output_, outputWords * 4, true)) {
            QTest::qFail("buffers", __FILE__, __LINE__);
            return -1;
        }
        if (planesBytes_ < sizes.planeWords * 4) {
            planesBytes_ = sizes.planeWords * 4;
            if (!iris::vk::createDeviceBuffer(device_->physical(), device_->device(), planesBytes_,
                                              VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, planes_, planesMemory_)
                     .ok()) {
                QTest::qFail("planes", __FILE__, __LINE__);
                return -1;
            }
        }
        iris::gpu::JpegReconstruct::pack(tiles, places, static_cast<uint32_t*>(input_.mapped));
        std::memset(output_.mapped, 0x5a, outputWords * 4); // a pixel left unwritten shows
        if (!dispatch(sizes, sizes.inputWords, outputWords)) return -1;

        int compared = 0;
        for (size_t i = 0; i < taken.size(); ++i) {
            const Stream& s = *taken[i];
            std::vector<uint8_t> cpu(size_t(s.width) * s.height * 4);
            const iris::Result r = iris::decodeJpegFrameRgba(s.bytes.data(), s.bytes.size(), s.width, s.height, s.colour,
                                                             cpu.data(), size_t(s.width) * 4);
            if (!r.ok()) {
                QTest::qFail(("libjpeg-turbo refused " + s.name + ": " + describe(r)).c_str(), __FILE__, __LINE__);
                return -1;
            }
            const uint8_t* gpu = static_cast<const uint8_t*>(output_.mapped) + uint64_t(places[i].outputWord) * 4;
            if (std::memcmp(gpu, cpu.data(), cpu.size()) != 0) {
                size_t differ = 0, first = SIZE_MAX;
                int worst = 0;
                for (size_t b = 0; b < cpu.size(); ++b)
                    if (gpu[b] != cpu[b]) {
                        ++differ;
                        first = std::min(first, b);
                        worst = std::max(worst, std::abs(int(gpu[b]) - int(cpu[b])));
                    }
                const size_t px = first / 4;
                const std::string why = s.name + ": " + std::to_string(differ) + " bytes differ, worst by " +
                                        std::to_string(worst) + "; first at (" + std::to_string(px % s.width) + ", " +
                                        std::to_string(px / s.width) + ") channel " + std::to_string(first % 4) +
                                        ": GPU " + std::to_string(gpu[first]) + ", libjpeg-turbo " + std::to_string(cpu[first]);
                QTest::qFail(why.c_str(), __FILE__, __LINE__);
                return -1;
            }
            ++compared;
        }
        return compared;
    }

private slots:
    void initTestCase() {
        iris::EngineConfig config;
        config.validation = validationLayerInstalled();
        device_ = std::make_unique<iris::gpu::Device>(log_);
        const iris::Result r = device_->init(config);
        QVERIFY2(r.ok(), describe(r).c_str());
        jpeg_ = std::make_unique<iris::gpu::JpegReconstruct>(*device_);
        const iris::Result j = jpeg_->init();
        QVERIFY2(j.ok(), describe(j).c_str());
        VkDevice dev = device_->device();
        const VkCommandPoolCreateInfo cpci{.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO, .pNext = nullptr,
                                           .flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT,
                                           .queueFamilyIndex = device_->family(iris::gpu::Device::Role::Compute)};
        QCOMPARE(vkCreateCommandPool(dev, &cpci, nullptr, pool_.replace(dev)), VK_SUCCESS);
        const VkCommandBufferAllocateInfo cbai{.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO, .pNext = nullptr,
                                               .commandPool = pool_.get(), .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
                                               .commandBufferCount = 1};
        QCOMPARE(vkAllocateCommandBuffers(dev, &cbai, &cmd_), VK_SUCCESS);
        const VkFenceCreateInfo fci{.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO, .pNext = nullptr, .flags = 0};
        QCOMPARE(vkCreateFence(dev, &fci, nullptr, fence_.replace(dev)), VK_SUCCESS);
        qInfo("device: %s (%s), validation %s", device_->properties().deviceName, device_->driverName().c_str(),
              config.validation ? "on" : "not installed");
    }

    void cleanupTestCase() {
        if (!device_) return;
        (void)device_->waitIdle();
        const uint64_t messages = device_->validationMessages();
        jpeg_.reset();
        input_ = {};
        output_ = {};
        planes_.reset();
        planesMemory_.reset();
        fence_.reset();
        pool_.reset();
        QCOMPARE(messages, uint64_t(0));
    }

    void synthetic_data() {
        QTest::addColumn<int>("subsamp");
        QTest::addColumn<int>("quality");
        QTest::addColumn<bool>("progressive");
        QTest::addColumn<int>("width");
        QTest::addColumn<int>("height");
        const std::pair<int, int> sizes[] = {{256, 256}, {240, 240}, {512, 1024}, {250, 131}, {17, 9}, {33, 70}};
        uint32_t row = 0;
        for (int subsamp : {int(TJSAMP_444), int(TJSAMP_422), int(TJSAMP_420), int(TJSAMP_GRAY)})
            for (int quality : {35, 90, 100})
                for (bool progressive : {false, true}) {
                    if (progressive && quality != 90) continue;
                    for (auto [w, h] : sizes) {
                        const Stream s = encode(w, h, subsamp, quality, progressive, row++);
                        QTest::newRow(s.name.c_str()) << subsamp << quality << progressive << w << h;
                    }
                }
    }

    void synthetic() {
        QFETCH(int, subsamp);
        QFETCH(int, quality);
        QFETCH(bool, progressive);
        QFETCH(int, width);
        QFETCH(int, height);
        const Stream s = encode(width, height, subsamp, quality, progressive, uint32_t(width * 31 + height + quality));
        QVERIFY(!s.bytes.empty());
        QCOMPARE(reconstructAndCompare({s}), 1);
    }

    void mixedBatch() {
        std::vector<Stream> streams;
        uint32_t seed = 1000;
        for (int subsamp : {int(TJSAMP_420), int(TJSAMP_GRAY), int(TJSAMP_444), int(TJSAMP_422)})
            for (auto [w, h] : {std::pair{256, 256}, std::pair{250, 131}, std::pair{240, 240}})
            {
                streams.push_back(encode(w, h, subsamp, 85, seed % 2 == 0, seed));
                ++seed;
            }
        QCOMPARE(reconstructAndCompare(streams), int(streams.size()));
    }

    void slideTiles() {
        std::vector<fs::path> slides;
        if (auto dir = slidesDir("aperio"))
            for (const fs::path& p : filesUnder(*dir, false)) slides.push_back(p);
        if (auto dir = slidesDir("generic-tiff"))
            for (const fs::path& p : filesUnder(*dir, false)) slides.push_back(p);
        if (auto sample = sampleSlidePath(); sample && fs::exists(*sample)) slides.push_back(*sample);
        if (slides.empty()) QSKIP("no test slides (IRIS_TESTDATA) and no sample slide");
        int total = 0;
        for (const fs::path& path : slides) {
            const std::vector<Stream> tiles = tiffJpegTiles(path, 200);
            int compared = 0;
            for (size_t at = 0; at < tiles.size(); at += 32) {
                const std::vector<Stream> batch(tiles.begin() + at, tiles.begin() + std::min(tiles.size(), at + 32));
                const int n = reconstructAndCompare(batch);
                if (n < 0) return;
                compared += n;
            }
            // What packing does to real tiles' blocks (jpegblocks).
            uint64_t packed = 0, dense = 0;
            for (const Stream& t : tiles)
                if (auto c = iris::readJpegCoefficients(t.bytes.data(), t.bytes.size(), t.width, t.height, t.colour)) {
                    packed += iris::jpegblocks::packedWords(c->blocks.data(), c->blockCount());
                    dense += uint64_t(c->blockCount()) * 32;
                }
            qInfo("%s: %d JPEG tiles equal libjpeg-turbo's decode (%zu read); blocks packed to %.0f%% of their size",
                  path.filename().c_str(), compared, tiles.size(), dense ? 100.0 * double(packed) / double(dense) : 0.0);
            total += compared;
        }
        QVERIFY2(total > 0, "no slide had a JPEG tile the GPU path takes");
    }

    // The overload that reads into the caller's memory (records, iris-bench's split floor)
    // packs the same coefficients (jpegblocks: the format unpacked here by its definition), and
    // refuses a room too small for them: from the frame header when even the table would not
    // fit, after the entropy decode otherwise (both UnsupportedFormat).
    void intoCallerMemory() {
        const Stream s = encode(256, 256, TJSAMP_420, 90, false, 11);
        auto own = iris::readJpegCoefficients(s.bytes.data(), s.bytes.size(), 256, 256, JpegColour::Auto);
        QVERIFY2(own.ok(), describe(own.error()).c_str());
        const uint32_t blocks = own->blockCount();
        QCOMPARE(blocks, 1024u + 2 * 256u);
        const uint64_t words = iris::jpegblocks::packedWords(own->blocks.data(), blocks);
        std::vector<uint32_t> room(words, 0x77777777u);
        auto into = iris::readJpegCoefficients(s.bytes.data(), s.bytes.size(), 256, 256, JpegColour::Auto, room.data(),
                                               room.size());
        QVERIFY2(into.ok(), describe(into.error()).c_str());
        QVERIFY(into->blocks.empty());
        QCOMPARE(into->blockCount(), blocks);
        QCOMPARE(into->packedWords, words);
        QVERIFY(iris::jpegblocks::valid(room.data(), blocks, words));
        // Unpacked: the table's mask and word, then the values in natural order.
        size_t nonZero = 0;
        for (uint32_t b = 0; b < blocks; ++b) {
            const uint64_t mask = room[3 * b] | uint64_t(room[3 * b + 1]) << 32;
            uint32_t index = 0;
            for (int k = 0; k < 64; ++k) {
                int16_t v = 0;
                if (mask >> k & 1) {
                    const uint32_t word = room[room[3 * b + 2] + index / 2];
                    v = int16_t(uint16_t(index & 1 ? word >> 16 : word & 0xffff));
                    QVERIFY(v != 0);
                    ++index;
                    ++nonZero;
                }
                QCOMPARE(v, own->blocks[size_t(b) * 64 + size_t(k)]);
            }
        }
        // Packed smaller than dense (this picture's noise and checkers are its worst; real tiles
        // pack to a fraction, as slideTiles reports).
        QVERIFY2(words < uint64_t(blocks) * 32, QByteArray::number(qulonglong(words)));
        QVERIFY(nonZero > blocks); // and yet not empty
        std::vector<uint32_t> packed(words);
        QCOMPARE(iris::jpegblocks::pack(own->blocks.data(), blocks, packed.data(), packed.size()), words);
        QVERIFY(packed == room);
        QCOMPARE(iris::jpegblocks::pack(own->blocks.data(), blocks, packed.data(), packed.size() - 1), uint64_t(0));
        // A room one word short: refused once the values are known.
        auto small = iris::readJpegCoefficients(s.bytes.data(), s.bytes.size(), 256, 256, JpegColour::Auto, room.data(),
                                                room.size() - 1);
        QVERIFY(!small && small.error().status() == iris::Status::UnsupportedFormat);
        // Room for less than the table: refused from the frame header.
        auto tiny = iris::readJpegCoefficients(s.bytes.data(), s.bytes.size(), 256, 256, JpegColour::Auto, room.data(),
                                               uint64_t(blocks) * 3 - 1);
        QVERIFY(!tiny && tiny.error().status() == iris::Status::UnsupportedFormat);
        QVERIFY2(std::string(tiny.error().message()).find("no room for") != std::string::npos, tiny.error().message().c_str());
        // A table that points a block's values past the packed words is not valid.
        room[3 * 5 + 2] = uint32_t(words) + 1;
        QVERIFY(!iris::jpegblocks::valid(room.data(), blocks, words));
    }

    // The RAM cache's coefficient records (jpegrecord, EngineTuning::JpegDecode::Gpu): what the
    // header says; every layout fits a tile buffer when its blocks are mostly zero (4:4:4 and
    // 4:2:2 as well as 4:2:0 and grey) and none does when they are not (noise at q100); and
    // records reconstructed with a valid part smaller than the tile equal libjpeg-turbo's
    // decode padded as padTileEdges pads it.
    void records() {
        namespace rec = iris::jpegrecord;
        std::vector<uint8_t> record(iris::kTileBytes);
        const Stream s420 = encode(256, 256, TJSAMP_420, 90, false, 21);
        QVERIFY(rec::write(s420.bytes.data(), s420.bytes.size(), 256, 256, JpegColour::Auto, 200, 100, record.data()).ok());
        JpegCoefficients h;
        uint32_t vw = 0, vh = 0;
        QVERIFY(rec::header(record.data(), h, vw, vh));
        QCOMPARE(h.width, 256u);
        QCOMPARE(vw, 200u);
        QCOMPARE(vh, 100u);
        QCOMPARE(h.components, 3u);
        QCOMPARE(h.blockCount(), 1536u);
        QVERIFY(h.hMax == 2 && h.vMax == 2);
        QVERIFY(h.transform == JpegCoefficients::Transform::YCbCr);
        QCOMPARE(rec::usedBytes(record.data()), size_t(rec::kBlocksWord + h.packedWords) * 4);
        QVERIFY(rec::usedBytes(record.data()) < iris::kTileBytes / 2);
        const auto table = [](const std::vector<uint8_t>& r) { return reinterpret_cast<const uint32_t*>(r.data()) + rec::kBlocksWord; };
        QVERIFY(iris::jpegblocks::valid(table(record), h.blockCount(), h.packedWords));
        // A table that points a block's values outside the record: not valid, though its header
        // reads (the buffer thread does not walk tables; the shader clamps what it reads).
        {
            std::vector<uint8_t> broken = record;
            const uint32_t outside = uint32_t(h.packedWords) + 1;
            std::memcpy(&broken[rec::kBlocksWord * 4 + 8], &outside, 4);
            QVERIFY(rec::header(broken.data(), h, vw, vh));
            QVERIFY(!iris::jpegblocks::valid(table(broken), h.blockCount(), h.packedWords));
            QCOMPARE(rec::usedBytes(broken.data()), rec::usedBytes(record.data()));
            // Used words fewer than the table: not a record.
            const uint32_t tooFew = rec::kBlocksWord + 3 * h.blockCount() - 1;
            std::memcpy(&broken[rec::kUsedWord * 4], &tooFew, 4);
            QVERIFY(!rec::header(broken.data(), h, vw, vh));
        }
        std::vector<uint8_t> notRecord(iris::kTileBytes, 0x43);
        QVERIFY(!rec::header(notRecord.data(), h, vw, vh));
        QCOMPARE(rec::usedBytes(notRecord.data()), size_t(iris::kTileBytes));

        // Which records fit: exactly those whose packed blocks fit after the header and tables.
        const auto fits = [](const Stream& st) {
            auto dense = iris::readJpegCoefficients(st.bytes.data(), st.bytes.size(), st.width, st.height, JpegColour::Auto);
            return dense && rec::kBlocksWord + iris::jpegblocks::packedWords(dense->blocks.data(), dense->blockCount()) <= rec::kWords;
        };
        std::vector<Stream> taken;
        taken.push_back(s420);
        for (int subsamp : {int(TJSAMP_422), int(TJSAMP_444), int(TJSAMP_GRAY)}) {
            const Stream smooth = encodePicture(smoothPicture(256, 256), 256, 256, subsamp, 90, false, "smooth");
            QVERIFY2(fits(smooth), smooth.name.c_str());
            taken.push_back(smooth);
            const Stream busy = encode(256, 256, subsamp, 90, false, 23);
            const iris::Result r =
                rec::write(busy.bytes.data(), busy.bytes.size(), 256, 256, JpegColour::Auto, 256, 256, record.data());
            QVERIFY2(r.ok() == fits(busy), busy.name.c_str());
            if (!r.ok()) QVERIFY2(r.status() == iris::Status::UnsupportedFormat, busy.name.c_str());
        }
        const Stream noise = encodePicture(noisePicture(256, 256, 24), 256, 256, TJSAMP_444, 100, false, "noise");
        QVERIFY(!fits(noise));
        const iris::Result r = rec::write(noise.bytes.data(), noise.bytes.size(), 256, 256, JpegColour::Auto, 256, 256, record.data());
        QVERIFY2(r.status() == iris::Status::UnsupportedFormat, describe(r).c_str());

        // The padded reconstruction, through the buffer path with the record's own layout.
        const uint64_t inputWords = iris::gpu::JpegReconstruct::kDescriptorWords + iris::kTileBytes / 4;
        QVERIFY(ensure(input_, inputWords * 4, false) && ensure(output_, uint64_t(iris::kTileBytes), true));
        if (planesBytes_ < 3 * 64 * 256 * 4) {
            planesBytes_ = 3 * 64 * 256 * 4;
            QVERIFY(iris::vk::createDeviceBuffer(device_->physical(), device_->device(), planesBytes_,
                                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, planes_, planesMemory_)
                        .ok());
        }
        for (const Stream& st : taken) {
            QVERIFY2(rec::write(st.bytes.data(), st.bytes.size(), 256, 256, JpegColour::Auto, 200, 100, record.data()).ok(),
                     st.name.c_str());
            QVERIFY(rec::header(record.data(), h, vw, vh));
            auto* words = static_cast<uint32_t*>(input_.mapped);
            const uint32_t at = iris::gpu::JpegReconstruct::kDescriptorWords;
            std::memset(words + at, 0x5a, iris::kTileBytes); // only the bytes in use are copied
            std::memcpy(words + at, record.data(), rec::usedBytes(record.data()));
            iris::gpu::JpegReconstruct::describe(h, {.outputWord = 0, .outputPitch = 256, .validWidth = vw, .validHeight = vh},
                                                 0, at + rec::kQuantWord, at + rec::kBlocksWord, 0, words);
            iris::gpu::JpegReconstruct::Sizes sizes{.tiles = 1, .inputWords = inputWords, .planeWords = 3 * 64 * 256,
                                                    .maxBlocks = h.blockCount(), .maxWidth = 256, .maxHeight = 256};
            QVERIFY(dispatch(sizes, inputWords, uint64_t(iris::kTileBytes) / 4));
            std::vector<uint8_t> cpu(iris::kTileBytes);
            QVERIFY(iris::decodeJpegFrameRgba(st.bytes.data(), st.bytes.size(), 256, 256, JpegColour::Auto, cpu.data(), 1024)
                        .ok());
            for (int y = 0; y < 256; ++y)
                for (int x = 0; x < 256; ++x)
                    std::memcpy(&cpu[(size_t(y) * 256 + x) * 4], &cpu[(size_t(std::min(y, 99)) * 256 + std::min(x, 199)) * 4], 4);
            QVERIFY2(std::memcmp(output_.mapped, cpu.data(), cpu.size()) == 0, st.name.c_str());
        }

        // A table that points blocks' values outside the record: its header still reads (the
        // buffer thread does not walk tables), and the shader reads nothing past the record's
        // packed blocks. The words after them are filled with two different patterns; the two
        // reconstructions must be equal (a shader reading the pattern would make them differ).
        {
            QVERIFY(rec::write(s420.bytes.data(), s420.bytes.size(), 256, 256, JpegColour::Auto, 256, 256, record.data()).ok());
            QVERIFY(rec::header(record.data(), h, vw, vh));
            const size_t used = rec::usedBytes(record.data());
            std::vector<uint8_t> broken = record;
            for (const uint32_t b : {0u, 700u, h.blockCount() - 1}) {
                const uint32_t outside = uint32_t(h.packedWords) + 64 + b;
                std::memcpy(&broken[(rec::kBlocksWord + 3 * size_t(b) + 2) * 4], &outside, 4);
            }
            QVERIFY(rec::header(broken.data(), h, vw, vh));
            QVERIFY(!iris::jpegblocks::valid(table(broken), h.blockCount(), h.packedWords));
            std::vector<uint8_t> outputs[2];
            for (int pass = 0; pass < 2; ++pass) {
                auto* words = static_cast<uint32_t*>(input_.mapped);
                const uint32_t at = iris::gpu::JpegReconstruct::kDescriptorWords;
                std::memset(words + at, pass ? 0x7f : 0x01, iris::kTileBytes);
                std::memcpy(words + at, broken.data(), used);
                iris::gpu::JpegReconstruct::describe(h, {.outputWord = 0, .outputPitch = 256}, 0, at + rec::kQuantWord,
                                                     at + rec::kBlocksWord, 0, words);
                iris::gpu::JpegReconstruct::Sizes sizes{.tiles = 1, .inputWords = inputWords, .planeWords = 3 * 64 * 256,
                                                        .maxBlocks = h.blockCount(), .maxWidth = 256, .maxHeight = 256};
                QVERIFY(dispatch(sizes, inputWords, uint64_t(iris::kTileBytes) / 4));
                const auto* out = static_cast<const uint8_t*>(output_.mapped);
                outputs[pass].assign(out, out + iris::kTileBytes);
            }
            QVERIFY2(outputs[0] == outputs[1], "the shader read past the record's packed blocks");
        }
    }

    // Inside the engine (EngineTuning::jpegDecode): two engines on a GPU's path (queue copies,
    // wide mips), one decoding JPEG tiles on the CPU and one finishing them on the GPU, show
    // the same settled frames byte for byte, at 1:1, at level downsamples and between them,
    // and at a level's corner, from a generic TIFF (the sample), an Aperio SVS and .iris files.
    void engineFrames() {
        std::vector<fs::path> slides;
        if (auto sample = sampleSlidePath(); sample && fs::exists(*sample)) slides.push_back(*sample);
        if (auto dir = slidesDir("aperio"); dir && fs::exists(*dir / "CMU-1-Small-Region.svs"))
            slides.push_back(*dir / "CMU-1-Small-Region.svs");
        if (auto dir = slidesDir("iris"))
            for (const char* f : {"CMU-1-Small-Region.v1.1.iris", "small.v1.0.iris"})
                if (fs::exists(*dir / f)) slides.push_back(*dir / f);
        if (slides.empty()) QSKIP("no slides");
        constexpr uint32_t kW = 640, kH = 480;
        TestEngine engines[2];
        for (int g = 0; g < 2; ++g) {
            iris::EngineConfig c;
            c.tuning.tileUpload = iris::EngineTuning::TileUpload::Queue;
            c.tuning.mipSchedule = iris::EngineTuning::MipSchedule::Wide;
            c.tuning.jpegDecode = g ? iris::EngineTuning::JpegDecode::Gpu : iris::EngineTuning::JpegDecode::Cpu;
            c.color.managed = false;
            engines[g] = createTestEngine(c);
            QVERIFY2(engines[g], describe(engines[g].error).c_str());
            QVERIFY(engines[g]->bindOffscreen(kW, kH).ok());
            QCOMPARE(engines[g]->device().jpegDecode, std::string(g ? "gpu" : "cpu"));
        }
        for (const fs::path& slide : slides) {
            // The GPU engine's loaders read these slides' base tiles as records (so its frames
            // below are the GPU's reconstruction, the .iris files' 4:2:2 tiles included), but
            // for the SVS, whose 240×240 tiles are not the engine's grid (decoded on the CPU).
            if (slide.extension() != ".svs") {
                auto source = slide.extension() == ".iris" ? iris::IrisFileSource::open(slide.string())
                                                           : iris::TiffTileSource::tryOpen(slide.string());
                QVERIFY2(source, slide.c_str());
                QVERIFY2((*source)->readsCoefficients(0), slide.c_str());
                const iris::LevelInfo& base = (*source)->info().levels[0];
                std::vector<uint8_t> record(iris::kTileBytes);
                int64_t read = 0, recorded = 0;
                for (int64_t ty = 0; ty < base.tilesY; ty += std::max<int64_t>(1, base.tilesY / 4))
                    for (int64_t tx = 0; tx < base.tilesX; tx += std::max<int64_t>(1, base.tilesX / 4), ++read)
                        recorded += (*source)->readTileCoefficients(0, tx, ty, record.data()).ok();
                QVERIFY2(read > 0 && recorded == read, (slide.string() + ": " + std::to_string(recorded) + " of " +
                                                        std::to_string(read) + " tiles read as records").c_str());
            }
            for (TestEngine& e : engines) QVERIFY2(e->open(slide.string()).ok(), slide.c_str());
            const auto infoOpt = engines[0]->slideInfo();
            QVERIFY(infoOpt.has_value());
            const iris::SlideInfo& info = *infoOpt;
            const double w = double(info.width), h = double(info.height);
            const double fit = std::max(w / kW, h / kH); // a small slide is not shrunk further
            const struct {
                const char* what;
                iris::View view;
            } views[] = {
                {"1:1 centre", viewWithOrigin(std::floor(w / 2 - kW / 2), std::floor(h / 2 - kH / 2), 1, kW, kH)},
                {"1:1 corner", viewWithOrigin(w - kW / 2.0, h - kH / 2.0, 1, kW, kH)},
                {"downsample 4", viewWithOrigin(0, 0, std::min(4.0, fit), kW, kH)},
                {"downsample 2.7", viewWithOrigin(w / 5, h / 7, std::min(2.7, fit), kW, kH)},
                {"whole slide", viewWithOrigin(0, 0, fit, kW, kH)},
            };
            for (const auto& v : views) {
                std::string why;
                auto a = renderSettled(*engines[0].engine, v.view, kW, kH, 60s, &why);
                QVERIFY2(a, (slide.filename().string() + " " + v.what + " (CPU decode): " + why).c_str());
                auto b = renderSettled(*engines[1].engine, v.view, kW, kH, 60s, &why);
                QVERIFY2(b, (slide.filename().string() + " " + v.what + " (GPU decode): " + why).c_str());
                const DiffStats d = compareImages(a->image, b->image, nullptr, 4);
                if (d.differing)
                    qWarning("%s", saveFailureArtefacts("jpeg_gpu." + slide.filename().string() + "." + v.what, b->image,
                                                        a->image, nullptr)
                                       .c_str());
                QVERIFY2(d.differing == 0, (slide.filename().string() + " " + v.what + ": " + d.summary()).c_str());
            }
            qInfo("%s: frames equal with the GPU's share of the decode", slide.filename().c_str());
        }
        for (TestEngine& e : engines) QCOMPARE(e->validationMessageCount(), uint64_t(0));
    }

    void refused() {
        for (int subsamp : {int(TJSAMP_411), int(TJSAMP_440)}) {
            const Stream s = encode(256, 256, subsamp, 80, false, 5);
            auto c = iris::readJpegCoefficients(s.bytes.data(), s.bytes.size(), 256, 256, JpegColour::Auto);
            QVERIFY2(!c && c.error().status() == iris::Status::UnsupportedFormat, s.name.c_str());
        }
        const Stream s = encode(256, 256, TJSAMP_420, 80, false, 6);
        auto wrongSize = iris::readJpegCoefficients(s.bytes.data(), s.bytes.size(), 240, 256, JpegColour::Auto);
        QVERIFY(!wrongSize && wrongSize.error().status() == iris::Status::CorruptData);
        auto truncated = iris::readJpegCoefficients(s.bytes.data(), s.bytes.size() / 2, 256, 256, JpegColour::Auto);
        QVERIFY(!truncated && truncated.error().status() == iris::Status::CorruptData);
        const std::vector<uint8_t> garbage(4096, 0x37);
        auto bad = iris::readJpegCoefficients(garbage.data(), garbage.size(), 256, 256, JpegColour::Auto);
        QVERIFY(!bad && bad.error().status() == iris::Status::CorruptData);
        const Stream g = encode(64, 64, TJSAMP_GRAY, 80, false, 7);
        auto grey = iris::readJpegCoefficients(g.bytes.data(), g.bytes.size(), 64, 64, JpegColour::YCbCr);
        QVERIFY2(!grey && grey.error().status() == iris::Status::CorruptData, "a grey stream read as YCbCr");
    }
};

QTEST_GUILESS_MAIN(TestJpegGpu)
#include "tst_jpeg_gpu.moc"
