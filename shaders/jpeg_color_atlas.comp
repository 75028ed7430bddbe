#version 450
// The GPU JPEG reconstruction's second pass, writing the tile atlas's base level (the buffer
// thread, EngineTuning::gpuDecode). The pass itself: jpeg_color.glsl.
#extension GL_GOOGLE_include_directive : require
#define JPEG_OUTPUT_ATLAS
#include "jpeg_color.glsl"
