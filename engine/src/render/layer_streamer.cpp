#include "render/layer_streamer.h"
#include "core/thread_name.h"

#include <algorithm>

namespace iris::render {

size_t ChunkKeyHash::operator()(const ChunkKey& k) const noexcept {
    size_t h = std::hash<const void*>()(k.map);
    for (int v : {k.level, k.cx, k.cy}) h = h * 1000003u ^ std::hash<int>()(v);
    return h;
}

LayerStreamer::LayerStreamer(std::function<void()> wake) : wake_(std::move(wake)) {
    thread_ = std::thread([this] {
        nameThisThread("iris-layers");
        run();
    });
}

LayerStreamer::~LayerStreamer() {
    {
        std::lock_guard lock(mutex_);
        stop_ = true;
        queue_.clear();
    }
    cv_.notify_all();
    thread_.join();
}

bool LayerStreamer::want(std::vector<Request> requests) {
    std::unique_lock lock(mutex_, std::try_to_lock);
    if (!lock.owns_lock()) return false;
    queue_.clear();
    for (Request& r : requests) {
        if (reading_ && r.key == inFlight_) continue;
        if (std::any_of(done_.begin(), done_.end(), [&](const Result_& d) { return d.key == r.key; })) continue;
        queue_.push_back(std::move(r));
    }
    const bool any = !queue_.empty();
    lock.unlock();
    if (any) cv_.notify_one();
    return true;
}

bool LayerStreamer::collect(std::vector<Result_>& out) {
    std::unique_lock lock(mutex_, std::try_to_lock);
    if (!lock.owns_lock()) return false;
    for (Result_& d : done_) out.push_back(std::move(d));
    done_.clear();
    return true;
}

bool LayerStreamer::busy() const {
    std::unique_lock lock(mutex_, std::try_to_lock);
    if (!lock.owns_lock()) return true;
    return reading_ || !queue_.empty() || !done_.empty();
}

void LayerStreamer::run() {
    std::unique_lock lock(mutex_);
    while (true) {
        cv_.wait(lock, [&] { return stop_ || !queue_.empty(); });
        if (stop_) return;
        Request req = std::move(queue_.front());
        queue_.pop_front();
        reading_ = true;
        inFlight_ = req.key;
        lock.unlock();

        Result_ done{req.key, req.map, {}, {}};
        const size_t bpp = req.map->kind == RasterKind::Label ? 2 : 4;
        done.pixels.resize(size_t(req.w) * size_t(req.h) * bpp);
        done.error = readRasterRegion(*req.map, req.key.level, req.x, req.y, req.w, req.h, done.pixels.data());
        if (!done.error.ok()) done.pixels = {};
        req.map.reset();

        lock.lock();
        reading_ = false;
        done_.push_back(std::move(done));
        lock.unlock();
        wake_(); // outside the lock: the render thread's try-locks never meet it
        lock.lock();
    }
}

} // namespace iris::render
