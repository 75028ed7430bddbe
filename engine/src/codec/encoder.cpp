// encodeIris(): any slide the engine opens → .iris (version 1.0). See iris/encoder.h for
// what is written, docs/ARCHITECTURE.md ("The .iris encoder") for how.
//
// Pipeline: N worker threads claim tile indices in file order (lowest layer first, each
// row-major) from a shared counter, decode the tile with SlideSource::readTile into their
// own buffer, composite it over white and compress it with their own TurboJPEG handle, and
// leave the JPEG in the window slot of that index. The calling thread writes the slots in
// index order through OutputFile's 8 MiB buffer. A worker may run at most `window` tiles
// ahead of the writer, so memory is bounded by the window (a few MB of JPEG) plus one raw
// tile and one JPEG buffer per thread, however large the slide.
#include "iris/encoder.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <new>
#include <span>
#include <thread>

#include "codec/iris_writer.h"
#include "codec/jpeg_encode.h"
#include "codec/output_file.h"
#include "slide/iris_file.h"
#include "slide/slide_source.h"
#include "slide/synthetic_source.h"
#include "core/thread_name.h"

namespace iris {

namespace {

namespace fs = std::filesystem;

constexpr uint32_t kMaxThreads = 1024;
constexpr uint32_t kMaxTilesPerSide = 1u << 21; // what readers (ours included) address

bool cancelled(const EncodeOptions& o) { return o.cancel && o.cancel->load(std::memory_order_relaxed); }

Result cancelledResult() { return Result(Status::Cancelled, "Encoding cancelled; no output was written"); }

std::string num(uint64_t v) { return std::to_string(v); }

// What is written, from the source's SlideInfo.
struct Plan {
    ife::WriteInfo info;
    std::vector<uint64_t> firstTile; // per layer (lowest first), plus the total at the end
    uint64_t totalTiles = 0;
};

// Layers as the reference encoder makes them from OpenSlide's levels: reversed (layer 0 the
// coarsest), SCALE the layer's larger side over the same side of the coarsest layer, so the
// lowest-resolution layer has scale 1 and X_EXTENT/Y_EXTENT are its size.
Result planLayers(const SlideInfo& si, const std::string& name, Plan& plan) {
    const size_t n = si.levels.size();
    if (n == 0 || n > size_t(ife::kMaxLayers)) {
        return Result(Status::UnsupportedFormat, "Cannot encode '" + name + "': it has " + num(n) +
                                                     " levels; an .iris file holds 1 to " + num(ife::kMaxLayers));
    }
    const LevelInfo& low = si.levels.back();
    if (low.width > int64_t(UINT32_MAX) || low.height > int64_t(UINT32_MAX)) {
        return Result(Status::UnsupportedFormat, "Cannot encode '" + name + "': its lowest level is too large");
    }
    plan.info.xExtent = uint32_t(low.width);
    plan.info.yExtent = uint32_t(low.height);
    uint64_t first = 0;
    for (size_t i = 0; i < n; ++i) {
        const LevelInfo& l = si.levels[n - 1 - i];
        if (l.tilesX < 1 || l.tilesY < 1 || l.tilesX > kMaxTilesPerSide || l.tilesY > kMaxTilesPerSide) {
            return Result(Status::UnsupportedFormat, "Cannot encode '" + name + "': level " + num(n - 1 - i) + " is " +
                                                         num(uint64_t(l.tilesX)) + "x" + num(uint64_t(l.tilesY)) +
                                                         " tiles; an .iris layer holds 1 to 2^21 tiles a side");
        }
        ife::WriteLayer w;
        w.xTiles = uint32_t(l.tilesX);
        w.yTiles = uint32_t(l.tilesY);
        w.scale = l.width > l.height ? float(l.width) / float(low.width) : float(l.height) / float(low.height);
        if (i > 0 && !(w.scale > plan.info.layers.back().scale)) {
            return Result(Status::UnsupportedFormat,
                          "Cannot encode '" + name + "': levels " + num(n - i) + " and " + num(n - 1 - i) + " (" +
                              num(uint64_t(si.levels[n - i].width)) + "x" + num(uint64_t(si.levels[n - i].height)) +
                              " and " + num(uint64_t(l.width)) + "x" + num(uint64_t(l.height)) +
                              ") do not grow in size; .iris layers must");
        }
        plan.info.layers.push_back(w);
        plan.firstTile.push_back(first);
        first += uint64_t(w.xTiles) * w.yTiles;
    }
    plan.firstTile.push_back(first);
    plan.totalTiles = first;
    return {};
}

// Properties → FREE_TEXT attributes, as the reference encoder copies them: everything but
// OpenSlide's own "openslide.*" properties, which describe the source file (its levels, its
// quickhash) and would be wrong for the .iris file; mpp and objective power go to METADATA.
// An .iris source gives its attributes as stored (not the "iris.*" ones its reader adds).
void planAttributes(const SlideSource& src, Plan& plan, std::vector<std::string>& warnings) {
    std::vector<std::pair<std::string, std::string>> attrs;
    if (const auto* irisSrc = dynamic_cast<const IrisFileSource*>(&src)) {
        attrs = irisSrc->layout().attributes;
    } else {
        for (const auto& kv : src.info().properties) {
            if (kv.first.find("openslide") == std::string::npos) attrs.push_back(kv);
        }
    }
    for (auto& kv : attrs) {
        if (kv.first.empty()) continue;
        if (kv.first.size() > 0xFFFF || kv.second.size() > UINT32_MAX) {
            warnings.push_back("property '" + kv.first.substr(0, 80) + "…' left out: too long for an .iris attribute");
            continue;
        }
        plan.info.attributes.push_back(std::move(kv));
    }
}

void planPhysics(const SlideInfo& si, Plan& plan, std::vector<std::string>& warnings) {
    // METADATA holds both for scale 1 (the lowest layer); the finest layer's scale is its
    // downsample from there.
    const double finest = plan.info.layers.back().scale;
    if (si.mppX > 0 && std::isfinite(si.mppX)) {
        plan.info.micronsPerPixel = float(si.mppX * finest);
        if (si.mppY > 0 && std::abs(si.mppY - si.mppX) > 1e-3 * si.mppX) {
            warnings.push_back("the slide's pixels are not square (mpp " + std::to_string(si.mppX) + " x " +
                               std::to_string(si.mppY) + "); .iris stores one value, the horizontal one");
        }
    }
    if (si.objectivePower > 0 && std::isfinite(si.objectivePower)) {
        plan.info.magnification = float(si.objectivePower / finest);
    }
}

// Associated images, in name order, JPEG-compressed with the tile settings. One that cannot
// be read is left out with a warning (the reference encoder does the same) rather than
// failing a conversion whose slide is fine.
Result planImages(SlideSource& src, const EncodeOptions& o, JpegEncoder& jpeg, Plan& plan,
                  std::vector<std::string>& warnings) {
    std::vector<std::string> names = src.info().associatedImages;
    std::sort(names.begin(), names.end());
    names.erase(std::unique(names.begin(), names.end()), names.end());
    for (const std::string& name : names) {
        if (cancelled(o)) return cancelledResult();
        Expected<Image> img = src.readAssociatedImage(name);
        if (!img) {
            warnings.push_back("associated image '" + name + "' left out: " + img.error().message());
            continue;
        }
        if (name.size() > 0xFFFF || img->width == 0 || img->height == 0 ||
            img->rgba.size() != size_t(img->width) * img->height * 4) {
            warnings.push_back("associated image '" + name.substr(0, 80) + "' left out: it is empty or malformed");
            continue;
        }
        compositeStraightOnWhite(img->rgba.data(), size_t(img->width) * img->height);
        auto enc = jpeg.encodeRgba(img->rgba.data(), int(std::min<uint32_t>(img->width, INT32_MAX)),
                                   int(std::min<uint32_t>(img->height, INT32_MAX)), size_t(img->width) * 4, o.quality,
                                   o.subsampling);
        if (!enc) {
            if (enc.error().status() == Status::OutOfMemory) return enc.error();
            warnings.push_back("associated image '" + name + "' left out: " + enc.error().message());
            continue;
        }
        ife::WriteImage w;
        w.title = name;
        w.width = img->width;
        w.height = img->height;
        w.bytes.assign(enc->begin(), enc->end());
        plan.info.images.push_back(std::move(w));
    }
    return {};
}

// The encoder's workers and their window of tiles in file order (see the top of the file).
class EncodeWorkers {
public:
    EncodeWorkers(SlideSource& src, const Plan& plan, const EncodeOptions& o, uint32_t threads, std::string name)
        : src_(src), plan_(plan), o_(o), threads_(threads), name_(std::move(name)),
          window_(std::clamp<uint64_t>(uint64_t(threads) * 8, 64, 1024)), slots_(window_) {}

    ~EncodeWorkers() { stopAndJoin(); }

    // Writes every tile to `out` in file order; fills `tiles` with their entries.
    Result run(OutputFile& out, std::vector<ife::PackedTile>& tiles) {
        const uint64_t total = plan_.totalTiles;
        tiles.clear();
        tiles.reserve(total);
        if (o_.progress) o_.progress(0, total);
        try {
            for (uint32_t t = 0; t < threads_; ++t)
                workers_.emplace_back([this] {
                    nameThisThread("iris-encode");
                    work();
                });
        } catch (const std::exception& e) {
            fail(Result(Status::OutOfMemory, std::string("Cannot start the encoder's threads: ") + e.what()));
        }
        for (uint64_t i = 0; i < total; ++i) {
            Slot& s = slots_[i % window_];
            {
                std::unique_lock lock(mutex_);
                readyCv_.wait(lock, [&] { return stop_ || s.ready; });
                if (stop_) break;
            }
            // The slot is the writer's until it is marked free again.
            const uint64_t offset = out.size();
            if (offset + s.bytes.size() > ife::kMaxTileOffset || s.bytes.size() > ife::kMaxTileSize) {
                fail(Result(Status::UnsupportedFormat, "Cannot encode '" + name_ +
                                                           "': the output would exceed the 1 TiB an .iris file can address"));
                break;
            }
            if (Result r = out.append(s.bytes.data(), s.bytes.size()); !r.ok()) {
                fail(r);
                break;
            }
            tiles.push_back(ife::packTile(offset, uint32_t(s.bytes.size())));
            {
                std::lock_guard lock(mutex_);
                s.ready = false;
                ++written_;
            }
            spaceCv_.notify_one();
            if (o_.progress) o_.progress(i + 1, total);
            if (cancelled(o_)) {
                fail(cancelledResult());
                break;
            }
        }
        stopAndJoin();
        std::lock_guard lock(mutex_);
        return error_;
    }

private:
    struct Slot {
        std::vector<uint8_t> bytes; // the tile's JPEG (capacity kept from tile to tile)
        bool ready = false;         // guarded by mutex_
    };

    void fail(Result r) {
        {
            std::lock_guard lock(mutex_);
            if (error_.ok()) error_ = std::move(r);
            stop_ = true;
        }
        spaceCv_.notify_all();
        readyCv_.notify_all();
    }

    void stopAndJoin() {
        {
            std::lock_guard lock(mutex_);
            stop_ = true;
        }
        spaceCv_.notify_all();
        readyCv_.notify_all();
        for (std::thread& t : workers_) {
            if (t.joinable()) t.join();
        }
        workers_.clear();
    }

    void work() {
        try {
            JpegEncoder jpeg;
            std::unique_ptr<uint8_t[]> raw(new uint8_t[kTileBytes]);
            const size_t layers = plan_.info.layers.size();
            size_t layer = 0;
            for (;;) {
                uint64_t i;
                {
                    std::unique_lock lock(mutex_);
                    spaceCv_.wait(lock, [&] { return stop_ || next_ >= plan_.totalTiles || next_ < written_ + window_; });
                    if (stop_ || next_ >= plan_.totalTiles) return;
                    i = next_++;
                }
                if (cancelled(o_)) return fail(cancelledResult());
                // Indices only grow for a thread, so its layer only moves up.
                while (i >= plan_.firstTile[layer + 1]) ++layer;
                const ife::WriteLayer& l = plan_.info.layers[layer];
                const uint64_t k = i - plan_.firstTile[layer];
                const int level = int(layers - 1 - layer);
                const int64_t tx = int64_t(k % l.xTiles), ty = int64_t(k / l.xTiles);
                if (Result r = src_.readTile(level, tx, ty, raw.get()); !r.ok()) {
                    return fail(Result(r.status(), "Cannot encode '" + name_ + "': " + r.message()));
                }
                compositePremultipliedOnWhite(raw.get(), size_t(kTileSize) * kTileSize);
                auto enc = jpeg.encodeRgba(raw.get(), kTileSize, kTileSize, size_t(kTileSize) * 4, o_.quality,
                                           o_.subsampling);
                if (!enc) {
                    return fail(Result(enc.error().status(), "Cannot encode tile (" + num(uint64_t(tx)) + ", " +
                                                                 num(uint64_t(ty)) + ") of level " + num(uint64_t(level)) +
                                                                 " of '" + name_ + "': " + enc.error().message()));
                }
                // Slot i % window is this thread's: the writer is past i − window.
                Slot& s = slots_[i % window_];
                s.bytes.assign(enc->begin(), enc->end());
                {
                    std::lock_guard lock(mutex_);
                    s.ready = true;
                }
                readyCv_.notify_one();
            }
        } catch (const std::bad_alloc&) {
            fail(Result(Status::OutOfMemory, "Cannot encode '" + name_ + "': out of memory"));
        } catch (const std::exception& e) {
            fail(Result(Status::IoError, "Cannot encode '" + name_ + "': " + e.what()));
        }
    }

    SlideSource& src_;
    const Plan& plan_;
    const EncodeOptions& o_;
    const uint32_t threads_;
    const std::string name_;
    const uint64_t window_;

    std::mutex mutex_;
    std::condition_variable spaceCv_; // workers: a slot became free, or stop
    std::condition_variable readyCv_; // writer: a slot became ready, or stop
    uint64_t next_ = 0;               // next index to claim
    uint64_t written_ = 0;            // tiles written
    bool stop_ = false;
    Result error_;                    // first error wins
    std::vector<Slot> slots_;
    std::vector<std::thread> workers_;
};

Result checkOptions(const EncodeOptions& o) {
    if (o.quality < 1 || o.quality > 100) {
        return Result(Status::InvalidArgument, "JPEG quality " + std::to_string(o.quality) + " is out of range (1 to 100)");
    }
    switch (o.subsampling) {
    case ChromaSubsampling::S444:
    case ChromaSubsampling::S422:
    case ChromaSubsampling::S420: break;
    default: return Result(Status::InvalidArgument, "unknown chroma subsampling");
    }
    switch (o.source) {
    case SourcePreference::Auto:
    case SourcePreference::OpenSlide:
    case SourcePreference::Iris: break;
    default: return Result(Status::InvalidArgument, "unknown source preference");
    }
    return {};
}

Expected<EncodeStats> encode(const std::string& sourcePath, const std::string& outputPath, const EncodeOptions& o) {
    const auto t0 = std::chrono::steady_clock::now();
    if (Result r = checkOptions(o); !r.ok()) return r;
    if (outputPath.empty()) return Result(Status::InvalidArgument, "No output path given");

    auto opened = openSlideSource(sourcePath, o.source);
    if (!opened) return opened.error();
    SlideSource& src = **opened;
    const bool synthetic = SyntheticSource::detect(sourcePath);
    const std::string name = synthetic ? sourcePath : fs::path(sourcePath).filename().string();

    std::error_code ec;
    if (!synthetic && fs::exists(outputPath, ec) && fs::equivalent(sourcePath, outputPath, ec)) {
        return Result(Status::InvalidArgument,
                      "Cannot write '" + outputPath + "': it is the source slide itself; choose another output name");
    }

    EncodeStats stats;
    stats.outputPath = outputPath;
    if (!synthetic) stats.sourceBytes = fs::file_size(sourcePath, ec);
    if (ec) stats.sourceBytes = 0;

    Plan plan;
    plan.info.codecMajor = IRIS_VERSION_MAJOR;
    plan.info.codecMinor = IRIS_VERSION_MINOR;
    plan.info.codecBuild = IRIS_VERSION_PATCH;
    if (Result r = planLayers(src.info(), name, plan); !r.ok()) return r;
    planAttributes(src, plan, stats.warnings);
    planPhysics(src.info(), plan, stats.warnings);
    plan.info.icc = src.info().iccProfile;

    auto file = OutputFile::create(outputPath);
    if (!file) return file.error();
    OutputFile& out = **file;

    {
        JpegEncoder jpeg;
        if (Result r = planImages(src, o, jpeg, plan, stats.warnings); !r.ok()) return r;
    }

    // The header is written last, when the offsets are known; zeros hold its place.
    const std::array<uint8_t, ife::kHeaderSize> zeros{};
    if (Result r = out.append(zeros.data(), zeros.size()); !r.ok()) return r;

    uint32_t threads = o.threads ? o.threads : std::max(1u, std::thread::hardware_concurrency());
    threads = uint32_t(std::clamp<uint64_t>(std::min<uint64_t>(threads, plan.totalTiles), 1, kMaxThreads));
    std::vector<ife::PackedTile> tiles;
    const auto tilesStart = std::chrono::steady_clock::now();
    {
        EncodeWorkers workers(src, plan, o, threads, name);
        if (Result r = workers.run(out, tiles); !r.ok()) return r;
    }
    stats.tileSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - tilesStart).count();

    auto trailer = ife::buildTrailer(out.size(), plan.info, tiles);
    if (!trailer) return trailer.error();
    if (Result r = out.append(trailer->bytes.data(), trailer->bytes.size()); !r.ok()) return r;
    const auto header = ife::fileHeader(out.size(), trailer->tileTable, trailer->metadata);
    if (Result r = out.writeAt(0, header.data(), header.size()); !r.ok()) return r;
    if (cancelled(o)) return cancelledResult();
    if (Result r = out.commit(); !r.ok()) return r;

    stats.tiles = plan.totalTiles;
    stats.levels = uint32_t(plan.info.layers.size());
    stats.associatedImages = uint32_t(plan.info.images.size());
    stats.bytesWritten = out.size();
    stats.pixelBytes = plan.totalTiles * uint64_t(kTileBytes);
    stats.threads = threads;
    stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return stats;
}

} // namespace

Expected<EncodeStats> encodeIris(const std::string& sourcePath, const std::string& outputPath,
                                 const EncodeOptions& options) {
    // No exception crosses the API; OutputFile's destructor removes the temporary file on
    // every way out of encode() that is not a commit.
    try {
        return encode(sourcePath, outputPath, options);
    } catch (const std::bad_alloc&) {
        return Result(Status::OutOfMemory, "Cannot encode '" + sourcePath + "': out of memory");
    } catch (const std::exception& e) {
        return Result(Status::IoError, "Cannot encode '" + sourcePath + "': " + e.what());
    }
}

std::string irisFileName(const std::string& sourcePath) {
    if (SyntheticSource::detect(sourcePath)) {
        std::string s = sourcePath;
        std::replace(s.begin(), s.end(), ':', '-');
        std::replace(s.begin(), s.end(), '/', '-');
        return s + ".iris";
    }
    std::string stem = fs::path(sourcePath).stem().string();
    if (stem.empty() || stem == "." || stem == "..") stem = "slide";
    return stem + ".iris";
}

const char* chromaSubsamplingName(ChromaSubsampling s) noexcept {
    switch (s) {
    case ChromaSubsampling::S444: return "4:4:4";
    case ChromaSubsampling::S422: return "4:2:2";
    case ChromaSubsampling::S420: return "4:2:0";
    }
    return "unknown";
}

} // namespace iris
