// The tile atlas: one 2D-array image of 256×256 RGBA8 tiles with a full mip chain, one layer
// per slot, sized from the VRAM budget at startup (no Vulkan allocation after startup), and
// the lock-free TileMap (core/tile_map.h) saying which slot holds which tile.
//
// The image stays in VK_IMAGE_LAYOUT_GENERAL for its whole life: uploads (copy, mips) and
// sampling are ordered by barriers alone, so an upload into one layer never needs a layout
// transition that a frame sampling other layers could observe.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "gpu/device.h"
#include "core/tile_map.h"
#include "gpu/vk_handle.h"

namespace iris::gpu {

inline constexpr uint32_t kTileMipLevels = 9; // 256 → 1

class TileAtlas {
public:
    // UNORM: bytes in, bytes out, no sRGB conversion. RGBA8, or BGRA8 where the exact copy goes
    // into X11's BGRA swapchains (Engine::Impl::init: CPU devices, whose mips are made on the
    // host; the buffer thread then swaps red and blue as it stages each tile).
    static constexpr VkFormat kFormat = VK_FORMAT_R8G8B8A8_UNORM;
    static constexpr VkFormat kSwappedFormat = VK_FORMAT_B8G8R8A8_UNORM;
    explicit TileAtlas(Device& device) : device_(device) {}
    // An atlas of vramBudgetBytes / bytesPerSlot() slots (64 .. maxImageArrayLayers), halved
    // while the device cannot allocate it (VK_ERROR_OUT_OF_DEVICE_MEMORY: a budget larger than
    // the device allows). allocationLimit > 0 makes every allocation above that many bytes fail
    // as if the device had run out (EngineTuning::deviceAllocationLimit, for tests).
    //
    // hostWritten asks for an atlas the buffer thread writes from the host (EngineTuning::
    // tileUpload): a linear image in host-visible, host-coherent memory, mapped for the atlas's
    // life. Where the device cannot sample such an image of this size, or has no such memory,
    // the atlas is made the usual way (optimal tiling, device-local) and hostFallback() says
    // why; hostWritten() tells which it is.
    Result init(uint64_t vramBudgetBytes, uint64_t allocationLimit = 0, VkFormat format = kFormat,
                bool hostWritten = false);
    VkFormat format() const { return format_; }
    bool hostWritten() const { return mapped_ != nullptr; }
    const std::string& hostFallback() const { return hostFallback_; }
    // A host-written atlas: where level `level` of `slot` lies in the mapped memory, and the
    // bytes from one of its rows to the next. The caller owns the slot (TileMap FILLING): no
    // frame samples it until it is activated, and frames that sampled it before have ended.
    uint8_t* hostLevel(int slot, uint32_t level) const {
        return mapped_ + levels_[level].offset + VkDeviceSize(slot) * levels_[level].arrayPitch;
    }
    VkDeviceSize hostRowPitch(uint32_t level) const { return levels_[level].rowPitch; }
    // The atlas holds BGRA: staged tiles (RGBA in RAM) have their red and blue swapped.
    bool swapped() const { return format_ == kSwappedFormat; }
    // The slots the budget asked for; slotCount() is what the device gave.
    uint32_t requestedSlots() const { return requested_; }

    static uint64_t bytesPerSlot();
    VkImage image() const { return image_.get(); }
    VkImageView view() const { return view_.get(); }
    // Storage views of one mip level across all layers (for the mip compute pass).
    VkImageView mipView(uint32_t level) const { return mipViews_[level].get(); }
    VkSampler sampler() const { return sampler_.get(); }
    uint32_t slotCount() const { return map_ ? map_->slotCount() : 0; }

    TileMap& map() { return *map_; }
    const TileMap& map() const { return *map_; }

private:
    // Makes image_ and memory_ for n slots: optimal tiling and device-local, or (host) linear
    // tiling in host-visible, coherent memory, mapped into mapped_ with levels_ filled.
    Result create(uint32_t n, bool host);
    struct HostLevel {
        VkDeviceSize offset = 0, rowPitch = 0, arrayPitch = 0;
    };

    Device& device_;
    VkFormat format_ = kFormat;
    uint8_t* mapped_ = nullptr; // host-written atlas: memory_ mapped (unmapped when it is freed)
    HostLevel levels_[kTileMipLevels];
    std::string hostFallback_;
    vk::Memory memory_;
    vk::Image image_;
    vk::ImageView view_;
    vk::ImageView mipViews_[kTileMipLevels];
    vk::Sampler sampler_;

    std::unique_ptr<TileMap> map_;
    uint32_t requested_ = 0;
};

} // namespace iris::gpu
