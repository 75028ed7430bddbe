// Renders one frame of a slide with the installed engine and checks two pixels: the view is
// centred on the slide's right edge, so the left half shows the slide and the right half the
// background colour, which must come back exactly.
//   engine_consumer SLIDE
#include <cstdio>

#include <iris/engine.h>
#include <iris/version.h>

int main(int argc, char** argv)
{
    if (argc != 2) {
        std::fprintf(stderr, "usage: engine_consumer SLIDE\n");
        return 2;
    }
    iris::EngineConfig config;
    config.background = {1.0f, 0.0f, 1.0f};  // magenta, which no slide pixel here has
    auto engine = iris::Engine::create(config);
    if (!engine) {
        std::fprintf(stderr, "engine_consumer: %s\n", engine.error().message().c_str());
        return 1;
    }
    auto& e = **engine;
    constexpr uint32_t size = 256;
    if (auto r = e.bindOffscreen(size, size); !r) {
        std::fprintf(stderr, "engine_consumer: %s\n", r.message().c_str());
        return 1;
    }
    if (auto r = e.open(argv[1]); !r) {
        std::fprintf(stderr, "engine_consumer: %s\n", r.message().c_str());
        return 1;
    }
    const auto info = e.slideInfo();
    e.setView({.centerX = double(info->width), .centerY = info->height / 2.0, .downsample = 1});
    if (auto r = e.waitForFrame(std::chrono::seconds(60)); !r) {
        std::fprintf(stderr, "engine_consumer: no complete frame: %s\n", r.message().c_str());
        return 1;
    }
    auto frame = e.readFrame();
    if (!frame) {
        std::fprintf(stderr, "engine_consumer: %s\n", frame.error().message().c_str());
        return 1;
    }
    const auto pixel = [&](uint32_t x, uint32_t y) { return &frame->image.rgba[(y * size + x) * 4]; };
    const uint8_t* outside = pixel(size - 8, size / 2);
    const uint8_t* inside = pixel(8, size / 2);
    std::printf("engine_consumer: Iris View %s, slide %lldx%lld, outside %u,%u,%u, inside %u,%u,%u\n",
                IRIS_VIEW_VERSION_STRING, (long long)info->width, (long long)info->height,
                outside[0], outside[1], outside[2], inside[0], inside[1], inside[2]);
    const bool background = outside[0] == 255 && outside[1] == 0 && outside[2] == 255 && outside[3] == 255;
    const bool slide = !(inside[0] == 255 && inside[1] == 0 && inside[2] == 255);
    if (!background || !slide) {
        std::fprintf(stderr, "engine_consumer: wrong pixels (want magenta outside the slide, slide inside)\n");
        return 1;
    }
    return 0;
}
