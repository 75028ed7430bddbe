// The reader of streamed layer levels (iris::RasterLevel::source): the layer pass's chunks of a
// level that lives in its file, or that is made from a finer one on demand, are read here, on a
// thread of its own, never on the render thread (a chunk can take milliseconds of file reading
// and decoding, a coarser level made on demand many more).
//
// The render thread says each frame which chunks it still needs, in the order it wants them
// (want(): the list replaces the one before, so a view that moved on cancels what it no longer
// needs, except the one chunk being read), and takes what has been read (collect()). Neither
// call waits: both only try the streamer's lock and report that they did not get it, and the
// frame then tries again in the next one. The worker takes the lock only to take a request and
// to hand over its result, never while it reads. Each result bumps the shared wake counter, so
// the render thread draws the frame that shows it.
//
// Memory: at most the wanted list's chunks are read ahead of being collected (the layer pass
// asks for no more than its budget allows a view), and a result holds the chunk's pixels once.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "iris/layers.h"

namespace iris::render {

// A chunk: kChunk × kChunk level pixels of one level of one map (LayerPass::kChunk).
struct ChunkKey {
    const RasterMap* map;
    int level, cx, cy;
    bool operator==(const ChunkKey&) const = default;
};
struct ChunkKeyHash {
    size_t operator()(const ChunkKey& k) const noexcept;
};

class LayerStreamer {
public:
    struct Request {
        ChunkKey key;
        std::shared_ptr<const RasterMap> map; // keeps the key's map alive while it is read
        int32_t x, y, w, h;                   // the level's pixels to read (the chunk and its apron)
    };
    struct Result_ {
        ChunkKey key;
        std::shared_ptr<const RasterMap> map;
        std::vector<uint8_t> pixels; // w × h of the map's kind, rows packed
        Result error;                // not ok: nothing to draw for this chunk (logged by the pass)
    };

    explicit LayerStreamer(std::function<void()> wake);
    ~LayerStreamer();
    LayerStreamer(const LayerStreamer&) = delete;
    LayerStreamer& operator=(const LayerStreamer&) = delete;

    // Render thread. False: the lock was busy, nothing changed; try again next frame.
    bool want(std::vector<Request> requests);
    bool collect(std::vector<Result_>& out);
    // Whether a chunk is being read, waits to be read or to be collected (true when the lock
    // was busy).
    bool busy() const;

private:
    void run();

    std::function<void()> wake_;
    mutable std::mutex mutex_;
    std::condition_variable cv_;
    std::deque<Request> queue_;
    std::vector<Result_> done_;
    bool reading_ = false;
    ChunkKey inFlight_{nullptr, 0, 0, 0};
    bool stop_ = false;
    std::thread thread_;
};

} // namespace iris::render
