// Fonts for overlay text: a font file read into memory (FreeType faces are made from the
// bytes, so the file is read once, on the thread that asked for it, and the render thread
// never touches the file system), and the system's default sans-serif found through
// fontconfig. Both run on API threads (Engine::setOverlayFont, Engine::setOverlayVisible).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "iris/types.h"

namespace iris::overlay {

// The family asked of fontconfig when the host names no font (Debian: fonts-dejavu-core).
inline constexpr const char* kDefaultFontFamily = "DejaVu Sans";

// A font file's bytes, immutable once loaded and shared by reference: the render thread's
// FreeType face reads from them for as long as it lives.
struct FontData {
    std::string path;
    std::vector<uint8_t> bytes;
    uint64_t id = 0; // unique per load: a new id means "make a new face"
};

// Reads a font file and checks that FreeType can use it for overlay text (a scalable face
// with digits). Errors name the file and the reason.
Expected<std::shared_ptr<const FontData>> loadFontFile(const std::string& path);

// The file fontconfig picks for kDefaultFontFamily (a scalable face), or why there is none.
Expected<std::string> findDefaultFontFile();

} // namespace iris::overlay
