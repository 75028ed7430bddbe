// The mip reduction kernel (shaders/mip_reduce.comp) as constants shared with the host, a CPU
// reference of exactly the same arithmetic (mip_kernel.cpp) for the tests, and the same kernel
// made fast for the host mip schedule (reduceChain8: the buffer thread makes the levels on the
// CPU where the "GPU" is the CPU, EngineTuning::MipSchedule::Host).
// The kernel is documented in docs/ENHANCEMENT.md.
//
// Level k (r = 2^k, n = 256 / r texels per side), per channel, from the 1× base tile only:
//   S_k[p]  integer sum of the r×r base block of output texel p        (exact)
//   A_k[p]  = S_k[p] / (r²·255)                                        (area average)
//   G_k[p]  = Σ_{i,j∈{-1,0,1}} b_i b_j A_k[clamp(p + (i, j))] / 16, b = (1, 2, 1)
//             (binomial blur of A_k on the level's own grid; indices clamped to the tile)
//   E_k[p]  = clamp(A_k[p] + λ·(A_k[p] − G_k[p]), 0, 1)                 (enhance on)
//   E_k[p]  = A_k[p]                                                   (enhance off)
// A − G is computed as an exact integer (16·S − Σ b_i b_j S) before the single float step.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace iris::gpu::mipkernel {

inline constexpr int kTile = 256;
inline constexpr int kLevels = 8;       // mip levels 1..8 (128×128 … 1×1)
inline constexpr float kLambda = 0.5f;  // sharpening gain λ (push constant of the shader)
inline constexpr int kBinomial[3] = {1, 2, 1};
// Largest overshoot of a step edge of height h, from the kernel's negative lobe: λ/4 · h.
inline constexpr float kOvershootBound = kLambda / 4.0f;

// Level `level` (1..8) of one 256×256 RGBA8 tile (row-major, 4 bytes a texel): (256>>level)²
// RGBA values in [0, 1], before the 8-bit store.
std::vector<float> reduceLevel(const uint8_t* tile, int level, bool enhance, float lambda = kLambda);
// The same, quantised as the GPU's UNORM8 store does (round to nearest).
std::vector<uint8_t> reduceLevel8(const uint8_t* tile, int level, bool enhance, float lambda = kLambda);

// Levels 1..8 of one tile packed one after another, each row-major RGBA8 (level k at
// chainOffset(k), (256>>k)² texels).
inline constexpr size_t chainOffset(int level) {
    size_t o = 0;
    for (int k = 1; k < level; ++k) o += size_t(kTile >> k) * size_t(kTile >> k) * 4;
    return o;
}
inline constexpr size_t kChainBytes = chainOffset(kLevels + 1); // 87 380

// All 8 levels of `tile` into `out` (kChainBytes), equal byte for byte to reduceLevel8 of each
// level (unit.mip_chain), at a small part of its cost: each level's block sums are the 2×2 sums
// of the level above (exact in integers), the 3×3 binomial runs as two 1-D passes (its index
// clamp is per axis, so that is the same sum), and the one float step per value is the
// reference's own expression. Thread-safe; keeps its scratch per thread.
void reduceChain8(const uint8_t* tile, uint8_t* out, bool enhance, float lambda = kLambda);

} // namespace iris::gpu::mipkernel
