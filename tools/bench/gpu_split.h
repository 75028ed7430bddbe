// The decode floor split between the CPU and the GPU (issue 20): the field's tiles read and
// entropy-decoded on every core (libjpeg's jpeg_read_coefficients, straight into mapped memory
// the GPU reads), then dequantised, inverse-transformed, upsampled and converted to RGBA on the
// GPU in one batch (the engine's gpu/jpeg_reconstruct, shaders/jpeg_*.comp). Timed from the
// first read to the GPU's end, one after the other (no overlap of the two halves): what that
// division of the decode costs a field at best, before any upload into an atlas. Every tile's
// result is then compared, untimed, with libjpeg-turbo's decode of the same stream.
//
// It has its own Vulkan device (the bench's engine is gone by then), on the device the
// engine's configuration picks.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "iris/engine.h"

namespace benchsplit {

// A tile's stream, as the floor's threads read it (tables + tile).
struct TileStream {
    const uint8_t* data = nullptr;
    size_t size = 0;
};

class GpuSplit {
public:
    // nullptr and `why` when no device or pipeline can be made.
    static std::unique_ptr<GpuSplit> create(const iris::EngineConfig& config, std::string& why);
    ~GpuSplit();

    // Room for `tiles` tiles of at most 256×256; false (and `why`) when it cannot be made.
    bool reserve(uint32_t tiles, std::string& why);
    // Thread-safe for distinct `index`: entropy-decodes the tile into its room and writes its
    // descriptor. False when the GPU path does not take it (the field then does not count).
    bool entropyDecode(uint32_t index, const TileStream& s, int width, int height, bool ycbcr);
    // Uploads tiles [0, count)'s input into device memory, reconstructs them there and waits;
    // the GPU's own time (timestamps) in gpuMs, of which the two dispatches' in computeMs (the
    // rest is the upload), NaN where the queue has none. False on a Vulkan error (`why`).
    bool reconstruct(uint32_t count, double& gpuMs, double& computeMs, std::string& why);
    // Copies tiles [0, count)'s pixels back to the host (after reconstruct, untimed).
    bool readBack(uint32_t count, std::string& why);
    // After readBack: tile `index`'s RGBA8 pixels (width × height, rows width·4 bytes).
    const uint8_t* pixels(uint32_t index) const;

    std::string deviceName() const;

private:
    GpuSplit();
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace benchsplit
