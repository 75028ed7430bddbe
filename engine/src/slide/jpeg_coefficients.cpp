#include "slide/jpeg_coefficients.h"

#include <csetjmp>
#include <cstdio>
#include <algorithm>
#include <bit>
#include <cstring>
#include <new>
#include <string>

#include <jpeglib.h>

#include "slide/libjpeg_errors.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace iris {

namespace {

using ErrorManager = libjpeg::Errors;

enum Outcome { Read = 0, Corrupt = 1, Unsupported = 2 };

// The mask of a block's non-zero coefficients (bit k: natural-order coefficient k).
inline uint64_t nonZeroMask(const int16_t* c) {
#if defined(__SSE2__)
    // Sixteen coefficients at a time: compare with zero, narrow to bytes, take the byte signs.
    const __m128i zero = _mm_setzero_si128();
    uint64_t mask = 0;
    for (int i = 0; i < 4; ++i) {
        const __m128i a = _mm_cmpeq_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(c + 16 * i)), zero);
        const __m128i b = _mm_cmpeq_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(c + 16 * i + 8)), zero);
        const uint32_t zeros = uint32_t(_mm_movemask_epi8(_mm_packs_epi16(a, b)));
        mask |= uint64_t(~zeros & 0xffffu) << (16 * i);
    }
    return mask;
#else
    uint64_t mask = 0;
    for (int k = 0; k < 64; ++k) mask |= uint64_t(c[k] != 0) << k;
    return mask;
#endif
}

// Packs one block (jpegblocks): its table entry at `entry`, its values at `table + cursor`,
// `cursor` moved past them; false when they do not fit `capacity` words from `table`.
inline bool packBlock(const int16_t* c, uint32_t* entry, uint32_t* table, uint64_t& cursor, uint64_t capacity) {
    uint64_t mask = nonZeroMask(c);
    const uint32_t n = uint32_t(std::popcount(mask));
    const uint64_t words = (n + 1) / 2;
    if (cursor + words > capacity) return false;
    entry[0] = uint32_t(mask);
    entry[1] = uint32_t(mask >> 32);
    entry[2] = uint32_t(cursor);
    uint32_t* out = table + cursor;
    for (uint32_t i = 0; mask; ++i, mask &= mask - 1) {
        const uint32_t v = uint16_t(c[std::countr_zero(mask)]);
        if (i & 1) out[i >> 1] |= v << 16;
        else out[i >> 1] = v;
    }
    cursor += words;
    return true;
}

// The result's vector sized for `values` coefficients, or null when there is no memory for it.
int16_t* denseBlocks(JpegCoefficients* out, size_t values) {
    try {
        out->blocks.resize(values);
    } catch (const std::bad_alloc&) {
        return nullptr;
    }
    return out->blocks.data();
}

// Where the blocks go: the result's vector (dst null), or packed into the caller's memory.
struct Sink {
    JpegCoefficients* out;
    uint32_t* dst;
    uint64_t capacity; // words
};

// The part between setjmp and the end: no C++ object with a destructor lives in this frame
// (longjmp would skip it). The blocks' vector is the caller's; denseBlocks sizes it and turns a
// failed allocation into a null pointer, so no exception crosses the jump either.
int read(jpeg_decompress_struct* cinfo, ErrorManager* err, const uint8_t* data, size_t size, int width, int height,
         JpegColour colour, Sink* sink) {
    JpegCoefficients* out = sink->out;
    if (setjmp(err->jump)) return Corrupt;
    jpeg_create_decompress(cinfo);
    jpeg_mem_src(cinfo, data, static_cast<unsigned long>(size));
    if (jpeg_read_header(cinfo, TRUE) != JPEG_HEADER_OK) {
        std::snprintf(err->message, sizeof err->message, "no JPEG image in the stream");
        return Corrupt;
    }
    if (int(cinfo->image_width) != width || int(cinfo->image_height) != height) {
        std::snprintf(err->message, sizeof err->message, "the JPEG is %ux%u pixels, expected %dx%d",
                      unsigned(cinfo->image_width), unsigned(cinfo->image_height), width, height);
        return Corrupt;
    }
    if (cinfo->data_precision != 8) {
        std::snprintf(err->message, sizeof err->message, "%d-bit samples", cinfo->data_precision);
        return Unsupported;
    }
    const int n = cinfo->num_components;
    if (n != 1 && n != 3) {
        std::snprintf(err->message, sizeof err->message, "%d components", n);
        return Unsupported;
    }
    if (colour != JpegColour::Auto && n != 3) {
        std::snprintf(err->message, sizeof err->message, "the JPEG has %d components, expected 3", n);
        return Corrupt;
    }
    J_COLOR_SPACE space = cinfo->jpeg_color_space;
    if (colour == JpegColour::YCbCr) space = JCS_YCbCr;
    if (colour == JpegColour::Rgb) space = JCS_RGB;
    if (n == 1) {
        out->transform = JpegCoefficients::Transform::Grey;
    } else if (space == JCS_YCbCr) {
        out->transform = JpegCoefficients::Transform::YCbCr;
    } else if (space == JCS_RGB) {
        out->transform = JpegCoefficients::Transform::Rgb;
    } else {
        std::snprintf(err->message, sizeof err->message, "colour space %d", int(space));
        return Unsupported;
    }
    const jpeg_component_info* c = cinfo->comp_info;
    if (n == 3) {
        const bool chroma11 = c[1].h_samp_factor == 1 && c[1].v_samp_factor == 1 && c[2].h_samp_factor == 1 &&
                              c[2].v_samp_factor == 1;
        const int h = c[0].h_samp_factor, v = c[0].v_samp_factor;
        // 4:4:4, 4:2:2 and 4:2:0; libjpeg's fancy upsampling (the one the GPU repeats) needs a
        // downsampled row of more than two samples.
        const bool layout = chroma11 && ((h == 1 && v == 1) || (h == 2 && v == 1) || (h == 2 && v == 2));
        if (!layout || (h == 2 && (cinfo->image_width + 1) / 2 <= 2)) {
            std::snprintf(err->message, sizeof err->message, "sampling %dx%d,%dx%d,%dx%d", h, v, c[1].h_samp_factor,
                          c[1].v_samp_factor, c[2].h_samp_factor, c[2].v_samp_factor);
            return Unsupported;
        }
        out->hMax = uint32_t(h);
        out->vMax = uint32_t(v);
    }
    if (sink->dst) {
        // Blocks a component has (libjpeg's width_in_blocks × height_in_blocks, from the frame
        // header): a stream whose blocks' table alone will not fit the caller's room is
        // refused before the entropy decode, so that the caller's fallback does not pay for
        // two decodes.
        int hMax = 1, vMax = 1;
        for (int ci = 0; ci < n; ++ci) {
            hMax = std::max(hMax, c[ci].h_samp_factor);
            vMax = std::max(vMax, c[ci].v_samp_factor);
        }
        uint64_t predicted = 0;
        for (int ci = 0; ci < n; ++ci) {
            const uint64_t wide = (uint64_t(cinfo->image_width) * c[ci].h_samp_factor + uint64_t(hMax) * 8 - 1) / (uint64_t(hMax) * 8);
            const uint64_t high = (uint64_t(cinfo->image_height) * c[ci].v_samp_factor + uint64_t(vMax) * 8 - 1) / (uint64_t(vMax) * 8);
            predicted += wide * high;
        }
        if (predicted * jpegblocks::kTableWords > sink->capacity) {
            std::snprintf(err->message, sizeof err->message, "no room for %llu blocks", static_cast<unsigned long long>(predicted));
            return Unsupported;
        }
    }
    jvirt_barray_ptr* arrays = jpeg_read_coefficients(cinfo);
    size_t total = 0;
    for (int ci = 0; ci < n; ++ci) {
        if (!c[ci].quant_table) {
            std::snprintf(err->message, sizeof err->message, "component %d has no quantisation table", ci);
            return Corrupt;
        }
        out->comp[ci].blocksWide = c[ci].width_in_blocks;
        out->comp[ci].blocksHigh = c[ci].height_in_blocks;
        out->comp[ci].firstBlock = uint32_t(total);
        for (int k = 0; k < 64; ++k) out->comp[ci].quant[k] = c[ci].quant_table->quantval[k];
        total += size_t(c[ci].width_in_blocks) * c[ci].height_in_blocks;
    }
    if (total > (1u << 26)) {
        std::snprintf(err->message, sizeof err->message, "%zu blocks", total);
        return Corrupt;
    }
    out->blocksTotal = uint32_t(total);
    if (sink->dst) {
        // Packed straight from libjpeg's rows: the table first, each block's values after it.
        uint64_t cursor = total * jpegblocks::kTableWords;
        if (cursor > sink->capacity || sink->capacity > 0xffffffffu) {
            std::snprintf(err->message, sizeof err->message, "no room for %zu blocks", total);
            return Unsupported;
        }
        uint32_t* entry = sink->dst;
        for (int ci = 0; ci < n; ++ci) {
            for (JDIMENSION row = 0; row < c[ci].height_in_blocks; ++row) {
                JBLOCKARRAY line = (*cinfo->mem->access_virt_barray)(reinterpret_cast<j_common_ptr>(cinfo), arrays[ci],
                                                                     row, 1, FALSE);
                static_assert(sizeof(JCOEF) == sizeof(int16_t));
                for (JDIMENSION bx = 0; bx < c[ci].width_in_blocks; ++bx, entry += jpegblocks::kTableWords) {
                    if (!packBlock(line[0][bx], entry, sink->dst, cursor, sink->capacity)) {
                        std::snprintf(err->message, sizeof err->message,
                                      "coefficients beyond the room's %llu words (too few of them zero)",
                                      static_cast<unsigned long long>(sink->capacity));
                        return Unsupported;
                    }
                }
            }
        }
        out->packedWords = cursor;
    } else {
        int16_t* dst = denseBlocks(out, total * 64);
        if (!dst) {
            std::snprintf(err->message, sizeof err->message, "no memory for %zu blocks", total);
            return Corrupt;
        }
        for (int ci = 0; ci < n; ++ci) {
            const JDIMENSION wide = c[ci].width_in_blocks;
            for (JDIMENSION row = 0; row < c[ci].height_in_blocks; ++row) {
                JBLOCKARRAY line = (*cinfo->mem->access_virt_barray)(reinterpret_cast<j_common_ptr>(cinfo), arrays[ci],
                                                                     row, 1, FALSE);
                std::memcpy(dst, line[0], size_t(wide) * sizeof(JBLOCK));
                dst += size_t(wide) * 64;
            }
        }
    }
    jpeg_finish_decompress(cinfo);
    return Read;
}

} // namespace

Expected<JpegCoefficients> readJpegCoefficients(const uint8_t* data, size_t size, int width, int height,
                                                JpegColour colour) {
    return readJpegCoefficients(data, size, width, height, colour, nullptr, 0);
}

Expected<JpegCoefficients> readJpegCoefficients(const uint8_t* data, size_t size, int width, int height,
                                                JpegColour colour, uint32_t* dst, uint64_t capacity) {
    if (!data || size == 0) return Result(Status::CorruptData, "the JPEG stream is empty");
    if (size > 0xffffffffu) return Result(Status::CorruptData, "the JPEG stream is too large");
    if (width <= 0 || height <= 0) return Result(Status::InvalidArgument, "bad size for the JPEG read");
    JpegCoefficients out;
    out.width = uint32_t(width);
    out.height = uint32_t(height);
    jpeg_decompress_struct cinfo{};
    ErrorManager err{};
    libjpeg::install(cinfo, err);
    Sink sink{&out, dst, capacity};
    const int outcome = read(&cinfo, &err, data, size, width, height, colour, &sink);
    if (outcome == Read) out.components = uint32_t(cinfo.num_components);
    jpeg_destroy_decompress(&cinfo);
    if (outcome == Corrupt) return Result(Status::CorruptData, std::string("the JPEG data is corrupt (") + err.message + ")");
    if (outcome == Unsupported)
        return Result(Status::UnsupportedFormat, std::string("the GPU JPEG path does not take ") + err.message);
    return out;
}

namespace jpegblocks {

uint64_t packedWords(const int16_t* blocks, uint32_t count) {
    uint64_t words = uint64_t(count) * kTableWords;
    for (uint32_t b = 0; b < count; ++b) words += (uint32_t(std::popcount(nonZeroMask(blocks + size_t(b) * 64))) + 1) / 2;
    return words;
}

uint64_t pack(const int16_t* blocks, uint32_t count, uint32_t* dst, uint64_t capacity) {
    uint64_t cursor = uint64_t(count) * kTableWords;
    if (cursor > capacity || capacity > 0xffffffffu) return 0;
    for (uint32_t b = 0; b < count; ++b)
        if (!packBlock(blocks + size_t(b) * 64, dst + size_t(b) * kTableWords, dst, cursor, capacity)) return 0;
    return cursor;
}

bool valid(const uint32_t* packed, uint32_t count, uint64_t words) {
    const uint64_t first = uint64_t(count) * kTableWords;
    if (first > words) return false;
    for (uint32_t b = 0; b < count; ++b) {
        const uint32_t* e = packed + size_t(b) * kTableWords;
        const uint64_t n = uint64_t(std::popcount(e[0])) + uint64_t(std::popcount(e[1]));
        if (e[2] < first || e[2] + (n + 1) / 2 > words) return false;
    }
    return true;
}

} // namespace jpegblocks

namespace jpegrecord {

Result write(const uint8_t* data, size_t size, int width, int height, JpegColour colour, int validWidth, int validHeight,
             uint8_t* record) {
    auto* words = reinterpret_cast<uint32_t*>(record);
    Expected<JpegCoefficients> c =
        readJpegCoefficients(data, size, width, height, colour, words + kBlocksWord, uint64_t(kWords - kBlocksWord));
    if (!c) return c.error(); // too many coefficients for a record: UnsupportedFormat, a layout the path does not take
    std::memset(words, 0, size_t(kBlocksWord) * 4);
    words[0] = kMagic;
    words[1] = c->width;
    words[2] = c->height;
    words[3] = uint32_t(std::clamp(validWidth, 1, width));
    words[4] = uint32_t(std::clamp(validHeight, 1, height));
    words[5] = uint32_t(c->transform);
    words[6] = c->hMax;
    words[7] = c->vMax;
    words[8] = c->components;
    words[9] = c->blockCount();
    for (uint32_t i = 0; i < c->components; ++i) {
        words[10 + 3 * i] = c->comp[i].blocksWide;
        words[11 + 3 * i] = c->comp[i].blocksHigh;
        words[12 + 3 * i] = c->comp[i].firstBlock;
        for (int q = 0; q < 64; ++q) words[kQuantWord + 64 * i + q] = c->comp[i].quant[q];
    }
    words[kUsedWord] = uint32_t(kBlocksWord + c->packedWords);
    return {};
}

bool header(const uint8_t* record, JpegCoefficients& out, uint32_t& validWidth, uint32_t& validHeight) {
    uint32_t w[kHeaderWords];
    std::memcpy(w, record, sizeof w);
    if (w[0] != kMagic || w[1] == 0 || w[2] == 0 || w[1] > uint32_t(kTileSize) || w[2] > uint32_t(kTileSize) || (w[8] != 1 && w[8] != 3) ||
        w[9] > 3 * 32 * 32 || w[5] > 2 || w[kUsedWord] > kWords || w[kUsedWord] < kBlocksWord + uint64_t(w[9]) * jpegblocks::kTableWords)
        return false;
    out = JpegCoefficients{};
    out.width = w[1];
    out.height = w[2];
    validWidth = w[3];
    validHeight = w[4];
    out.transform = JpegCoefficients::Transform(w[5]);
    out.hMax = w[6];
    out.vMax = w[7];
    out.components = w[8];
    out.blocksTotal = w[9];
    // What the shaders index by must hold together: each component's blocks follow the
    // previous one's, within a 256×256 tile's 32×32 blocks, adding up to the total.
    if (out.hMax < 1 || out.hMax > 2 || out.vMax < 1 || out.vMax > 2 || validWidth < 1 || validWidth > out.width ||
        validHeight < 1 || validHeight > out.height)
        return false;
    uint32_t next = 0;
    for (uint32_t i = 0; i < out.components; ++i) {
        JpegCoefficients::Component& c = out.comp[i];
        c.blocksWide = w[10 + 3 * i];
        c.blocksHigh = w[11 + 3 * i];
        c.firstBlock = w[12 + 3 * i];
        if (c.firstBlock != next || c.blocksWide == 0 || c.blocksHigh == 0 || c.blocksWide > 32 || c.blocksHigh > 32 ||
            c.blocksWide * 8 * (i == 0 ? 1 : out.hMax) < out.width || c.blocksHigh * 8 * (i == 0 ? 1 : out.vMax) < out.height)
            return false;
        next += c.blocksWide * c.blocksHigh;
    }
    if (next != out.blocksTotal) return false;
    out.packedWords = w[kUsedWord] - kBlocksWord;
    return true;
}

} // namespace jpegrecord

} // namespace iris
