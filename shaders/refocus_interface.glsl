// Interface of the refocus pass, shared by refocus.frag and mirrored by
// src/passes/refocus.rs (`GpuViewWarp`, `RefocusPush`): keep the two in step.
//
// Per view i the warp is H_i = A_i + b_i m^T (see src/geometry/homography.rs):
// columns of A_i in a0..a2 (xyz), the texture layer in a0.w, b_i in b_weight.xyz and the
// aperture weight in b_weight.w.
struct ViewWarp {
    vec4 a0;
    vec4 a1;
    vec4 a2;
    vec4 b_weight;
};

layout(push_constant) uniform RefocusPush {
    vec4 plane;      // m = K_r^-T n_r / d_r in xyz
    vec2 view_size;  // W, H of the views in pixels
    vec2 out_scale;  // reference-view pixels per output pixel
    uint first_view; // first warp of this draw
    uint view_count; // number of warps of this draw
} pc;
