#include "render/resolve_pass.h"

#include <cmath>
#include <cstring>

#include <iris_shaders/tile_resolve_comp.h>

namespace iris::render {

namespace {
// The page table's header (std430, shaders/tile_resolve.comp).
struct LayerHeader {
    int32_t range[4];
    float geometry[4];
    int32_t extent[4];
};
struct TableHeader {
    float background[4];
    int32_t info[4];
    float turn[4];   // the view's turn (ViewTransform::m) about `centre`
    float centre[4]; // x, y: the view's target centre; unused
    LayerHeader layers[3];
};
constexpr uint32_t kMaxEntries = 65536; // tiles of the three layers' visible ranges
constexpr VkDeviceSize kTableBytes = sizeof(TableHeader) + kMaxEntries * sizeof(int32_t);
} // namespace

Result ResolvePass::init(uint32_t frameSlots) {
    VkDevice dev = device_.device();
    if (Result r =
            vk::createShaderModule(dev, tile_resolve_comp_spv, sizeof(tile_resolve_comp_spv), *shader_.replace(dev));
        !r.ok())
        return r;
    const VkDescriptorSetLayoutBinding bindings[4] = {
        {0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
        {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
        {2, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
        {3, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
    };
    const VkDescriptorSetLayoutCreateInfo dslci{.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
                                                .pNext = nullptr,
                                                .flags = 0,
                                                .bindingCount = 4,
                                                .pBindings = bindings};
    IRIS_VK_TRY(vkCreateDescriptorSetLayout(dev, &dslci, nullptr, setLayout_.replace(dev)));
    const VkDescriptorSetLayout setLayout = setLayout_.get();
    const VkPipelineLayoutCreateInfo plci{.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                          .pNext = nullptr,
                                          .flags = 0,
                                          .setLayoutCount = 1,
                                          .pSetLayouts = &setLayout,
                                          .pushConstantRangeCount = 0,
                                          .pPushConstantRanges = nullptr};
    IRIS_VK_TRY(vkCreatePipelineLayout(dev, &plci, nullptr, layout_.replace(dev)));
    for (int managed = 0; managed < 2; ++managed) {
        const gpu::ColorSpecialization spec(managed != 0, tiles_.lutSampled());
        Expected<VkPipeline> pipeline = vk::createComputePipeline(dev, layout_.get(), shader_.get(), &spec.info);
        if (!pipeline) return pipeline.error();
        pipelines_[managed] = vk::Pipeline(dev, *pipeline);
    }
    const VkDescriptorPoolSize sizes[3] = {{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 2 * frameSlots},
                                           {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, frameSlots},
                                           {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, frameSlots}};
    const VkDescriptorPoolCreateInfo dpci{.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
                                          .pNext = nullptr,
                                          .flags = 0,
                                          .maxSets = frameSlots,
                                          .poolSizeCount = 3,
                                          .pPoolSizes = sizes};
    IRIS_VK_TRY(vkCreateDescriptorPool(dev, &dpci, nullptr, pool_.replace(dev)));
    slots_.resize(frameSlots);
    for (Slot& s : slots_) {
        if (Result r = vk::createMappedBuffer(device_.physical(), dev, kTableBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                              false, s.table);
            !r.ok())
            return r;
        const VkDescriptorSetAllocateInfo dsai{.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
                                               .pNext = nullptr,
                                               .descriptorPool = pool_.get(),
                                               .descriptorSetCount = 1,
                                               .pSetLayouts = &setLayout};
        IRIS_VK_TRY(vkAllocateDescriptorSets(dev, &dsai, &s.set));
        const VkDescriptorImageInfo atlasInfo{atlas_.sampler(), atlas_.view(), VK_IMAGE_LAYOUT_GENERAL};
        const VkDescriptorImageInfo lutInfo{tiles_.colorLut().sampler(), tiles_.colorLut().view(),
                                            gpu::ColorLutTexture::kLayout};
        const VkDescriptorBufferInfo tableInfo{s.table.buffer, 0, VK_WHOLE_SIZE};
        const VkWriteDescriptorSet writes[3] = {
            {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, nullptr, s.set, 0, 0, 1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
             &atlasInfo, nullptr, nullptr},
            {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, nullptr, s.set, 1, 0, 1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
             &lutInfo, nullptr, nullptr},
            {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, nullptr, s.set, 3, 0, 1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
             nullptr, &tableInfo, nullptr},
        };
        vkUpdateDescriptorSets(dev, 3, writes, 0, nullptr);
    }
    return {};
}

Result ResolvePass::prepare(const FrameContext& frame, const DrawList& list, const std::array<float, 4>& background,
                            VkImageView target) {
    Slot& slot = slots_[frame.slot];
    auto* header = static_cast<TableHeader*>(slot.table.mapped);
    auto* entries = reinterpret_cast<int32_t*>(static_cast<uint8_t*>(slot.table.mapped) + sizeof(TableHeader));
    std::memset(header, 0, sizeof(TableHeader));
    std::memcpy(header->background, background.data(), sizeof(header->background));
    header->info[0] = int32_t(frame.extent.width);
    header->info[1] = int32_t(frame.extent.height);
    {
        const ViewTransform t = ViewTransform::of(frame.viewport.view, frame.viewport.width, frame.viewport.height);
        for (int i = 0; i < 4; ++i) header->turn[i] = float(t.m[size_t(i)]);
        header->centre[0] = float(t.targetCX);
        header->centre[1] = float(t.targetCY);
    }
    int32_t layers = 0;
    uint32_t used = 0;
    colorManaged_ = frame.snap.colorLut != nullptr;
    if (frame.snap.slide) {
        const SlideInfo& info = frame.snap.slide->info;
        const Viewport& vp = frame.viewport;
        for (int i = 2; i >= 0; --i) { // HR, LR, base: finest first
            const LevelDraw& d = list.levels[size_t(i)];
            if (d.level < 0 || d.range.empty()) continue;
            const uint32_t n = uint32_t(d.layers.size());
            if (used + n > kMaxEntries) break; // a coarser layer that does not fit is left out
            const LevelInfo& level = info.levels[size_t(d.level)];
            LayerHeader& h = header->layers[layers++];
            h.range[0] = int32_t(d.range.x0);
            h.range[1] = int32_t(d.range.y0);
            h.range[2] = int32_t(d.range.x1);
            h.range[3] = int32_t(d.range.y1);
            h.geometry[0] = float((vp.view.centerX - vp.width * 0.5 * vp.view.downsample) / level.downsample);
            h.geometry[1] = float((vp.view.centerY - vp.height * 0.5 * vp.view.downsample) / level.downsample);
            h.geometry[2] = float(vp.view.downsample / level.downsample);
            h.geometry[3] = float(std::max(0.0, std::log2(vp.view.downsample / level.downsample)));
            h.extent[0] = int32_t(level.width);
            h.extent[1] = int32_t(level.height);
            h.extent[2] = int32_t(used);
            std::memcpy(entries + used, d.layers.data(), n * sizeof(int32_t));
            used += n;
        }
    }
    header->info[2] = layers;
    if (Result r = vk::flush(device_.device(), slot.table); !r.ok()) return r;
    if (slot.target != target) {
        const VkDescriptorImageInfo targetInfo{VK_NULL_HANDLE, target, VK_IMAGE_LAYOUT_GENERAL};
        const VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, nullptr,     slot.set, 2,      0, 1,
                                     VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,       &targetInfo, nullptr,  nullptr};
        vkUpdateDescriptorSets(device_.device(), 1, &w, 0, nullptr);
        slot.target = target;
    }
    return {};
}

void ResolvePass::record(VkCommandBuffer cmd, const FrameContext& frame, VkImage target) {
    // Previous contents are discarded; the wait on the previous frame's copy is in the stages.
    const VkImageMemoryBarrier2 toGeneral =
        vk::imageBarrier(target, VK_PIPELINE_STAGE_2_COPY_BIT | VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                         VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                         VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL, vk::colorRange(0, 1, 0, 1));
    vk::pipelineBarrier(cmd, &toGeneral, 1);
    const Slot& slot = slots_[frame.slot];
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipelines_[colorManaged_ ? 1 : 0].get());
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_.get(), 0, 1, &slot.set, 0, nullptr);
    vkCmdDispatch(cmd, (frame.extent.width + 15) / 16, (frame.extent.height + 15) / 16, 1);
    const VkImageMemoryBarrier2 toColor =
        vk::imageBarrier(target, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                         VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                         VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                         VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, vk::colorRange(0, 1, 0, 1));
    vk::pipelineBarrier(cmd, &toColor, 1);
}

} // namespace iris::render
