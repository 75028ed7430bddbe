// Iris View engine — mapping IRIS_* environment variables onto EngineTuning.
//
// The engine itself never reads the environment (EngineConfig says everything). Tools and
// test programs call this, once, where they build their EngineConfig, so that a run can be
// switched from the shell (docs/GPU-RUNS.md runs every suite again with IRIS_QUEUES=single):
//
//   IRIS_PACE_FRAMES=0|1          tuning.pacing = Off | On
//   IRIS_DRAW_COVERED=0|1         tuning.drawCovered
//   IRIS_MIP_SCHEDULE=wide|serial|host  tuning.mipSchedule = Wide | Serial | Host
//   IRIS_DEVICE=TEXT              tuning.deviceName (a part of the Vulkan device's name)
//   IRIS_QUEUES=single|auto       tuning.singleQueue = true | false
//   IRIS_TILE_RESOLVE=auto|quads|compute  tuning.tileResolve = Auto | Quads | Compute
//   IRIS_COLOR_LOOKUP=auto|sampler|nodes  tuning.colorLookup = Auto | Sampler | Nodes
//   IRIS_EXACT_COPY=auto|0|1      tuning.exactCopy = Auto | Off | On
//   IRIS_TILE_UPLOAD=auto|queue|host  tuning.tileUpload = Auto | Queue | Host
//   IRIS_JPEG_DECODE=auto|cpu|gpu  tuning.jpegDecode = Auto | Cpu | Gpu
//
// An unset or empty variable leaves `base`'s value. Any other value is an error
// (InvalidArgument) naming the variable and the values it takes, so a typo in a benchmark
// script does not silently measure the default.
#pragma once

#include "iris/engine.h"

namespace iris {

IRIS_API Expected<EngineTuning> tuningFromEnvironment(EngineTuning base = {});

} // namespace iris
