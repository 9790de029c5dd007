#version 450
// Compute strategy summing in RGBA32F (see refocus_compute.glsl).
#define ACCUM_FORMAT rgba32f
#include "refocus_compute.glsl"
