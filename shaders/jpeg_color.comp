#version 450
// The GPU JPEG reconstruction's second pass, writing RGBA8 words into a buffer (the bench and
// engine.jpeg_gpu). The pass itself: jpeg_color.glsl.
#extension GL_GOOGLE_include_directive : require
#include "jpeg_color.glsl"
