#include "gpu_split.h"

#include <cmath>
#include <cstring>

#include "core/log.h"
#include "gpu/device.h"
#include "gpu/jpeg_reconstruct.h"
#include "gpu/vk_util.h"
#include "slide/jpeg_coefficients.h"

namespace benchsplit {

namespace {
using iris::gpu::JpegReconstruct;
constexpr uint64_t kTilePixels = 256 * 256;
// A 256×256 tile's most: three components of 32×32 blocks (4:4:4), 32 words a block; their
// quantisation tables; their planes (rows of 64 words, 256 rows each).
constexpr uint64_t kMaxBlocks = 3 * 32 * 32;
// Packed blocks' most: every coefficient non-zero (a table entry and 32 words of values each).
constexpr uint64_t kRoomWords = 3 * 64 + kMaxBlocks * (iris::jpegblocks::kTableWords + 32);
constexpr uint64_t kPlaneRoomWords = 3 * 64 * 256;
constexpr uint64_t kDescriptorWords = JpegReconstruct::kDescriptorWords;
} // namespace

struct GpuSplit::Impl {
    iris::Log log{[](iris::LogLevel level, std::string_view line) {
        if (level >= iris::LogLevel::Warning) std::fprintf(stderr, "iris-bench: split: %.*s\n", int(line.size()), line.data());
    }};
    iris::gpu::Device device{log};
    std::unique_ptr<JpegReconstruct> jpeg;
    iris::vk::CommandPool pool;
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    iris::vk::Fence fence;
    iris::vk::QueryPool queries;
    double periodNs = 0;
    uint32_t room = 0; // tiles
    iris::vk::MappedBuffer input, readback;
    // The input copied into device memory before the dispatches, as an engine would upload it
    // (the shaders' scattered reads of host memory would cross the bus one by one).
    iris::vk::Memory deviceInputMemory, planesMemory, outputMemory;
    iris::vk::Buffer deviceInput, planes, output;
    VkDescriptorSet set = VK_NULL_HANDLE;
    std::vector<iris::JpegCoefficients> headers;

    uint64_t roomWord(uint32_t i) const { return uint64_t(room) * kDescriptorWords + uint64_t(i) * kRoomWords; }

    bool submitAndWait(std::string& why) {
        const VkCommandBufferSubmitInfo info = iris::vk::commandInfo(cmd);
        VkFence f = fence.get();
        vkResetFences(device.device(), 1, &f);
        if (VkResult r = device.submit(iris::gpu::Device::Role::Compute, iris::vk::submitInfo(&info), f); r != VK_SUCCESS) {
            why = std::string("submit: ") + iris::vk::resultName(r);
            return false;
        }
        if (VkResult r = vkWaitForFences(device.device(), 1, &f, VK_TRUE, 60'000'000'000ull); r != VK_SUCCESS) {
            why = std::string("wait: ") + iris::vk::resultName(r);
            return false;
        }
        return true;
    }
};

GpuSplit::GpuSplit() : impl_(std::make_unique<Impl>()) {}

GpuSplit::~GpuSplit() {
    if (impl_ && impl_->device.device() != VK_NULL_HANDLE) (void)impl_->device.waitIdle();
}

std::unique_ptr<GpuSplit> GpuSplit::create(const iris::EngineConfig& config, std::string& why) {
    std::unique_ptr<GpuSplit> s(new GpuSplit());
    Impl& m = *s->impl_;
    iris::EngineConfig c = config;
    c.log = {};
    if (iris::Result r = m.device.init(c); !r.ok()) {
        why = r.message();
        return nullptr;
    }
    m.jpeg = std::make_unique<JpegReconstruct>(m.device);
    if (iris::Result r = m.jpeg->init(1); !r.ok()) {
        why = r.message();
        return nullptr;
    }
    VkDevice dev = m.device.device();
    const uint32_t family = m.device.family(iris::gpu::Device::Role::Compute);
    const VkCommandPoolCreateInfo cpci{.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO, .pNext = nullptr,
                                       .flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT, .queueFamilyIndex = family};
    const VkFenceCreateInfo fci{.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO, .pNext = nullptr, .flags = 0};
    if (vkCreateCommandPool(dev, &cpci, nullptr, m.pool.replace(dev)) != VK_SUCCESS ||
        vkCreateFence(dev, &fci, nullptr, m.fence.replace(dev)) != VK_SUCCESS) {
        why = "cannot make a command pool or a fence";
        return nullptr;
    }
    const VkCommandBufferAllocateInfo cbai{.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO, .pNext = nullptr,
                                           .commandPool = m.pool.get(), .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
                                           .commandBufferCount = 1};
    if (vkAllocateCommandBuffers(dev, &cbai, &m.cmd) != VK_SUCCESS) {
        why = "cannot allocate a command buffer";
        return nullptr;
    }
    VkQueryPool q = VK_NULL_HANDLE;
    if (iris::Result r = iris::vk::createTimestampPool(m.device.physical(), dev, family, 3, q, m.periodNs); r.ok() && q)
        m.queries = iris::vk::QueryPool(dev, q);
    return s;
}

std::string GpuSplit::deviceName() const { return impl_->device.properties().deviceName; }

bool GpuSplit::reserve(uint32_t tiles, std::string& why) {
    Impl& m = *impl_;
    if (tiles <= m.room) return true;
    VkDevice dev = m.device.device();
    VkPhysicalDevice pd = m.device.physical();
    (void)m.device.waitIdle();
    if (m.set != VK_NULL_HANDLE) m.jpeg->freeSet(m.set);
    m.set = VK_NULL_HANDLE;
    m.room = tiles;
    const VkDeviceSize inputBytes = (uint64_t(tiles) * kDescriptorWords + uint64_t(tiles) * kRoomWords) * 4;
    const VkDeviceSize planeBytes = uint64_t(tiles) * kPlaneRoomWords * 4;
    const VkDeviceSize outputBytes = uint64_t(tiles) * kTilePixels * 4;
    iris::Result r = iris::vk::createMappedBuffer(pd, dev, inputBytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, false, m.input);
    if (r.ok())
        r = iris::vk::createDeviceBuffer(pd, dev, inputBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                         m.deviceInput, m.deviceInputMemory);
    if (r.ok()) r = iris::vk::createMappedBuffer(pd, dev, outputBytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, true, m.readback);
    if (r.ok()) r = iris::vk::createDeviceBuffer(pd, dev, planeBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, m.planes, m.planesMemory);
    if (r.ok())
        r = iris::vk::createDeviceBuffer(pd, dev, outputBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                         m.output, m.outputMemory);
    if (r.ok()) {
        auto set = m.jpeg->makeSet(m.deviceInput.get(), 0, inputBytes, m.planes.get(), planeBytes, m.output.get(), 0, outputBytes);
        if (set) m.set = *set;
        else r = set.error();
    }
    if (!r.ok()) {
        m.room = 0;
        why = r.message();
        return false;
    }
    m.headers.assign(tiles, {});
    return true;
}

bool GpuSplit::entropyDecode(uint32_t index, const TileStream& s, int width, int height, bool ycbcr) {
    Impl& m = *impl_;
    if (index >= m.room || width > 256 || height > 256) return false;
    auto* words = static_cast<uint32_t*>(m.input.mapped);
    const uint64_t at = m.roomWord(index);
    // Its packed blocks after room for three quantisation tables; the tables go just before them.
    auto c = iris::readJpegCoefficients(s.data, s.size, width, height, ycbcr ? iris::JpegColour::YCbCr : iris::JpegColour::Rgb,
                                        words + at + 3 * 64, kRoomWords - 3 * 64);
    if (!c) return false;
    const JpegReconstruct::Placement place{.outputWord = uint32_t(uint64_t(index) * kTilePixels), .outputPitch = uint32_t(width)};
    JpegReconstruct::describe(*c, place, index, at, at + 3 * 64, uint64_t(index) * kPlaneRoomWords, words);
    JpegReconstruct::writeQuant(*c, words + at);
    m.headers[index] = std::move(c.value());
    return true;
}

bool GpuSplit::reconstruct(uint32_t count, double& gpuMs, double& computeMs, std::string& why) {
    Impl& m = *impl_;
    gpuMs = computeMs = NAN;
    if (count == 0 || count > m.room) return true;
    if (iris::Result r = iris::vk::flush(m.device.device(), m.input); !r.ok()) {
        why = r.message();
        return false;
    }
    JpegReconstruct::Sizes sizes;
    sizes.tiles = count;
    for (uint32_t i = 0; i < count; ++i) {
        sizes.maxBlocks = std::max(sizes.maxBlocks, m.headers[i].blockCount());
        sizes.maxWidth = std::max(sizes.maxWidth, m.headers[i].width);
        sizes.maxHeight = std::max(sizes.maxHeight, m.headers[i].height);
    }
    // The descriptors are laid out for `room` tiles: those past `count` are never read (the
    // dispatches stop at sizes.tiles).
    const VkCommandBufferBeginInfo begin{.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO, .pNext = nullptr,
                                         .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT, .pInheritanceInfo = nullptr};
    vkResetCommandBuffer(m.cmd, 0);
    vkBeginCommandBuffer(m.cmd, &begin);
    if (m.queries) {
        vkCmdResetQueryPool(m.cmd, m.queries.get(), 0, 3);
        vkCmdWriteTimestamp2(m.cmd, VK_PIPELINE_STAGE_2_TOP_OF_PIPE_BIT, m.queries.get(), 0);
    }
    // Earlier fields' work on these buffers (dispatches, a copy back) before this one's.
    iris::vk::memoryBarrier(m.cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT,
                            VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
    // The descriptors, then each tile's tables and blocks (not the rest of its room).
    std::vector<VkBufferCopy> regions;
    regions.reserve(count + 1);
    regions.push_back({.srcOffset = 0, .dstOffset = 0, .size = uint64_t(count) * kDescriptorWords * 4});
    for (uint32_t i = 0; i < count; ++i) {
        const uint64_t at = m.roomWord(i) * 4;
        // Three tables' room before the blocks, whatever the component count.
        const uint64_t used = 3 * 64 + JpegReconstruct::blockWords(m.headers[i]);
        regions.push_back({.srcOffset = at, .dstOffset = at, .size = used * 4});
    }
    vkCmdCopyBuffer(m.cmd, m.input.buffer, m.deviceInput.get(), uint32_t(regions.size()), regions.data());
    iris::vk::memoryBarrier(m.cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                            VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
    if (m.queries) vkCmdWriteTimestamp2(m.cmd, VK_PIPELINE_STAGE_2_COPY_BIT, m.queries.get(), 1);
    m.jpeg->record(m.cmd, m.set, sizes);
    if (m.queries) vkCmdWriteTimestamp2(m.cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, m.queries.get(), 2);
    vkEndCommandBuffer(m.cmd);
    if (!m.submitAndWait(why)) return false;
    if (m.queries) {
        uint64_t ts[3] = {};
        if (vkGetQueryPoolResults(m.device.device(), m.queries.get(), 0, 3, sizeof ts, ts, sizeof ts[0],
                                  VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT) == VK_SUCCESS) {
            gpuMs = double(ts[2] - ts[0]) * m.periodNs / 1e6;
            computeMs = double(ts[2] - ts[1]) * m.periodNs / 1e6;
        }
    }
    return true;
}

bool GpuSplit::readBack(uint32_t count, std::string& why) {
    Impl& m = *impl_;
    if (count == 0 || count > m.room) return true;
    const VkCommandBufferBeginInfo begin{.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO, .pNext = nullptr,
                                         .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT, .pInheritanceInfo = nullptr};
    vkResetCommandBuffer(m.cmd, 0);
    vkBeginCommandBuffer(m.cmd, &begin);
    iris::vk::memoryBarrier(m.cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                            VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
    const VkBufferCopy copy{.srcOffset = 0, .dstOffset = 0, .size = uint64_t(count) * kTilePixels * 4};
    vkCmdCopyBuffer(m.cmd, m.output.get(), m.readback.buffer, 1, &copy);
    iris::vk::memoryBarrier(m.cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                            VK_ACCESS_2_HOST_READ_BIT);
    vkEndCommandBuffer(m.cmd);
    if (!m.submitAndWait(why)) return false;
    if (iris::Result r = iris::vk::invalidate(m.device.device(), m.readback); !r.ok()) {
        why = r.message();
        return false;
    }
    return true;
}

const uint8_t* GpuSplit::pixels(uint32_t index) const {
    return static_cast<const uint8_t*>(impl_->readback.mapped) + uint64_t(index) * kTilePixels * 4;
}

} // namespace benchsplit
