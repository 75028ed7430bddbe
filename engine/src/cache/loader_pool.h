// The loader pool: N threads that decode tiles into the RAM cache. Pull-style: each time a
// loader picks a tile it recomputes the buffer region from the newest published view and
// takes the first tile (in priority order) that is neither cached nor being decoded, so a
// stale work list cannot exist. Loaders never touch Vulkan.
#pragma once

#include <thread>
#include <vector>

#include "cache/tile_cache.h"
#include "core/log.h"
#include "core/shared_state.h"

namespace iris {

class LoaderPool {
public:
    LoaderPool(SharedState& shared, TileCache& cache, const Log& log, unsigned threads, int perimeter);
    ~LoaderPool(); // joins (shared.stopping must be set and bumped first, or the pool does it)
    void stop();

private:
    void run();
    bool loadOne();

    SharedState& shared_;
    TileCache& cache_;
    const Log& log_;
    const int perimeter_;
    std::vector<std::thread> threads_;
};

// Fills a tile with the visible "could not be decoded" placeholder (grey with red diagonals).
void fillFailedTilePlaceholder(uint8_t* rgba);

} // namespace iris
