// The buffer thread: moves decoded tiles from the RAM cache into the GPU tile atlas in small
// microtransactions (up to 8 tiles: staging copy → mip chain → hand-over to rendering). Each
// pass recomputes the buffer region from the newest published view, asks the tile map what is
// missing, and takes only tiles already decoded in RAM (it never waits for a loader), most of
// them already in staging, where the loader that decoded them copied them (prestage). Up to 8
// transactions are in flight; completion is read from the upload timeline semaphore without
// waiting, and only then are the tiles handed to rendering.
//
// Under the host mip schedule (CPU devices) this thread makes a tile's levels itself while it
// stages it, and the transaction is one copy of all nine levels on the compute queue. Where
// the atlas is host-written (EngineTuning::tileUpload; CPU devices) there is no copy either:
// this thread writes the nine levels into the atlas's mapped memory and activates the tiles
// at once, so that no upload waits behind a frame on the device's one queue.
//
// Queues: the copy runs on the transfer queue, the mip dispatch on the compute queue, drawing
// on the graphics queue. Where those families differ, each crossing is a matched release /
// acquire ownership-transfer pair with a semaphore between: transfer → compute inside the
// transaction (transfer timeline semaphore), compute → graphics through the Handover ring
// (the render thread records the acquire and waits on the upload timeline). Where they are
// one family (lavapipe) everything is one command buffer on one queue.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <shared_mutex>
#include <unordered_map>
#include <thread>
#include <unordered_set>
#include <vector>

#include "cache/tile_cache.h"
#include "core/log.h"
#include "core/shared_state.h"
#include "buffer/handover.h"
#include "gpu/jpeg_reconstruct.h"
#include "gpu/mip_pipeline.h"
#include "gpu/tile_atlas.h"
#include "gpu/vk_handle.h"
#include "gpu/vk_util.h"
#include "slide/jpeg_coefficients.h"

namespace iris {

class BufferThread {
public:
    BufferThread(SharedState& shared, TileCache& cache, gpu::Device& device, gpu::TileAtlas& atlas,
                 gpu::MipPipeline& mips, Handover& handover, UploadCounters& counters, const Log& log, int perimeter,
                 bool trackOpacity = false, EngineTuning::JpegDecode jpegDecode = EngineTuning::JpegDecode::Auto);
    ~BufferThread();
    Result init();
    void start();
    void stop(); // shared.stopping must be set first

    // Device loss (RenderThread::recover, through the engine's rebuild): park() returns once
    // this thread has waited for the device and destroyed every GPU object it holds, and sleeps;
    // while it sleeps the device and the atlas are recreated and init() makes its objects anew
    // on the caller's thread; resume() lets it go on from an empty atlas. A thread not started
    // (or stopped) counts as parked.
    void park();
    void resume();

    static constexpr uint32_t kTilesPerTransaction = 8;
    static constexpr uint32_t kMaxTransactions = 8;
    // Staging slots for tiles loaders stage ahead (prestage), beyond the transactions' own.
    static constexpr uint32_t kPrestageTiles = kTilesPerTransaction * kMaxTransactions;

    // Any loader, with a tile it has just decoded (LoaderPool's hook): where tiles go to the
    // atlas by queue copies (not a host-written atlas), copies it into a free staging slot now,
    // swapped and its alpha looked at as this thread would, so that this thread takes it from
    // there instead of copying it out of the RAM cache. One thread copying every tile of a
    // field into staging was what a new field waited for on a 16-core GPU machine (~2 ms of a
    // 6 ms HR-TeFOV at 2774×1750; BENCHMARKS.md, "Tiles staged by the loaders"). Nothing is
    // done when no slot is free beyond those this thread keeps for itself, when the tile is
    // staged already, or while this thread is parked.
    // `coefficients`: the buffer is a coefficient record (only while reconstructsJpeg()).
    void prestage(uint64_t key, const uint8_t* pixels, bool coefficients = false);

    // Whether this thread finishes JPEG tiles on the GPU (EngineTuning::JpegDecode::Gpu, where
    // tiles go by queue copies and the mips are made on the device): loaders may then publish
    // coefficient records. Decided at construction, the same after a device loss.
    bool reconstructsJpeg() const { return jpegOnGpu_; }

private:
    // A coefficient record's header, read once as its tile is staged (jpegrecord::header); a
    // default one (no components) stands for a tile staged as pixels.
    struct RecordHeader {
        JpegCoefficients coefficients; // without blocks
        uint32_t validWidth = 0, validHeight = 0;
        bool isRecord() const { return coefficients.components != 0; }
    };
    struct Transaction {
        VkCommandBuffer copyCmd = VK_NULL_HANDLE; // transfer queue (only when its family differs); freed with copyPool_
        VkCommandBuffer cmd = VK_NULL_HANDLE;     // compute queue; freed with pool_
        uint64_t signalValue = 0; // 0: idle
        std::chrono::steady_clock::time_point submitted; // UploadCounters::uploadNs
        bool enhance = true;      // Snapshot::enhance of the view this transaction was made for
        std::vector<int> slots;
        std::vector<uint32_t> staging;
        std::vector<uint8_t> opaque; // per slot: every pixel's alpha is 255 (only with trackOpacity_)
        std::vector<uint8_t> mipsReady; // per slot: its levels 1..8 go with it (else they wait: completeMips)
        std::vector<RecordHeader> headers; // per slot: its staged record's header (reconstructsJpeg), or none for pixels
    };
    void run();
    void releaseGpu();
    bool pollCompleted();
    void finish(Transaction& t);
    void writeToAtlas(const Transaction& t);
    void writeLevels(const uint8_t* entry, int slot, uint32_t first, uint32_t end);
    // Transaction::staging's value for a tile written into the atlas straight from the cache.
    static constexpr uint32_t kWritten = UINT32_MAX;
    bool levelsWaitFor(const Snapshot& snap, int level) const;
    bool completeMips(const Snapshot& snap, bool neededOnly, size_t maxTiles);
    bool submitNew(const Snapshot& snap);
    // Host-written atlas, with nothing else to do: the next free slots' memory made resident
    // (core/prefault.h), a batch at a time, up to kPrefaultAhead slots past the next free one.
    bool prefaultAtlas();
    static constexpr uint32_t kPrefaultAhead = 256, kPrefaultBatch = 16;
    Result record(Transaction& t);
    // reconstructsJpeg: the transaction's coefficient records into their slots' base levels
    // (two dispatches, then their writes made visible to the mip pass).
    void recordReconstruct(Transaction& t);
    // The host mip schedule: levels 1..8 of the staged tile at `tile`, packed after it.
    void makeHostMips(uint8_t* tile, bool enhance);
    Result submit(Transaction& t);

    SharedState& shared_;
    TileCache& cache_;
    gpu::Device& device_;
    gpu::TileAtlas& atlas_;
    gpu::MipPipeline& mips_;
    Handover& handover_;
    UploadCounters& counters_;
    const Log& log_;
    const int perimeter_;
    // The buffer region of the last view seen (slide identity + view serial), and its keys.
    const void* regionSlide_ = nullptr;
    uint64_t regionSerial_ = 0;
    bool atlasFull_ = false; // the last pass over the region found no slot it could reclaim
    // Whether every tile of the current region is in the tile map (or the atlas is full), with
    // nothing in flight and no levels still to make: the region is done (SharedState::bufferedView).
    bool regionDone(const Snapshot& snap) const;
    // ... every tile of it in the tile map (or the atlas full), levels still to come or not.
    bool regionUploaded(const Snapshot& snap) const;
    std::vector<TileRef> region_;
    std::unordered_set<uint64_t> keep_;

    // Destroyed with the members, after the destructor's stop() has waited for the uploads in flight.
    vk::CommandPool pool_;        // compute family
    vk::CommandPool copyPool_;    // transfer family, when separate
    vk::Semaphore timeline_;      // upload timeline: signalled by the compute stage
    vk::Semaphore copyTimeline_;  // transfer → compute, when separate
    vk::QueryPool mipTimestamps_; // 2 per transaction, around the mip dispatch
    double timestampPeriodNs_ = 0;
    bool separateCopy_ = false;
    bool hostMips_ = false;                 // MipPipeline::Schedule::Host: levels made here, uploaded by copy
    bool hostWrites_ = false;               // ... and written into the host-written atlas here, not uploaded
    // Host-written atlas: tiles activated with their base level alone, whose levels 1..8 this
    // thread makes later (levelsWaitFor, completeMips), oldest first; and the scratch for them.
    struct PendingMips {
        int slot;
        uint64_t key;
        bool enhance;
    };
    std::vector<PendingMips> pendingMips_;
    std::vector<uint8_t> mipScratch_;
    uint32_t prefaulted_ = 0; // host-written atlas: slots [0, prefaulted_) made resident
    // Look at each staged tile's alpha, so that the render thread may copy opaque tiles instead
    // of drawing them (EngineTuning::exactCopy; TileMap::opaqueOf). About 5 µs a tile.
    const bool trackOpacity_;
    VkDeviceSize stagingStride_ = kTileBytes; // one tile's staging (with its levels under the host schedule)
    uint32_t transferFamily_ = 0, computeFamily_ = 0, graphicsFamily_ = 0;
    uint64_t nextValue_ = 0;
    uint64_t submittedValue_ = 0; // the last timeline value a successful submission will signal
    vk::MappedBuffer staging_;
    // reconstructsJpeg: the pipeline, its per-transaction sample planes (device memory) and tile
    // tables (host-written), one descriptor set a transaction over its parts of them and the
    // staging ring (which the compute family then reads as well as the transfer family).
    const bool jpegOnGpu_;
    static bool finishesJpeg(EngineTuning::JpegDecode requested, const gpu::Device& device, const gpu::TileAtlas& atlas,
                             const gpu::MipPipeline& mips);
    std::unique_ptr<gpu::JpegReconstruct> jpeg_;
    vk::Memory jpegPlanesMemory_;
    vk::Buffer jpegPlanes_;
    vk::MappedBuffer jpegTables_;
    std::vector<VkDescriptorSet> jpegSets_; // freed with jpeg_
    // Guards freeStaging_ and prestaged_, which loaders (prestage) share with this thread.
    std::mutex stagingMutex_;
    std::vector<uint32_t> freeStaging_;
    struct Prestaged {
        uint32_t staging;
        bool opaque;
        bool coefficients; // a coefficient record
        std::chrono::steady_clock::time_point at; // when the loader's copy ended (UploadCounters::pickupNs)
    };
    std::unordered_map<uint64_t, Prestaged> prestaged_; // tile key → its staging slot, filled by a loader
    // Held shared by a loader while it copies into staging_, exclusively while staging_ is made
    // or destroyed (init, releaseGpu): a loader never writes into a buffer that is going away.
    std::shared_mutex stagingLife_;
    std::atomic<bool> prestaging_{false}; // staging_ takes loaders' copies (not a host-written atlas)
    static constexpr uint32_t kNoStaging = UINT32_MAX - 1;
    uint32_t takeFreeStaging();              // this thread: a free slot, kNoStaging when none
    // This thread, during a pass of submitNew: prestaged_ taken out (entries it leaves go back).
    std::unordered_map<uint64_t, Prestaged> prestagedPass_;
    void dropPrestaged();                    // slots of tiles outside the region, or uploaded, back to the free list
    std::vector<Transaction> txns_;
    std::thread thread_;
    // park()/resume(): parkRequested_ is set by park() and cleared by resume(); parked_ is the
    // thread's answer. Guarded by parkMutex_.
    std::mutex parkMutex_;
    std::condition_variable parkCv_;
    bool parkRequested_ = false;
    bool parked_ = false;
    bool stopped_ = false; // stop() was called: a parked thread wakes to end
};

} // namespace iris
