#include "buffer/buffer_thread.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <unordered_set>

#include "core/pixels.h"
#include "slide/jpeg_coefficients.h"
#include "core/prefault.h"
#include "gpu/mip_kernel.h"
#include "core/thread_name.h"

namespace iris {

namespace {
constexpr uint32_t kStagingTiles = BufferThread::kTilesPerTransaction * BufferThread::kMaxTransactions;
constexpr size_t kTilePixels = size_t(kTileSize) * kTileSize;
// One tile's sample planes in the JPEG reconstruction's scratch: three components of 256 rows
// of 64 words (4:4:4 at most).
constexpr uint32_t kJpegPlaneWords = 3 * 64 * 256;

// Whether every pixel of the staged RGBA tile (padding included) has alpha 255: the AND of all
// its 8-byte words, whose alpha bytes (3 and 7) must stay 0xFF.
bool allOpaque(const uint8_t* tile) {
    uint64_t acc = ~uint64_t(0);
    for (size_t i = 0; i < size_t(kTileBytes); i += 8) {
        uint64_t w;
        std::memcpy(&w, tile + i, 8);
        acc &= w;
    }
    uint8_t bytes[8];
    std::memcpy(bytes, &acc, 8);
    return bytes[3] == 0xFF && bytes[7] == 0xFF;
}
} // namespace

BufferThread::BufferThread(SharedState& shared, TileCache& cache, gpu::Device& device, gpu::TileAtlas& atlas,
                           gpu::MipPipeline& mips, Handover& handover, UploadCounters& counters, const Log& log,
                           int perimeter, bool trackOpacity, EngineTuning::JpegDecode jpegDecode)
    : shared_(shared), cache_(cache), device_(device), atlas_(atlas), mips_(mips), handover_(handover),
      counters_(counters), log_(log), perimeter_(perimeter), trackOpacity_(trackOpacity),
      jpegOnGpu_(finishesJpeg(jpegDecode, device, atlas, mips)) {
    if (jpegDecode == EngineTuning::JpegDecode::Gpu && !jpegOnGpu_)
        log_.warn("JPEG decode: finishing tiles on the GPU needs queue uploads and mips made on the device; "
                  "decoding on the CPU");
}

// Decided once, from what the engine made before this thread (a device loss rebuilds the same
// atlas and mip schedule on the same physical device): the loaders are told at their start.
// Auto: on GPUs, where it made a new field whole sooner in every alternated pair on the H200
// (BENCHMARKS.md, "The GPU's share of the decode in the engine"); a CPU device's "GPU" is the
// cores the entropy decode needs.
bool BufferThread::finishesJpeg(EngineTuning::JpegDecode requested, const gpu::Device& device,
                                const gpu::TileAtlas& atlas, const gpu::MipPipeline& mips) {
    const bool cpuDevice = device.properties().deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
    const bool wanted = requested == EngineTuning::JpegDecode::Gpu ||
                        (requested == EngineTuning::JpegDecode::Auto && !cpuDevice);
    return wanted && mips.schedule() != gpu::MipPipeline::Schedule::Host && !atlas.hostWritten() && !atlas.swapped();
}

BufferThread::~BufferThread() {
    stop(); // the uploads in flight finish before the pools, semaphores and staging ring go
}

Result BufferThread::init() {
    VkDevice dev = device_.device();
    using Role = gpu::Device::Role;
    transferFamily_ = device_.family(Role::Transfer);
    computeFamily_ = device_.family(Role::Compute);
    graphicsFamily_ = device_.family(Role::Graphics);
    // The host schedule uploads every level with one copy and dispatches nothing, so its copy
    // goes on the compute queue with the rest of the transaction.
    hostMips_ = mips_.schedule() == gpu::MipPipeline::Schedule::Host;
    // A host-written atlas takes each tile from this thread's writes (its levels made here too,
    // as the engine asks for it only under the host schedule): no queue is involved.
    hostWrites_ = atlas_.hostWritten() && hostMips_;
    separateCopy_ = transferFamily_ != computeFamily_ && !hostMips_;
    stagingStride_ = hostMips_ ? (VkDeviceSize(kTileBytes) + gpu::mipkernel::kChainBytes + 255) / 256 * 256
                               : VkDeviceSize(kTileBytes);
    const auto makePool = [&](uint32_t family, vk::CommandPool& pool) -> Result {
        const VkCommandPoolCreateInfo pci{.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
                                          .pNext = nullptr,
                                          .flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT,
                                          .queueFamilyIndex = family};
        IRIS_VK_TRY(vkCreateCommandPool(dev, &pci, nullptr, pool.replace(dev)));
        return {};
    };
    const auto makeTimeline = [&](vk::Semaphore& sem) -> Result {
        const VkSemaphoreTypeCreateInfo tci{.sType = VK_STRUCTURE_TYPE_SEMAPHORE_TYPE_CREATE_INFO,
                                            .pNext = nullptr,
                                            .semaphoreType = VK_SEMAPHORE_TYPE_TIMELINE,
                                            .initialValue = 0};
        const VkSemaphoreCreateInfo sci{.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO, .pNext = &tci, .flags = 0};
        IRIS_VK_TRY(vkCreateSemaphore(dev, &sci, nullptr, sem.replace(dev)));
        return {};
    };
    if (Result r = makePool(computeFamily_, pool_); !r.ok()) return r;
    if (Result r = makeTimeline(timeline_); !r.ok()) return r;
    if (separateCopy_) {
        if (Result r = makePool(transferFamily_, copyPool_); !r.ok()) return r;
        if (Result r = makeTimeline(copyTimeline_); !r.ok()) return r;
    }
    if (!hostMips_)
        if (Result r = vk::createTimestampPool(device_.physical(), dev, computeFamily_, 2 * kMaxTransactions,
                                               *mipTimestamps_.replace(dev), timestampPeriodNs_);
            !r.ok())
            return r;
    // Tiles written from the host were never owned by the compute family: nothing to hand over.
    handover_.needed = computeFamily_ != graphicsFamily_ && !hostWrites_;
    handover_.srcFamily = computeFamily_;
    handover_.uploadTimeline = timeline_.get();
    // The host schedule reads each base level back from staging to make its levels: cached
    // memory, where write-combined memory would make every read an uncached one.
    {
        // Loaders copy into staging_ (prestage) only while it lives: made and destroyed under
        // the exclusive lock.
        std::unique_lock life(stagingLife_);
        const uint32_t tiles = kStagingTiles + (hostWrites_ ? 0 : kPrestageTiles);
        // Finishing JPEG tiles on the GPU, the compute family reads coefficient records from
        // staging while the transfer family copies pixels out of it.
        const std::array<uint32_t, 2> families =
            jpegOnGpu_ ? std::array<uint32_t, 2>{transferFamily_, computeFamily_} : std::array<uint32_t, 2>{0, 0};
        if (Result r = vk::createMappedBuffer(device_.physical(), dev, VkDeviceSize(tiles) * stagingStride_,
                                              VK_BUFFER_USAGE_TRANSFER_SRC_BIT |
                                                  (jpegOnGpu_ ? VK_BUFFER_USAGE_STORAGE_BUFFER_BIT : 0),
                                              /*preferCached=*/hostMips_, staging_, families);
            !r.ok())
            return r;
        std::lock_guard lock(stagingMutex_);
        freeStaging_.clear();
        prestaged_.clear();
        for (uint32_t i = tiles; i-- > 0;) freeStaging_.push_back(i);
    }
    if (hostWrites_) mipScratch_.assign(size_t(kTileBytes) + gpu::mipkernel::kChainBytes, 0);
    txns_.resize(kMaxTransactions);
    if (jpegOnGpu_) {
        jpeg_ = std::make_unique<gpu::JpegReconstruct>(device_, gpu::JpegReconstruct::Output::Atlas);
        if (Result r = jpeg_->init(kMaxTransactions); !r.ok()) return r;
        const VkDeviceSize planes = VkDeviceSize(kJpegPlaneWords) * 4 * kTilesPerTransaction;
        const VkDeviceSize table = VkDeviceSize(gpu::JpegReconstruct::kDescriptorWords) * 4 * kTilesPerTransaction;
        if (Result r = vk::createDeviceBuffer(device_.physical(), dev, planes * kMaxTransactions,
                                              VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, jpegPlanes_, jpegPlanesMemory_);
            !r.ok())
            return r;
        if (Result r = vk::createMappedBuffer(device_.physical(), dev, table * kMaxTransactions,
                                              VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, false, jpegTables_);
            !r.ok())
            return r;
        jpegSets_.clear();
        for (uint32_t i = 0; i < kMaxTransactions; ++i) {
            Expected<VkDescriptorSet> set = jpeg_->makeAtlasSet(staging_.buffer, staging_.size, jpegPlanes_.get(), planes * i,
                                                                planes, atlas_.mipView(0), jpegTables_.buffer, table * i, table);
            if (!set) return set.error();
            jpegSets_.push_back(*set);
        }
    }
    const auto alloc = [&](VkCommandPool pool, VkCommandBuffer* out) -> Result {
        const VkCommandBufferAllocateInfo cai{.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
                                              .pNext = nullptr,
                                              .commandPool = pool,
                                              .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
                                              .commandBufferCount = 1};
        IRIS_VK_TRY(vkAllocateCommandBuffers(dev, &cai, out));
        return {};
    };
    for (Transaction& t : txns_) {
        if (Result r = alloc(pool_.get(), &t.cmd); !r.ok()) return r;
        if (separateCopy_)
            if (Result r = alloc(copyPool_.get(), &t.copyCmd); !r.ok()) return r;
    }
    // A host-written atlas takes tiles straight from the cache (no staging to fill ahead).
    prestaging_.store(!hostWrites_, std::memory_order_release);
    return {};
}

void BufferThread::prestage(uint64_t key, const uint8_t* pixels, bool coefficients) {
    if (!prestaging_.load(std::memory_order_acquire)) return;
    std::shared_lock life(stagingLife_, std::try_to_lock);
    if (!life.owns_lock() || !staging_.mapped) return; // being made or destroyed: this thread copies it later
    uint32_t st = 0;
    {
        std::lock_guard lock(stagingMutex_);
        // Slots for a transaction of this thread's own stay free (tiles no loader staged).
        if (freeStaging_.size() <= kTilesPerTransaction || prestaged_.count(key)) return;
        st = freeStaging_.back();
        freeStaging_.pop_back();
    }
    const auto copyStart = std::chrono::steady_clock::now();
    uint8_t* dst = static_cast<uint8_t*>(staging_.mapped) + size_t(st) * stagingStride_;
    bool opaque = false;
    if (coefficients) {
        std::memcpy(dst, pixels, jpegrecord::usedBytes(pixels)); // reconstructed opaque (JPEG has no alpha)
        opaque = true;
    } else if (trackOpacity_ || atlas_.swapped()) {
        opaque = copyPixels(pixels, dst, kTilePixels, atlas_.swapped());
    } else {
        std::memcpy(dst, pixels, kTileBytes);
    }
    const auto at = std::chrono::steady_clock::now();
    counters_.prestageNs.fetch_add(uint64_t(std::chrono::duration_cast<std::chrono::nanoseconds>(at - copyStart).count()),
                                   std::memory_order_relaxed);
    counters_.prestageTiles.fetch_add(1, std::memory_order_relaxed);
    std::lock_guard lock(stagingMutex_);
    if (!prestaged_.try_emplace(key, Prestaged{st, trackOpacity_ && opaque, coefficients, at}).second)
        freeStaging_.push_back(st);
    // This thread's next pass takes it (the loader bumps `wake` once it has published the tile).
}

uint32_t BufferThread::takeFreeStaging() {
    std::lock_guard lock(stagingMutex_);
    if (freeStaging_.empty()) return kNoStaging;
    const uint32_t st = freeStaging_.back();
    freeStaging_.pop_back();
    return st;
}

void BufferThread::dropPrestaged() {
    std::lock_guard lock(stagingMutex_);
    for (auto it = prestaged_.begin(); it != prestaged_.end();) {
        if (!keep_.count(it->first) || atlas_.map().contains(it->first)) {
            freeStaging_.push_back(it->second.staging);
            it = prestaged_.erase(it);
        } else {
            ++it;
        }
    }
}

void BufferThread::start() {
    thread_ = std::thread([this] {
        nameThisThread("iris-buffer");
        run();
    });
}

void BufferThread::stop() {
    {
        std::lock_guard lock(parkMutex_);
        stopped_ = true;
    }
    parkCv_.notify_all();
    if (thread_.joinable()) thread_.join();
    releaseGpu();
}

// Lets the GPU finish the uploads in flight before their resources go away. On a lost device
// nothing may signal the timeline again: the device is waited for as a whole instead.
void BufferThread::releaseGpu() {
    if (!device_.device()) return;
    if (device_.lost()) {
        (void)device_.waitIdle(); // reports the loss, known already
    } else if (timeline_ && submittedValue_ > 0) {
        const VkSemaphore timeline = timeline_.get();
        const VkSemaphoreWaitInfo wi{.sType = VK_STRUCTURE_TYPE_SEMAPHORE_WAIT_INFO,
                                     .pNext = nullptr,
                                     .flags = 0,
                                     .semaphoreCount = 1,
                                     .pSemaphores = &timeline,
                                     .pValues = &submittedValue_};
        if (const VkResult r = vkWaitSemaphores(device_.device(), &wi, UINT64_MAX); r != VK_SUCCESS) {
            if (r == VK_ERROR_DEVICE_LOST) device_.reportLost("vkWaitSemaphores (uploads in flight)");
            (void)device_.waitIdle();
        }
    }
    txns_.clear(); // their command buffers go with the pools
    prestaging_.store(false, std::memory_order_release);
    {
        std::unique_lock life(stagingLife_); // after every loader's copy into it
        std::lock_guard lock(stagingMutex_);
        freeStaging_.clear();
        prestaged_.clear();
        staging_ = {};
    }
    jpegSets_.clear();
    jpeg_.reset();
    jpegTables_ = {};
    jpegPlanes_ = {};
    jpegPlanesMemory_ = {};
    mipTimestamps_ = {};
    copyTimeline_ = {};
    timeline_ = {};
    copyPool_ = {};
    pool_ = {};
    nextValue_ = submittedValue_ = 0;
    handover_.uploadTimeline = VK_NULL_HANDLE;
    pendingMips_.clear();
    prefaulted_ = 0;
    regionSlide_ = nullptr; // the region is planned again against the new atlas
    regionSerial_ = 0;
    atlasFull_ = false;
}

void BufferThread::park() {
    std::unique_lock lock(parkMutex_);
    if (!thread_.joinable() || stopped_) return;
    parkRequested_ = true;
    lock.unlock();
    shared_.bump(); // a thread asleep on the wake counter looks again
    lock.lock();
    parkCv_.wait(lock, [&] { return parked_ || stopped_; });
}

void BufferThread::resume() {
    {
        std::lock_guard lock(parkMutex_);
        parkRequested_ = false;
    }
    parkCv_.notify_all();
}

void BufferThread::run() {
    while (!shared_.stopping.load(std::memory_order_acquire)) {
        const uint64_t seen = shared_.wakeValue();
        {
            std::unique_lock lock(parkMutex_);
            if (parkRequested_) {
                lock.unlock();
                releaseGpu();
                lock.lock();
                parked_ = true;
                parkCv_.notify_all();
                parkCv_.wait(lock, [&] { return !parkRequested_ || stopped_; });
                parked_ = false;
                continue;
            }
        }
        if (device_.lost()) {
            // Nothing submitted will complete and nothing new may be: wait for the render
            // thread's recovery to park this thread.
            shared_.waitChange(seen);
            continue;
        }
        bool progress = pollCompleted();
        const Snapshot snap = shared_.snapshot();
        if (snap.slide) {
            // Levels this view needs first (its frames leave those tiles out until then), then new
            // tiles, and with nothing else to do the levels still to come (host-written atlas).
            progress |= completeMips(snap, /*neededOnly=*/true, kTilesPerTransaction);
            progress |= submitNew(snap);
            // (Only once this view's tiles are all in: a new field's decodes and uploads come first.)
            if (!progress && regionUploaded(snap)) progress |= completeMips(snap, /*neededOnly=*/false, 2);
        }
        if (progress) continue;
        const bool inFlight = std::any_of(txns_.begin(), txns_.end(), [](const Transaction& t) { return t.signalValue; });
        if (inFlight) {
            // Sleep until the oldest upload completes or 2 ms pass, whichever is first; a new
            // view published meanwhile is picked up on the next pass.
            uint64_t oldest = UINT64_MAX;
            for (const auto& t : txns_)
                if (t.signalValue) oldest = std::min(oldest, t.signalValue);
            const VkSemaphore timeline = timeline_.get();
            const VkSemaphoreWaitInfo wi{.sType = VK_STRUCTURE_TYPE_SEMAPHORE_WAIT_INFO,
                                         .pNext = nullptr,
                                         .flags = 0,
                                         .semaphoreCount = 1,
                                         .pSemaphores = &timeline,
                                         .pValues = &oldest};
            if (const VkResult r = vkWaitSemaphores(device_.device(), &wi, 2'000'000); r < 0) {
                // The device is lost: nothing in flight will complete. The render thread
                // recovers (it parks this thread); any other error is reported once.
                if (r == VK_ERROR_DEVICE_LOST)
                    device_.reportLost("vkWaitSemaphores (uploads in flight)");
                else
                    shared_.setError(vk::check(r, "vkWaitSemaphores (uploads in flight)"));
                shared_.waitChange(seen);
            }
            continue;
        }
        if (snap.slide && snap.viewSerial != shared_.bufferedView.load(std::memory_order_relaxed) && regionDone(snap)) {
            shared_.bufferedView.store(snap.viewSerial, std::memory_order_release);
            shared_.bump(); // the render thread draws the settled frame
            continue;
        }
        if (prefaultAtlas()) continue;
        shared_.waitChange(seen);
    }
    // An ended thread counts as parked: a recovery that asks now must not wait for it.
    std::lock_guard lock(parkMutex_);
    parked_ = true;
    parkCv_.notify_all();
}

bool BufferThread::regionDone(const Snapshot& snap) const {
    return pendingMips_.empty() && regionUploaded(snap); // done with the levels made too
}

bool BufferThread::regionUploaded(const Snapshot& snap) const {
    if (regionSlide_ != snap.slide.get() || regionSerial_ != snap.viewSerial) return false; // not planned yet
    if (atlasFull_) return true;
    const TileMap& map = atlas_.map();
    return std::all_of(region_.begin(), region_.end(), [&](const TileRef& t) { return map.contains(t.key); });
}

bool BufferThread::pollCompleted() {
    uint64_t done = 0;
    const VkResult vr = vkGetSemaphoreCounterValue(device_.device(), timeline_.get(), &done);
    if (vr != VK_SUCCESS) {
        if (vr == VK_ERROR_DEVICE_LOST)
            device_.reportLost("vkGetSemaphoreCounterValue (uploads)");
        else
            shared_.setError(vk::check(vr, "vkGetSemaphoreCounterValue"));
        return false;
    }
    // In submission order (the ring's slots are reused out of order): a frame drawn while these
    // are handed over sees an earlier transaction's tiles — a field's LR tiles, requested
    // first — before a later one's, never the reverse.
    Transaction* completed[kMaxTransactions];
    size_t count = 0;
    for (Transaction& t : txns_) {
        if (!t.signalValue || t.signalValue > done) continue;
        size_t i = count++; // insertion by signal value (eight at most)
        for (; i > 0 && completed[i - 1]->signalValue > t.signalValue; --i) completed[i] = completed[i - 1];
        completed[i] = &t;
    }
    for (size_t i = 0; i < count; ++i) finish(*completed[i]);
    if (count) shared_.bump(); // the render thread has new tiles to draw
    return count > 0;
}

// A transaction's tiles are in the atlas (its upload has completed, or it was written from the
// host): count them, then hand them to rendering.
void BufferThread::finish(Transaction& t) {
    // Counted before the tiles become drawable, so that a field the render thread sees
    // complete has all its uploads counted (TPT).
    if (mipTimestamps_) {
        uint64_t ts[2] = {0, 0};
        const uint32_t q = uint32_t(&t - txns_.data()) * 2;
        if (vkGetQueryPoolResults(device_.device(), mipTimestamps_.get(), q, 2, sizeof(ts), ts, sizeof(uint64_t),
                                  VK_QUERY_RESULT_64_BIT) == VK_SUCCESS &&
            ts[1] >= ts[0]) {
            counters_.mipNs.fetch_add(uint64_t(double(ts[1] - ts[0]) * timestampPeriodNs_), std::memory_order_relaxed);
            counters_.mipTiles.fetch_add(t.slots.size(), std::memory_order_relaxed);
        }
    }
    // Each tile's sequence number: the counter's value once it is counted (the stamp that
    // tells metrics whether a tile was uploaded after a move).
    uint64_t seq = counters_.tiles.fetch_add(t.slots.size(), std::memory_order_relaxed);
    const auto now = StageLog::Clock::now();
    if (!hostWrites_) {
        counters_.uploadNs.fetch_add(uint64_t(std::chrono::duration_cast<std::chrono::nanoseconds>(now - t.submitted).count()),
                                     std::memory_order_relaxed);
        counters_.uploadTransactions.fetch_add(1, std::memory_order_release); // after its time (MetricsBoard)
    }
    shared_.tileStages.stamp(TileStage::GpuDone, uint32_t(t.slots.size()), now);
    if (!handover_.needed) shared_.tileStages.stamp(TileStage::Drawable, uint32_t(t.slots.size()), now);
    counters_.bytes.fetch_add(t.slots.size() * gpu::TileAtlas::bytesPerSlot(), std::memory_order_relaxed);
    // Single family: the compute submission made the tiles visible to fragment reads, so
    // they can be drawn now. Host writes: the submission of the first frame that draws them
    // makes them visible (a queue submission takes every host write before it). Separate
    // families: the render thread must first record the acquire half of the compute → graphics
    // ownership transfer; it activates them then.
    for (size_t i = 0; i < t.slots.size(); ++i) {
        ++seq;
        const bool opaque = t.opaque[i] != 0;
        if (handover_.needed)
            handover_.push({t.slots[i], t.signalValue, seq, opaque});
        else
            atlas_.map().activate(t.slots[i], seq, opaque, t.mipsReady[i] != 0);
    }
    {
        std::lock_guard lock(stagingMutex_);
        for (uint32_t s : t.staging)
            if (s != kWritten) freeStaging_.push_back(s);
    }
    t.slots.clear();
    t.staging.clear();
    t.opaque.clear();
    t.mipsReady.clear();
    t.headers.clear();
    t.signalValue = 0;
}

bool BufferThread::submitNew(const Snapshot& snap) {
    auto txIt = std::find_if(txns_.begin(), txns_.end(), [](const Transaction& t) { return t.signalValue == 0; });
    if (txIt == txns_.end()) return false;
    Transaction& tx = *txIt;
    {
        // Nothing to stage into, and nothing loaders staged: no tile can go.
        std::lock_guard lock(stagingMutex_);
        if (freeStaging_.empty() && prestaged_.empty()) return false;
    }
    if (regionSlide_ != snap.slide.get() || regionSerial_ != snap.viewSerial) {
        // Once per view, not once per wake-up (every decoded tile wakes this thread).
        region_ = bufferRegion(snap.slide->info, snap.slide->generation, snap.viewport, perimeter_);
        keep_.clear();
        keep_.reserve(region_.size() * 2);
        for (const TileRef& t : region_) keep_.insert(t.key);
        regionSlide_ = snap.slide.get();
        regionSerial_ = snap.viewSerial;
        dropPrestaged(); // staged for a view left behind
    }
    // The tiles loaders staged, taken out for this pass with one lock (not one a region tile);
    // those it leaves go back after it.
    {
        std::lock_guard lock(stagingMutex_);
        prestagedPass_.swap(prestaged_);
    }
    struct PutBack {
        BufferThread& self;
        ~PutBack() {
            std::lock_guard lock(self.stagingMutex_);
            for (const auto& [key, p] : self.prestagedPass_)
                if (!self.prestaged_.try_emplace(key, p).second) self.freeStaging_.push_back(p.staging);
            self.prestagedPass_.clear();
        }
    } putBack{*this};
    atlasFull_ = false;
    const std::vector<TileRef>& region = region_;
    const std::unordered_set<uint64_t>& keep = keep_;
    TileMap& map = atlas_.map();
    // allocate() may reclaim a slot only for a tile outside the region.
    const auto inRegion = [&](uint64_t k) { return keep.count(k) != 0; };
    auto* base = static_cast<uint8_t*>(staging_.mapped);
    if (!shared_.failingTiles.empty() && snap.slide->source->readsOverNetwork()) {
        // A tile failed for now: the render thread draws the placeholder in its place, from a
        // slot of its own that stays while tiles are listed (core/failing_tiles.h).
        const uint64_t ph = placeholderKey(snap.slide->generation);
        keep_.insert(ph);
        if (!map.contains(ph)) {
            const int slot = map.allocate(ph, inRegion);
            if (const uint32_t st = slot >= 0 ? takeFreeStaging() : kNoStaging; st == kNoStaging) {
                if (slot >= 0) map.abandon(slot);
            } else {
                fillFailedTilePlaceholder(base + size_t(st) * stagingStride_);
                if (atlas_.swapped()) swapRedBlue(base + size_t(st) * stagingStride_, base + size_t(st) * stagingStride_, kTilePixels);
                tx.opaque.push_back(trackOpacity_ && allOpaque(base + size_t(st) * stagingStride_));
                if (hostMips_) makeHostMips(base + size_t(st) * stagingStride_, snap.enhance);
                tx.mipsReady.push_back(true);
                tx.headers.emplace_back();
                tx.slots.push_back(slot);
                tx.staging.push_back(st);
            }
        }
    }
    for (const TileRef& t : region) {
        if (tx.slots.size() == kTilesPerTransaction) break;
        const auto pre = prestagedPass_.find(t.key);
        if (map.contains(t.key)) {
            if (pre != prestagedPass_.end()) { // in the atlas already (decoded again after an eviction from RAM)
                std::lock_guard lock(stagingMutex_);
                freeStaging_.push_back(pre->second.staging);
                prestagedPass_.erase(pre);
            }
            continue;
        }
        const bool staged = pre != prestagedPass_.end();
        if (!staged && !cache_.isReady(t.key)) continue;
        const int slot = map.allocate(t.key, inRegion);
        if (slot < 0) { // atlas full of tiles that are needed or still drawn
            atlasFull_ = true;
            break;
        }
        bool failed = false;
        const bool defer = hostWrites_ && levelsWaitFor(snap, t.level);
        if (defer && atlas_.hostRowPitch(0) == VkDeviceSize(kTileSize) * 4) {
            // Its base level alone, straight from the RAM cache into the atlas: one pass that
            // copies, swaps the channels where the atlas is BGRA and looks at the alpha.
            bool opaque = false;
            uint8_t* dst = atlas_.hostLevel(slot, 0);
            if (!cache_.readOut(
                    t.key, [&](const uint8_t* src) { opaque = copyPixels(src, dst, kTilePixels, atlas_.swapped()); },
                    &failed)) {
                map.abandon(slot); // evicted from RAM meanwhile; a loader will decode it again
                continue;
            }
            tx.opaque.push_back(trackOpacity_ && opaque);
            tx.mipsReady.push_back(false);
            tx.headers.emplace_back(); // no records where the atlas is host-written
            pendingMips_.push_back({slot, t.key, snap.enhance});
            shared_.tileStages.stamp(TileStage::Staged);
            tx.slots.push_back(slot);
            tx.staging.push_back(kWritten);
            continue;
        }
        uint32_t st = kNoStaging;
        bool coefficients = false;
        if (staged) { // a loader copied it in, swapped and looked at (prestage)
            st = pre->second.staging;
            coefficients = pre->second.coefficients;
            tx.opaque.push_back(pre->second.opaque);
            const auto waited = std::chrono::steady_clock::now() - pre->second.at;
            counters_.pickupNs.fetch_add(uint64_t(std::chrono::duration_cast<std::chrono::nanoseconds>(waited).count()),
                                         std::memory_order_relaxed);
            counters_.pickupTiles.fetch_add(1, std::memory_order_release); // after its time (MetricsBoard)
            prestagedPass_.erase(pre);
        } else {
            st = takeFreeStaging();
            if (st == kNoStaging) { // loaders hold the rest: their tiles come in the next pass
                map.abandon(slot);
                break;
            }
            if (!cache_.copyOut(t.key, base + size_t(st) * stagingStride_, &failed, &coefficients)) {
                map.abandon(slot); // evicted from RAM meanwhile; a loader will decode it again
                std::lock_guard lock(stagingMutex_);
                freeStaging_.push_back(st);
                continue;
            }
            if (coefficients) {
                tx.opaque.push_back(trackOpacity_); // reconstructed opaque (JPEG has no alpha)
            } else {
                if (atlas_.swapped())
                    swapRedBlue(base + size_t(st) * stagingStride_, base + size_t(st) * stagingStride_, kTilePixels);
                tx.opaque.push_back(trackOpacity_ && allOpaque(base + size_t(st) * stagingStride_));
            }
        }
        RecordHeader header;
        if (coefficients) {
            if (!jpegOnGpu_ || !jpegrecord::header(base + size_t(st) * stagingStride_, header.coefficients,
                                                   header.validWidth, header.validHeight)) {
                // Not a record this thread can finish (it cannot happen: loaders write records
                // only while it finishes them, and whole): never drawn, decoded again when needed.
                log_.error("JPEG decode: a tile's coefficient record is unusable; dropping it");
                map.abandon(slot);
                tx.opaque.pop_back();
                std::lock_guard lock(stagingMutex_);
                freeStaging_.push_back(st);
                continue;
            }
        }
        tx.headers.push_back(std::move(header));
        if (hostMips_ && !defer) makeHostMips(base + size_t(st) * stagingStride_, snap.enhance);
        tx.mipsReady.push_back(!defer);
        if (defer) pendingMips_.push_back({slot, t.key, snap.enhance}); // made once the tile is written
        shared_.tileStages.stamp(TileStage::Staged);
        tx.slots.push_back(slot);
        tx.staging.push_back(st);
    }
    // A reclaim that backed off may have made a frame skip that tile: draw again.
    if (map.takeReclaimAborted()) shared_.bump();
    if (tx.slots.empty()) return false;
    tx.enhance = snap.enhance;
    if (hostWrites_) {
        writeToAtlas(tx);
        shared_.tileStages.stamp(TileStage::Submitted, uint32_t(tx.slots.size()));
        finish(tx);
        shared_.bump(); // the render thread has new tiles to draw
        return true;
    }
    if (Result r = vk::flush(device_.device(), staging_); !r.ok()) { // non-coherent memory only
        shared_.setError(r);
        log_.error(r.message());
    }
    if (Result r = record(tx); !r.ok()) {
        shared_.setError(r);
        log_.error(r.message());
        for (int s : tx.slots) map.abandon(s);
        {
            std::lock_guard lock(stagingMutex_);
            for (uint32_t s : tx.staging) freeStaging_.push_back(s);
        }
        tx.slots.clear();
        tx.staging.clear();
        tx.opaque.clear();
        tx.mipsReady.clear();
        tx.headers.clear();
        return false;
    }
    tx.signalValue = ++nextValue_;
    tx.submitted = std::chrono::steady_clock::now();
    if (Result r = submit(tx); !r.ok()) {
        // The GPU state is unknown after a failed submit: leave the slots FILLING (never drawn).
        // A lost device is the render thread's to recover (Device marked it); anything else is
        // reported here.
        if (r.status() != Status::DeviceLost) {
            shared_.setError(r);
            log_.error(r.message());
        }
        tx.signalValue = 0;
        return false;
    }
    submittedValue_ = tx.signalValue;
    shared_.tileStages.stamp(TileStage::Submitted, uint32_t(tx.slots.size()));
    return true;
}

bool BufferThread::prefaultAtlas() {
    if (!hostWrites_) return false;
    const TileMap& map = atlas_.map();
    const uint32_t want = uint32_t(std::min<uint64_t>(map.slotCount(), uint64_t(map.nextFreeHint()) + kPrefaultAhead));
    if (prefaulted_ >= want) return false;
    const uint32_t end = std::min(want, prefaulted_ + kPrefaultBatch);
    // Each level of the slots [prefaulted_, end): one range of the mapped memory. Pages shared
    // with slots in use keep their contents (the call only makes pages resident).
    for (uint32_t m = 0; m < gpu::kTileMipLevels; ++m) {
        uint8_t* first = atlas_.hostLevel(int(prefaulted_), m);
        prefaultForWrite(first, size_t(atlas_.hostLevel(int(end), m) - first));
    }
    prefaulted_ = end;
    return true;
}

void BufferThread::makeHostMips(uint8_t* tile, bool enhance) {
    const auto t0 = std::chrono::steady_clock::now();
    gpu::mipkernel::reduceChain8(tile, tile + kTileBytes, enhance);
    const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - t0).count();
    counters_.mipNs.fetch_add(uint64_t(ns), std::memory_order_relaxed);
    counters_.mipTiles.fetch_add(1, std::memory_order_relaxed);
}

// The host-written atlas: levels [first, end) of a tile (`entry`: the base level, then the 8
// levels packed behind it), row by row, into `slot`'s layer. The slot is this thread's: FILLING
// (no frame samples it until finish() activates it), or ACTIVE without its levels (frames draw
// it only where they sample level 0 alone: TileMap::mipsReadyOf). The frames that sampled a
// reclaimed slot before have ended (the tile map reclaims only slots that no frame has pinned,
// and frames unpin after their fence).
void BufferThread::writeLevels(const uint8_t* entry, int slot, uint32_t first, uint32_t end) {
    for (uint32_t m = first; m < end; ++m) {
        const size_t side = size_t(kTileSize) >> m;
        const size_t row = side * 4;
        const uint8_t* src = m == 0 ? entry : entry + kTileBytes + gpu::mipkernel::chainOffset(int(m));
        uint8_t* dst = atlas_.hostLevel(slot, m);
        const size_t pitch = size_t(atlas_.hostRowPitch(m));
        if (pitch == row) {
            std::memcpy(dst, src, row * side);
        } else {
            for (size_t y = 0; y < side; ++y) std::memcpy(dst + y * pitch, src + y * row, row);
        }
    }
}

// Each staged tile of a transaction into the host-written atlas: all nine levels, or the base
// level alone where its levels wait (Transaction::mipsReady); those written straight from the
// RAM cache (kWritten) are there already.
void BufferThread::writeToAtlas(const Transaction& tx) {
    const auto* base = static_cast<const uint8_t*>(staging_.mapped);
    for (size_t i = 0; i < tx.slots.size(); ++i)
        if (tx.staging[i] != kWritten)
            writeLevels(base + size_t(tx.staging[i]) * stagingStride_, tx.slots[i], 0,
                        tx.mipsReady[i] ? gpu::kTileMipLevels : 1);
}

// A tile of `level` uploaded for this view waits for its levels 1..8 when the view samples it
// at level 0 alone: the view shows that level at its own scale or enlarged (lod 0; LR is always
// enlarged), and it is not the base level, whose tiles the overview also draws, shrunk. Its
// levels are made when the buffer thread has nothing to upload, or at once when a view needs
// them (completeMips). On a CPU device the levels are a third of the CPU a new field costs
// (0.3 ms a tile), and most fields are shown at a level's own scale.
bool BufferThread::levelsWaitFor(const Snapshot& snap, int level) const {
    const SlideInfo& info = snap.slide->info;
    if (level < 0 || size_t(level) >= info.levels.size()) return false;
    if (level == chooseLevels(info, snap.viewport.view.downsample).base) return false;
    return !(snap.viewport.view.downsample > info.levels[size_t(level)].downsample);
}

// Levels 1..8 of tiles activated without them, read back from the atlas's base level (the
// atlas's memory is the host's). With neededOnly, only those of levels the current view shrinks
// (whose tiles its frames leave out until then), else in the order they were uploaded; at most
// maxTiles a call, so that a new view is looked at between. Entries whose slot was reclaimed
// since, whose slot has its levels already, or whose slide generation is gone, are dropped.
bool BufferThread::completeMips(const Snapshot& snap, bool neededOnly, size_t maxTiles) {
    if (pendingMips_.empty()) return false;
    TileMap& map = atlas_.map();
    const SlideInfo* info = snap.slide ? &snap.slide->info : nullptr;
    size_t made = 0;
    bool any = false;
    for (size_t i = 0; i < pendingMips_.size() && made < maxTiles;) {
        const PendingMips p = pendingMips_[i];
        const int level = TileKey::level(p.key);
        const bool current = info && TileKey::generation(p.key) == (snap.slide->generation & 0xFFFF) &&
                             size_t(level) < info->levels.size();
        // (Ready already: the tile left the slot and came back to it with its levels.)
        if (!current || map.slotOf(p.key) != p.slot || map.mipsReadyOf(p.slot)) {
            pendingMips_.erase(pendingMips_.begin() + ptrdiff_t(i));
            continue;
        }
        if (neededOnly && !(snap.viewport.view.downsample > info->levels[size_t(level)].downsample)) {
            ++i;
            continue;
        }
        const auto t0 = std::chrono::steady_clock::now();
        const size_t row = size_t(kTileSize) * 4, pitch = size_t(atlas_.hostRowPitch(0));
        const uint8_t* base = atlas_.hostLevel(p.slot, 0);
        if (pitch != row) { // the base level into the scratch's first part, contiguous
            for (size_t y = 0; y < size_t(kTileSize); ++y)
                std::memcpy(mipScratch_.data() + y * row, base + y * pitch, row);
            base = mipScratch_.data();
        }
        gpu::mipkernel::reduceChain8(base, mipScratch_.data() + kTileBytes, p.enhance);
        writeLevels(mipScratch_.data(), p.slot, 1, gpu::kTileMipLevels);
        map.setMipsReady(p.slot);
        const auto ns =
            std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - t0).count();
        counters_.mipNs.fetch_add(uint64_t(ns), std::memory_order_relaxed);
        counters_.mipTiles.fetch_add(1, std::memory_order_relaxed);
        pendingMips_.erase(pendingMips_.begin() + ptrdiff_t(i));
        ++made;
        any = true;
    }
    if (any && neededOnly) shared_.bump(); // frames that left those tiles out can draw them now
    return any;
}

Result BufferThread::submit(Transaction& tx) {
    using Role = gpu::Device::Role;
    const VkSemaphoreSubmitInfo copyDone =
        vk::semaphoreInfo(copyTimeline_.get(), tx.signalValue, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT);
    if (separateCopy_) {
        const VkCommandBufferSubmitInfo cbi = vk::commandInfo(tx.copyCmd);
        IRIS_VK_TRY(device_.submit(Role::Transfer, vk::submitInfo(&cbi, nullptr, 0, &copyDone, 1), VK_NULL_HANDLE));
    }
    // The compute stage waits for the copy (its acquire barrier needs the release to have run).
    const VkSemaphoreSubmitInfo waitCopy =
        vk::semaphoreInfo(copyTimeline_.get(), tx.signalValue, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT);
    const VkSemaphoreSubmitInfo sig =
        vk::semaphoreInfo(timeline_.get(), tx.signalValue, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT);
    const VkCommandBufferSubmitInfo cbi = vk::commandInfo(tx.cmd);
    const VkSubmitInfo2 si = vk::submitInfo(&cbi, &waitCopy, separateCopy_ ? 1u : 0u, &sig, 1);
    IRIS_VK_TRY(device_.submit(Role::Compute, si, VK_NULL_HANDLE));
    return {};
}

namespace {

VkImageMemoryBarrier2 ownership(VkImage img, VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                                VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess, VkImageLayout oldLayout,
                                uint32_t srcFamily, uint32_t dstFamily, VkImageSubresourceRange range) {
    VkImageMemoryBarrier2 b = vk::imageBarrier(img, srcStage, srcAccess, dstStage, dstAccess, oldLayout,
                                               VK_IMAGE_LAYOUT_GENERAL, range);
    if (srcFamily != dstFamily) {
        b.srcQueueFamilyIndex = srcFamily;
        b.dstQueueFamilyIndex = dstFamily;
    }
    return b;
}

Result beginCommands(VkCommandBuffer cmd) {
    IRIS_VK_TRY(vkResetCommandBuffer(cmd, 0));
    const VkCommandBufferBeginInfo bi{.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                      .pNext = nullptr,
                                      .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT,
                                      .pInheritanceInfo = nullptr};
    IRIS_VK_TRY(vkBeginCommandBuffer(cmd, &bi));
    return {};
}

} // namespace

Result BufferThread::record(Transaction& t) {
    VkImage img = atlas_.image();
    const uint32_t n = uint32_t(t.slots.size());
    constexpr VkPipelineStageFlags2 kCopy = VK_PIPELINE_STAGE_2_COPY_BIT;
    constexpr VkPipelineStageFlags2 kCompute = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
    constexpr VkPipelineStageFlags2 kFragment = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
    const uint32_t T = transferFamily_, C = computeFamily_, G = graphicsFamily_;
    const auto base = [](int s) { return vk::colorRange(0, 1, uint32_t(s), 1); };
    const auto mips = [](int s) { return vk::colorRange(1, gpu::kTileMipLevels - 1, uint32_t(s), 1); };
    const auto all = [](int s) { return vk::colorRange(0, gpu::kTileMipLevels, uint32_t(s), 1); };
    std::vector<VkImageMemoryBarrier2> b;
    b.reserve(2 * n);
    // Tiles copied from staging (pixels), and tiles whose coefficient records the GPU finishes
    // (reconstructsJpeg: their base level is written by the compute pass, not copied).
    std::vector<int> copied, rebuilt;
    for (uint32_t i = 0; i < n; ++i) (t.headers[i].isRecord() ? rebuilt : copied).push_back(t.slots[i]);
    const uint32_t nc = uint32_t(copied.size());

    // The base level of each copied tile; under the host schedule also its 8 levels, packed after it.
    const uint32_t levels = hostMips_ ? gpu::kTileMipLevels : 1;
    std::vector<VkBufferImageCopy> copies;
    copies.reserve(size_t(nc) * levels);
    for (uint32_t i = 0; i < n; ++i) {
        if (t.headers[i].isRecord()) continue;
        for (uint32_t m = 0; m < levels; ++m) {
            const uint32_t side = uint32_t(kTileSize) >> m;
            copies.push_back(VkBufferImageCopy{
                .bufferOffset = VkDeviceSize(t.staging[i]) * stagingStride_ +
                                (m == 0 ? 0 : VkDeviceSize(kTileBytes) + gpu::mipkernel::chainOffset(int(m))),
                .bufferRowLength = 0,
                .bufferImageHeight = 0,
                .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, m, uint32_t(t.slots[i]), 1},
                .imageOffset = {0, 0, 0},
                .imageExtent = {side, side, 1},
            });
        }
    }
    // A reclaimed slot's old content is discarded (oldLayout UNDEFINED), which also lets the
    // uploading queue family take it without an ownership transfer back from graphics. Frames
    // that sampled it have completed (the tile map reclaims only unpinned slots, and frames
    // unpin after their fence), so only the stage order below is needed.
    if (separateCopy_) {
        // Transfer queue: discard + copy the base level, then release it to the compute family
        // (an empty command buffer when every tile is rebuilt: the submission still signals).
        if (Result r = beginCommands(t.copyCmd); !r.ok()) return r;
        if (nc > 0) {
            for (int s : copied)
                b.push_back(vk::imageBarrier(img, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE, kCopy,
                                             VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                                             VK_IMAGE_LAYOUT_GENERAL, base(s)));
            vk::pipelineBarrier(t.copyCmd, b.data(), nc);
            vkCmdCopyBufferToImage(t.copyCmd, staging_.buffer, img, VK_IMAGE_LAYOUT_GENERAL, uint32_t(copies.size()),
                                   copies.data());
            b.clear();
            for (int s : copied) // release: dst stage/access NONE (the acquire supplies them)
                b.push_back(ownership(img, kCopy, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE,
                                      VK_IMAGE_LAYOUT_GENERAL, T, C, base(s)));
            vk::pipelineBarrier(t.copyCmd, b.data(), nc);
        }
        IRIS_VK_TRY(vkEndCommandBuffer(t.copyCmd));
    }

    // Compute queue.
    VkCommandBuffer cmd = t.cmd;
    if (Result r = beginCommands(cmd); !r.ok()) return r;
    b.clear();
    if (separateCopy_) {
        for (int s : copied) { // acquire from transfer: src stage/access NONE (the release supplied them)
            b.push_back(ownership(img, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE, kCompute,
                                  VK_ACCESS_2_SHADER_STORAGE_READ_BIT, VK_IMAGE_LAYOUT_GENERAL, T, C, base(s)));
            b.push_back(vk::imageBarrier(img, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE, kCompute,
                                         VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                                         VK_IMAGE_LAYOUT_GENERAL, mips(s)));
        }
        for (int s : rebuilt) // the whole slot is this queue's to write: its old content discarded
            b.push_back(vk::imageBarrier(img, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE, kCompute,
                                         VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                                         VK_IMAGE_LAYOUT_GENERAL, all(s)));
        vk::pipelineBarrier(cmd, b.data(), uint32_t(b.size()));
    } else {
        // After the last frames that sampled the slot (on this queue when it also draws; else
        // their fences ordered them already, as for the transfer queue above).
        const VkPipelineStageFlags2 after = C == G ? kFragment : VK_PIPELINE_STAGE_2_NONE;
        for (int s : t.slots)
            b.push_back(vk::imageBarrier(img, after, VK_ACCESS_2_NONE, hostMips_ ? kCopy : kCopy | kCompute,
                                         hostMips_ ? VK_ACCESS_2_TRANSFER_WRITE_BIT
                                                   : VK_ACCESS_2_TRANSFER_WRITE_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                         VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL, all(s)));
        vk::pipelineBarrier(cmd, b.data(), n);
        if (!copies.empty())
            vkCmdCopyBufferToImage(cmd, staging_.buffer, img, VK_IMAGE_LAYOUT_GENERAL, uint32_t(copies.size()), copies.data());
        b.clear();
        if (!hostMips_ && nc > 0) {
            for (int s : copied)
                b.push_back(vk::imageBarrier(img, kCopy, VK_ACCESS_2_TRANSFER_WRITE_BIT, kCompute,
                                             VK_ACCESS_2_SHADER_STORAGE_READ_BIT, VK_IMAGE_LAYOUT_GENERAL,
                                             VK_IMAGE_LAYOUT_GENERAL, base(s)));
            vk::pipelineBarrier(cmd, b.data(), nc);
        }
    }
    if (!rebuilt.empty()) recordReconstruct(t);
    const uint32_t q = uint32_t(&t - txns_.data()) * 2;
    if (mipTimestamps_) {
        vkCmdResetQueryPool(cmd, mipTimestamps_.get(), q, 2);
        // Both stamps bracket only the dispatch: the first waits for the copy above to finish.
        vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, mipTimestamps_.get(), q);
    }
    if (!hostMips_) mips_.record(cmd, t.slots.data(), n, t.enhance);
    if (mipTimestamps_) vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, mipTimestamps_.get(), q + 1);
    b.clear();
    for (int s : t.slots) {
        if (C != G) {
            // Release to the graphics family; the render thread records the matching acquire.
            b.push_back(ownership(img, kCompute | kCopy, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                  VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE, VK_IMAGE_LAYOUT_GENERAL, C, G, all(s)));
        } else {
            b.push_back(vk::imageBarrier(img, kCompute | kCopy,
                                         VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT, kFragment,
                                         VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, VK_IMAGE_LAYOUT_GENERAL,
                                         VK_IMAGE_LAYOUT_GENERAL, all(s)));
        }
    }
    vk::pipelineBarrier(cmd, b.data(), n);
    IRIS_VK_TRY(vkEndCommandBuffer(cmd));
    return {};
}

void BufferThread::recordReconstruct(Transaction& t) {
    const uint32_t index = uint32_t(&t - txns_.data());
    auto* table = static_cast<uint32_t*>(jpegTables_.mapped) +
                  size_t(index) * kTilesPerTransaction * gpu::JpegReconstruct::kDescriptorWords;
    gpu::JpegReconstruct::Sizes sizes;
    for (size_t i = 0; i < t.slots.size(); ++i) {
        if (!t.headers[i].isRecord()) continue;
        const JpegCoefficients& h = t.headers[i].coefficients; // read as the tile was staged (submitNew)
        const uint32_t validWidth = t.headers[i].validWidth, validHeight = t.headers[i].validHeight;
        const uint64_t slotWord = uint64_t(t.staging[i]) * stagingStride_ / 4;
        const gpu::JpegReconstruct::Placement place{.outputWord = uint32_t(t.slots[i]), .outputPitch = 0,
                                                    .validWidth = validWidth, .validHeight = validHeight};
        gpu::JpegReconstruct::describe(h, place, sizes.tiles, slotWord + jpegrecord::kQuantWord,
                                       slotWord + jpegrecord::kBlocksWord, uint64_t(sizes.tiles) * kJpegPlaneWords, table);
        sizes.maxBlocks = std::max(sizes.maxBlocks, h.blockCount());
        sizes.maxWidth = std::max(sizes.maxWidth, h.width);
        sizes.maxHeight = std::max(sizes.maxHeight, h.height);
        ++sizes.tiles;
    }
    (void)vk::flush(device_.device(), jpegTables_); // non-coherent memory only; coherent is what it asks for
    jpeg_->record(t.cmd, jpegSets_[index], sizes);
    // Their base levels, written by the second dispatch, read by the mip pass.
    vk::memoryBarrier(t.cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                      VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
}

} // namespace iris
