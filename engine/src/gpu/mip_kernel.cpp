#include "gpu/mip_kernel.h"

#include <algorithm>
#include <cmath>

namespace iris::gpu::mipkernel {

std::vector<float> reduceLevel(const uint8_t* tile, int level, bool enhance, float lambda) {
    const int r = 1 << level;
    const int n = kTile >> level;
    std::vector<uint32_t> sums(size_t(n) * n * 4, 0);
    for (int y = 0; y < kTile; ++y)
        for (int x = 0; x < kTile; ++x)
            for (int c = 0; c < 4; ++c)
                sums[(size_t(y / r) * n + size_t(x / r)) * 4 + c] += tile[(size_t(y) * kTile + x) * 4 + c];
    const float texels = float(r * r);
    std::vector<float> out(sums.size());
    for (int py = 0; py < n; ++py)
        for (int px = 0; px < n; ++px)
            for (int c = 0; c < 4; ++c) {
                const uint32_t s = sums[(size_t(py) * n + px) * 4 + c];
                const float a = float(s) / (texels * 255.0f);
                if (!enhance) {
                    out[(size_t(py) * n + px) * 4 + c] = a;
                    continue;
                }
                int64_t g = 0;
                for (int j = -1; j <= 1; ++j)
                    for (int i = -1; i <= 1; ++i) {
                        const int qx = std::clamp(px + i, 0, n - 1), qy = std::clamp(py + j, 0, n - 1);
                        g += int64_t(kBinomial[i + 1] * kBinomial[j + 1]) * sums[(size_t(qy) * n + qx) * 4 + c];
                    }
                const int32_t d = int32_t(16 * int64_t(s) - g); // 16·(A − G)·r²·255, exact
                const float e = a + lambda * (float(d) / (16.0f * texels * 255.0f));
                out[(size_t(py) * n + px) * 4 + c] = std::clamp(e, 0.0f, 1.0f);
            }
    return out;
}

std::vector<uint8_t> reduceLevel8(const uint8_t* tile, int level, bool enhance, float lambda) {
    const std::vector<float> f = reduceLevel(tile, level, enhance, lambda);
    std::vector<uint8_t> out(f.size());
    for (size_t i = 0; i < f.size(); ++i) out[i] = uint8_t(std::lround(f[i] * 255.0f));
    return out;
}

namespace {

// The 8-bit store of one value in [0, 1]: std::lround(v · 255), as reduceLevel8 does. Rounding
// half away from zero is written out (trunc, then up when the fraction is at least one half:
// x − trunc(x) is exact in float), which vectorises where a call to lround does not.
inline uint8_t store8(float v) {
    const float x = v * 255.0f;
    const int t = int(x);
    return uint8_t(t + ((x - float(t)) >= 0.5f ? 1 : 0));
}

// Row y of the horizontal (1 2 1) pass over block sums `s` (rows of `row` values, RGBA
// interleaved), the index clamped at both ends: at x = 0 it is 3·S0 + S1.
void blurRow(const uint32_t* s, size_t row, int y, uint32_t* o) {
    const uint32_t* r = s + size_t(y) * row;
    if (row == 4) {
        for (int c = 0; c < 4; ++c) o[c] = 4 * r[c];
        return;
    }
    for (int c = 0; c < 4; ++c) o[c] = 3 * r[c] + r[4 + c];
    for (size_t i = 4; i + 4 < row; ++i) o[i] = r[i - 4] + 2 * r[i] + r[i + 4];
    for (size_t c = 0; c < 4; ++c) o[row - 4 + c] = r[row - 8 + c] + 3 * r[row - 4 + c];
}

// One level from its block sums `s` (n×n RGBA, row-major) into `out`; `ring` is scratch for
// three rows. Every value goes through reduceLevel's float expressions, in its order. Row by
// row (the vertical pass over a ring of three horizontally blurred rows), so that a level's
// passes stay in the cache, and as plain array loops, so that the compiler vectorises them.
void emitLevel(const uint32_t* s, int n, int level, bool enhance, float lambda, uint32_t* ring, uint8_t* out) {
    const float texels = float(1 << (2 * level));
    const size_t row = size_t(n) * 4;
    if (!enhance) {
        for (size_t i = 0; i < row * size_t(n); ++i) out[i] = store8(float(s[i]) / (texels * 255.0f));
        return;
    }
    const auto slot = [&](int y) { return ring + size_t(y % 3) * row; };
    blurRow(s, row, 0, slot(0));
    if (n > 1) blurRow(s, row, 1, slot(1));
    for (int y = 0; y < n; ++y) {
        if (y > 0 && y + 1 < n) blurRow(s, row, y + 1, slot(y + 1)); // replaces row y − 2
        // Vertical (1 2 1), clamped the same way: g = Σ b_i b_j S as in reduceLevel.
        const uint32_t* up = slot(std::max(y - 1, 0));
        const uint32_t* mid = slot(y);
        const uint32_t* down = slot(std::min(y + 1, n - 1));
        const uint32_t* sr = s + size_t(y) * row;
        uint8_t* o = out + size_t(y) * row;
        for (size_t i = 0; i < row; ++i) {
            const int32_t d = int32_t(16 * sr[i]) - int32_t(up[i] + 2 * mid[i] + down[i]); // 16·(A − G)·r²·255
            const float a = float(sr[i]) / (texels * 255.0f);
            const float e = a + lambda * (float(d) / (16.0f * texels * 255.0f));
            o[i] = store8(std::min(std::max(e, 0.0f), 1.0f)); // std::clamp(e, 0, 1), branch-free
        }
    }
}

// The sums of the 2×2 blocks of a 2n×2n RGBA grid `src` (the base's bytes, or a level's sums)
// into n×n `s`: each pair of rows added first (a plain vector loop), then neighbouring texels,
// one RGBA quad at a time.
template <typename T>
void sumBlocks(const T* src, int n, uint32_t* s) {
    const int m = 2 * n;
    uint32_t pair[kTile * 4];
    for (int py = 0; py < n; ++py) {
        const T* r0 = src + size_t(2 * py) * m * 4;
        const T* r1 = r0 + size_t(m) * 4;
        for (int i = 0; i < m * 4; ++i) pair[i] = uint32_t(r0[i]) + r1[i];
        uint32_t* o = s + size_t(py) * n * 4;
        for (int px = 0; px < n; ++px) {
            const uint32_t* q = pair + px * 8;
            for (int c = 0; c < 4; ++c) o[px * 4 + c] = q[c] + q[c + 4];
        }
    }
}

} // namespace

void reduceChain8(const uint8_t* tile, uint8_t* out, bool enhance, float lambda) {
    constexpr size_t kLevel1 = size_t(kTile / 2) * (kTile / 2) * 4;
    thread_local std::vector<uint32_t> sums[2], ring;
    for (auto& v : sums) v.resize(kLevel1);
    ring.resize(3 * size_t(kTile / 2) * 4);
    // Level 1 from the base's bytes, level k from level k−1's sums.
    sumBlocks(tile, kTile / 2, sums[1].data());
    emitLevel(sums[1].data(), kTile / 2, 1, enhance, lambda, ring.data(), out + chainOffset(1));
    for (int k = 2; k <= kLevels; ++k) {
        sumBlocks(sums[(k - 1) & 1].data(), kTile >> k, sums[k & 1].data());
        emitLevel(sums[k & 1].data(), kTile >> k, k, enhance, lambda, ring.data(), out + chainOffset(k));
    }
}

} // namespace iris::gpu::mipkernel
