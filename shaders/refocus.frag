#version 450
// Fragment strategy: one fullscreen triangle per draw; additive blending sums the draws into
// the float accumulation target.
#include "refocus_accumulate.glsl"

layout(location = 0) out vec4 accum;

void main() {
    accum = accumulate(gl_FragCoord.xy);
}
