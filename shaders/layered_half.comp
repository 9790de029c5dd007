#version 450
// Layered anti-aliasing into an RGBA16F accumulation image (see layered.glsl).
#define ACCUM_FORMAT rgba16f
#include "layered.glsl"
