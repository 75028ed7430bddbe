// The buffer thread: moves decoded tiles from the RAM cache into the GPU tile atlas in small
// microtransactions (a few tiles each: staging copy → mip chain → hand-over to rendering).
// Each pass recomputes the buffer region from the newest published view, asks the atlas
// what is missing, and takes only tiles already decoded in RAM (it never waits for a
// loader). Many transactions may be in flight; completion is read from a timeline
// semaphore and only then do the tiles' slots flip to ACTIVE.
//
// Mips (this slice): a plain 2× box filter, one vkCmdBlitImage per level over all tiles of
// the transaction. The reduction-enhancement compute pipeline replaces it (issue 6).
#pragma once

#include <atomic>
#include <thread>
#include <vector>

#include "cache/tile_cache.h"
#include "core/log.h"
#include "core/shared_state.h"
#include "gpu/tile_atlas.h"
#include "gpu/vk_util.h"

namespace iris {

class BufferThread {
public:
    BufferThread(SharedState& shared, TileCache& cache, gpu::Device& device, gpu::TileAtlas& atlas, const Log& log,
                 int perimeter);
    ~BufferThread();
    Result init();
    void start();
    void stop(); // shared.stopping must be set first

    static constexpr uint32_t kTilesPerTransaction = 8;
    static constexpr uint32_t kMaxTransactions = 8;

private:
    struct Transaction {
        VkCommandBuffer cmd = VK_NULL_HANDLE;
        uint64_t signalValue = 0; // 0: idle
        std::vector<int> slots;
        std::vector<uint32_t> staging;
    };
    void run();
    bool pollCompleted();
    bool submitNew(const Snapshot& snap);
    Result record(Transaction& t);

    SharedState& shared_;
    TileCache& cache_;
    gpu::Device& device_;
    gpu::TileAtlas& atlas_;
    const Log& log_;
    const int perimeter_;

    VkCommandPool pool_ = VK_NULL_HANDLE;
    VkSemaphore timeline_ = VK_NULL_HANDLE;
    uint64_t nextValue_ = 0;
    vk::MappedBuffer staging_;
    std::vector<uint32_t> freeStaging_;
    std::vector<Transaction> txns_;
    std::thread thread_;
};

} // namespace iris
