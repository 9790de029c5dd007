//! Host-side mirror of `shaders/refocus_interface.glsl`: the per-view warp record of the
//! storage buffer and the push constants. `#[repr(C)]` with only 16-byte vectors and 4-byte
//! scalars, so the C layout equals std430 / push-constant layout; the test below reads the GLSL
//! file and checks that both sides declare the same members, in the same order, at the same
//! offsets.

use crate::geometry::homography::ViewWarp;
use crate::gpu::pod::Pod;
use crate::refocus::antialias::Footprint;
use crate::refocus::surface::{SurfacePlan, MAX_PLANES};

/// One view's warp `H_i = A_i + b_i mᵀ` as the shaders read it (`ViewWarp` in GLSL).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GpuViewWarp {
    /// Column 0 of A_i; `w`: the view's texture layer.
    pub a0: [f32; 4],
    /// Column 1 of A_i.
    pub a1: [f32; 4],
    /// Column 2 of A_i.
    pub a2: [f32; 4],
    /// b_i in xyz; `w`: the aperture weight.
    pub b_weight: [f32; 4],
}

impl GpuViewWarp {
    /// The record of view `layer` with `weight` (the f64 warp rounded to f32).
    pub fn new(warp: &ViewWarp, layer: usize, weight: f64) -> Self {
        let a = warp.a.as_mat3();
        let b = warp.b.as_vec3();
        GpuViewWarp {
            a0: [a.x_axis.x, a.x_axis.y, a.x_axis.z, layer as f32],
            a1: [a.y_axis.x, a.y_axis.y, a.y_axis.z, 0.0],
            a2: [a.z_axis.x, a.z_axis.y, a.z_axis.z, 0.0],
            b_weight: [b.x, b.y, b.z, weight as f32],
        }
    }
}

/// One view's aperture-cell footprint as the shaders read it (`ViewFootprint` in GLSL; see
/// [`crate::refocus::antialias::Footprint`]): homogeneous offsets in xyz; the three `w`s hold
/// the parallax vector (x, y, z); `vis[0]` is 1 when the view's visibility map is bound,
/// `vis[1]` its index, `vis[2]` the guard and `vis[3]` the focus test's threshold (0: no
/// test).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GpuFootprint {
    pub origin: [f32; 4],
    pub span_s: [f32; 4],
    pub span_t: [f32; 4],
    pub vis: [f32; 4],
}

impl GpuFootprint {
    /// The record of `f` (rounded to f32), `visible` when its visibility map is bound, with
    /// the plan's visibility guard in pixels ([`crate::refocus::antialias::AntialiasPlan::guard_px`])
    /// and focus test threshold ([`crate::refocus::antialias::AntialiasPlan::focus_threshold`],
    /// 0: no test).
    pub fn new(f: &Footprint, visible: bool, guard_px: f64, focus_threshold: f64) -> Self {
        let v = |d: glam::DVec3, w: f64| [d.x as f32, d.y as f32, d.z as f32, w as f32];
        let g = f.parallax;
        GpuFootprint {
            origin: v(f.origin, g.x),
            span_s: v(f.span_s, g.y),
            span_t: v(f.span_t, g.z),
            vis: [
                if visible { 1.0 } else { 0.0 },
                f.map as f32,
                guard_px as f32,
                focus_threshold as f32,
            ],
        }
    }
}

/// The push constants of the accumulation shaders (`RefocusPush` in GLSL).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RefocusPush {
    /// The plane term m in xyz.
    pub plane: [f32; 4],
    /// Width and height of the views in pixels.
    pub view_size: [f32; 2],
    /// Reference-view pixels per output pixel, x and y.
    pub out_scale: [f32; 2],
    pub first_view: u32,
    pub view_count: u32,
    /// Compute strategy: 1 adds to the accumulation image, 0 replaces it.
    pub accumulate: u32,
    /// Planes of a focus surface with the nearest-plane rule (the plane included).
    pub plane_count: u32,
    /// Warps of the whole uploaded plan (anti-aliasing's focus test reads every view whatever
    /// the draw's range).
    pub total_views: u32,
    /// Anti-aliasing: the residual `|s − σ|` below which a pixel's own surface is in focus and
    /// its sub-samples under half a pixel read Catmull-Rom
    /// ([`crate::refocus::antialias::AntialiasPlan::focused_reach`]; 0: none).
    pub focused_reach: f32,
    /// Layered footprints: the batch's views in the stage's binning order
    /// (the layered stage's `GpuLayerParams::order`), the centred part `[centred_from, centred_to)`
    /// and the rest `[rim_from, rim_to)`; worked out per batch on the host, so that no pixel
    /// searches the order (the viewer's progressive batches did, 16 % of their time). 0
    /// elsewhere.
    pub centred_from: u32,
    pub centred_to: u32,
    pub rim_from: u32,
    pub rim_to: u32,
}

// SAFETY: repr(C), only f32 arrays: no padding.
unsafe impl Pod for GpuViewWarp {}
// SAFETY: repr(C), only f32 arrays: no padding.
unsafe impl Pod for GpuFootprint {}
// SAFETY: repr(C), f32 arrays, u32s and an f32, all 4-byte aligned, 72 bytes: no padding.
unsafe impl Pod for RefocusPush {}

/// The focus surface's plane terms as the shaders read them (`Surface` in
/// refocus_accumulate.glsl: `vec4 surface_planes[MAX_PLANES]`, std140).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GpuSurface {
    pub planes: [[f32; 4]; MAX_PLANES],
}

impl GpuSurface {
    /// The record of `surface` (plane terms rounded to f32, unused slots zero).
    pub fn new(surface: &SurfacePlan) -> Self {
        let mut g = GpuSurface::default();
        for (slot, m) in g.planes.iter_mut().zip(&surface.terms) {
            *slot = [m.x as f32, m.y as f32, m.z as f32, 0.0];
        }
        g
    }
}

// SAFETY: repr(C), only f32 arrays: no padding.
unsafe impl Pod for GpuSurface {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::pod::{as_bytes, glsl_block};
    use std::mem::{offset_of, size_of};

    const GLSL: &str = include_str!("../../../shaders/refocus_interface.glsl");

    #[test]
    fn view_warp_matches_the_glsl_struct() {
        let glsl = glsl_block(GLSL, "struct ViewWarp");
        let rust = [
            ("a0", offset_of!(GpuViewWarp, a0), 16),
            ("a1", offset_of!(GpuViewWarp, a1), 16),
            ("a2", offset_of!(GpuViewWarp, a2), 16),
            ("b_weight", offset_of!(GpuViewWarp, b_weight), 16),
        ];
        let rust: Vec<_> = rust
            .iter()
            .map(|(n, o, s)| (n.to_string(), *o, *s))
            .collect();
        assert_eq!(glsl, rust);
        assert_eq!(size_of::<GpuViewWarp>(), 64);
    }

    #[test]
    fn footprint_matches_the_glsl_struct() {
        let glsl = glsl_block(GLSL, "struct ViewFootprint");
        let rust = [
            ("origin", offset_of!(GpuFootprint, origin), 16),
            ("span_s", offset_of!(GpuFootprint, span_s), 16),
            ("span_t", offset_of!(GpuFootprint, span_t), 16),
            ("vis", offset_of!(GpuFootprint, vis), 16),
        ];
        let rust: Vec<_> = rust
            .iter()
            .map(|(n, o, s)| (n.to_string(), *o, *s))
            .collect();
        assert_eq!(glsl, rust);
        // std140 arrays of this struct have a 64-byte stride: no padding between records.
        assert_eq!(size_of::<GpuFootprint>(), 64);
    }

    #[test]
    fn push_constants_match_the_glsl_block() {
        let glsl = glsl_block(GLSL, "uniform RefocusPush");
        let rust = [
            ("plane", offset_of!(RefocusPush, plane), 16),
            ("view_size", offset_of!(RefocusPush, view_size), 8),
            ("out_scale", offset_of!(RefocusPush, out_scale), 8),
            ("first_view", offset_of!(RefocusPush, first_view), 4),
            ("view_count", offset_of!(RefocusPush, view_count), 4),
            ("accumulate", offset_of!(RefocusPush, accumulate), 4),
            ("plane_count", offset_of!(RefocusPush, plane_count), 4),
            ("total_views", offset_of!(RefocusPush, total_views), 4),
            ("focused_reach", offset_of!(RefocusPush, focused_reach), 4),
            ("centred_from", offset_of!(RefocusPush, centred_from), 4),
            ("centred_to", offset_of!(RefocusPush, centred_to), 4),
            ("rim_from", offset_of!(RefocusPush, rim_from), 4),
            ("rim_to", offset_of!(RefocusPush, rim_to), 4),
        ];
        let rust: Vec<_> = rust
            .iter()
            .map(|(n, o, s)| (n.to_string(), *o, *s))
            .collect();
        assert_eq!(glsl, rust);
        let end = glsl.last().map(|(_, o, s)| o + s).unwrap();
        assert_eq!(size_of::<RefocusPush>(), end);
        // Vulkan guarantees at least 128 bytes of push constants.
        assert!(size_of::<RefocusPush>() <= 128);
    }

    #[test]
    fn surface_record_matches_the_glsl_block() {
        let glsl = include_str!("../../../shaders/refocus_accumulate.glsl");
        assert!(glsl.contains("uniform Surface { vec4 surface_planes[MAX_PLANES]; };"));
        assert!(glsl.contains(&format!("const uint MAX_PLANES = {MAX_PLANES}u;")));
        // std140 vec4 arrays have a 16-byte stride, as [f32; 4].
        assert_eq!(size_of::<GpuSurface>(), 16 * MAX_PLANES);
    }

    #[test]
    fn warp_record_keeps_layer_weight_and_columns() {
        use glam::{DMat3, DVec3};
        let warp = ViewWarp {
            a: DMat3::from_cols(
                DVec3::new(1.0, 2.0, 3.0),
                DVec3::new(4.0, 5.0, 6.0),
                DVec3::new(7.0, 8.0, 9.0),
            ),
            b: DVec3::new(-1.0, -2.0, -3.0),
        };
        let g = GpuViewWarp::new(&warp, 17, 0.25);
        assert_eq!(g.a0, [1.0, 2.0, 3.0, 17.0]);
        assert_eq!(g.a2, [7.0, 8.0, 9.0, 0.0]);
        assert_eq!(g.b_weight, [-1.0, -2.0, -3.0, 0.25]);
        assert_eq!(as_bytes(&[g, g]).len(), 128);
    }
}
