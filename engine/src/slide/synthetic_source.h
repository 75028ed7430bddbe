// A procedural slide of any size, for tests and benchmarks that need slides no file could
// hold (for example 200000×200000 pixels). Path syntax: "synthetic:WIDTHxHEIGHT", or
// "synthetic:WIDTHxHEIGHT:LEVELS" to store at most LEVELS levels (":1" is a slide without
// reduced levels, for the engine's synthetic levels; see pyramid_source.h).
//
// Pixels are a pure function of level-0 coordinates (a colour ramp, a 256-px checker and a
// fine diagonal pattern), so a test can compute any expected pixel; level k shows the level-0
// pixel at (i·2^k, j·2^k). Levels halve until the longer side is ≤ 512.
#pragma once

#include "slide/slide_source.h"

namespace iris {

class SyntheticSource final : public SlideSource {
public:
    static bool detect(const std::string& path);
    static Expected<std::unique_ptr<SlideSource>> open(const std::string& path);
    // The RGBA of level-0 pixel (x, y).
    static void pixel(int64_t x, int64_t y, uint8_t* rgba);

    const SlideInfo& info() const override { return info_; }
    Result readTile(int level, int64_t tx, int64_t ty, uint8_t* dst) override;
    Expected<Image> readAssociatedImage(const std::string& name) override;

private:
    explicit SyntheticSource(SlideInfo info) : info_(std::move(info)) {}
    SlideInfo info_;
};

} // namespace iris
