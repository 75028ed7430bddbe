// tuningFromEnvironment: the one place that knows the IRIS_* variables. Nothing in the engine
// calls it; tools and tests do (iris/environment.h).
#include "iris/environment.h"

#include <cstdlib>
#include <initializer_list>
#include <string>
#include <utility>

namespace iris {

namespace {

// The variable's value, or an empty string when it is unset.
std::string variable(const char* name) {
    const char* v = std::getenv(name);
    return v ? std::string(v) : std::string();
}

template <class T>
Result pick(const char* name, std::initializer_list<std::pair<const char*, T>> values, T& out) {
    const std::string v = variable(name);
    if (v.empty()) return {};
    std::string allowed;
    for (const auto& [text, value] : values) {
        if (v == text) {
            out = value;
            return {};
        }
        allowed += allowed.empty() ? text : std::string(", ") + text;
    }
    return Result(Status::InvalidArgument,
                  std::string(name) + " must be one of " + allowed + ", not '" + v + "'");
}

} // namespace

Expected<EngineTuning> tuningFromEnvironment(EngineTuning base) {
    using Pacing = EngineTuning::Pacing;
    using Schedule = EngineTuning::MipSchedule;
    if (Result r = pick<Pacing>("IRIS_PACE_FRAMES", {{"0", Pacing::Off}, {"1", Pacing::On}}, base.pacing); !r.ok())
        return r;
    if (Result r = pick<bool>("IRIS_DRAW_COVERED", {{"0", false}, {"1", true}}, base.drawCovered); !r.ok()) return r;
    if (Result r = pick<Schedule>("IRIS_MIP_SCHEDULE", {{"wide", Schedule::Wide}, {"serial", Schedule::Serial}, {"host", Schedule::Host}},
                                  base.mipSchedule);
        !r.ok())
        return r;
    if (Result r = pick<bool>("IRIS_QUEUES", {{"single", true}, {"auto", false}}, base.singleQueue); !r.ok()) return r;
    if (Result r = pick<EngineTuning::TileResolve>("IRIS_TILE_RESOLVE",
                                                   {{"auto", EngineTuning::TileResolve::Auto},
                                                    {"quads", EngineTuning::TileResolve::Quads},
                                                    {"compute", EngineTuning::TileResolve::Compute}},
                                                   base.tileResolve);
        !r.ok())
        return r;
    if (Result r = pick<EngineTuning::ExactCopy>("IRIS_EXACT_COPY",
                                                 {{"auto", EngineTuning::ExactCopy::Auto},
                                                  {"0", EngineTuning::ExactCopy::Off},
                                                  {"1", EngineTuning::ExactCopy::On}},
                                                 base.exactCopy);
        !r.ok())
        return r;
    if (Result r = pick<EngineTuning::TileUpload>("IRIS_TILE_UPLOAD",
                                                  {{"auto", EngineTuning::TileUpload::Auto},
                                                   {"queue", EngineTuning::TileUpload::Queue},
                                                   {"host", EngineTuning::TileUpload::Host}},
                                                  base.tileUpload);
        !r.ok())
        return r;
    if (Result r = pick<EngineTuning::JpegDecode>("IRIS_JPEG_DECODE",
                                                  {{"auto", EngineTuning::JpegDecode::Auto},
                                                   {"cpu", EngineTuning::JpegDecode::Cpu},
                                                   {"gpu", EngineTuning::JpegDecode::Gpu}},
                                                  base.jpegDecode);
        !r.ok())
        return r;
    if (Result r = pick<EngineTuning::ColorLookup>("IRIS_COLOR_LOOKUP",
                                                   {{"auto", EngineTuning::ColorLookup::Auto},
                                                    {"sampler", EngineTuning::ColorLookup::Sampler},
                                                    {"nodes", EngineTuning::ColorLookup::Nodes}},
                                                   base.colorLookup);
        !r.ok())
        return r;
    if (std::string device = variable("IRIS_DEVICE"); !device.empty()) base.deviceName = std::move(device);
    return base;
}

} // namespace iris
