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

} // namespace iris::gpu::mipkernel
