// The tile stage log (issue 20, "measure first"): when tiles pass each stage of their way from
// the slide to the screen — a loader starts reading one, has decoded it, the buffer thread has
// copied it into staging, submitted its upload, seen the upload and its mips complete, the tile
// became drawable, a frame first drew it. Each stage keeps the times of its last kSlots events
// in a ring; the render thread's metrics summarise the events that fall within a timed field
// (from the move to the field's completion) into FieldStats::stages.
//
// Writers are any engine thread and never wait: an event is one fetch_add on the stage's
// cursor and one relaxed store of the time. The reader (the render thread, once per finished
// field) scans the rings: an event being written while it scans is read as its old or its new
// time, and either lies outside the field's window or inside it as it should; a field with
// more than kSlots events of one stage loses its oldest (stated in the summary's count).
// Statistics only: nothing is ordered by it.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <vector>

#include "iris/types.h"

namespace iris {

class StageLog {
public:
    static constexpr size_t kSlots = 4096; // events kept per stage

    using Clock = std::chrono::steady_clock;

    // `count` tiles passed `stage` at `at` (now by default).
    void stamp(TileStage stage, uint32_t count = 1, Clock::time_point at = Clock::now()) noexcept {
        Ring& r = rings_[size_t(stage)];
        const int64_t t = at.time_since_epoch().count();
        for (uint32_t i = 0; i < count; ++i) r.times[r.next.fetch_add(1, std::memory_order_relaxed) % kSlots].store(t, std::memory_order_relaxed);
    }

    // The events of `stage` at or after `from` and at or before `to`, as offsets from `from`.
    StageTimes summarise(TileStage stage, Clock::time_point from, Clock::time_point to) const {
        const std::vector<int64_t> in = within(stage, from, to);
        StageTimes s;
        if (in.empty()) return s;
        const auto ms = [](int64_t d) { return std::chrono::duration<double, std::milli>(Clock::duration(d)).count(); };
        s.tiles = uint32_t(in.size());
        s.firstMs = ms(in.front());
        s.medianMs = ms(in[in.size() / 2]);
        s.lastMs = ms(in.back());
        return s;
    }

    // The mean number of tiles between stages `a` and `b` (begun, not yet through) from `from` to
    // the last event of `b` at or before `to`: how many loaders were decoding at once, for
    // DecodeStart and Decoded. Tiles begun before `from` and ended after it count from `from`
    // (as many as the window's ends exceed its starts at any point). -1 with no event of `b`.
    double meanBetween(TileStage a, TileStage b, Clock::time_point from, Clock::time_point to) const {
        const std::vector<int64_t> starts = within(a, from, to), ends = within(b, from, to);
        if (ends.empty()) return -1;
        const int64_t last = ends.back();
        std::vector<std::pair<int64_t, int>> steps; // (time, +1 begun / -1 through), up to `last`
        for (const int64_t t : starts)
            if (t <= last) steps.emplace_back(t, 1);
        for (const int64_t t : ends) steps.emplace_back(t, -1);
        std::sort(steps.begin(), steps.end());
        int64_t open = 0, lowest = 0; // in flight at `from`: the deepest the running count goes below 0
        for (const auto& step : steps) lowest = std::min(lowest, open += step.second);
        open = -lowest;
        int64_t area = 0, at = 0; // tiles in flight × time, from `from`
        for (const auto& [t, d] : steps) {
            area += open * (t - at);
            at = t;
            open += d;
        }
        return last > 0 ? double(area) / double(last) : -1;
    }

    // Where the loaders' time goes, summed over all of them: a pass that decoded a tile (the
    // buffer, the read, the copy into staging, publishing), of which getting a buffer to decode
    // into; a pass that found none, making the cache's reserve, asleep. Beside them the reads
    // and decodes alone (SlideSource::readTile) and their tiles, for the decoders' own speed.
    enum class LoaderTime { Acquire, Work, Search, Replenish, Asleep, Count };
    // A pass that decoded a tile, counted when it ends: its whole time, then its parts (getting
    // the buffer, the read and decode). The parts are added after the whole with release and
    // read before it with acquire (the getters below, MetricsBoard), so that any sums read
    // together have work ≥ acquire and work ≥ decode, even while a pass is being counted.
    void addDecodedPass(Clock::duration work, Clock::duration acquire, Clock::duration decode) noexcept {
        loaderNs_[size_t(LoaderTime::Work)].fetch_add(ns(work), std::memory_order_relaxed);
        loaderNs_[size_t(LoaderTime::Acquire)].fetch_add(ns(acquire), std::memory_order_release);
        decodeTiles_.fetch_add(1, std::memory_order_release);
        decodeNs_.fetch_add(ns(decode), std::memory_order_release);
    }
    // A pass of another kind (Search, Replenish, Asleep), counted when it ends.
    void addLoaderTime(LoaderTime k, Clock::duration d) noexcept {
        loaderNs_[size_t(k)].fetch_add(ns(d), std::memory_order_relaxed);
    }
    // Read the parts (decodeNs, decodeTiles, Acquire) before Work (see addDecodedPass).
    uint64_t decodeNs() const noexcept { return decodeNs_.load(std::memory_order_acquire); }
    uint64_t decodeTiles() const noexcept { return decodeTiles_.load(std::memory_order_acquire); }
    uint64_t loaderNs(LoaderTime k) const noexcept { return loaderNs_[size_t(k)].load(std::memory_order_acquire); }

private:
    static uint64_t ns(Clock::duration d) noexcept {
        return uint64_t(std::chrono::duration_cast<std::chrono::nanoseconds>(d).count());
    }
    // The events of `stage` in [from, to], as offsets from `from` (clock ticks), sorted.
    std::vector<int64_t> within(TileStage stage, Clock::time_point from, Clock::time_point to) const {
        const Ring& r = rings_[size_t(stage)];
        const int64_t a = from.time_since_epoch().count(), b = to.time_since_epoch().count();
        std::vector<int64_t> in;
        const size_t n = std::min<uint64_t>(r.next.load(std::memory_order_relaxed), kSlots);
        for (size_t i = 0; i < n; ++i) {
            const int64_t t = r.times[i].load(std::memory_order_relaxed);
            if (t >= a && t <= b) in.push_back(t - a);
        }
        std::sort(in.begin(), in.end());
        return in;
    }

    std::atomic<uint64_t> decodeNs_{0}, decodeTiles_{0};
    std::array<std::atomic<uint64_t>, size_t(LoaderTime::Count)> loaderNs_{};
    struct Ring {
        std::atomic<uint64_t> next{0};
        std::array<std::atomic<int64_t>, kSlots> times{};
    };
    std::array<Ring, kTileStageCount> rings_{};
};

} // namespace iris
