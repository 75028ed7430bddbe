#include "buffer/buffer_thread.h"

#include <algorithm>
#include <unordered_set>

namespace iris {

namespace {
constexpr uint32_t kStagingTiles = BufferThread::kTilesPerTransaction * BufferThread::kMaxTransactions;
}

BufferThread::BufferThread(SharedState& shared, TileCache& cache, gpu::Device& device, gpu::TileAtlas& atlas,
                           const Log& log, int perimeter)
    : shared_(shared), cache_(cache), device_(device), atlas_(atlas), log_(log), perimeter_(perimeter) {}

BufferThread::~BufferThread() {
    stop();
    VkDevice dev = device_.device();
    if (!dev) return;
    if (pool_) vkDestroyCommandPool(dev, pool_, nullptr);
    if (timeline_) vkDestroySemaphore(dev, timeline_, nullptr);
    vk::destroyMappedBuffer(dev, staging_);
}

Result BufferThread::init() {
    VkDevice dev = device_.device();
    const VkCommandPoolCreateInfo pci{.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
                                      .pNext = nullptr,
                                      .flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT,
                                      .queueFamilyIndex = device_.queueFamily()};
    IRIS_VK_TRY(vkCreateCommandPool(dev, &pci, nullptr, &pool_));
    const VkSemaphoreTypeCreateInfo tci{.sType = VK_STRUCTURE_TYPE_SEMAPHORE_TYPE_CREATE_INFO,
                                        .pNext = nullptr,
                                        .semaphoreType = VK_SEMAPHORE_TYPE_TIMELINE,
                                        .initialValue = 0};
    const VkSemaphoreCreateInfo sci{.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO, .pNext = &tci, .flags = 0};
    IRIS_VK_TRY(vkCreateSemaphore(dev, &sci, nullptr, &timeline_));
    if (Result r = vk::createMappedBuffer(device_.physical(), dev, VkDeviceSize(kStagingTiles) * kTileBytes,
                                          VK_BUFFER_USAGE_TRANSFER_SRC_BIT, /*preferCached=*/false, staging_);
        !r.ok())
        return r;
    for (uint32_t i = kStagingTiles; i-- > 0;) freeStaging_.push_back(i);
    txns_.resize(kMaxTransactions);
    std::vector<VkCommandBuffer> cmds(kMaxTransactions);
    const VkCommandBufferAllocateInfo cai{.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
                                          .pNext = nullptr,
                                          .commandPool = pool_,
                                          .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
                                          .commandBufferCount = kMaxTransactions};
    IRIS_VK_TRY(vkAllocateCommandBuffers(dev, &cai, cmds.data()));
    for (uint32_t i = 0; i < kMaxTransactions; ++i) txns_[i].cmd = cmds[i];
    return {};
}

void BufferThread::start() {
    thread_ = std::thread([this] { run(); });
}

void BufferThread::stop() {
    if (thread_.joinable()) thread_.join();
    // Let the GPU finish the uploads in flight before their resources go away.
    if (timeline_ && nextValue_ > 0) {
        const VkSemaphoreWaitInfo wi{.sType = VK_STRUCTURE_TYPE_SEMAPHORE_WAIT_INFO,
                                     .pNext = nullptr,
                                     .flags = 0,
                                     .semaphoreCount = 1,
                                     .pSemaphores = &timeline_,
                                     .pValues = &nextValue_};
        vkWaitSemaphores(device_.device(), &wi, UINT64_MAX);
    }
}

void BufferThread::run() {
    while (!shared_.stopping.load(std::memory_order_acquire)) {
        const uint64_t seen = shared_.wakeValue();
        bool progress = pollCompleted();
        const Snapshot snap = shared_.snapshot();
        if (snap.slide) progress |= submitNew(snap);
        if (progress) continue;
        const bool inFlight = std::any_of(txns_.begin(), txns_.end(), [](const Transaction& t) { return t.signalValue; });
        if (inFlight) {
            // Sleep until the oldest upload completes or 2 ms pass, whichever is first; a new
            // view published meanwhile is picked up on the next pass.
            uint64_t oldest = UINT64_MAX;
            for (const auto& t : txns_)
                if (t.signalValue) oldest = std::min(oldest, t.signalValue);
            const VkSemaphoreWaitInfo wi{.sType = VK_STRUCTURE_TYPE_SEMAPHORE_WAIT_INFO,
                                         .pNext = nullptr,
                                         .flags = 0,
                                         .semaphoreCount = 1,
                                         .pSemaphores = &timeline_,
                                         .pValues = &oldest};
            vkWaitSemaphores(device_.device(), &wi, 2'000'000);
            continue;
        }
        shared_.waitChange(seen);
    }
}

bool BufferThread::pollCompleted() {
    uint64_t done = 0;
    const VkResult vr = vkGetSemaphoreCounterValue(device_.device(), timeline_, &done);
    if (vr != VK_SUCCESS) {
        shared_.setError(vk::check(vr, "vkGetSemaphoreCounterValue"));
        return false;
    }
    bool any = false;
    for (Transaction& t : txns_) {
        if (!t.signalValue || t.signalValue > done) continue;
        for (int s : t.slots) atlas_.map().activate(s);
        for (uint32_t s : t.staging) freeStaging_.push_back(s);
        t.slots.clear();
        t.staging.clear();
        t.signalValue = 0;
        any = true;
    }
    if (any) shared_.bump(); // the render thread has new tiles to draw
    return any;
}

bool BufferThread::submitNew(const Snapshot& snap) {
    auto txIt = std::find_if(txns_.begin(), txns_.end(), [](const Transaction& t) { return t.signalValue == 0; });
    if (txIt == txns_.end() || freeStaging_.empty()) return false;
    Transaction& tx = *txIt;
    const std::vector<TileRef> region = bufferRegion(snap.slide->info, snap.slide->generation, snap.viewport, perimeter_);
    std::unordered_set<uint64_t> keep;
    keep.reserve(region.size() * 2);
    for (const TileRef& t : region) keep.insert(t.key);
    gpu::TileMap& map = atlas_.map();
    const auto outsideRegion = [&](uint64_t k) { return keep.count(k) != 0; };
    auto* base = static_cast<uint8_t*>(staging_.mapped);
    for (const TileRef& t : region) {
        if (tx.slots.size() == kTilesPerTransaction || freeStaging_.empty()) break;
        if (map.contains(t.key) || !cache_.isReady(t.key)) continue;
        const int slot = map.allocate(t.key, outsideRegion);
        if (slot < 0) break; // atlas full of tiles that are needed or still drawn
        const uint32_t st = freeStaging_.back();
        bool failed = false;
        if (!cache_.copyOut(t.key, base + size_t(st) * kTileBytes, &failed)) {
            map.abandon(slot); // evicted from RAM meanwhile; a loader will decode it again
            continue;
        }
        freeStaging_.pop_back();
        tx.slots.push_back(slot);
        tx.staging.push_back(st);
    }
    // A reclaim that backed off may have made a frame skip that tile: draw again.
    if (map.takeReclaimAborted()) shared_.bump();
    if (tx.slots.empty()) return false;
    if (Result r = record(tx); !r.ok()) {
        shared_.setError(r);
        log_.error(r.message());
        for (int s : tx.slots) map.abandon(s);
        for (uint32_t s : tx.staging) freeStaging_.push_back(s);
        tx.slots.clear();
        tx.staging.clear();
        return false;
    }
    tx.signalValue = ++nextValue_;
    const VkCommandBufferSubmitInfo cbi{
        .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO, .pNext = nullptr, .commandBuffer = tx.cmd, .deviceMask = 0};
    const VkSemaphoreSubmitInfo sig{.sType = VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO,
                                    .pNext = nullptr,
                                    .semaphore = timeline_,
                                    .value = tx.signalValue,
                                    .stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                                    .deviceIndex = 0};
    const VkSubmitInfo2 si{.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO_2,
                           .pNext = nullptr,
                           .flags = 0,
                           .waitSemaphoreInfoCount = 0,
                           .pWaitSemaphoreInfos = nullptr,
                           .commandBufferInfoCount = 1,
                           .pCommandBufferInfos = &cbi,
                           .signalSemaphoreInfoCount = 1,
                           .pSignalSemaphoreInfos = &sig};
    const VkResult vr = device_.submit(si, VK_NULL_HANDLE);
    if (vr != VK_SUCCESS) {
        shared_.setError(vk::check(vr, "vkQueueSubmit2 (tile upload)"));
        // The GPU state is unknown after a failed submit: leave the slots FILLING (never drawn).
        tx.signalValue = 0;
        return false;
    }
    return true;
}

Result BufferThread::record(Transaction& t) {
    VkCommandBuffer cmd = t.cmd;
    IRIS_VK_TRY(vkResetCommandBuffer(cmd, 0));
    const VkCommandBufferBeginInfo bi{.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                      .pNext = nullptr,
                                      .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT,
                                      .pInheritanceInfo = nullptr};
    IRIS_VK_TRY(vkBeginCommandBuffer(cmd, &bi));
    VkImage img = atlas_.image();
    const uint32_t n = uint32_t(t.slots.size());
    constexpr VkPipelineStageFlags2 kXfer = VK_PIPELINE_STAGE_2_COPY_BIT | VK_PIPELINE_STAGE_2_BLIT_BIT;

    // Reused slots: earlier frames may still sample them (write-after-read: an execution
    // dependency on the fragment stage) and an earlier upload wrote them (write-after-write).
    std::vector<VkImageMemoryBarrier2> barriers;
    barriers.reserve(n);
    for (int s : t.slots) {
        barriers.push_back(vk::imageBarrier(img, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | kXfer, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                            kXfer, VK_ACCESS_2_TRANSFER_WRITE_BIT | VK_ACCESS_2_TRANSFER_READ_BIT,
                                            VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_GENERAL,
                                            vk::colorRange(0, gpu::kTileMipLevels, uint32_t(s), 1)));
    }
    vk::pipelineBarrier(cmd, barriers.data(), n);

    std::vector<VkBufferImageCopy> copies(n);
    for (uint32_t i = 0; i < n; ++i) {
        copies[i] = VkBufferImageCopy{
            .bufferOffset = VkDeviceSize(t.staging[i]) * kTileBytes,
            .bufferRowLength = 0,
            .bufferImageHeight = 0,
            .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, uint32_t(t.slots[i]), 1},
            .imageOffset = {0, 0, 0},
            .imageExtent = {uint32_t(kTileSize), uint32_t(kTileSize), 1},
        };
    }
    vkCmdCopyBufferToImage(cmd, staging_.buffer, img, VK_IMAGE_LAYOUT_GENERAL, n, copies.data());

    std::vector<VkImageBlit> blits(n);
    for (uint32_t m = 1; m < gpu::kTileMipLevels; ++m) {
        barriers.clear();
        for (int s : t.slots) {
            barriers.push_back(vk::imageBarrier(img, kXfer, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_BLIT_BIT,
                                                VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_GENERAL,
                                                VK_IMAGE_LAYOUT_GENERAL, vk::colorRange(m - 1, 1, uint32_t(s), 1)));
        }
        vk::pipelineBarrier(cmd, barriers.data(), n);
        const int32_t src = kTileSize >> (m - 1), dst = kTileSize >> m;
        for (uint32_t i = 0; i < n; ++i) {
            blits[i] = VkImageBlit{
                .srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, m - 1, uint32_t(t.slots[i]), 1},
                .srcOffsets = {{0, 0, 0}, {src, src, 1}},
                .dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, m, uint32_t(t.slots[i]), 1},
                .dstOffsets = {{0, 0, 0}, {dst, dst, 1}},
            };
        }
        vkCmdBlitImage(cmd, img, VK_IMAGE_LAYOUT_GENERAL, img, VK_IMAGE_LAYOUT_GENERAL, n, blits.data(), VK_FILTER_LINEAR);
    }
    // Hand-over to rendering: the whole mip chain becomes visible to fragment-shader reads.
    barriers.clear();
    for (int s : t.slots) {
        barriers.push_back(vk::imageBarrier(img, kXfer, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
                                            VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, VK_IMAGE_LAYOUT_GENERAL,
                                            VK_IMAGE_LAYOUT_GENERAL, vk::colorRange(0, gpu::kTileMipLevels, uint32_t(s), 1)));
    }
    vk::pipelineBarrier(cmd, barriers.data(), n);
    IRIS_VK_TRY(vkEndCommandBuffer(cmd));
    return {};
}

} // namespace iris
