#include "linked.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <mutex>
#include <thread>

namespace {

using Clock = std::chrono::steady_clock;

struct Member {
    std::unique_ptr<iris::Engine> engine;
    std::mutex mutex;
    std::vector<std::pair<Clock::time_point, iris::View>> frames; // every frame drawn, with its view
    std::vector<double> gpuMs;
};

} // namespace

LinkedResult runLinked(const std::string& slide, int views, uint32_t cellW, uint32_t cellH, int ticks,
                       const iris::EngineConfig& base) {
    LinkedResult res;
    res.views = views;
    res.cellW = cellW;
    res.cellH = cellH;
    res.ticks = ticks;
    std::vector<std::unique_ptr<Member>> members;
    for (int i = 0; i < views; ++i) {
        auto m = std::make_unique<Member>();
        auto created = iris::Engine::create(base);
        if (!created) {
            res.notes = created.error().message();
            return res;
        }
        m->engine = std::move(created.value());
        if (auto r = m->engine->bindOffscreen(cellW, cellH, /*readback=*/false); !r) {
            res.notes = r.message();
            return res;
        }
        if (auto r = m->engine->open(slide); !r) {
            res.notes = r.message();
            return res;
        }
        members.push_back(std::move(m));
    }
    res.device = members[0]->engine->device().name;
    const iris::SlideInfo info = *members[0]->engine->slideInfo();

    // The glide: from the slide's centre at a downsample that shows a fraction of it (the
    // finest level a cell of this size fits 6 times across, at least 1:1), 12 cell pixels right
    // and 5 down per tick, turning 0.2° per tick; at the slide's edge it turns back.
    double ds = std::max(1.0, double(info.width) / (6.0 * cellW));
    iris::View v{double(info.width) / 2, double(info.height) / 2, ds, 0};
    for (auto& m : members) {
        m->engine->setView(v);
        (void)m->engine->waitForSettled(std::chrono::seconds(60));
        m->engine->setFrameCallback([mp = m.get()](const iris::FrameStats& s) {
            std::lock_guard lock(mp->mutex);
            mp->frames.emplace_back(Clock::now(), s.view);
            if (s.gpuMs >= 0) mp->gpuMs.push_back(s.gpuMs);
        });
    }
    std::vector<std::pair<Clock::time_point, iris::View>> published;
    double dx = 12 * ds, dy = 5 * ds;
    const auto tick = std::chrono::microseconds(16667);
    auto next = Clock::now();
    for (int k = 0; k < ticks; ++k) {
        if (v.centerX + dx < 0 || v.centerX + dx > double(info.width)) dx = -dx;
        if (v.centerY + dy < 0 || v.centerY + dy > double(info.height)) dy = -dy;
        v.centerX += dx;
        v.centerY += dy;
        v.rotation = iris::normalizedRotation(v.rotation + 0.2);
        const auto t = Clock::now();
        for (auto& m : members) m->engine->setView(v);
        published.emplace_back(t, v);
        next += tick;
        std::this_thread::sleep_until(next);
    }
    // Let the last tick's frames arrive.
    for (auto& m : members) (void)m->engine->waitForFrame(std::chrono::seconds(10));
    const Clock::time_point end = Clock::now();
    for (auto& m : members) m->engine->setFrameCallback({});

    for (size_t k = 0; k < published.size(); ++k) {
        const auto& [t, pv] = published[k];
        double worst = 0;
        bool all = true;
        for (auto& m : members) {
            std::lock_guard lock(m->mutex);
            const auto it = std::find_if(m->frames.begin(), m->frames.end(),
                                         [&](const auto& f) { return f.first >= t && f.second == pv; });
            if (it == m->frames.end()) {
                all = false;
                break;
            }
            worst = std::max(worst, std::chrono::duration<double, std::milli>(it->first - t).count());
        }
        if (all) res.latencyMs.push_back(worst);
        else ++res.missed;
    }
    const double seconds = std::chrono::duration<double>(end - published.front().first).count();
    for (auto& m : members) {
        std::lock_guard lock(m->mutex);
        const auto first = std::find_if(m->frames.begin(), m->frames.end(),
                                        [&](const auto& f) { return f.first >= published.front().first; });
        res.fps.push_back(double(m->frames.end() - first) / seconds);
        res.gpuMs.insert(res.gpuMs.end(), m->gpuMs.begin(), m->gpuMs.end());
        if (m->engine->validationMessageCount() > 0)
            res.notes += std::to_string(m->engine->validationMessageCount()) + " Vulkan validation messages. ";
    }
    return res;
}
