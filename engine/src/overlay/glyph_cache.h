// The glyph cache: FreeType rasterises overlay glyphs at the pixel size they are drawn at
// (label size × device pixel ratio) into an 8-bit coverage atlas, packed in shelves. It is
// the CPU half of the glyph atlas: it decides where each glyph goes and keeps the bitmaps
// waiting for upload; gpu/overlay_pipeline owns the image they are copied into.
//
// Owned and used by the render thread only (an FT_Library and its faces are not
// thread-safe). The face is made from the bytes of a FontData that the API thread read, so
// nothing here reads a file.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "iris/types.h"
#include "overlay/font.h"

struct FT_LibraryRec_;
struct FT_FaceRec_;

namespace iris::overlay {

struct Glyph {
    int atlasX = 0, atlasY = 0; // the bitmap's top-left texel in the atlas
    int width = 0, height = 0;  // bitmap size (0 for blanks such as the space)
    int left = 0;               // bitmap's left edge relative to the pen
    int top = 0;                // rows of the bitmap above the baseline
    double advance = 0;         // unhinted advance, device pixels
};

// A bitmap waiting to be copied into the atlas: `bytes` of pending() from `offset`, tightly
// packed rows of `width` bytes.
struct GlyphUpload {
    int x = 0, y = 0, width = 0, height = 0;
    size_t offset = 0;
};

// A label laid out at one pixel size: each glyph with its pen position (whole device pixels,
// from the unhinted advances, so that a label at twice the size is twice as wide).
struct ShapedText {
    bool ok = false;         // a font is loaded and every glyph has a place in the atlas
    std::vector<std::pair<const Glyph*, int>> glyphs;
    double width = 0;        // advance width, device pixels
    double ascent = 0;       // the font's ascender and descender at this size, device pixels
    double descent = 0;
};

class GlyphCache {
public:
    static constexpr int kAtlasSize = 1024; // R8 texels a side

    GlyphCache() = default;
    ~GlyphCache();
    GlyphCache(const GlyphCache&) = delete;
    GlyphCache& operator=(const GlyphCache&) = delete;

    Result init();
    // Makes `font` the face labels use (a new face when its id differs; null: no text).
    // Forgets every glyph of the previous face. An error leaves no face.
    Result setFont(const std::shared_ptr<const FontData>& font);
    bool hasFont() const { return face_ != nullptr; }
    uint64_t fontId() const { return font_ ? font_->id : 0; }

    // Shapes (and rasterises, on first use) `text` at pixelSize device pixels. When the
    // atlas is full, ok is false: clear() and shape the frame's labels again.
    ShapedText shape(const std::u32string& text, int pixelSize);
    // Forgets every glyph; the atlas fills again from the top.
    void clear();

    const std::vector<GlyphUpload>& uploads() const { return uploads_; }
    const std::vector<uint8_t>& pending() const { return pending_; }
    void clearUploads();

private:
    const Glyph* glyph(char32_t c, int pixelSize);

    FT_LibraryRec_* lib_ = nullptr;
    FT_FaceRec_* face_ = nullptr;
    std::shared_ptr<const FontData> font_; // the bytes face_ reads from
    int facePixelSize_ = 0;
    std::unordered_map<uint64_t, Glyph> glyphs_; // (pixel size << 32 | code point) → glyph
    int shelfX_ = 0, shelfY_ = 0, shelfH_ = 0;   // shelf packer
    bool full_ = false;
    std::vector<GlyphUpload> uploads_;
    std::vector<uint8_t> pending_;
};

} // namespace iris::overlay
