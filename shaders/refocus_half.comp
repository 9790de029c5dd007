#version 450
// Compute strategy summing in RGBA16F (see refocus_compute.glsl).
#define ACCUM_FORMAT rgba16f
#include "refocus_compute.glsl"
