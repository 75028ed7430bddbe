#include "overlay/glyph_cache.h"

#include <cmath>
#include <cstring>

#include <ft2build.h>
#include FT_FREETYPE_H

namespace iris::overlay {

GlyphCache::~GlyphCache() {
    if (face_) FT_Done_Face(face_);
    if (lib_) FT_Done_FreeType(lib_);
}

Result GlyphCache::init() {
    if (FT_Init_FreeType(&lib_) != 0) {
        lib_ = nullptr;
        return Result(Status::OutOfMemory, "FreeType could not be initialised");
    }
    return {};
}

Result GlyphCache::setFont(const std::shared_ptr<const FontData>& font) {
    if (fontId() == (font ? font->id : 0) && (face_ != nullptr) == (font != nullptr)) return {};
    if (face_) FT_Done_Face(face_);
    face_ = nullptr;
    font_.reset();
    facePixelSize_ = 0;
    clear();
    if (!font || !lib_) return {};
    FT_Face face = nullptr;
    if (FT_Error e = FT_New_Memory_Face(lib_, font->bytes.data(), FT_Long(font->bytes.size()), 0, &face)) {
        const char* text = FT_Error_String(e);
        return Result(Status::CorruptData, "FreeType cannot open '" + font->path + "': " +
                                               (text ? text : "error " + std::to_string(int(e))));
    }
    face_ = face;
    font_ = font;
    return {};
}

void GlyphCache::clear() {
    glyphs_.clear();
    shelfX_ = shelfY_ = shelfH_ = 0;
    full_ = false;
    clearUploads();
}

void GlyphCache::clearUploads() {
    uploads_.clear();
    pending_.clear();
}

const Glyph* GlyphCache::glyph(char32_t c, int pixelSize) {
    const uint64_t key = (uint64_t(uint32_t(pixelSize)) << 32) | uint64_t(c);
    if (auto it = glyphs_.find(key); it != glyphs_.end()) return &it->second;
    if (full_) return nullptr;
    if (facePixelSize_ != pixelSize) {
        if (FT_Set_Pixel_Sizes(face_, 0, FT_UInt(pixelSize)) != 0) return nullptr;
        facePixelSize_ = pixelSize;
    }
    Glyph g;
    // Unhinted: outlines and advances scale linearly with the pixel size, so a label drawn at
    // twice the ratio is the same label at twice the size. Antialiased 8-bit coverage.
    if (FT_Load_Char(face_, FT_ULong(c), FT_LOAD_RENDER | FT_LOAD_NO_HINTING | FT_LOAD_TARGET_NORMAL) == 0) {
        const FT_GlyphSlot slot = face_->glyph;
        const FT_Bitmap& bm = slot->bitmap;
        g.advance = double(slot->linearHoriAdvance) / 65536.0;
        if (bm.pixel_mode == FT_PIXEL_MODE_GRAY && bm.width > 0 && bm.rows > 0) {
            const int w = int(bm.width), h = int(bm.rows);
            if (w + 1 > kAtlasSize || h + 1 > kAtlasSize) return nullptr; // larger than the atlas
            if (shelfX_ + w + 1 > kAtlasSize) { // next shelf (one texel apart: no neighbour can bleed in)
                shelfY_ += shelfH_ + 1;
                shelfX_ = 0;
                shelfH_ = 0;
            }
            if (shelfY_ + h + 1 > kAtlasSize) {
                full_ = true;
                return nullptr;
            }
            g.atlasX = shelfX_;
            g.atlasY = shelfY_;
            g.width = w;
            g.height = h;
            g.left = slot->bitmap_left;
            g.top = slot->bitmap_top;
            shelfX_ += w + 1;
            shelfH_ = std::max(shelfH_, h);
            const size_t offset = pending_.size();
            pending_.resize(offset + size_t(w) * size_t(h));
            for (int y = 0; y < h; ++y) {
                const unsigned char* row = bm.pitch >= 0 ? bm.buffer + ptrdiff_t(y) * bm.pitch
                                                         : bm.buffer + ptrdiff_t(h - 1 - y) * -bm.pitch;
                std::memcpy(pending_.data() + offset + size_t(y) * size_t(w), row, size_t(w));
            }
            uploads_.push_back(GlyphUpload{g.atlasX, g.atlasY, w, h, offset});
        }
    }
    // A glyph FreeType cannot load is remembered as a blank, so it is not tried every frame.
    return &glyphs_.emplace(key, g).first->second;
}

ShapedText GlyphCache::shape(const std::u32string& text, int pixelSize) {
    ShapedText out;
    if (!face_ || pixelSize <= 0) return out;
    double pen = 0;
    for (char32_t c : text) {
        const Glyph* g = glyph(c, pixelSize);
        if (!g) return out; // the atlas is full
        out.glyphs.emplace_back(g, int(std::lround(pen)));
        pen += g->advance;
    }
    const double scale = double(pixelSize) / double(face_->units_per_EM);
    out.width = pen;
    out.ascent = double(face_->ascender) * scale;
    out.descent = -double(face_->descender) * scale;
    out.ok = true;
    return out;
}

} // namespace iris::overlay
