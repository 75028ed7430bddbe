// The layer pass: the host's raster layers (Engine::addLayer; iris/layers.h) drawn over the
// tiles and under the annotations, bottom first (render/frame_pass.h). Each pixel is shaded as
// iris::shadeLayerAt writes it down (shaders/layer_common.glsl) and blended "over" as
// iris::blendOver does.
//
// A layer's level is never one texture: the level the view needs (chooseRasterLevel) is cut
// into chunks of kChunk × kChunk map pixels, and only the chunks the view covers are uploaded,
// each with a one-pixel apron of its neighbours for the bilinear taps. Chunks are immutable
// (a new map is new chunks), kept in an LRU of kBudgetBytes of device memory, uploaded at most
// kUploadBytesPerFrame a frame (a frame that could not take them all is incomplete and another
// follows), and destroyed only once no frame in flight samples them. Colour maps and class
// tables are small palette images, shared by content. Render thread only.
//
// A streamed level (RasterLevel::source: a large map left in its file) is never read here: its
// missing chunks go to the LayerStreamer's thread, nearest the view's centre first, and until
// all of them are in, the layer is drawn at the finest coarser level whose chunks are (a held
// level always is), and the frame is incomplete. Each chunk read wakes the render thread.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "core/log.h"
#include "gpu/device.h"
#include "gpu/vk_handle.h"
#include "render/frame_pass.h"
#include "render/layer_streamer.h"

namespace iris::render {

class LayerPass final : public FramePass {
public:
    // `wake` bumps the shared wake counter (a streamed chunk was read).
    LayerPass(gpu::Device& device, const Log& log, std::function<void()> wake)
        : device_(device), log_(log), wake_(std::move(wake)) {}
    ~LayerPass() override;
    LayerPass(const LayerPass&) = delete;
    LayerPass& operator=(const LayerPass&) = delete;

    Result init(uint32_t frameSlots);
    const char* name() const override { return "layers"; }
    Result prepare(FrameContext& frame) override;
    void recordUploads(VkCommandBuffer cmd, const FrameContext& frame) override;
    Result recordDraws(VkCommandBuffer cmd, const FrameContext& frame) override;

    static constexpr int kChunk = 512;
    static constexpr VkDeviceSize kBudgetBytes = VkDeviceSize(256) << 20;
    static constexpr VkDeviceSize kUploadBytesPerFrame = VkDeviceSize(16) << 20;

    // What the last prepared frame drew (tests, metrics).
    uint32_t chunksDrawn() const { return uint32_t(draws_.size()); }
    size_t chunksResident() const { return chunks_.size(); }

private:
    // A device image with its view and descriptor set, and the frame serial that last used it.
    struct Texture {
        vk::Image image;
        vk::Memory memory;
        vk::ImageView view;
        VkDescriptorSet set = VK_NULL_HANDLE; // freed back to its pool by release()
        VkDescriptorPool pool = VK_NULL_HANDLE;
        uint64_t lastUsed = 0;
        VkDeviceSize bytes = 0;
        bool uploaded = false;
    };
    struct Chunk {
        std::shared_ptr<const RasterMap> map; // keeps the key's address from being reused
        Texture tex;
        int texX = 0, texY = 0; // the level pixel of texel (0, 0)
        int texW = 0, texH = 0;
    };
    struct Upload {
        VkImage image;
        VkDeviceSize offset;
        uint32_t width, height;
    };
    struct Draw {
        uint8_t push[128];
        VkDescriptorSet chunk, palette;
        bool integer; // layer_uint.frag (labels, RGBA) or layer_float.frag (scalar)
    };

    Result makeTexture(Texture& t, VkFormat format, uint32_t width, uint32_t height, VkDescriptorPool pool);
    void release(Texture& t);
    // The palette image of a layer's colour map or class table, made and staged when new.
    Texture* palette(const std::vector<uint32_t>& entries, FrameContext& frame, bool& deferred);
    // Copies `bytes` into the slot's staging buffer; false when this frame's share is spent.
    bool stage(uint32_t slot, const void* data, size_t rowBytes, uint32_t rows, size_t srcStride, VkImage image,
               uint32_t width);
    void evict(uint64_t serial);
    VkPipeline pipelineFor(VkFormat format, bool integer);

    gpu::Device& device_;
    const Log& log_;
    vk::ShaderModule vert_, floatFrag_, uintFrag_;
    vk::DescriptorSetLayout setLayout_;
    vk::PipelineLayout layout_;
    vk::DescriptorPool chunkPool_, palettePool_;
    vk::Sampler sampler_;
    std::unordered_map<int, vk::Pipeline> pipelines_; // key: format × 2 + integer

    std::unordered_map<ChunkKey, Chunk, ChunkKeyHash> chunks_;
    std::unordered_map<std::string, Texture> palettes_; // key: the entries' bytes
    VkDeviceSize residentBytes_ = 0;
    struct Retired {
        Texture tex;
        uint64_t lastUsed;
    };
    std::vector<Retired> retired_; // evicted, waiting for the frames that used them

    struct Slot {
        vk::MappedBuffer staging;
        VkDeviceSize used = 0;
        std::vector<Upload> uploads;
    };
    std::vector<Slot> slots_;
    std::vector<Draw> draws_;
    std::unordered_set<const RasterMap*> shown_; // the maps of this frame's layers
    bool warnedBudget_ = false;

    // Streamed levels: the reader (made when the first streamed level is shown), the chunks it
    // has read that wait for their upload, and those it could not read (not drawn, and asked
    // for again once a view no longer needs them and another does).
    std::function<void()> wake_;
    std::unique_ptr<LayerStreamer> streamer_;
    std::unordered_map<ChunkKey, LayerStreamer::Result_, ChunkKeyHash> ready_;
    std::unordered_map<ChunkKey, std::shared_ptr<const RasterMap>, ChunkKeyHash> failed_;
    std::unordered_set<const RasterMap*> warnedRead_;
};

} // namespace iris::render
