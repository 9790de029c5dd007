#version 450
// Layered anti-aliasing into an RGBA32F accumulation image (see layered.glsl).
#define ACCUM_FORMAT rgba32f
#include "layered.glsl"
