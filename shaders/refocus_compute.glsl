// Compute strategy: one invocation per output pixel (or PIXELS of them) adds a batch of views
// into the float accumulation image. Data-centre GPUs run fragment shaders on a small part of
// the chip; compute uses all of it. The including file defines ACCUM_FORMAT (the storage
// image's format is part of the shader: refocus.comp sums in rgba32f, refocus_half.comp in
// rgba16f).
#include "refocus_accumulate.glsl"

// The plain sum (no anti-aliasing, no focus surface) with PIXELS output pixels per invocation
// (1-4, 8 apart along x, so a warp's pixels stay neighbours), summed in one loop over the views
// without a branch per sample: a view that misses a pixel adds weight 0 at a clamped position.
// Every texel fetch of an iteration is independent, so a GPU keeps several in flight per
// invocation, where the per-pixel loop's `continue` serialises them; one warp load and matrix
// per view serve PIXELS pixels. The arithmetic per sample is the per-pixel loop's, so the sums
// are the same numbers. PIXELS 0 keeps the per-pixel loop (accumulate()) for every pixel.
layout(constant_id = 8) const uint PIXELS = 1u;
const uint MAX_PIXELS = 4u;
// Views per iteration of that loop (1-8): their warps and fetches are all issued before the
// samples are added (in view order, so the sums are the same numbers). A whole 512² output is
// one wave of invocations on a large GPU, each walking the views one dependent fetch after
// another; more fetches in flight per invocation, not more invocations, hide the latency.
layout(constant_id = 9) const uint UNROLL = 1u;
const uint MAX_UNROLL = 8u;

// The workgroup's shape (spec constants 10 and 11; the pass dispatches to match).
layout(local_size_x_id = 10, local_size_y_id = 11) in;
layout(set = 1, binding = 0, ACCUM_FORMAT) uniform image2D accum_image;

void store(ivec2 px, vec4 v) {
    if (pc.accumulate != 0u) {
        v += imageLoad(accum_image, px);
    }
    imageStore(accum_image, px, v);
}

void main() {
    ivec2 size = imageSize(accum_image);
    if (PIXELS == 0u || ANTIALIAS != 0u || SURFACE != 0u) {
        ivec2 px = ivec2(gl_GlobalInvocationID.xy);
        if (any(greaterThanEqual(px, size))) {
            return;
        }
        store(px, accumulate(vec2(px) + 0.5));
        return;
    }
    uint n = min(PIXELS, MAX_PIXELS);
    uint tile = gl_WorkGroupSize.x;
    ivec2 px0 = ivec2(gl_WorkGroupID.x * tile * n + gl_LocalInvocationID.x, gl_GlobalInvocationID.y);
    if (px0.x >= size.x || px0.y >= size.y) {
        return;
    }
    vec3 xs[MAX_PIXELS];
    float ss[MAX_PIXELS];
    vec4 acc[MAX_PIXELS];
    for (uint j = 0u; j < n; ++j) {
        // As accumulate(): pixel-index coordinates of the reference view and the plane's
        // inverse depth along the pixel's ray.
        vec2 frag = vec2(px0 + ivec2(int(tile * j), 0)) + 0.5;
        xs[j] = vec3(frag * pc.out_scale - 0.5, 1.0);
        ss[j] = max(dot(pc.plane.xyz, xs[j]), 0.0);
        acc[j] = vec4(0.0);
    }
    vec2 lo = vec2(-0.5);
    vec2 hi = pc.view_size - 0.5;
    uint k_end = pc.first_view + pc.view_count;
    uint u_n = clamp(UNROLL, 1u, MAX_UNROLL);
    for (uint k = pc.first_view; k < k_end; k += u_n) {
        vec4 samples[MAX_UNROLL * MAX_PIXELS];
        for (uint u = 0u; u < u_n; ++u) {
            // Past the last view: view k_end - 1 again at weight 0 (no branch).
            bool real = k + u < k_end;
            ViewWarp w = warp_of(real ? k + u : k_end - 1u);
            mat3 a = mat3(w.a0.xyz, w.a1.xyz, w.a2.xyz);
            for (uint j = 0u; j < n; ++j) {
                vec3 y = a * xs[j] + w.b_weight.xyz * ss[j];
                vec2 p = y.xy / y.z;
                // In front of camera i and inside view i (accumulate()'s two `continue`s).
                bool ok = real && y.z > 0.0 && all(greaterThanEqual(p, lo))
                    && all(lessThanEqual(p, hi));
                float weight = ok ? w.b_weight.w : 0.0;
                samples[u * MAX_PIXELS + j] = vec4(weight * fetch(ok ? p : vec2(0.0), w.a0.w), weight);
            }
        }
        for (uint u = 0u; u < u_n; ++u) {
            for (uint j = 0u; j < n; ++j) {
                acc[j] += samples[u * MAX_PIXELS + j];
            }
        }
    }
    for (uint j = 0u; j < n; ++j) {
        ivec2 px = px0 + ivec2(int(tile * j), 0);
        if (px.x < size.x) {
            store(px, acc[j]);
        }
    }
}
