// Interface of the plane-sweep depth passes (depth_cost.comp, depth_box.comp, depth_wta.comp).
// Mirrored by `GpuSweepView`, `GuidePixel` and `DepthPush` in src/passes/depth/interface.rs and
// src/depth/guide.rs; a unit test reads this file and checks names, types and offsets.
//
// Buffers are indexed plane-major: element (k, pixel) of a chunk lives at k * width * height +
// pixel, pixel = y * width + x (row 0 at the top).

// One view matched against the reference: reference pixel x at sweep parameter p is sampled at
// A' x + b' p (homogeneous; src/depth/sweep.rs). `halves` is 1 for each half-aperture (left,
// right, up, down) the view lies in; info.x is its first texel in `texels`.
struct SweepView {
    vec4 a0;
    vec4 a1;
    vec4 a2;
    vec4 b;
    vec4 halves;
    uvec4 info;
};

// The guided filter's per-pixel guide data: the reference colour I, its window mean, and the
// inverse of its regularised window covariance (xx, xy, xz, yy | yz, zz).
struct GuidePixel {
    vec4 colour;
    vec4 mean;
    vec4 inv0;
    vec4 inv1;
};

// Streaming winner-take-all state of one pixel: best = (c1, k1, cost at k1 - 1, cost at k1 + 1);
// run = (min over planes <= current - gap, c2 = min over planes at least `gap` from k1, 0, 0).
// The costs of the last `gap` planes are kept in `history`.
struct WtaState {
    vec4 best;
    vec4 run;
};

layout(push_constant) uniform DepthPush {
    uint width;
    uint height;
    uint view_count;   // matched views in `views`
    uint ref_texel;    // first texel of the reference view in `texels`
    float p0;          // sweep parameter of plane 0
    float dp;          // spacing of the planes
    uint plane_first;  // first plane of this chunk
    uint plane_count;  // planes in this chunk
    uint radius;       // aggregation window radius
    float truncation;  // largest per-view cost
    float conf_eps;    // noise floor of the confidence ratio
    uint conf_gap;     // planes within this distance of the winner do not count for c2
} pc;

// RGBA8 sRGB-encoded texels, one u32 each, views after each other (the reference first).
layout(std430, set = 0, binding = 0) readonly buffer Texels { uint texels[]; };
layout(std430, set = 0, binding = 1) readonly buffer Views { SweepView views[]; };
layout(std430, set = 0, binding = 2) readonly buffer Guide { GuidePixel guide[]; };
// Raw costs of the chunk, then (after aggregation) the aggregated costs.
layout(std430, set = 0, binding = 3) buffer Cost { float cost[]; };
// Row sums of the box filter.
layout(std430, set = 0, binding = 4) buffer Rows { vec4 rows[]; };
// The guided filter's coefficients (a, b) per window.
layout(std430, set = 0, binding = 5) buffer Coeffs { vec4 coeffs[]; };
layout(std430, set = 0, binding = 6) buffer State { WtaState state[]; };
// Per pixel: (fractional plane index, confidence, best cost, second cost).
layout(std430, set = 0, binding = 7) buffer Result { vec4 result[]; };
// The last conf_gap aggregated costs of each pixel (a ring: plane g in slot g % conf_gap).
layout(std430, set = 0, binding = 8) buffer History { float history[]; };
// The first UBO_VIEWS records of `views` again, in a uniform buffer (UNIFORM_VIEWS in
// depth_cost.comp). llvmpipe compiles a storage-buffer load indexed by the loop counter into a
// loop over the SIMD lanes with a bounds check and a branch per lane, a uniform-buffer load
// into one gather (refocus::settings::WarpMemory measured the same for the warps).
const uint UBO_VIEWS = 160u; // passes::depth::UBO_VIEWS: 15 KiB, under the 16 KiB guaranteed
layout(std140, set = 0, binding = 9) uniform ViewsU { SweepView views_u[UBO_VIEWS]; };

const float BIG = 3.0e38;
