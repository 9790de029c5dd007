//! Host-side mirror of `shaders/depth_interface.glsl`: the matched-view record and the push
//! constants (the guide record is [`crate::depth::guide::GuidePixel`]). `#[repr(C)]` with only
//! 16-byte vectors and 4-byte scalars, so the C layout equals std430 / push-constant layout; the
//! tests read the GLSL and check that both sides agree member by member.

use crate::depth::guide::GuidePixel;
use crate::depth::sweep::SweepView;
use crate::gpu::pod::Pod;

/// One matched view as the shaders read it (`SweepView` in GLSL).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GpuSweepView {
    pub a0: [f32; 4],
    pub a1: [f32; 4],
    pub a2: [f32; 4],
    pub b: [f32; 4],
    /// 1.0 for each half-aperture (left, right, up, down) the view lies in.
    pub halves: [f32; 4],
    /// x: the view's first texel in the texel buffer.
    pub info: [u32; 4],
}

impl GpuSweepView {
    /// The record of `v` whose texels start at `first_texel` (f64 warps rounded to f32).
    pub fn new(v: &SweepView, first_texel: u32) -> Self {
        let a = v.a.as_mat3();
        let b = v.b.as_vec3();
        let h = |i: usize| if v.halves[i] { 1.0 } else { 0.0 };
        GpuSweepView {
            a0: [a.x_axis.x, a.x_axis.y, a.x_axis.z, 0.0],
            a1: [a.y_axis.x, a.y_axis.y, a.y_axis.z, 0.0],
            a2: [a.z_axis.x, a.z_axis.y, a.z_axis.z, 0.0],
            b: [b.x, b.y, b.z, 0.0],
            halves: [h(0), h(1), h(2), h(3)],
            info: [first_texel, 0, 0, 0],
        }
    }
}

/// The push constants of the depth passes (`DepthPush` in GLSL).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DepthPush {
    pub width: u32,
    pub height: u32,
    pub view_count: u32,
    pub ref_texel: u32,
    pub p0: f32,
    pub dp: f32,
    pub plane_first: u32,
    pub plane_count: u32,
    pub radius: u32,
    pub truncation: f32,
    pub conf_eps: f32,
    pub conf_gap: u32,
}

// SAFETY: repr(C), only f32/u32 arrays: no padding.
unsafe impl Pod for GpuSweepView {}
// SAFETY: repr(C), twelve 4-byte scalars: no padding.
unsafe impl Pod for DepthPush {}
// SAFETY: repr(C), only f32 arrays: no padding.
unsafe impl Pod for GuidePixel {}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{offset_of, size_of};

    use crate::gpu::pod::glsl_block;

    const GLSL: &str = include_str!("../../../shaders/depth_interface.glsl");

    /// (name, offset) of the GLSL block's members ([`glsl_block`] without the sizes).
    fn offsets(head: &str) -> Vec<(String, usize)> {
        glsl_block(GLSL, head)
            .into_iter()
            .map(|(name, offset, _)| (name, offset))
            .collect()
    }

    fn named(v: &[(&str, usize)]) -> Vec<(String, usize)> {
        v.iter().map(|(n, o)| (n.to_string(), *o)).collect()
    }

    #[test]
    fn sweep_view_matches_the_glsl_struct() {
        let rust = named(&[
            ("a0", offset_of!(GpuSweepView, a0)),
            ("a1", offset_of!(GpuSweepView, a1)),
            ("a2", offset_of!(GpuSweepView, a2)),
            ("b", offset_of!(GpuSweepView, b)),
            ("halves", offset_of!(GpuSweepView, halves)),
            ("info", offset_of!(GpuSweepView, info)),
        ]);
        assert_eq!(offsets("struct SweepView"), rust);
        assert_eq!(size_of::<GpuSweepView>(), 96);
    }

    #[test]
    fn guide_pixel_matches_the_glsl_struct() {
        let rust = named(&[
            ("colour", offset_of!(GuidePixel, colour)),
            ("mean", offset_of!(GuidePixel, mean)),
            ("inv0", offset_of!(GuidePixel, inv0)),
            ("inv1", offset_of!(GuidePixel, inv1)),
        ]);
        assert_eq!(offsets("struct GuidePixel"), rust);
        assert_eq!(size_of::<GuidePixel>(), 64);
    }

    #[test]
    fn push_constants_match_the_glsl_block() {
        let rust = named(&[
            ("width", offset_of!(DepthPush, width)),
            ("height", offset_of!(DepthPush, height)),
            ("view_count", offset_of!(DepthPush, view_count)),
            ("ref_texel", offset_of!(DepthPush, ref_texel)),
            ("p0", offset_of!(DepthPush, p0)),
            ("dp", offset_of!(DepthPush, dp)),
            ("plane_first", offset_of!(DepthPush, plane_first)),
            ("plane_count", offset_of!(DepthPush, plane_count)),
            ("radius", offset_of!(DepthPush, radius)),
            ("truncation", offset_of!(DepthPush, truncation)),
            ("conf_eps", offset_of!(DepthPush, conf_eps)),
            ("conf_gap", offset_of!(DepthPush, conf_gap)),
        ]);
        assert_eq!(offsets("uniform DepthPush"), rust);
        assert_eq!(size_of::<DepthPush>(), 48);
    }

    #[test]
    fn records_keep_columns_halves_and_texel_offset() {
        use glam::{DMat3, DVec3};
        let v = SweepView {
            index: 3,
            s: 0,
            t: 1,
            a: DMat3::from_cols(
                DVec3::X,
                DVec3::new(0.5, 1.0, 0.0),
                DVec3::new(7.0, 8.0, 1.0),
            ),
            b: DVec3::new(-1.0, 0.0, 0.0),
            halves: [true, false, false, true],
        };
        let g = GpuSweepView::new(&v, 4096);
        assert_eq!(g.a1, [0.5, 1.0, 0.0, 0.0]);
        assert_eq!(g.a2, [7.0, 8.0, 1.0, 0.0]);
        assert_eq!(g.halves, [1.0, 0.0, 0.0, 1.0]);
        assert_eq!(g.info[0], 4096);
    }
}
