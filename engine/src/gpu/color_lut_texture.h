// The colour transform's lookup table on the GPU (color/color_lut.h, docs/COLOR.md): one 3D
// image of kLutSize³ RGBA16F texels, sampled with trilinear filtering by the tile pass's
// fragment shaders (shaders/color_lut.glsl) when colour management is on for the frame.
//
// Render thread only. A new table is written into the frame slot's own staging buffer in
// prepare and copied into the image before that frame's render pass; the copy's barrier waits
// for every earlier frame's sampling on the queue (first synchronisation scope: all commands
// submitted before), so frames in flight never see a half-written table.
#pragma once

#include <memory>
#include <vector>

#include "color/color_lut.h"
#include "gpu/device.h"
#include "gpu/vk_handle.h"
#include "gpu/vk_util.h"

namespace iris::gpu {

// The specialization constants of shaders/color_lut.glsl, for every pipeline that includes it:
// constant 0 COLOR_MANAGED (the colour step at all), constant 1 LUT_SAMPLED (the table's
// trilinear interpolation by the sampler rather than in float from its eight nodes: on a CPU
// device, where the sampler is exact enough and three times cheaper; docs/COLOR.md).
struct ColorSpecialization {
    VkBool32 values[2];
    VkSpecializationMapEntry entries[2] = {{.constantID = 0, .offset = 0, .size = sizeof(VkBool32)},
                                           {.constantID = 1, .offset = sizeof(VkBool32), .size = sizeof(VkBool32)}};
    VkSpecializationInfo info;
    ColorSpecialization(bool managed, bool sampled)
        : values{managed ? VK_TRUE : VK_FALSE, sampled ? VK_TRUE : VK_FALSE},
          info{.mapEntryCount = 2, .pMapEntries = entries, .dataSize = sizeof(values), .pData = values} {}
    ColorSpecialization(const ColorSpecialization&) = delete; // `info` points into the object
    ColorSpecialization& operator=(const ColorSpecialization&) = delete;
};

class ColorLutTexture {
public:
    static constexpr VkFormat kFormat = VK_FORMAT_R16G16B16A16_SFLOAT; // sampled + linear filter: mandatory
    explicit ColorLutTexture(Device& device) : device_(device) {}
    ColorLutTexture(const ColorLutTexture&) = delete;
    ColorLutTexture& operator=(const ColorLutTexture&) = delete;

    Result init(uint32_t frameSlots);
    VkImageView view() const { return view_.get(); }
    VkSampler sampler() const { return sampler_.get(); }
    // The image's layout whenever a frame samples it.
    static constexpr VkImageLayout kLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;

    // Makes `lut` (null: no transform; the image then keeps its table, or gets a placeholder
    // the first time, since the descriptor set needs a defined image) the table of the frames
    // from this one on: stages it in slot `slot` when it differs from the
    // table already in the image. Returns an error for a table of another size than the
    // image's (nothing is staged then).
    Result prepare(uint32_t slot, std::shared_ptr<const color::Lut3D> lut);
    // Records the copy staged by prepare() for this slot (if any), with its barriers.
    void recordUpload(VkCommandBuffer cmd, uint32_t slot);

private:
    Device& device_;
    vk::Memory memory_;
    vk::Image image_;
    vk::ImageView view_;
    vk::Sampler sampler_;
    std::vector<vk::MappedBuffer> staging_;       // one per frame slot
    std::vector<bool> pending_;                   // a staged table waits for its copy, per slot
    bool defined_ = false;                        // the image holds a table (its layout is kLayout)
    std::shared_ptr<const color::Lut3D> current_; // the table the image holds or is about to hold
    bool currentIsIdentity_ = false;
};

} // namespace iris::gpu
