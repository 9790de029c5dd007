// Interface of the refocus pass, shared by refocus.frag and refocus.comp. Mirrored by
// `GpuViewWarp` and `RefocusPush` in src/passes/refocus/interface.rs; a unit test there reads
// this file and checks that member names, types and offsets agree with the Rust types.
//
// Per view i the warp is H_i = A_i + b_i m^T (docs/conventions.md, "Homographies"): the
// columns of A_i in a0..a2 (xyz), the texture layer in a0.w, b_i in b_weight.xyz and the
// aperture weight in b_weight.w. A_i and b_i change only with the view set, the aperture or the
// reference camera; moving the plane changes m alone, a push constant.
struct ViewWarp {
    vec4 a0;
    vec4 a1;
    vec4 a2;
    vec4 b_weight;
};

// Anti-aliasing (docs/conventions.md §11): view i's aperture cell as homogeneous offsets per
// unit of residual inverse depth s - sigma; the sub-sample at (u, v) in [0, 1]^2 lies at
// origin + u span_s + v span_t (xyz). The three w components hold the parallax vector
// g_i = K_r R_r (C_r - C_i) of the occlusion test; vis.x is 1 when the view's visibility map
// is bound (binding 8), 0 without one, vis.y that map's index and vis.z the guard: sub-samples
// closer than that (pixels) to the plain sample skip the map; vis.w the focus test's threshold
// (0: no test; the same in every record). Mirrored by `GpuFootprint`.
struct ViewFootprint {
    vec4 origin;
    vec4 span_s;
    vec4 span_t;
    vec4 vis;
};

layout(push_constant) uniform RefocusPush {
    vec4 plane;      // m = K_r^-T n_r / d_r in xyz
    vec2 view_size;  // W, H of the views in pixels
    vec2 out_scale;  // reference-view pixels per output pixel (x, y)
    uint first_view; // first warp of this draw or dispatch
    uint view_count; // number of warps of this draw or dispatch
    uint accumulate; // compute: 1 adds to the accumulation image, 0 replaces its contents
    uint plane_count; // planes of a focus surface (SURFACE 1), the plane's included
    uint total_views; // warps of the whole plan (anti-aliasing's focus test reads them all)
    float focused_reach; // anti-aliasing: |s - sigma| below which a pixel's own surface is in
                         // focus and its sub-samples under half a pixel read Catmull-Rom (0: none)
    uint centred_from; // layered footprints: the batch's views in the binning order (order4 in
    uint centred_to;   // layered.glsl), the centred part [centred_from, centred_to) and the
    uint rim_from;     // rest [rim_from, rim_to); 0 elsewhere
    uint rim_to;
} pc;
