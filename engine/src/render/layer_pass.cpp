#include "render/layer_pass.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <optional>
#include <unordered_set>

#include <iris_shaders/layer_float_frag.h>
#include <iris_shaders/layer_uint_frag.h>
#include <iris_shaders/layer_vert.h>

#include "gpu/vk_util.h"

namespace iris::render {

namespace {

// shaders/layer_push.glsl, member for member.
struct LayerPush {
    float toLocalX[4], toLocalY[4], toScreenX[4], toScreenY[4];
    int32_t core[4], level[4];
    float params[4];
    int32_t mode[4];
};
static_assert(sizeof(LayerPush) == 128, "the layer pass's push constants are 128 bytes, the guaranteed minimum");

constexpr VkDeviceSize kAlign = 16;
constexpr uint32_t kChunkSets = 2048, kPaletteSets = 128;

VkFormat formatOf(RasterKind k) {
    switch (k) {
    case RasterKind::Scalar: return VK_FORMAT_R32_SFLOAT;
    case RasterKind::Label: return VK_FORMAT_R16_UINT;
    case RasterKind::Rgba: return VK_FORMAT_R8G8B8A8_UINT;
    }
    return VK_FORMAT_UNDEFINED;
}
size_t texelBytes(RasterKind k) { return k == RasterKind::Label ? 2 : 4; }
const uint8_t* levelBytes(RasterKind k, const RasterLevel& l) {
    switch (k) {
    case RasterKind::Scalar: return reinterpret_cast<const uint8_t*>(l.scalar.data());
    case RasterKind::Label: return reinterpret_cast<const uint8_t*>(l.label.data());
    case RasterKind::Rgba: return l.rgba.data();
    }
    return nullptr;
}
uint32_t pack(Rgba8 c) { return uint32_t(c.r) | uint32_t(c.g) << 8 | uint32_t(c.b) << 16 | uint32_t(c.a) << 24; }

Result poolOf(VkDevice dev, uint32_t sets, vk::DescriptorPool& out) {
    const VkDescriptorPoolSize ps{.type = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, .descriptorCount = sets};
    const VkDescriptorPoolCreateInfo dpci{.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
                                          .pNext = nullptr,
                                          .flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT,
                                          .maxSets = sets,
                                          .poolSizeCount = 1,
                                          .pPoolSizes = &ps};
    IRIS_VK_TRY(vkCreateDescriptorPool(dev, &dpci, nullptr, out.replace(dev)));
    return {};
}

} // namespace

LayerPass::~LayerPass() {
    // The render thread waited for the device before its passes go (RenderThread::releaseGpu).
    for (auto& [key, c] : chunks_) release(c.tex);
    for (auto& [key, t] : palettes_) release(t);
    for (Retired& r : retired_) release(r.tex);
}

Result LayerPass::init(uint32_t frameSlots) {
    VkDevice dev = device_.device();
    if (Result r = vk::createShaderModule(dev, layer_vert_spv, sizeof(layer_vert_spv), *vert_.replace(dev)); !r.ok())
        return r;
    if (Result r = vk::createShaderModule(dev, layer_float_frag_spv, sizeof(layer_float_frag_spv), *floatFrag_.replace(dev));
        !r.ok())
        return r;
    if (Result r = vk::createShaderModule(dev, layer_uint_frag_spv, sizeof(layer_uint_frag_spv), *uintFrag_.replace(dev));
        !r.ok())
        return r;
    const VkDescriptorSetLayoutBinding binding{.binding = 0,
                                               .descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
                                               .descriptorCount = 1,
                                               .stageFlags = VK_SHADER_STAGE_FRAGMENT_BIT,
                                               .pImmutableSamplers = nullptr};
    const VkDescriptorSetLayoutCreateInfo dslci{.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
                                                .pNext = nullptr,
                                                .flags = 0,
                                                .bindingCount = 1,
                                                .pBindings = &binding};
    IRIS_VK_TRY(vkCreateDescriptorSetLayout(dev, &dslci, nullptr, setLayout_.replace(dev)));
    // Set 0: the chunk; set 1: the palette. The same layout serves both.
    const VkDescriptorSetLayout sets[2] = {setLayout_.get(), setLayout_.get()};
    const VkPushConstantRange push{.stageFlags = VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT,
                                   .offset = 0,
                                   .size = sizeof(LayerPush)};
    const VkPipelineLayoutCreateInfo plci{.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                          .pNext = nullptr,
                                          .flags = 0,
                                          .setLayoutCount = 2,
                                          .pSetLayouts = sets,
                                          .pushConstantRangeCount = 1,
                                          .pPushConstantRanges = &push};
    IRIS_VK_TRY(vkCreatePipelineLayout(dev, &plci, nullptr, layout_.replace(dev)));
    if (Result r = poolOf(dev, kChunkSets, chunkPool_); !r.ok()) return r;
    if (Result r = poolOf(dev, kPaletteSets, palettePool_); !r.ok()) return r;
    const VkSamplerCreateInfo sci = vk::clampSampler(VK_FILTER_NEAREST, 0); // texelFetch only
    IRIS_VK_TRY(vkCreateSampler(dev, &sci, nullptr, sampler_.replace(dev)));
    slots_.resize(frameSlots);
    return {};
}

Result LayerPass::makeTexture(Texture& t, VkFormat format, uint32_t width, uint32_t height, VkDescriptorPool pool) {
    VkDevice dev = device_.device();
    const VkImageCreateInfo ici =
        vk::image2D(format, width, height, 1, 1, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT);
    if (Result r = vk::createDeviceImage(device_.physical(), dev, ici, t.image, t.memory); !r.ok()) return r;
    if (Result r = vk::createImageView(dev, t.image.get(), VK_IMAGE_VIEW_TYPE_2D, format, vk::colorRange(0, 1, 0, 1),
                                       *t.view.replace(dev));
        !r.ok())
        return r;
    const VkDescriptorSetLayout layout = setLayout_.get();
    const VkDescriptorSetAllocateInfo dsai{.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
                                           .pNext = nullptr,
                                           .descriptorPool = pool,
                                           .descriptorSetCount = 1,
                                           .pSetLayouts = &layout};
    IRIS_VK_TRY(vkAllocateDescriptorSets(dev, &dsai, &t.set));
    t.pool = pool;
    const VkDescriptorImageInfo info{.sampler = sampler_.get(),
                                     .imageView = t.view.get(),
                                     .imageLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    const VkWriteDescriptorSet write{.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                     .pNext = nullptr,
                                     .dstSet = t.set,
                                     .dstBinding = 0,
                                     .dstArrayElement = 0,
                                     .descriptorCount = 1,
                                     .descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
                                     .pImageInfo = &info,
                                     .pBufferInfo = nullptr,
                                     .pTexelBufferView = nullptr};
    vkUpdateDescriptorSets(dev, 1, &write, 0, nullptr);
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(dev, t.image.get(), &req);
    t.bytes = req.size;
    return {};
}

void LayerPass::release(Texture& t) {
    if (t.set) (void)vkFreeDescriptorSets(device_.device(), t.pool, 1, &t.set);
    t.set = VK_NULL_HANDLE;
    t.view.reset();
    t.image.reset();
    t.memory.reset();
}

bool LayerPass::stage(uint32_t slot, const void* data, size_t rowBytes, uint32_t rows, size_t srcStride, VkImage image,
                      uint32_t width) {
    Slot& s = slots_[slot];
    const VkDeviceSize bytes = VkDeviceSize(rowBytes) * rows;
    const VkDeviceSize offset = (s.used + kAlign - 1) / kAlign * kAlign;
    if (offset + bytes > kUploadBytesPerFrame) return false;
    if (s.staging.size < kUploadBytesPerFrame) {
        if (Result r = vk::createMappedBuffer(device_.physical(), device_.device(), kUploadBytesPerFrame,
                                              VK_BUFFER_USAGE_TRANSFER_SRC_BIT, false, s.staging);
            !r.ok()) {
            log_.warn("layers: no staging buffer: " + r.message());
            return false;
        }
    }
    auto* dst = static_cast<uint8_t*>(s.staging.mapped) + offset;
    const auto* src = static_cast<const uint8_t*>(data);
    for (uint32_t r = 0; r < rows; ++r) std::memcpy(dst + size_t(r) * rowBytes, src + size_t(r) * srcStride, rowBytes);
    s.used = offset + bytes;
    s.uploads.push_back(Upload{image, offset, width, rows});
    return true;
}

LayerPass::Texture* LayerPass::palette(const std::vector<uint32_t>& entries, FrameContext& frame, bool& deferred) {
    deferred = false;
    std::string key(reinterpret_cast<const char*>(entries.data()), entries.size() * sizeof(uint32_t));
    if (auto it = palettes_.find(key); it != palettes_.end()) {
        it->second.lastUsed = frame.serial;
        return &it->second;
    }
    if (palettes_.size() >= kPaletteSets) evict(frame.serial); // frees unused palettes first
    if (palettes_.size() >= kPaletteSets) {
        deferred = true;
        return nullptr;
    }
    const uint32_t rows = uint32_t((entries.size() + 255) / 256);
    std::vector<uint32_t> texels(size_t(rows) * 256, 0);
    std::copy(entries.begin(), entries.end(), texels.begin());
    Texture t;
    if (Result r = makeTexture(t, VK_FORMAT_R8G8B8A8_UINT, 256, rows, palettePool_.get()); !r.ok()) {
        log_.warn("layers: no palette image: " + r.message());
        release(t);
        deferred = true;
        return nullptr;
    }
    if (!stage(frame.slot, texels.data(), 256 * 4, rows, 256 * 4, t.image.get(), 256)) {
        release(t);
        deferred = true; // the next frame has room
        return nullptr;
    }
    t.uploaded = true;
    t.lastUsed = frame.serial;
    return &palettes_.emplace(std::move(key), std::move(t)).first->second;
}

void LayerPass::evict(uint64_t serial) {
    // Chunks of maps no longer shown, then the least recently used over the budget; never one
    // this frame draws. They wait in retired_ for the frames in flight.
    std::vector<std::pair<uint64_t, ChunkKey>> byAge;
    for (auto& [key, c] : chunks_)
        if (c.tex.lastUsed < serial) byAge.emplace_back(c.tex.lastUsed, key);
    std::sort(byAge.begin(), byAge.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [used, key] : byAge) {
        auto it = chunks_.find(key);
        const bool stale = !shown_.count(key.map);
        if (!stale && residentBytes_ <= kBudgetBytes) continue;
        residentBytes_ -= it->second.tex.bytes;
        retired_.push_back(Retired{std::move(it->second.tex), used});
        chunks_.erase(it);
    }
    if (palettes_.size() > kPaletteSets / 2) {
        for (auto it = palettes_.begin(); it != palettes_.end();) {
            if (it->second.lastUsed < serial) {
                const uint64_t used = it->second.lastUsed;
                retired_.push_back(Retired{std::move(it->second), used});
                it = palettes_.erase(it);
            } else {
                ++it;
            }
        }
    }
}

VkPipeline LayerPass::pipelineFor(VkFormat format, bool integer) {
    const int key = int(format) * 2 + int(integer);
    if (auto it = pipelines_.find(key); it != pipelines_.end()) return it->second.get();
    VkDevice dev = device_.device();
    Expected<VkPipeline> p =
        vk::createBlendedPipeline(dev, layout_.get(), vert_.get(), integer ? uintFrag_.get() : floatFrag_.get(), 0,
                                  VK_VERTEX_INPUT_RATE_VERTEX, VK_PRIMITIVE_TOPOLOGY_TRIANGLE_STRIP, nullptr, 0, format);
    if (!p) {
        log_.error("layers: " + p.error().message());
        return VK_NULL_HANDLE;
    }
    return pipelines_.emplace(key, vk::Pipeline(dev, *p)).first->second.get();
}

Result LayerPass::prepare(FrameContext& frame) {
    draws_.clear();
    Slot& slot = slots_[frame.slot];
    slot.used = 0;
    slot.uploads.clear();
    // The frame slot's previous frame has completed: frames up to serial − slots are done.
    const uint64_t done = frame.serial >= slots_.size() ? frame.serial - slots_.size() : 0;
    std::erase_if(retired_, [&](Retired& r) {
        if (r.lastUsed > done) return false;
        release(r.tex);
        return true;
    });
    const Snapshot& snap = frame.snap;
    shown_.clear();
    if (snap.slide)
        for (const Engine::LayerEntry& e : *snap.layers) shown_.insert(e.map.get());
    // The streamed chunks read since the last frame.
    if (streamer_) {
        std::vector<LayerStreamer::Result_> got;
        if (streamer_->collect(got)) {
            for (LayerStreamer::Result_& g : got) {
                if (!g.error.ok()) {
                    if (warnedRead_.insert(g.key.map).second)
                        log_.warn("layers: '" + g.map->title + "': " + g.error.message() +
                                  "; the part of the layer it holds is not drawn");
                    failed_[g.key] = g.map;
                } else {
                    const ChunkKey key = g.key;
                    ready_[key] = std::move(g);
                }
            }
        } else {
            frame.redraw = true; // the reader was handing one over: take it next frame
        }
    }
    if (shown_.empty()) {
        if (!chunks_.empty()) evict(frame.serial);
        ready_.clear();
        failed_.clear();
        if (streamer_ && !streamer_->want({})) frame.redraw = true;
        return {};
    }
    const ViewTransform view = ViewTransform::of(frame.viewport.view, frame.viewport.width, frame.viewport.height);
    const double w = frame.viewport.width, h = frame.viewport.height;
    std::vector<LayerStreamer::Request> wanted;
    std::unordered_set<ChunkKey, ChunkKeyHash> needed; // streamed chunks this frame looks at
    for (const Engine::LayerEntry& e : *snap.layers) {
        if (!e.map || !e.style.visible || !(e.style.opacity > 0) || e.map->levels.empty()) continue;
        const RasterMap& map = *e.map;
        const Placement place = e.placement ? *e.placement
                                            : Placement::spanning(map.width(), map.height(), snap.slide->info.width,
                                                                  snap.slide->info.height);
        const size_t bpt = texelBytes(map.kind);
        // Where level k lies under the target: the affine map target → level pixels, and the
        // chunks the target covers (none when the placement is singular or misses the view;
        // none, with one warning, when they are over half the budget).
        struct Plan {
            int k = 0;
            double a = 0, b = 0, d = 0, f = 0, det = 0;
            std::array<double, 2> o{}, centre{};
            int cx0 = 0, cy0 = 0, cx1 = -1, cy1 = -1;
        };
        const auto planFor = [&](int k) -> std::optional<Plan> {
            const RasterLevel& lv = map.levels[size_t(k)];
            const double sx = double(lv.width) / map.width(), sy = double(lv.height) / map.height();
            bool singular = false;
            const auto toLevel = [&](double x, double y) {
                const auto s = view.toSlide(x, y);
                const auto m = place.toMap(s[0], s[1]);
                if (!m) singular = true;
                return m ? std::array<double, 2>{(*m)[0] * sx, (*m)[1] * sy} : std::array<double, 2>{0, 0};
            };
            Plan p;
            p.k = k;
            p.o = toLevel(0, 0);
            const auto ex = toLevel(1, 0), ey = toLevel(0, 1);
            p.centre = toLevel(w / 2, h / 2);
            if (singular) return std::nullopt;
            p.a = ex[0] - p.o[0], p.b = ey[0] - p.o[0], p.d = ex[1] - p.o[1], p.f = ey[1] - p.o[1];
            p.det = p.a * p.f - p.b * p.d;
            if (!std::isfinite(p.det) || p.det == 0) return std::nullopt;
            double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
            for (auto [cx, cy] : {std::array<double, 2>{0, 0}, {w, 0}, {0, h}, {w, h}}) {
                const auto q = toLevel(cx, cy);
                x0 = std::min(x0, q[0]), x1 = std::max(x1, q[0]), y0 = std::min(y0, q[1]), y1 = std::max(y1, q[1]);
            }
            x0 = std::max(x0 - 1, 0.0), y0 = std::max(y0 - 1, 0.0);
            x1 = std::min(x1 + 1, double(lv.width)), y1 = std::min(y1 + 1, double(lv.height));
            if (!(x1 > x0 && y1 > y0)) return std::nullopt;
            p.cx0 = int(x0) / kChunk, p.cy0 = int(y0) / kChunk;
            p.cx1 = (int(std::ceil(x1)) - 1) / kChunk, p.cy1 = (int(std::ceil(y1)) - 1) / kChunk;
            const VkDeviceSize need = VkDeviceSize(p.cx1 - p.cx0 + 1) * VkDeviceSize(p.cy1 - p.cy0 + 1) *
                                      VkDeviceSize(kChunk + 2) * VkDeviceSize(kChunk + 2) * bpt;
            if (need > kBudgetBytes / 2) {
                if (!warnedBudget_) {
                    warnedBudget_ = true;
                    log_.warn("layers: '" + map.title + "' needs " + std::to_string(need >> 20) + " MiB of its level " +
                              std::to_string(k) + " for this view, more than half the layer budget (" +
                              std::to_string(kBudgetBytes >> 20) + " MiB); it is not drawn. A map with coarser levels "
                              "(a pyramid) is drawn at every magnification");
                }
                return std::nullopt;
            }
            return p;
        };
        // Whether every chunk of a plan can be drawn now (streamed levels: uploaded, read, or
        // failed); the streamed ones it still needs go into `missing`.
        const auto whole = [&](const Plan& p, std::vector<LayerStreamer::Request>* missing) {
            const RasterLevel& lv = map.levels[size_t(p.k)];
            if (!lv.streamed()) return true;
            bool all = true;
            for (int cy = p.cy0; cy <= p.cy1; ++cy)
                for (int cx = p.cx0; cx <= p.cx1; ++cx) {
                    const ChunkKey key{&map, p.k, cx, cy};
                    if (missing) needed.insert(key);
                    if (chunks_.count(key) || ready_.count(key) || failed_.count(key)) continue;
                    all = false;
                    if (!missing) return false;
                    const int ox = cx * kChunk, oy = cy * kChunk;
                    const int tx = std::max(ox - 1, 0), ty = std::max(oy - 1, 0);
                    missing->push_back(LayerStreamer::Request{key, e.map, tx, ty,
                                                              std::min(ox + kChunk + 1, lv.width) - tx,
                                                              std::min(oy + kChunk + 1, lv.height) - ty});
                }
            return all;
        };
        std::optional<Plan> plan = planFor(chooseRasterLevel(map, place, frame.viewport.view.downsample));
        if (!plan) continue;
        std::vector<LayerStreamer::Request> missing;
        if (!whole(*plan, &missing)) {
            // Nearest the view's centre first; meanwhile the finest coarser level that is whole.
            const auto dist = [&](const LayerStreamer::Request& r) {
                const double dx = (r.key.cx + 0.5) * kChunk - plan->centre[0], dy = (r.key.cy + 0.5) * kChunk - plan->centre[1];
                return dx * dx + dy * dy;
            };
            std::stable_sort(missing.begin(), missing.end(),
                             [&](const auto& l, const auto& r) { return dist(l) < dist(r); });
            for (auto& m : missing) wanted.push_back(std::move(m));
            frame.complete = false;
            std::optional<Plan> coarser;
            for (int j = plan->k + 1; j < int(map.levels.size()) && !coarser; ++j)
                if (auto pj = planFor(j); pj && whole(*pj, nullptr)) coarser = pj;
            if (!coarser) continue; // nothing of this layer is ready yet
            plan = coarser;
            for (int cy = plan->cy0; cy <= plan->cy1; ++cy) // keep what it draws from
                for (int cx = plan->cx0; cx <= plan->cx1; ++cx) needed.insert(ChunkKey{&map, plan->k, cx, cy});
        }
        const int k = plan->k;
        const RasterLevel& lv = map.levels[size_t(k)];
        const double a = plan->a, b = plan->b, d = plan->d, f = plan->f, det = plan->det;
        const auto o = plan->o;
        // The palette: the colour map, or the class table (an invisible class: alpha 0).
        std::vector<uint32_t> entries;
        if (map.kind == RasterKind::Scalar) {
            for (const Rgba8& c : e.style.colorMap.entries) entries.push_back(pack(c));
        } else if (map.kind == RasterKind::Label) {
            for (const LabelClass& c : e.style.classes) entries.push_back(c.visible ? pack(c.color) : 0u);
            if (entries.empty()) continue; // no class is drawn
        } else {
            entries.push_back(0);
        }
        bool deferred = false;
        Texture* pal = palette(entries, frame, deferred);
        if (!pal) {
            frame.complete = false;
            frame.redraw = true;
            continue;
        }
        const double low = std::isnan(e.style.low) ? map.minValue : e.style.low;
        const double high = std::isnan(e.style.high) ? map.maxValue : e.style.high;
        const double margin = 2.0 * std::sqrt(a * a + b * b + d * d + f * f);
        const VkFormat format = formatOf(map.kind);
        for (int cy = plan->cy0; cy <= plan->cy1; ++cy) {
            for (int cx = plan->cx0; cx <= plan->cx1; ++cx) {
                const ChunkKey key{&map, k, cx, cy};
                auto it = chunks_.find(key);
                if (it == chunks_.end()) {
                    if (failed_.count(key)) continue; // could not be read: nothing to draw
                    const int ox = cx * kChunk, oy = cy * kChunk;
                    Chunk c;
                    c.map = e.map;
                    c.texX = std::max(ox - 1, 0), c.texY = std::max(oy - 1, 0);
                    c.texW = std::min(ox + kChunk + 1, lv.width) - c.texX;
                    c.texH = std::min(oy + kChunk + 1, lv.height) - c.texY;
                    // Held: the level's own rows; streamed: the chunk the reader read.
                    const uint8_t* src = nullptr;
                    size_t stride = 0;
                    auto ready = ready_.end();
                    if (lv.streamed()) {
                        ready = ready_.find(key);
                        if (ready == ready_.end()) continue; // (whole() said it is there)
                        src = ready->second.pixels.data();
                        stride = size_t(c.texW) * bpt;
                    } else {
                        src = levelBytes(map.kind, lv) + (size_t(c.texY) * size_t(lv.width) + size_t(c.texX)) * bpt;
                        stride = size_t(lv.width) * bpt;
                    }
                    if (Result r = makeTexture(c.tex, format, uint32_t(c.texW), uint32_t(c.texH), chunkPool_.get());
                        !r.ok()) {
                        release(c.tex);
                        evict(frame.serial); // room for the next frame
                        frame.complete = false;
                        frame.redraw = true;
                        continue;
                    }
                    if (!stage(frame.slot, src, size_t(c.texW) * bpt, uint32_t(c.texH), stride, c.tex.image.get(),
                               uint32_t(c.texW))) {
                        release(c.tex);
                        frame.complete = false; // this frame's uploads are spent: the next one goes on
                        frame.redraw = true;
                        continue;
                    }
                    if (ready != ready_.end()) ready_.erase(ready); // on its way to the GPU
                    c.tex.uploaded = true;
                    residentBytes_ += c.tex.bytes;
                    it = chunks_.emplace(key, std::move(c)).first;
                }
                Chunk& c = it->second;
                c.tex.lastUsed = frame.serial;
                const int ox = cx * kChunk, oy = cy * kChunk;
                LayerPush p{};
                // Local = level − origin; target → local and its inverse.
                p.toLocalX[0] = float(a), p.toLocalX[1] = float(b), p.toLocalX[2] = float(o[0] - ox);
                p.toLocalX[3] = float(margin);
                p.toLocalY[0] = float(d), p.toLocalY[1] = float(f), p.toLocalY[2] = float(o[1] - oy);
                const double ia = f / det, ib = -b / det, id = -d / det, ie = a / det;
                const double lx = o[0] - ox, ly = o[1] - oy;
                p.toScreenX[0] = float(ia), p.toScreenX[1] = float(ib), p.toScreenX[2] = float(-(ia * lx + ib * ly));
                p.toScreenX[3] = float(frame.extent.width);
                p.toScreenY[0] = float(id), p.toScreenY[1] = float(ie), p.toScreenY[2] = float(-(id * lx + ie * ly));
                p.toScreenY[3] = float(frame.extent.height);
                p.core[0] = std::min(kChunk, lv.width - ox), p.core[1] = std::min(kChunk, lv.height - oy);
                p.core[2] = ox, p.core[3] = oy;
                p.level[0] = lv.width, p.level[1] = lv.height, p.level[2] = c.texX, p.level[3] = c.texY;
                p.params[0] = float(std::clamp(e.style.opacity, 0.0, 1.0));
                p.params[1] = float(e.style.threshold);
                p.params[2] = float(low), p.params[3] = float(high);
                p.mode[0] = map.kind == RasterKind::Scalar ? 0 : map.kind == RasterKind::Rgba ? 1 : 2;
                p.mode[1] = e.style.sampling == LayerSampling::Nearest ? 1 : 0;
                p.mode[2] = int32_t(entries.size());
                Draw draw{};
                std::memcpy(draw.push, &p, sizeof(p));
                draw.chunk = c.tex.set;
                draw.palette = pal->set;
                draw.integer = map.kind != RasterKind::Scalar;
                draws_.push_back(draw);
            }
        }
    }
    // The reader's list: this frame's missing chunks (an empty list cancels what a view that
    // moved on no longer needs). Read chunks, and failures, that no view looks at are let go.
    if (!wanted.empty() && !streamer_) streamer_ = std::make_unique<LayerStreamer>(wake_);
    if (streamer_ && !streamer_->want(std::move(wanted))) frame.redraw = true;
    std::erase_if(ready_, [&](const auto& kv) { return !needed.count(kv.first); });
    std::erase_if(failed_, [&](const auto& kv) { return !needed.count(kv.first); });
    // Over the budget, or holding chunks of maps no longer shown: give them back now.
    bool stale = residentBytes_ > kBudgetBytes || chunks_.size() > kChunkSets / 2;
    for (auto it = chunks_.begin(); !stale && it != chunks_.end(); ++it) stale = !shown_.count(it->first.map);
    if (stale) evict(frame.serial);
    if (slot.used > 0)
        if (Result r = vk::flush(device_.device(), slot.staging); !r.ok()) return r;
    return {};
}

void LayerPass::recordUploads(VkCommandBuffer cmd, const FrameContext& frame) {
    Slot& s = slots_[frame.slot];
    if (s.uploads.empty()) return;
    std::vector<VkImageMemoryBarrier2> b;
    b.reserve(s.uploads.size());
    for (const Upload& u : s.uploads)
        b.push_back(vk::imageBarrier(u.image, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_COPY_BIT,
                                     VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                                     VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, vk::colorRange(0, 1, 0, 1)));
    vk::pipelineBarrier(cmd, b.data(), uint32_t(b.size()));
    for (const Upload& u : s.uploads) {
        const VkBufferImageCopy copy{.bufferOffset = u.offset,
                                     .bufferRowLength = 0,
                                     .bufferImageHeight = 0,
                                     .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
                                     .imageOffset = {0, 0, 0},
                                     .imageExtent = {u.width, u.height, 1}};
        vkCmdCopyBufferToImage(cmd, s.staging.buffer, u.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &copy);
    }
    b.clear();
    for (const Upload& u : s.uploads)
        b.push_back(vk::imageBarrier(u.image, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                     VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
                                     VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                                     vk::colorRange(0, 1, 0, 1)));
    vk::pipelineBarrier(cmd, b.data(), uint32_t(b.size()));
}

Result LayerPass::recordDraws(VkCommandBuffer cmd, const FrameContext& frame) {
    if (draws_.empty()) return {};
    const VkViewport viewport{0, 0, float(frame.extent.width), float(frame.extent.height), 0, 1};
    const VkRect2D scissor{{0, 0}, frame.extent};
    VkPipeline bound = VK_NULL_HANDLE;
    for (const Draw& d : draws_) {
        const VkPipeline p = pipelineFor(frame.format, d.integer);
        if (!p) return Result(Status::Vulkan, "no layer pipeline for the target's format");
        if (p != bound) {
            vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p);
            vkCmdSetViewport(cmd, 0, 1, &viewport);
            vkCmdSetScissor(cmd, 0, 1, &scissor);
            bound = p;
        }
        const VkDescriptorSet sets[2] = {d.chunk, d.palette};
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout_.get(), 0, 2, sets, 0, nullptr);
        vkCmdPushConstants(cmd, layout_.get(), VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                           sizeof(LayerPush), d.push);
        vkCmdDraw(cmd, 4, 1, 0, 0);
    }
    return {};
}

} // namespace iris::render
