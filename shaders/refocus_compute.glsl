// Compute strategy: one invocation per output pixel adds a batch of views into the float
// accumulation image. Data-centre GPUs run fragment shaders on a small part of the chip;
// compute uses all of it. The including file defines ACCUM_FORMAT (the storage image's format
// is part of the shader: refocus.comp sums in rgba32f, refocus_half.comp in rgba16f).
#include "refocus_accumulate.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 1, binding = 0, ACCUM_FORMAT) uniform image2D accum_image;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, imageSize(accum_image)))) {
        return;
    }
    vec4 v = accumulate(vec2(px) + 0.5);
    if (pc.accumulate != 0u) {
        v += imageLoad(accum_image, px);
    }
    imageStore(accum_image, px, v);
}
