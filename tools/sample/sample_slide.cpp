// iris_sample: procedural H&E-like whole-slide image written as a pyramidal tiled-JPEG TIFF.
//
// Layout (what OpenSlide 3.4.1's generic-tiff reader accepts):
//   one TIFF directory per level, level 0 first, reduced levels marked FILETYPE_REDUCEDIMAGE;
//   tiled 256x256, COMPRESSION_JPEG, 8 bits x 3 samples, planar contig;
//   PHOTOMETRIC_YCBCR with YCbCrSubsampling 2,2: every tile is a complete JFIF (YCbCr 4:2:0)
//   stream from TurboJPEG, written with TIFFWriteRawTile so libtiff encodes nothing;
//   X/YResolution in pixels per centimetre (OpenSlide derives openslide.mpp-x/y from them).
//
// Speed: level-0 tiles are generated and encoded on all cores one tile row ("band") at a
// time; each finished tile is box-filtered 2x into the band of level 1, whose finished bands
// feed level 2, and so on. Tiles that are pure glass are all identical (the glass noise is
// periodic with the tile size), so each level encodes its glass tile once.

#include "sample_slide.h"

#include <tiffio.h>
#include <turbojpeg.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <memory>
#include <mutex>
#include <numbers>
#include <thread>

namespace iris::sample {
namespace {

constexpr int T = kTileSize;
constexpr int kGridStep = 16;             // coarse field grid spacing inside a tile
constexpr int kGridN = T / kGridStep + 1; // 17 samples per axis
constexpr int kTableSize = 1024;          // stripe profile tables
constexpr int kNucleusCell = 22;          // nucleus placement cell (pixels)
constexpr int kNucleusMaxRadius = 12;

// ---------------------------------------------------------------------------------------
// Hashing and noise

inline uint64_t mix64(uint64_t z) {
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

inline uint64_t hash2(int64_t x, int64_t y, uint64_t seed) {
    return mix64(seed + static_cast<uint64_t>(x) * 0x632be59bd9b4e019ull +
                 static_cast<uint64_t>(y) * 0x8cb92ba72f3d8dd7ull);
}

// Cheap per-pixel hash (32-bit) for grain.
inline uint32_t hash32(uint32_t x, uint32_t y, uint32_t seed) {
    uint32_t h = x * 0x27d4eb2du ^ (y * 0x165667b1u) ^ seed;
    h ^= h >> 15;
    h *= 0x2c1b3c6du;
    h ^= h >> 12;
    h *= 0x297a2d39u;
    h ^= h >> 15;
    return h;
}

inline double unit(uint64_t h) { return static_cast<double>(h >> 11) * 0x1.0p-53; }

// Value noise in [0, 1), lattice spacing 1.
double valueNoise(double x, double y, uint64_t seed) {
    const double fx = std::floor(x);
    const double fy = std::floor(y);
    const auto ix = static_cast<int64_t>(fx);
    const auto iy = static_cast<int64_t>(fy);
    double tx = x - fx;
    double ty = y - fy;
    tx = tx * tx * (3.0 - 2.0 * tx);
    ty = ty * ty * (3.0 - 2.0 * ty);
    const double a = unit(hash2(ix, iy, seed));
    const double b = unit(hash2(ix + 1, iy, seed));
    const double c = unit(hash2(ix, iy + 1, seed));
    const double d = unit(hash2(ix + 1, iy + 1, seed));
    const double top = a + (b - a) * tx;
    const double bottom = c + (d - c) * tx;
    return top + (bottom - top) * ty;
}

inline double smoothstep(double e0, double e1, double x) {
    double t = (x - e0) / (e1 - e0);
    t = t < 0 ? 0 : (t > 1 ? 1 : t);
    return t * t * (3.0 - 2.0 * t);
}

// Rounds and clamps to 0..255 (inputs are far inside the int range). Branch-free so loops
// using it vectorise.
inline uint8_t clampByte(float v) {
    int i = static_cast<int>(v + 0.5f);
    i = i < 0 ? 0 : i;
    i = i > 255 ? 255 : i;
    return static_cast<uint8_t>(i);
}

// ---------------------------------------------------------------------------------------
// The scene: everything derived from (seed, width, height).

struct Piece {
    double cx, cy, invRx, invRy, cosA, sinA;
};

struct Scene {
    uint64_t seed = 0;
    int64_t width = 0, height = 0;
    std::vector<Piece> pieces;
    double lipschitz = 0;    // bound on |grad| of the blob field
    double lobeScale = 1;    // lattice size of the large boundary lobes (pixels)
    float edgeWidth = 0.01f; // tissue/glass transition in field units
    uint64_t sLobe = 0, sEdge = 0, sHole = 0, sFib1 = 0, sFib2 = 0, sFine = 0, sFineMask = 0, sCell1 = 0, sCell2 = 0,
             sNuc = 0;
    double fineCos = 1, fineSin = 0;
    uint32_t grainSeed = 0;
    float fibreProfile[kTableSize];
    float fineProfile[kTableSize];
    std::vector<uint8_t> glass; // T x T x 3, the level-0 glass tile
};

constexpr double kLobeAmp = 0.30, kEdgeAmp = 0.08;
constexpr double kFibreLambda = 7.0; // collagen bundle spacing (pixels)
constexpr double kFineLambda = 3.0;  // fine striation spacing (pixels): aliases when
                                     // point-sampled

std::unique_ptr<Scene> makeScene(uint64_t seed, int64_t width, int64_t height) {
    auto s = std::make_unique<Scene>();
    s->seed = seed;
    s->width = width;
    s->height = height;
    uint64_t state = mix64(seed ^ 0x1415926535897932ull);
    auto next = [&state]() {
        state += 0x9e3779b97f4a7c15ull;
        return mix64(state);
    };
    auto uni = [&next]() { return unit(next()); };
    s->sLobe = next();
    s->sEdge = next();
    s->sHole = next();
    s->sFib1 = next();
    s->sFib2 = next();
    s->sFine = next();
    s->sFineMask = next();
    s->sCell1 = next();
    s->sCell2 = next();
    s->sNuc = next();
    s->grainSeed = static_cast<uint32_t>(next());
    const double fineAngle = uni() * std::numbers::pi;
    s->fineCos = std::cos(fineAngle);
    s->fineSin = std::sin(fineAngle);

    // Tissue pieces: one per cell of a 3x2 (landscape) or 2x3 (portrait) grid, some missing.
    const double w = static_cast<double>(width), h = static_cast<double>(height);
    const int cols = width >= height ? 3 : 2;
    const int rows = width >= height ? 2 : 3;
    const double cellW = w / cols, cellH = h / rows;
    const double cellMin = std::min(cellW, cellH);
    s->lobeScale = std::max(8.0, std::min(w, h) * 0.07);
    for (int r = 0; r < rows; ++r) {
        for (int c = 0; c < cols; ++c) {
            const double present = uni();
            const double jx = uni(), jy = uni(), ra = uni(), rb = uni(), ang = uni();
            if (present < 0.2 && s->pieces.size() + (rows * cols - r * cols - c) > 3) continue;
            Piece p{};
            p.cx = (c + 0.5 + (jx - 0.5) * 0.3) * cellW;
            p.cy = (r + 0.5 + (jy - 0.5) * 0.3) * cellH;
            const double rx = cellMin * (0.30 + 0.16 * ra);
            const double ry = rx * (0.6 + 0.4 * rb);
            p.invRx = 1.0 / rx;
            p.invRy = 1.0 / ry;
            p.cosA = std::cos(ang * std::numbers::pi);
            p.sinA = std::sin(ang * std::numbers::pi);
            s->lipschitz = std::max(s->lipschitz, std::max(p.invRx, p.invRy));
            s->pieces.push_back(p);
        }
    }

    // Soft tissue edge: ~40 px where the blob field dominates, never sharper than ~2 px at holes.
    s->edgeWidth = static_cast<float>(std::max(0.01, 40.0 * s->lipschitz));

    for (int i = 0; i < kTableSize; ++i) {
        const double t = (i + 0.5) / kTableSize;
        const double c = 0.5 + 0.5 * std::cos(2.0 * std::numbers::pi * t);
        s->fibreProfile[i] = static_cast<float>(std::pow(c, 6.0)); // thin lines
        s->fineProfile[i] = static_cast<float>(c);
    }

    // Glass: near-white (242) with slight noise, periodic with the tile size so every
    // all-glass tile is byte-identical.
    s->glass.resize(static_cast<size_t>(T) * T * 3);
    for (int y = 0; y < T; ++y) {
        for (int x = 0; x < T; ++x) {
            const uint32_t hv = hash32(static_cast<uint32_t>(x), static_cast<uint32_t>(y), s->grainSeed ^ 0xa5a5a5a5u);
            const int lum = static_cast<int>(hv % 5u) - 2; // -2..2
            uint8_t* px = &s->glass[(static_cast<size_t>(y) * T + x) * 3];
            px[0] = static_cast<uint8_t>(242 + lum + static_cast<int>((hv >> 8) % 3u) - 1);
            px[1] = static_cast<uint8_t>(242 + lum + static_cast<int>((hv >> 16) % 3u) - 1);
            px[2] = static_cast<uint8_t>(242 + lum + static_cast<int>((hv >> 24) % 3u) - 1);
        }
    }
    return s;
}

double blobField(const Scene& s, double x, double y) {
    double best = -1e30;
    for (const Piece& p : s.pieces) {
        const double dx = x - p.cx, dy = y - p.cy;
        const double u = (dx * p.cosA + dy * p.sinA) * p.invRx;
        const double v = (-dx * p.sinA + dy * p.cosA) * p.invRy;
        best = std::max(best, 1.0 - std::sqrt(u * u + v * v));
    }
    return best;
}

// Tissue field: > 0 inside tissue. Holes (lumens / fat) only ever subtract.
double tissueField(const Scene& s, double x, double y) {
    double t = blobField(s, x, y);
    if (t + kLobeAmp * 0.5 + kEdgeAmp * 0.5 <= 0) return t; // far out on the glass
    const double ls = s.lobeScale;
    t += kLobeAmp * (0.65 * valueNoise(x / ls, y / ls, s.sLobe) +
                     0.35 * valueNoise(x / (ls * 0.4), y / (ls * 0.4), s.sLobe + 1) - 0.5);
    t += kEdgeAmp * (valueNoise(x / 180.0, y / 180.0, s.sEdge) - 0.5);
    const double hole = valueNoise(x / 520.0, y / 520.0, s.sHole);
    if (hole > 0.74) t -= 0.9 * (hole - 0.74) / 0.26;
    return t;
}

// Cellularity in [0, 1]: stroma (low) vs cell-rich regions (high).
double cellularity(const Scene& s, double x, double y) {
    return 0.65 * valueNoise(x / 1500.0, y / 1500.0, s.sCell1) + 0.35 * valueNoise(x / 380.0, y / 380.0, s.sCell2);
}

// Collagen stripes follow the iso-lines of a smooth field whose gradient is ~1 px/px.
double fibrePhase(const Scene& s, double x, double y) {
    const double f =
        1400.0 * valueNoise(x / 700.0, y / 700.0, s.sFib1) + 110.0 * valueNoise(x / 170.0, y / 170.0, s.sFib2);
    return f / kFibreLambda; // in cycles
}

double finePhase(const Scene& s, double x, double y) {
    const double f = x * s.fineCos + y * s.fineSin + 60.0 * valueNoise(x / 260.0, y / 260.0, s.sFine);
    return f / kFineLambda;
}

// Collagen bundle strength: bundles fade in and out along the fibres.
double fibreStrength(const Scene& s, double x, double y) { return valueNoise(x / 70.0, y / 70.0, s.sFib2 + 7); }

double fineMask(const Scene& s, double x, double y) {
    return smoothstep(0.58, 0.72, valueNoise(x / 2600.0, y / 2600.0, s.sFineMask));
}

// ---------------------------------------------------------------------------------------
// Tile generation

struct TileScratch {
    std::vector<float> density = std::vector<float>(static_cast<size_t>(T) * T);
};

// Conservative early-out: true when the whole tile is certainly glass.
bool tileCertainlyGlass(const Scene& s, int64_t x0, int64_t y0) {
    const double cx = static_cast<double>(x0) + T * 0.5, cy = static_cast<double>(y0) + T * 0.5;
    const double bound = blobField(s, cx, cy) + s.lipschitz * 182.0 + kLobeAmp * 0.5 + kEdgeAmp * 0.5;
    return bound <= 0.0;
}

// Tissue field on the coarse grid; returns true when it is <= 0 everywhere (glass tile).
bool fieldGrid(const Scene& s, int64_t x0, int64_t y0, float* grid) {
    if (tileCertainlyGlass(s, x0, y0)) {
        std::fill(grid, grid + kGridN * kGridN, 0.f);
        return true;
    }
    bool glass = true;
    for (int j = 0; j < kGridN; ++j) {
        for (int i = 0; i < kGridN; ++i) {
            const double x = static_cast<double>(x0 + i * kGridStep);
            const double y = static_cast<double>(y0 + j * kGridStep);
            const float t = static_cast<float>(tissueField(s, x, y));
            grid[j * kGridN + i] = t;
            if (t > 0.f) glass = false;
        }
    }
    return glass;
}

[[gnu::noinline]] void drawNuclei(const Scene& s, int64_t x0, int64_t y0, uint8_t* rgb, size_t pitch,
                                  const float* density) {
    const int64_t cx0 = (x0 - kNucleusMaxRadius - kNucleusCell) / kNucleusCell - 1;
    const int64_t cx1 = (x0 + T + kNucleusMaxRadius) / kNucleusCell + 1;
    const int64_t cy0 = (y0 - kNucleusMaxRadius - kNucleusCell) / kNucleusCell - 1;
    const int64_t cy1 = (y0 + T + kNucleusMaxRadius) / kNucleusCell + 1;
    for (int64_t cy = cy0; cy <= cy1; ++cy) {
        for (int64_t cx = cx0; cx <= cx1; ++cx) {
            const uint64_t h = hash2(cx, cy, s.sNuc);
            const double centreX = (static_cast<double>(cx) + 0.1 + 0.8 * unit(mix64(h ^ 1))) * kNucleusCell;
            const double centreY = (static_cast<double>(cy) + 0.1 + 0.8 * unit(mix64(h ^ 2))) * kNucleusCell;
            if (centreX < static_cast<double>(x0) - kNucleusMaxRadius ||
                centreX > static_cast<double>(x0 + T) + kNucleusMaxRadius ||
                centreY < static_cast<double>(y0) - kNucleusMaxRadius ||
                centreY > static_cast<double>(y0 + T) + kNucleusMaxRadius)
                continue;
            const double cell = cellularity(s, centreX, centreY);
            const double p = 0.07 + 0.6 * smoothstep(0.3, 0.78, cell);
            if (unit(h) >= p) continue;
            // Nucleus shape and stain.
            const double u4 = unit(mix64(h ^ 4)), u5 = unit(mix64(h ^ 5)), u6 = unit(mix64(h ^ 6));
            const double u7 = unit(mix64(h ^ 7));
            double rx, ry;
            float base[3];
            if (unit(mix64(h ^ 3)) < 0.22) { // lymphocyte: small, round, very dark
                rx = ry = 4.0 + 1.6 * u4;
                base[0] = 62.f;
                base[1] = 42.f;
                base[2] = 122.f;
            } else { // epithelial / stromal nucleus: larger, elliptical, paler with chromatin
                rx = 6.0 + 5.0 * u4;
                ry = rx * (0.42 + 0.5 * u5);
                const float tone = static_cast<float>(u7);
                base[0] = 96.f + 40.f * tone;
                base[1] = 68.f + 36.f * tone;
                base[2] = 160.f + 25.f * tone;
            }
            const double ang = u6 * std::numbers::pi;
            const double ca = std::cos(ang), sa = std::sin(ang);
            const double invRx2 = 1.0 / (rx * rx), invRy2 = 1.0 / (ry * ry);
            const double edge = 0.5 * std::min(rx, ry);
            const int64_t bx0 = std::max<int64_t>(x0, static_cast<int64_t>(std::floor(centreX - rx - 1)));
            const int64_t bx1 = std::min<int64_t>(x0 + T - 1, static_cast<int64_t>(std::ceil(centreX + rx + 1)));
            const int64_t by0 = std::max<int64_t>(y0, static_cast<int64_t>(std::floor(centreY - rx - 1)));
            const int64_t by1 = std::min<int64_t>(y0 + T - 1, static_cast<int64_t>(std::ceil(centreY + rx + 1)));
            const auto grain = s.grainSeed ^ static_cast<uint32_t>(h >> 32);
            for (int64_t py = by0; py <= by1; ++py) {
                const double dy = static_cast<double>(py) + 0.5 - centreY;
                const float* drow = density + (py - y0) * T;
                uint8_t* row = rgb + static_cast<size_t>(py - y0) * pitch;
                for (int64_t px = bx0; px <= bx1; ++px) {
                    const float dens = drow[px - x0];
                    if (dens <= 0.f) continue;
                    const double dx = static_cast<double>(px) + 0.5 - centreX;
                    const double a = dx * ca + dy * sa, b = -dx * sa + dy * ca;
                    const double q = a * a * invRx2 + b * b * invRy2;
                    if (q >= 1.0) continue;
                    const double alpha = std::min(1.0, (1.0 - q) * edge);
                    const float op = static_cast<float>(0.93 * alpha) * dens;
                    const uint32_t hv = hash32(static_cast<uint32_t>(px) >> 1, static_cast<uint32_t>(py) >> 1, grain);
                    const float speckle = static_cast<float>(hv & 0xff) * (1.f / 255.f);
                    const float rim = static_cast<float>(smoothstep(0.5, 0.95, q));
                    const float dark = 0.55f * rim + 0.22f * speckle * speckle;
                    uint8_t* o = row + (px - x0) * 3;
                    for (int c = 0; c < 3; ++c) {
                        const float col = base[c] * (1.f - 0.42f * dark);
                        const float cur = o[c];
                        o[c] = clampByte(cur + (col - cur) * op);
                    }
                }
            }
        }
    }
}

// Renders level-0 tile (x0, y0 in pixels, tile aligned) into rgb (pitch bytes a row).
// Returns true when the tile is pure glass.
bool renderTile(const Scene& s, int64_t x0, int64_t y0, uint8_t* rgb, size_t pitch, TileScratch& scratch) {
    float dGrid[kGridN * kGridN];
    if (fieldGrid(s, x0, y0, dGrid)) {
        for (int y = 0; y < T; ++y) std::memcpy(rgb + y * pitch, &s.glass[static_cast<size_t>(y) * T * 3], T * 3);
        return true;
    }
    double a1Grid[kGridN * kGridN], a2Grid[kGridN * kGridN];
    float vGrid[kGridN * kGridN], wGrid[kGridN * kGridN], sGrid[kGridN * kGridN];
    for (int j = 0; j < kGridN; ++j) {
        for (int i = 0; i < kGridN; ++i) {
            const int k = j * kGridN + i;
            const double x = static_cast<double>(x0 + i * kGridStep);
            const double y = static_cast<double>(y0 + j * kGridStep);
            // Cells whose four corners are glass never read these; compute anyway (cheap enough
            // compared with the pixels) except when the whole neighbourhood is glass.
            a1Grid[k] = fibrePhase(s, x, y);
            a2Grid[k] = finePhase(s, x, y);
            vGrid[k] = static_cast<float>(smoothstep(0.4, 0.75, cellularity(s, x, y)));
            wGrid[k] = static_cast<float>(fineMask(s, x, y));
            sGrid[k] = static_cast<float>(0.25 + 0.95 * fibreStrength(s, x, y));
        }
    }

    float* density = scratch.density.data();
    constexpr float kInvStep = 1.f / kGridStep;
    const float invEdge = 1.f / s.edgeWidth;
    // Per-row planar scratch, so the colour pass vectorises.
    alignas(32) float tArr[T], vArr[T], wArr[T], sArr[T], a1Arr[T], a2Arr[T], fibArr[T], fineArr[T];
    alignas(32) uint8_t rOut[T], gOut[T], bOut[T];
    for (int y = 0; y < T; ++y) {
        const int gy = y / kGridStep;
        const int gy1 = std::min(gy + 1, kGridN - 1);
        const float fy = static_cast<float>(y % kGridStep) * kInvStep;
        const double fyd = static_cast<double>(y % kGridStep) / kGridStep;
        float tRow[kGridN], vRow[kGridN], wRow[kGridN], sRow[kGridN];
        double a1Row[kGridN], a2Row[kGridN];
        bool anyTissue = false;
        for (int i = 0; i < kGridN; ++i) {
            const int k0 = gy * kGridN + i, k1 = gy1 * kGridN + i;
            tRow[i] = dGrid[k0] + (dGrid[k1] - dGrid[k0]) * fy;
            vRow[i] = vGrid[k0] + (vGrid[k1] - vGrid[k0]) * fy;
            wRow[i] = wGrid[k0] + (wGrid[k1] - wGrid[k0]) * fy;
            sRow[i] = sGrid[k0] + (sGrid[k1] - sGrid[k0]) * fy;
            a1Row[i] = a1Grid[k0] + (a1Grid[k1] - a1Grid[k0]) * fyd;
            a2Row[i] = a2Grid[k0] + (a2Grid[k1] - a2Grid[k0]) * fyd;
            if (tRow[i] > 0.f) anyTissue = true;
        }
        uint8_t* row = rgb + y * pitch;
        const uint8_t* glassRow = &s.glass[static_cast<size_t>(y) * T * 3];
        float* dOut = density + y * T;
        if (!anyTissue) { // the field is <= 0 along the whole row: pure glass
            std::memcpy(row, glassRow, T * 3);
            std::fill(dOut, dOut + T, 0.f);
            continue;
        }
        // 1. Linear interpolation of the fields inside each grid cell.
        for (int cell = 0; cell < kGridN - 1; ++cell) {
            const int xs = cell * kGridStep;
            const float tL = tRow[cell], tStep = (tRow[cell + 1] - tL) * kInvStep;
            const float vL = vRow[cell], vStep = (vRow[cell + 1] - vL) * kInvStep;
            const float wL = wRow[cell], wStep = (wRow[cell + 1] - wL) * kInvStep;
            const float sL = sRow[cell], sStep = (sRow[cell + 1] - sL) * kInvStep;
            // Phases in table units, reduced modulo one cycle at the cell start.
            const double a1L = a1Row[cell], a2L = a2Row[cell];
            const float a1Start = static_cast<float>((a1L - std::floor(a1L)) * kTableSize);
            const float a2Start = static_cast<float>((a2L - std::floor(a2L)) * kTableSize);
            const float a1Step = static_cast<float>((a1Row[cell + 1] - a1L) * kTableSize) * kInvStep;
            const float a2Step = static_cast<float>((a2Row[cell + 1] - a2L) * kTableSize) * kInvStep;
            for (int k = 0; k < kGridStep; ++k) {
                const float kf = static_cast<float>(k);
                tArr[xs + k] = tL + tStep * kf;
                vArr[xs + k] = vL + vStep * kf;
                wArr[xs + k] = wL + wStep * kf;
                sArr[xs + k] = sL + sStep * kf;
                a1Arr[xs + k] = a1Start + a1Step * kf;
                a2Arr[xs + k] = a2Start + a2Step * kf;
            }
        }
        // 2. Stripe profiles (table lookups).
        for (int x = 0; x < T; ++x) {
            fibArr[x] = s.fibreProfile[static_cast<int>(a1Arr[x]) & (kTableSize - 1)];
            fineArr[x] = s.fineProfile[static_cast<int>(a2Arr[x]) & (kTableSize - 1)];
        }
        // 3. Colour. Where the density is 0 the result is exactly the glass pixel.
        const auto py = static_cast<uint32_t>(y0 + y);
        const auto px0 = static_cast<uint32_t>(x0);
        for (int x = 0; x < T; ++x) {
            float u = tArr[x] * invEdge;
            u = u < 0.f ? 0.f : u;
            u = u > 1.f ? 1.f : u;
            const float d = u * u * (3.f - 2.f * u);
            dOut[x] = d;
            const float v = vArr[x];
            const float fib = fibArr[x] * (1.f - 0.55f * v) * sArr[x];
            const float fine = fineArr[x] * wArr[x];
            const uint32_t hv = hash32(px0 + static_cast<uint32_t>(x), py, s.grainSeed);
            const float grain = static_cast<float>(static_cast<int>(hv & 3u)) * 0.8f - 1.2f;
            // Stroma pink -> cell-rich mauve, minus collagen fibres and fine striations.
            const float r = 238.f - 32.f * v - 30.f * fib - 22.f * fine + grain;
            const float g = 168.f - 26.f * v - 58.f * fib - 27.f * fine + grain;
            const float b = 204.f - 2.f * v - 36.f * fib - 22.f * fine + grain;
            const float gr = glassRow[x * 3], gg = glassRow[x * 3 + 1], gb = glassRow[x * 3 + 2];
            rOut[x] = clampByte(gr + (r - gr) * d);
            gOut[x] = clampByte(gg + (g - gg) * d);
            bOut[x] = clampByte(gb + (b - gb) * d);
        }
        for (int x = 0; x < T; ++x) {
            row[3 * x] = rOut[x];
            row[3 * x + 1] = gOut[x];
            row[3 * x + 2] = bOut[x];
        }
    }
    drawNuclei(s, x0, y0, rgb, pitch, density);
    return false;
}

// 2x box filter of a T x T tile (srcPitch) into a (T/2) x (T/2) block (dstPitch).
void downsampleTile(const uint8_t* src, size_t srcPitch, uint8_t* dst, size_t dstPitch) {
    uint16_t sum[T * 3];
    for (int y = 0; y < T / 2; ++y) {
        const uint8_t* r0 = src + (2 * y) * srcPitch;
        const uint8_t* r1 = r0 + srcPitch;
        for (int i = 0; i < T * 3; ++i) sum[i] = static_cast<uint16_t>(r0[i] + r1[i]);
        uint8_t* o = dst + y * dstPitch;
        for (int x = 0; x < T / 2; ++x) {
            const uint16_t* s = sum + 6 * x;
            o[3 * x] = static_cast<uint8_t>((s[0] + s[3] + 2) >> 2);
            o[3 * x + 1] = static_cast<uint8_t>((s[1] + s[4] + 2) >> 2);
            o[3 * x + 2] = static_cast<uint8_t>((s[2] + s[5] + 2) >> 2);
        }
    }
}

// ---------------------------------------------------------------------------------------
// JPEG encoding

class Encoder {
public:
    Encoder() : handle_(tjInitCompress()) {
        buffer_size_ = tjBufSize(T, T, TJSAMP_420);
        if (handle_) buffer_ = tjAlloc(static_cast<int>(buffer_size_));
    }
    ~Encoder() {
        if (buffer_) tjFree(buffer_);
        if (handle_) tjDestroy(handle_);
    }
    Encoder(const Encoder&) = delete;
    Encoder& operator=(const Encoder&) = delete;

    bool ok() const { return handle_ && buffer_; }

    bool encode(const uint8_t* rgb, size_t pitch, int quality, std::vector<uint8_t>& out, std::string& error) {
        unsigned long size = buffer_size_;
        unsigned char* buf = buffer_;
        if (tjCompress2(handle_, rgb, T, static_cast<int>(pitch), T, TJPF_RGB, &buf, &size, TJSAMP_420, quality,
                        TJFLAG_NOREALLOC | TJFLAG_FASTDCT) != 0) {
            error = std::string("JPEG encoding failed: ") + tjGetErrorStr2(handle_);
            return false;
        }
        out.assign(buf, buf + size);
        return true;
    }

private:
    tjhandle handle_ = nullptr;
    unsigned char* buffer_ = nullptr;
    unsigned long buffer_size_ = 0;
};

// ---------------------------------------------------------------------------------------
// Parallel helper: runs fn(index, worker) for index in [0, n) on `workers` threads
// (the calling thread is worker 0).

template <typename Fn>
void parallelFor(int64_t n, int workers, Fn&& fn) {
    if (n <= 0) return;
    const int count = static_cast<int>(std::min<int64_t>(workers, n));
    std::atomic<int64_t> next{0};
    auto body = [&](int worker) {
        for (;;) {
            const int64_t i = next.fetch_add(1, std::memory_order_relaxed);
            if (i >= n) break;
            fn(i, worker);
        }
    };
    std::vector<std::thread> threads;
    threads.reserve(count > 0 ? count - 1 : 0);
    for (int w = 1; w < count; ++w) threads.emplace_back(body, w);
    body(0);
    for (auto& t : threads) t.join();
}

// ---------------------------------------------------------------------------------------
// libtiff error capture (only the writing thread calls libtiff).

std::mutex g_tiffErrorMutex;
std::string g_tiffError;

void captureTiffError(const char* module, const char* fmt, va_list ap) {
    char text[1024];
    std::vsnprintf(text, sizeof text, fmt, ap);
    std::lock_guard<std::mutex> lock(g_tiffErrorMutex);
    g_tiffError = (module ? std::string(module) + ": " : std::string()) + text;
}
void ignoreTiffWarning(const char*, const char*, va_list) {}

struct TiffHandlerScope {
    TIFFErrorHandler oldError, oldWarning;
    TiffHandlerScope()
        : oldError(TIFFSetErrorHandler(captureTiffError)), oldWarning(TIFFSetWarningHandler(ignoreTiffWarning)) {
        std::lock_guard<std::mutex> lock(g_tiffErrorMutex);
        g_tiffError.clear();
    }
    ~TiffHandlerScope() {
        TIFFSetErrorHandler(oldError);
        TIFFSetWarningHandler(oldWarning);
    }
    static std::string last() {
        std::lock_guard<std::mutex> lock(g_tiffErrorMutex);
        return g_tiffError.empty() ? std::string("unknown libtiff error") : g_tiffError;
    }
};

Result fail(std::string message) { return Result{false, std::move(message)}; }

struct Level {
    int64_t width = 0, height = 0;
    int64_t tilesX = 0, tilesY = 0;
    // Reduced levels: the band (one row of tiles) being assembled from the level above.
    std::vector<uint8_t> band;
    size_t bandPitch = 0;
    std::vector<uint8_t> bandGlass; // per tile of the band: all children were glass
    int64_t bandRow = 0;
    std::vector<uint8_t> glassPixels; // T x T x 3 glass tile of this level
    std::vector<uint8_t> glassJpeg;
    std::vector<std::vector<uint8_t>> tiles; // encoded tiles (reduced levels); empty = glass
};

void fillBandWithGlass(Level& L) {
    for (int y = 0; y < T; ++y) {
        uint8_t* row = L.band.data() + y * L.bandPitch;
        for (int64_t tx = 0; tx < L.tilesX; ++tx)
            std::memcpy(row + tx * T * 3, &L.glassPixels[static_cast<size_t>(y) * T * 3], T * 3);
    }
    std::fill(L.bandGlass.begin(), L.bandGlass.end(), uint8_t{1});
}

bool setDirectoryFields(TIFF* tif, const Level& L, int levelIndex, const Options& o) {
    const double resolution = 10000.0 / kMicronsPerPixel / std::ldexp(1.0, levelIndex); // px/cm
    bool ok = true;
    ok &= TIFFSetField(tif, TIFFTAG_SUBFILETYPE, levelIndex == 0 ? 0 : FILETYPE_REDUCEDIMAGE) == 1;
    ok &= TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, static_cast<uint32_t>(L.width)) == 1;
    ok &= TIFFSetField(tif, TIFFTAG_IMAGELENGTH, static_cast<uint32_t>(L.height)) == 1;
    ok &= TIFFSetField(tif, TIFFTAG_TILEWIDTH, static_cast<uint32_t>(T)) == 1;
    ok &= TIFFSetField(tif, TIFFTAG_TILELENGTH, static_cast<uint32_t>(T)) == 1;
    ok &= TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, 8) == 1;
    ok &= TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, 3) == 1;
    ok &= TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG) == 1;
    ok &= TIFFSetField(tif, TIFFTAG_COMPRESSION, COMPRESSION_JPEG) == 1;
    ok &= TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_YCBCR) == 1;
    ok &= TIFFSetField(tif, TIFFTAG_YCBCRSUBSAMPLING, 2, 2) == 1;
    ok &= TIFFSetField(tif, TIFFTAG_XRESOLUTION, resolution) == 1;
    ok &= TIFFSetField(tif, TIFFTAG_YRESOLUTION, resolution) == 1;
    ok &= TIFFSetField(tif, TIFFTAG_RESOLUTIONUNIT, RESUNIT_CENTIMETER) == 1;
    ok &= TIFFSetField(tif, TIFFTAG_SOFTWARE, "iris-sample (Iris View)") == 1;
    if (levelIndex == 0) {
        char description[160];
        std::snprintf(description, sizeof description, "Iris View sample slide, seed %llu, 40x, %.2f mpp, quality %d",
                      static_cast<unsigned long long>(o.seed), kMicronsPerPixel, o.quality);
        ok &= TIFFSetField(tif, TIFFTAG_IMAGEDESCRIPTION, description) == 1;
        if (!o.iccProfile.empty())
            ok &= TIFFSetField(tif, TIFFTAG_ICCPROFILE, static_cast<uint32_t>(o.iccProfile.size()), o.iccProfile.data()) == 1;
    }
    return ok;
}

} // namespace

// ---------------------------------------------------------------------------------------

Result validateOptions(const Options& o) {
    if (o.width < 1 || o.width > kMaxDimension)
        return fail("width must be between 1 and " + std::to_string(kMaxDimension) + " (got " +
                    std::to_string(o.width) + ")");
    if (o.height < 1 || o.height > kMaxDimension)
        return fail("height must be between 1 and " + std::to_string(kMaxDimension) + " (got " +
                    std::to_string(o.height) + ")");
    if (o.quality < 1 || o.quality > 100)
        return fail("quality must be between 1 and 100 (got " + std::to_string(o.quality) + ")");
    if (o.outPath.empty()) return fail("output path is empty");
    if (o.threads < 0) return fail("thread count must not be negative");
    return Result{true, {}};
}

std::vector<LevelInfo> pyramidLevels(int64_t width, int64_t height) {
    std::vector<LevelInfo> levels;
    if (width < 1 || height < 1) return levels;
    levels.push_back({width, height});
    while (levels.back().width > T || levels.back().height > T) {
        const LevelInfo& p = levels.back();
        levels.push_back({(p.width + 1) / 2, (p.height + 1) / 2});
    }
    return levels;
}

bool generateTile(const Options& o, int64_t tileX, int64_t tileY, std::vector<uint8_t>& rgb) {
    if (!validateOptions(o).ok) return false;
    if (tileX < 0 || tileY < 0 || tileX * T >= o.width || tileY * T >= o.height) return false;
    const auto scene = makeScene(o.seed, o.width, o.height);
    TileScratch scratch;
    rgb.resize(static_cast<size_t>(T) * T * 3);
    renderTile(*scene, tileX * T, tileY * T, rgb.data(), static_cast<size_t>(T) * 3, scratch);
    return true;
}

bool isGlassTile(const Options& o, int64_t tileX, int64_t tileY) {
    if (!validateOptions(o).ok) return false;
    const auto scene = makeScene(o.seed, o.width, o.height);
    float grid[kGridN * kGridN];
    return fieldGrid(*scene, tileX * T, tileY * T, grid);
}

Result writeSampleSlide(const Options& o, const ProgressCallback& progress) {
    if (Result r = validateOptions(o); !r.ok) return r;
    const int workers = o.threads > 0 ? o.threads : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
    const auto scene = makeScene(o.seed, o.width, o.height);
    const auto infos = pyramidLevels(o.width, o.height);
    const int levelCount = static_cast<int>(infos.size());

    std::vector<Level> levels(infos.size());
    int64_t totalTiles = 0;
    for (int i = 0; i < levelCount; ++i) {
        Level& L = levels[i];
        L.width = infos[i].width;
        L.height = infos[i].height;
        L.tilesX = (L.width + T - 1) / T;
        L.tilesY = (L.height + T - 1) / T;
        totalTiles += L.tilesX * L.tilesY;
    }

    // Glass tiles of every level: level 0 from the scene, each further level the 2x box
    // filter of four copies of the one above.
    std::vector<Encoder> encoders(static_cast<size_t>(workers));
    for (const Encoder& e : encoders)
        if (!e.ok()) return fail("cannot initialise the TurboJPEG encoder");
    std::string error;
    for (int i = 0; i < levelCount; ++i) {
        Level& L = levels[i];
        L.glassPixels.resize(static_cast<size_t>(T) * T * 3);
        if (i == 0) {
            L.glassPixels = scene->glass;
        } else {
            const auto& up = levels[i - 1].glassPixels;
            for (int q = 0; q < 4; ++q) {
                uint8_t* dst = L.glassPixels.data() + ((q / 2) * (T / 2) * T + (q % 2) * (T / 2)) * 3;
                downsampleTile(up.data(), T * 3, dst, T * 3);
            }
        }
        if (!encoders[0].encode(L.glassPixels.data(), T * 3, o.quality, L.glassJpeg, error)) return fail(error);
        if (i > 0) {
            L.bandPitch = static_cast<size_t>(L.tilesX) * T * 3;
            L.band.resize(L.bandPitch * T);
            L.bandGlass.assign(static_cast<size_t>(L.tilesX), 1);
            L.tiles.resize(static_cast<size_t>(L.tilesX * L.tilesY));
            fillBandWithGlass(L);
        }
    }

    // Classic TIFF unless the file could pass 4 GiB (bound: 2 bytes a pixel of JPEG data,
    // far above what 4:2:0 at any sane quality produces).
    const double bound = static_cast<double>(totalTiles) * T * T * 2.0 + 1e6;
    const bool bigTiff = bound > 4.0e9;

    TiffHandlerScope handlers;
    errno = 0;
    TIFF* tif = TIFFOpen(o.outPath.c_str(), bigTiff ? "w8" : "w");
    if (!tif) {
        const int err = errno;
        return fail("cannot create '" + o.outPath +
                    "': " + (err ? std::string(std::strerror(err)) : TiffHandlerScope::last()));
    }
    auto abandon = [&](const std::string& message) {
        TIFFClose(tif);
        std::remove(o.outPath.c_str());
        return fail(message);
    };

    if (!setDirectoryFields(tif, levels[0], 0, o))
        return abandon("cannot set TIFF fields: " + TiffHandlerScope::last());

    struct Pending {
        std::vector<uint8_t> jpeg;
        bool glass = false;
        bool failed = false;
        std::string error;
    };
    std::vector<Pending> row0(static_cast<size_t>(levels[0].tilesX));
    std::vector<std::vector<uint8_t>> tileBuffers(static_cast<size_t>(workers),
                                                  std::vector<uint8_t>(static_cast<size_t>(T) * T * 3));
    std::vector<TileScratch> scratches(static_cast<size_t>(workers));
    int64_t tilesDone = 0;
    bool anyFailure = false;
    std::string failure;

    // Finishes the current band of reduced level li: encodes its tiles and feeds level li+1.
    std::function<void(int)> finishBand = [&](int li) {
        Level& L = levels[li];
        const bool hasNext = li + 1 < levelCount;
        Level* N = hasNext ? &levels[li + 1] : nullptr;
        const int64_t by = L.bandRow;
        std::vector<Pending> pend(static_cast<size_t>(L.tilesX));
        parallelFor(L.tilesX, workers, [&](int64_t tx, int worker) {
            const uint8_t* src = L.band.data() + tx * T * 3;
            Pending& p = pend[static_cast<size_t>(tx)];
            p.glass = L.bandGlass[static_cast<size_t>(tx)] != 0;
            if (!p.glass && !encoders[worker].encode(src, L.bandPitch, o.quality, p.jpeg, p.error)) p.failed = true;
            if (N) {
                uint8_t* dst = N->band.data() + (by & 1) * (T / 2) * N->bandPitch + tx * (T / 2) * 3;
                downsampleTile(src, L.bandPitch, dst, N->bandPitch);
            }
        });
        for (int64_t tx = 0; tx < L.tilesX; ++tx) {
            Pending& p = pend[static_cast<size_t>(tx)];
            if (p.failed && !anyFailure) {
                anyFailure = true;
                failure = p.error;
            }
            if (N && !p.glass) N->bandGlass[static_cast<size_t>(tx / 2)] = 0;
            L.tiles[static_cast<size_t>(by * L.tilesX + tx)] = std::move(p.jpeg);
        }
        tilesDone += L.tilesX;
        fillBandWithGlass(L);
        ++L.bandRow;
        if (N && ((by & 1) == 1 || by == L.tilesY - 1)) finishBand(li + 1);
    };

    Level& L0 = levels[0];
    Level* L1 = levelCount > 1 ? &levels[1] : nullptr;
    for (int64_t ty = 0; ty < L0.tilesY && !anyFailure; ++ty) {
        parallelFor(L0.tilesX, workers, [&](int64_t tx, int worker) {
            uint8_t* buf = tileBuffers[static_cast<size_t>(worker)].data();
            Pending& p = row0[static_cast<size_t>(tx)];
            p.jpeg.clear();
            p.glass = renderTile(*scene, tx * T, ty * T, buf, T * 3, scratches[static_cast<size_t>(worker)]);
            if (!p.glass && !encoders[worker].encode(buf, T * 3, o.quality, p.jpeg, p.error)) p.failed = true;
            if (L1) {
                uint8_t* dst = L1->band.data() + (ty & 1) * (T / 2) * L1->bandPitch + tx * (T / 2) * 3;
                downsampleTile(buf, T * 3, dst, L1->bandPitch);
            }
        });
        for (int64_t tx = 0; tx < L0.tilesX; ++tx) {
            Pending& p = row0[static_cast<size_t>(tx)];
            if (p.failed) return abandon(p.error);
            if (L1 && !p.glass) L1->bandGlass[static_cast<size_t>(tx / 2)] = 0;
            const std::vector<uint8_t>& bytes = p.glass ? L0.glassJpeg : p.jpeg;
            const auto index = static_cast<uint32_t>(ty * L0.tilesX + tx);
            if (TIFFWriteRawTile(tif, index, const_cast<uint8_t*>(bytes.data()), static_cast<tmsize_t>(bytes.size())) <
                0)
                return abandon("cannot write '" + o.outPath + "': " + TiffHandlerScope::last());
        }
        tilesDone += L0.tilesX;
        if (L1 && ((ty & 1) == 1 || ty == L0.tilesY - 1)) finishBand(1);
        if (progress) progress(static_cast<double>(tilesDone) / static_cast<double>(totalTiles));
    }
    if (anyFailure) return abandon(failure);

    for (int li = 0; li < levelCount; ++li) {
        Level& L = levels[li];
        if (li > 0) {
            if (!setDirectoryFields(tif, L, li, o))
                return abandon("cannot set TIFF fields: " + TiffHandlerScope::last());
            for (int64_t i = 0; i < L.tilesX * L.tilesY; ++i) {
                std::vector<uint8_t>& t = L.tiles[static_cast<size_t>(i)];
                const std::vector<uint8_t>& bytes = t.empty() ? L.glassJpeg : t;
                if (TIFFWriteRawTile(tif, static_cast<uint32_t>(i), const_cast<uint8_t*>(bytes.data()),
                                     static_cast<tmsize_t>(bytes.size())) < 0)
                    return abandon("cannot write '" + o.outPath + "': " + TiffHandlerScope::last());
                std::vector<uint8_t>().swap(t);
            }
        }
        if (!TIFFWriteDirectory(tif)) return abandon("cannot write '" + o.outPath + "': " + TiffHandlerScope::last());
    }
    // TIFFClose flushes; check the stream state through TIFFFlush first.
    if (!TIFFFlush(tif)) return abandon("cannot write '" + o.outPath + "': " + TiffHandlerScope::last());
    TIFFClose(tif);
    if (progress) progress(1.0);

    char summary[256];
    std::snprintf(summary, sizeof summary, "wrote %s: %lld x %lld, %d levels, seed %llu%s", o.outPath.c_str(),
                  static_cast<long long>(o.width), static_cast<long long>(o.height), levelCount,
                  static_cast<unsigned long long>(o.seed), bigTiff ? " (BigTIFF)" : "");
    return Result{true, summary};
}

} // namespace iris::sample
