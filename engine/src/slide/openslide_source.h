// SlideSource over OpenSlide: every vendor format OpenSlide reads (Aperio, Hamamatsu,
// Leica, MIRAX, Philips, Sakura, Trestle, Ventana, generic tiled TIFF).
#pragma once

#include <initializer_list>
#include <mutex>
#include <string_view>
#include <vector>

#include "slide/slide_source.h"

typedef struct _openslide openslide_t;

namespace iris {

class OpenSlideSource final : public SlideSource {
public:
    static bool detect(const std::string& path);
    static Expected<std::unique_ptr<SlideSource>> open(const std::string& path);
    // open(), but only a file for which OpenSlide names one of `vendors` ("aperio", …) from its
    // tags or name alone (openslide_detect_vendor); any other is UnsupportedFormat, without
    // being opened. After checkFileForOpenSlide, like every open.
    static Expected<std::unique_ptr<SlideSource>> openAs(const std::string& path,
                                                         std::initializer_list<std::string_view> vendors);
    ~OpenSlideSource() override;

    const SlideInfo& info() const override { return info_; }
    Result readTile(int level, int64_t tx, int64_t ty, uint8_t* dst) override;
    Expected<Image> readAssociatedImage(const std::string& name) override;

private:
    OpenSlideSource(openslide_t* osr, SlideInfo info, std::vector<int32_t> osLevels, std::unique_ptr<PinnedFile> pinned)
        : pinned_(std::move(pinned)), osr_(osr), info_(std::move(info)), osLevels_(std::move(osLevels)) {}
    Result checkError(const char* what) const;

    // A TIFF-based slide as opened (OpenSlide opens more handles by name as threads read);
    // null for formats OpenSlide finds by their names (MIRAX, VMS).
    std::unique_ptr<PinnedFile> pinned_;
    openslide_t* osr_; // thread-safe per OpenSlide's documentation
    // Associated images are read one at a time. OpenSlide is thread-safe, but it hands its TIFF
    // handles and libjpeg's buffers between threads under GLib's futex mutexes, which
    // ThreadSanitizer cannot see (stress.storm under the tsan preset reported the hand-over as
    // a race); a host reads these images once per slide, so serialising them costs nothing.
    mutable std::mutex associatedMutex_;
    SlideInfo info_;
    // OpenSlide's index of each of info_.levels: a level that is not coarser than the one
    // before it is left out of info_, so the two numberings can differ.
    std::vector<int32_t> osLevels_;
};

} // namespace iris
