#include "overlay/font.h"

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <fontconfig/fontconfig.h>
#include <ft2build.h>
#include FT_FREETYPE_H

namespace iris::overlay {

namespace {

constexpr uintmax_t kMaxFontBytes = 64ull << 20; // larger is not a font we want to hold in RAM

std::string ftErrorText(FT_Error e) {
    if (const char* s = FT_Error_String(e)) return s;
    char buf[32];
    std::snprintf(buf, sizeof buf, "FreeType error 0x%02X", unsigned(e));
    return buf;
}

// FreeType's own check: a face it can open from the bytes, scalable, with the digits every
// label needs. A library of its own: FT_Library is not thread-safe and this runs on API threads.
Result validate(const std::string& path, const std::vector<uint8_t>& bytes) {
    FT_Library lib = nullptr;
    if (FT_Error e = FT_Init_FreeType(&lib)) return Result(Status::OutOfMemory, "FreeType: " + ftErrorText(e));
    FT_Face face = nullptr;
    Result r;
    if (FT_Error e = FT_New_Memory_Face(lib, bytes.data(), FT_Long(bytes.size()), 0, &face)) {
        r = Result(e == FT_Err_Unknown_File_Format ? Status::UnsupportedFormat : Status::CorruptData,
                   "'" + path + "' is not a font FreeType can read (" + ftErrorText(e) + ")");
    } else if (!FT_IS_SCALABLE(face)) {
        r = Result(Status::UnsupportedFormat,
                   "'" + path + "' is a bitmap-only font; overlay text needs a scalable (outline) font");
    } else if (FT_Get_Char_Index(face, '0') == 0) {
        r = Result(Status::UnsupportedFormat, "'" + path + "' has no digits; overlay text needs them");
    }
    if (face) FT_Done_Face(face);
    FT_Done_FreeType(lib);
    return r;
}

} // namespace

Expected<std::shared_ptr<const FontData>> loadFontFile(const std::string& path) {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::file_status st = fs::status(path, ec);
    if (path.empty() || !fs::exists(st)) return Result(Status::NotFound, "Font file '" + path + "' does not exist");
    if (!fs::is_regular_file(st)) return Result(Status::NotAFile, "Font path '" + path + "' is not a regular file");
    const uintmax_t size = fs::file_size(path, ec);
    if (ec) return Result(Status::IoError, "Cannot read font file '" + path + "': " + ec.message());
    if (size == 0) return Result(Status::CorruptData, "Font file '" + path + "' is empty");
    if (size > kMaxFontBytes) return Result(Status::UnsupportedFormat, "Font file '" + path + "' is larger than 64 MiB");
    auto font = std::make_shared<FontData>();
    font->path = path;
    font->bytes.resize(size_t(size));
    std::ifstream in(path, std::ios::binary);
    if (!in.read(reinterpret_cast<char*>(font->bytes.data()), std::streamsize(size)))
        return Result(Status::IoError, "Cannot read font file '" + path + "'");
    if (Result r = validate(path, font->bytes); !r.ok()) return r;
    static std::atomic<uint64_t> nextId{1}; // unique ids only: relaxed
    font->id = nextId.fetch_add(1, std::memory_order_relaxed);
    return std::shared_ptr<const FontData>(std::move(font));
}

Expected<std::string> findDefaultFontFile() {
    // A configuration of our own (not FcInit's process-wide one): nothing stays behind and
    // nothing is shared with a host that uses fontconfig itself.
    FcConfig* config = FcInitLoadConfigAndFonts();
    if (!config) return Result(Status::NotFound, "fontconfig could not load its configuration; no overlay font");
    FcPattern* pattern = FcNameParse(reinterpret_cast<const FcChar8*>(kDefaultFontFamily));
    std::string file;
    if (pattern) {
        FcPatternAddBool(pattern, FC_SCALABLE, FcTrue);
        FcConfigSubstitute(config, pattern, FcMatchPattern);
        FcDefaultSubstitute(pattern);
        FcResult result = FcResultNoMatch;
        if (FcPattern* match = FcFontMatch(config, pattern, &result)) {
            FcChar8* f = nullptr;
            if (FcPatternGetString(match, FC_FILE, 0, &f) == FcResultMatch && f) file = reinterpret_cast<const char*>(f);
            FcPatternDestroy(match);
        }
        FcPatternDestroy(pattern);
    }
    FcConfigDestroy(config);
    if (file.empty()) {
        return Result(Status::NotFound, std::string("fontconfig found no font for '") + kDefaultFontFamily +
                                            "' (install fonts-dejavu-core, or give a font file to setOverlayFont)");
    }
    return file;
}

} // namespace iris::overlay
