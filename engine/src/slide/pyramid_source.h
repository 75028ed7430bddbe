// PyramidSource: the levels a slide's file does not store, computed from its coarsest one.
//
// The engine keeps the coarsest level resident so that the screen is never empty and the
// overview map shows the whole slide (docs/ARCHITECTURE.md, "Levels"). That needs a coarsest
// level of at most kMaxResidentBaseTiles tiles. Most slides store such a level; a slide
// without reduced levels (a plain tiled TIFF, a cut region, a scanner's single-level export)
// may not, and then neither guarantee would hold. For such a slide this decorator appends
// levels at 2×, 4×, 8×, … the coarsest stored level's downsample, until one fits; each is
// marked LevelInfo::synthetic.
//
// A synthetic tile is the exact area average (rounded to nearest) of the 2^k × 2^k block of
// stored pixels under each of its pixels, read through the wrapped source's readTile: it is
// computed from the stored level directly (never from another synthetic level), so no
// rounding accumulates. Its cost is reading 4^k stored tiles; the buffer region asks for a
// synthetic base after the stored levels' visible and perimeter tiles (view_model.cpp). Premultiplied
// RGBA averages componentwise.
//
// Threading: as SlideSource — readTile may run on every loader at once (the per-thread
// scratch is thread_local; the wrapped source is thread-safe itself).
#pragma once

#include <atomic>
#include <memory>

#include "slide/slide_source.h"

namespace iris {

class PyramidSource final : public SlideSource {
public:
    // `inner` itself when its coarsest level has at most kMaxResidentBaseTiles tiles (or it
    // has no levels); otherwise `inner` wrapped, with synthetic levels appended.
    static std::unique_ptr<SlideSource> complete(std::unique_ptr<SlideSource> inner);

    const SlideInfo& info() const override { return info_; }
    // A stored tile that fails to decode is counted as the failed-tile placeholder: the
    // synthetic tile is still whole (keepsPartialTiles), and the first error is returned.
    Result readTile(int level, int64_t tx, int64_t ty, uint8_t* dst) override;
    bool keepsPartialTiles(int level) const override { return level >= stored_ || inner_->keepsPartialTiles(level); }
    Expected<Image> readAssociatedImage(const std::string& name) override { return inner_->readAssociatedImage(name); }
    // Stored levels' records pass through; a synthetic tile is always pixels.
    bool readsCoefficients(int level) const override { return level < stored_ && inner_->readsCoefficients(level); }
    Result readTileCoefficients(int level, int64_t tx, int64_t ty, uint8_t* dst) override {
        if (level >= stored_) return Result(Status::UnsupportedFormat, "a synthetic level");
        return inner_->readTileCoefficients(level, tx, ty, dst);
    }
    // Reads in progress stop before their next stored tile (Status::Cancelled), so that a
    // closed slide does not keep the loaders (or the engine's shutdown) for seconds.
    void abandon() override {
        abandoned_.store(true, std::memory_order_relaxed);
        inner_->abandon();
    }
    // A network source's hints pass through for the stored levels. A synthetic tile is
    // computed from many stored tiles, read one after another (blocking on the network there):
    // it is never asked for ahead.
    bool readsOverNetwork() const override { return inner_->readsOverNetwork(); }
    void prefetch(const std::vector<TileAddress>& tiles, std::function<void()> arrived) override;
    bool requestTile(int level, int64_t tx, int64_t ty) override {
        return level >= stored_ || inner_->requestTile(level, tx, ty);
    }

private:
    PyramidSource(std::unique_ptr<SlideSource> inner, SlideInfo info, int stored)
        : inner_(std::move(inner)), info_(std::move(info)), stored_(stored) {}
    std::unique_ptr<SlideSource> inner_;
    SlideInfo info_;
    int stored_; // levels [0, stored_) are the file's; the rest are synthetic
    std::atomic<bool> abandoned_{false};
};

} // namespace iris
