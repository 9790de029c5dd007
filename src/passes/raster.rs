//! The mesh raster pass: renders a [`MeshScene`] headlessly with exact pinhole projections, for
//! synthetic light fields and their optical ground truth.
//!
//! One output image is the mean of several *samples*, each a full rasterization with its own
//! 3×4 projection: sub-pixel jitters for anti-aliasing, or aperture positions of a thin lens for
//! the optical ground truth. Every sample is drawn twice inside one dynamic rendering instance:
//! a depth pre-pass (`GREATER`, reverse Z, colour writes off), then the colour pass
//! (`GREATER_OR_EQUAL`, no depth writes) that adds linear-light albedo and coverage 1 into an
//! RGBA32F accumulation target by additive blending. The pre-pass makes the sum take exactly
//! the nearest surface per sample whatever the draw order; both passes run the same vertex and
//! fragment shaders (only fixed-function state differs), so they produce the same depths. The
//! CPU divides by the sample count (see [`RasterImage`]).
//!
//! An optional *geometry* render (no jitter) writes the camera-frame unit normal facing the
//! camera and the camera-frame depth z at each pixel centre into a second RGBA32F target
//! (z = 0 where nothing is hit).
//!
//! Projection ([`Projection::new`]): for P = K [R | t] in pixel-index coordinates (pixel (i, j)'s
//! centre at (i, j)), a sample with jitter o renders the image point (i + oₓ, j + o_y) at the
//! fragment centre (i + ½, j + ½):
//! `clip = [(2/W)·p₀ + (2(½ − oₓ)/W − 1)·p₂; (2/H)·p₁ + (2(½ − o_y)/H − 1)·p₂; near; p₂]`.
//! y points down in both conventions, so there is no flip. Depth is reverse Z with an infinite
//! far plane: depth = near / z, cleared to 0, `near` = [`NEAR`] world units.
//!
//! Textures: RGBA8 sRGB (decoded to linear by the sampler), bilinear, no mipmaps (the jittered
//! samples anti-alias), clamp-to-edge or repeat per texture. Untextured draws use a 1×1 white
//! texture. Vertex and index buffers are host-visible (small scenes; no staging needed).
//!
//! Everything frees itself when the pass is dropped, in field order: pipelines → textures
//! (images, descriptor pool, samplers) → buffers → submission → targets.

use ash::vk;
use glam::{DMat3, DMat4, DVec2, DVec3, DVec4};

use crate::error::{Error, Result};
use crate::geometry::camera::Camera;
use crate::gpu::commands::{
    begin_rendering, format_barrier, image_barrier, record_readback, stage, ImageReadback,
    ImageTransition, Submission,
};
use crate::gpu::pipeline::{self, graphics_pipeline, Blend, DepthTest, PipelineDesc};
use crate::gpu::pod::{as_bytes, Pod};
use crate::gpu::resources::{rgba_f32, Buffer, Image, ImageDesc};
use crate::gpu::shaders;
use crate::gpu::upload::{upload_images, ImageRegion};
use crate::gpu::{GpuContext, Owned};
use crate::scene::mesh::{MeshDraw, MeshScene, VERTEX_BYTES};

/// Near plane distance (world units, metres for the synthetic scenes): surfaces nearer than
/// this to a camera's image plane are clipped.
pub const NEAR: f64 = 1e-3;

const PUSH_BYTES: usize = std::mem::size_of::<Projection>();
const ACCUM_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;

/// One rasterization's matrices (f32, column-major, as the shaders read them): the push
/// constants `MeshPush` of shaders/mesh_interface.glsl, member for member (tested).
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C)]
pub struct Projection {
    pub clip_from_world: [f32; 16],
    pub camera_from_world: [f32; 16],
}

// SAFETY: repr(C), two f32 arrays: no padding, no pointers.
unsafe impl Pod for Projection {}

impl Projection {
    /// From the rows of a 3×4 projection `p` (pixel-index coordinates, third row = the depth
    /// along the camera's axis), the world → camera transform (for depth and normals), the
    /// output size and a sub-pixel `jitter` (see the module docs).
    pub fn new(
        p: [DVec4; 3],
        camera_from_world: DMat4,
        width: u32,
        height: u32,
        jitter: DVec2,
    ) -> Self {
        let (w, h) = (width as f64, height as f64);
        let rows = [
            (2.0 / w) * p[0] + (2.0 * (0.5 - jitter.x) / w - 1.0) * p[2],
            (2.0 / h) * p[1] + (2.0 * (0.5 - jitter.y) / h - 1.0) * p[2],
            DVec4::new(0.0, 0.0, 0.0, NEAR),
            p[2],
        ];
        let clip = DMat4::from_cols(rows[0], rows[1], rows[2], rows[3]).transpose();
        Projection {
            clip_from_world: clip.as_mat4().to_cols_array(),
            camera_from_world: camera_from_world.as_mat4().to_cols_array(),
        }
    }

    /// The pinhole projection of `camera` with a sub-pixel jitter.
    pub fn of_camera(camera: &Camera, width: u32, height: u32, jitter: DVec2) -> Self {
        Self::new(
            projection_rows(camera.k, camera.r, camera.t),
            camera_from_world(camera.r, camera.t),
            width,
            height,
            jitter,
        )
    }
}

/// Rows of `K [R | t]`.
pub fn projection_rows(k: DMat3, r: DMat3, t: DVec3) -> [DVec4; 3] {
    let kr = k * r;
    let kt = k * t;
    [0, 1, 2].map(|i| kr.row(i).extend(kt[i]))
}

/// The 4×4 `[R | t; 0 0 0 1]`.
pub fn camera_from_world(r: DMat3, t: DVec3) -> DMat4 {
    DMat4::from_cols(
        r.x_axis.extend(0.0),
        r.y_axis.extend(0.0),
        r.z_axis.extend(0.0),
        t.extend(1.0),
    )
}

/// A rendered image read back from the GPU.
#[derive(Debug, Clone)]
pub struct RasterImage {
    pub width: u32,
    pub height: u32,
    /// Per pixel, row-major: the mean over samples of linear albedo (0 where a sample hit
    /// nothing) in rgb, and the covered fraction of samples in alpha. Compose a background
    /// colour b as `rgb + b·(1 − alpha)`.
    pub color: Vec<[f32; 4]>,
    /// Camera-frame unit normal facing the camera and depth z (0 = nothing hit), when asked.
    pub geometry: Option<Vec<[f32; 4]>>,
}

struct Targets {
    width: u32,
    height: u32,
    accum: Image,
    geometry: Image,
    depth: Image,
    readback: Buffer,
}

impl Targets {
    fn new(ctx: &GpuContext, width: u32, height: u32) -> Result<Self> {
        let color = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC;
        let image = |format, usage, name| {
            Image::new(
                ctx,
                ImageDesc::new_2d(format, width, height, usage),
                &[format],
                name,
            )
        };
        Ok(Targets {
            width,
            height,
            accum: image(ACCUM_FORMAT, color, "raster accumulation target")?,
            geometry: image(ACCUM_FORMAT, color, "raster geometry target")?,
            depth: image(
                DEPTH_FORMAT,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
                "raster depth buffer",
            )?,
            readback: Buffer::new(
                ctx,
                width as u64 * height as u64 * 32,
                vk::BufferUsageFlags::TRANSFER_DST,
                true,
                "raster readback",
            )?,
        })
    }
}

/// Pipelines, mesh buffers, textures and targets for one mesh scene.
pub struct RasterPass {
    pipelines: MeshPipelines,
    textures: MeshTextures,
    vertices: Buffer,
    indices: Buffer,
    draws: Vec<MeshDraw>,
    submission: Submission,
    targets: Option<Targets>,
}

impl RasterPass {
    /// Uploads `mesh` and creates the pipelines.
    pub fn new(ctx: &GpuContext, mesh: &MeshScene) -> Result<Self> {
        if mesh.indices.is_empty() {
            return Err(Error::Invalid(format!(
                "{}: the scene has no triangles",
                mesh.name
            )));
        }
        let pipelines = MeshPipelines::new(ctx)?;
        let textures = MeshTextures::new(ctx, mesh, *pipelines.set_layout)?;
        // Mesh buffers (host-visible: the scenes are small).
        let mut vbytes = Vec::with_capacity(mesh.vertices.len() * VERTEX_BYTES);
        for v in &mesh.vertices {
            for f in v.to_floats() {
                vbytes.extend_from_slice(&f.to_ne_bytes());
            }
        }
        let ibytes: Vec<u8> = mesh.indices.iter().flat_map(|i| i.to_ne_bytes()).collect();
        Ok(RasterPass {
            pipelines,
            textures,
            vertices: Buffer::with_bytes(
                ctx,
                &vbytes,
                vk::BufferUsageFlags::VERTEX_BUFFER,
                "mesh vertices",
            )?,
            indices: Buffer::with_bytes(
                ctx,
                &ibytes,
                vk::BufferUsageFlags::INDEX_BUFFER,
                "mesh indices",
            )?,
            draws: mesh.draws.clone(),
            submission: Submission::new(ctx, "mesh raster")?,
            targets: None,
        })
    }

    /// Renders the mean of `samples` (at least one) into a `width × height` image, plus the
    /// geometry render of `geometry` when given, and reads both back.
    pub fn render(
        &mut self,
        ctx: &GpuContext,
        width: u32,
        height: u32,
        samples: &[Projection],
        geometry: Option<&Projection>,
    ) -> Result<RasterImage> {
        if samples.is_empty() || width == 0 || height == 0 {
            return Err(Error::Invalid(
                "a raster render needs a non-empty image and at least one sample".into(),
            ));
        }
        // `Option::is_none_or` needs Rust 1.82; the crate supports 1.80.
        if self
            .targets
            .as_ref()
            .map_or(true, |t| (t.width, t.height) != (width, height))
        {
            self.targets = None;
            self.targets = Some(Targets::new(ctx, width, height)?);
        }
        let Some(t) = self.targets.as_mut() else {
            unreachable!("targets were just created")
        };
        let extent = vk::Extent2D { width, height };
        let pixels = width as u64 * height as u64;
        let draws = Draws {
            vertices: self.vertices.buffer,
            indices: self.indices.buffer,
            draws: &self.draws,
            sets: &self.textures.sets,
            layout: *self.pipelines.layout,
        };
        let b = &self.pipelines;
        let (accum, geom, depth) = (&t.accum, &t.geometry, &t.depth);
        let readback = t.readback.buffer;
        self.submission.run(ctx, |d, cmd| {
            image_barrier(
                d,
                cmd,
                accum.image,
                1,
                ImageTransition {
                    from: stage::UNDEFINED,
                    to: stage::COLOR_WRITE,
                },
            );
            let to_depth = ImageTransition {
                from: stage::UNDEFINED,
                to: stage::DEPTH_WRITE,
            };
            format_barrier(d, cmd, depth.image, DEPTH_FORMAT, to_depth);
            let draw_all = |pipeline: &Owned<vk::Pipeline>, p: &Projection| {
                draws.record(d, cmd, **pipeline, p)
            };
            for (k, p) in samples.iter().enumerate() {
                if k > 0 {
                    attachments_barrier(d, cmd);
                }
                begin_rendering(
                    d,
                    cmd,
                    extent,
                    accum.views[0],
                    if k == 0 {
                        vk::AttachmentLoadOp::CLEAR
                    } else {
                        vk::AttachmentLoadOp::LOAD
                    },
                    Some((depth.views[0], 0.0)),
                );
                draw_all(&b.prepass, p);
                draw_all(&b.accum, p);
                // SAFETY: inside the rendering instance begun above.
                unsafe { d.cmd_end_rendering(cmd) };
            }
            // The readback buffer holds 2 · w·h·16 bytes.
            let copy = |image: vk::Image, offset: u64| {
                let copy = ImageReadback {
                    image,
                    from: stage::COLOR_WRITE,
                    then: None,
                    width,
                    height,
                    buffer: readback,
                    offset,
                };
                record_readback(d, cmd, &copy);
            };
            if let Some(g) = geometry {
                attachments_barrier(d, cmd);
                image_barrier(
                    d,
                    cmd,
                    geom.image,
                    1,
                    ImageTransition {
                        from: stage::UNDEFINED,
                        to: stage::COLOR_WRITE,
                    },
                );
                begin_rendering(
                    d,
                    cmd,
                    extent,
                    geom.views[0],
                    vk::AttachmentLoadOp::CLEAR,
                    Some((depth.views[0], 0.0)),
                );
                draw_all(&b.geometry, g);
                // SAFETY: inside the rendering instance begun above.
                unsafe { d.cmd_end_rendering(cmd) };
                copy(geom.image, pixels * 16);
            }
            copy(accum.image, 0);
        })?;
        let bytes = t.readback.bytes_mut();
        let read = |offset: usize, scale: f32| {
            rgba_f32(&bytes[offset..offset + pixels as usize * 16], scale)
        };
        let color = read(0, 1.0 / samples.len() as f32);
        let geometry = geometry.map(|_| read(pixels as usize * 16, 1.0));
        Ok(RasterImage {
            width,
            height,
            color,
            geometry,
        })
    }
}

/// What one sample's draws bind: the mesh buffers, a descriptor set per draw's texture and the
/// layout of the push constants.
struct Draws<'a> {
    vertices: vk::Buffer,
    indices: vk::Buffer,
    draws: &'a [MeshDraw],
    /// Descriptor set per texture, the white texture's last.
    sets: &'a [vk::DescriptorSet],
    layout: vk::PipelineLayout,
}

impl Draws<'_> {
    /// Records every draw of the mesh with `pipeline` under projection `p`.
    fn record(
        &self,
        d: &ash::Device,
        cmd: vk::CommandBuffer,
        pipeline: vk::Pipeline,
        p: &Projection,
    ) {
        let push = as_bytes(std::slice::from_ref(p));
        // SAFETY: recording inside a rendering instance whose formats match.
        unsafe {
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, pipeline);
            d.cmd_push_constants(
                cmd,
                self.layout,
                vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
                0,
                push,
            );
            d.cmd_bind_vertex_buffers(cmd, 0, &[self.vertices], &[0]);
            d.cmd_bind_index_buffer(cmd, self.indices, 0, vk::IndexType::UINT32);
            for draw in self.draws {
                let set = self.sets[draw.texture.unwrap_or(self.sets.len() - 1)];
                d.cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::GRAPHICS,
                    self.layout,
                    0,
                    &[set],
                    &[],
                );
                d.cmd_draw_indexed(cmd, draw.index_count, 1, draw.first_index, 0, 0);
            }
        }
    }
}

/// Orders one sample's attachment writes before the next sample's (additive blending reads the
/// accumulation target; the depth buffer is cleared and rewritten).
fn attachments_barrier(d: &ash::Device, cmd: vk::CommandBuffer) {
    use vk::{AccessFlags2 as A, PipelineStageFlags2 as S};
    let stages = S::COLOR_ATTACHMENT_OUTPUT | S::EARLY_FRAGMENT_TESTS | S::LATE_FRAGMENT_TESTS;
    let access = A::COLOR_ATTACHMENT_WRITE
        | A::COLOR_ATTACHMENT_READ
        | A::DEPTH_STENCIL_ATTACHMENT_WRITE
        | A::DEPTH_STENCIL_ATTACHMENT_READ;
    let barrier = [vk::MemoryBarrier2::default()
        .src_stage_mask(stages)
        .src_access_mask(access)
        .dst_stage_mask(stages)
        .dst_access_mask(access)];
    // SAFETY: recording outside a rendering instance.
    unsafe {
        d.cmd_pipeline_barrier2(
            cmd,
            &vk::DependencyInfo::default().memory_barriers(&barrier),
        )
    };
}

/// The three mesh pipelines and their layouts.
struct MeshPipelines {
    prepass: Owned<vk::Pipeline>,
    accum: Owned<vk::Pipeline>,
    geometry: Owned<vk::Pipeline>,
    layout: Owned<vk::PipelineLayout>,
    set_layout: Owned<vk::DescriptorSetLayout>,
}

impl MeshPipelines {
    fn new(ctx: &GpuContext) -> Result<Self> {
        let bindings = [vk::DescriptorSetLayoutBinding::default()
            .binding(0)
            .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
            .descriptor_count(1)
            .stage_flags(vk::ShaderStageFlags::FRAGMENT)];
        let set_layout = pipeline::set_layout(ctx, &bindings, "mesh set layout")?;
        let push = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT)
            .offset(0)
            .size(PUSH_BYTES as u32)];
        let layout = pipeline::pipeline_layout(ctx, &[*set_layout], &push, "mesh layout")?;
        let vert = shaders::module(ctx, shaders::MESH_VERT, "mesh.vert")?;
        let accum = shaders::module(ctx, shaders::MESH_ACCUM_FRAG, "mesh_accum.frag")?;
        let geom = shaders::module(ctx, shaders::MESH_GEOM_FRAG, "mesh_geom.frag")?;
        let make = |frag: &Owned<vk::ShaderModule>, mode, name| {
            mesh_pipeline(ctx, *layout, *vert, **frag, mode, name)
        };
        Ok(MeshPipelines {
            prepass: make(&accum, Mode::DepthPrepass, "mesh depth pre-pass pipeline")?,
            accum: make(&accum, Mode::Accumulate, "mesh accumulation pipeline")?,
            geometry: make(&geom, Mode::Geometry, "mesh geometry pipeline")?,
            layout,
            set_layout,
        })
    }
}

/// The mesh's textures (and a 1×1 white one for untextured draws) with a descriptor set each.
struct MeshTextures {
    _images: Vec<Image>,
    /// Descriptor set per texture, the white texture's last.
    sets: Vec<vk::DescriptorSet>,
    _pool: Owned<vk::DescriptorPool>,
    _clamp: Owned<vk::Sampler>,
    _repeat: Owned<vk::Sampler>,
}

impl MeshTextures {
    /// Uploads every texture through one staging buffer and writes their sets.
    fn new(
        ctx: &GpuContext,
        mesh: &MeshScene,
        set_layout: vk::DescriptorSetLayout,
    ) -> Result<Self> {
        let white = [255u8; 4];
        let mut all: Vec<(u32, u32, &[u8], bool, String)> = mesh
            .textures
            .iter()
            .map(|t| (t.width, t.height, &t.rgba[..], t.repeat, t.name.clone()))
            .collect();
        all.push((1, 1, &white[..], false, "white texture".into()));
        for (w, h, data, _, name) in &all {
            if data.len() != (*w as usize) * (*h as usize) * 4 {
                return Err(Error::Invalid(format!(
                    "{}: texture {name} has {} bytes for {w}×{h} RGBA8",
                    mesh.name,
                    data.len()
                )));
            }
        }
        let images = all
            .iter()
            .map(|(w, h, _, _, name)| {
                let desc = ImageDesc::new_2d(
                    vk::Format::R8G8B8A8_SRGB,
                    *w,
                    *h,
                    vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST,
                );
                Image::new(ctx, desc, &[vk::Format::R8G8B8A8_SRGB], name)
            })
            .collect::<Result<Vec<_>>>()?;
        let mut at = 0u64;
        let regions: Vec<ImageRegion> = images
            .iter()
            .zip(&all)
            .map(|(image, a)| {
                let offset = at;
                at += a.2.len() as u64;
                ImageRegion {
                    image,
                    offsets: vec![offset],
                }
            })
            .collect();
        upload_images(ctx, &regions, at, "mesh texture staging", |dst| {
            let mut at = 0usize;
            for (_, _, data, _, _) in &all {
                dst[at..at + data.len()].copy_from_slice(data);
                at += data.len();
            }
            Ok(())
        })?;
        let sampler = |mode, name| {
            let info = vk::SamplerCreateInfo::default()
                .mag_filter(vk::Filter::LINEAR)
                .min_filter(vk::Filter::LINEAR)
                .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
                .address_mode_u(mode)
                .address_mode_v(mode)
                .address_mode_w(mode)
                .max_lod(0.0);
            pipeline::sampler(ctx, &info, name)
        };
        let clamp = sampler(
            vk::SamplerAddressMode::CLAMP_TO_EDGE,
            "mesh texture sampler (clamp)",
        )?;
        let repeat = sampler(
            vk::SamplerAddressMode::REPEAT,
            "mesh texture sampler (repeat)",
        )?;
        let n = images.len() as u32;
        let sizes = [vk::DescriptorPoolSize {
            ty: vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
            descriptor_count: n,
        }];
        let pool = pipeline::descriptor_pool(ctx, n, &sizes, "mesh texture descriptors")?;
        let sets = pipeline::allocate_sets(ctx, *pool, &vec![set_layout; n as usize])?;
        for ((set, image), a) in sets.iter().zip(&images).zip(&all) {
            let info = [vk::DescriptorImageInfo::default()
                .sampler(if a.3 { *repeat } else { *clamp })
                .image_view(image.views[0])
                .image_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)];
            let write = vk::WriteDescriptorSet::default()
                .dst_set(*set)
                .dst_binding(0)
                .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
                .image_info(&info);
            // SAFETY: a new, unused set; the view and sampler are live.
            unsafe { ctx.device.update_descriptor_sets(&[write], &[]) };
        }
        Ok(MeshTextures {
            _images: images,
            sets,
            _pool: pool,
            _clamp: clamp,
            _repeat: repeat,
        })
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Mode {
    DepthPrepass,
    Accumulate,
    Geometry,
}

fn mesh_pipeline(
    ctx: &GpuContext,
    layout: vk::PipelineLayout,
    vert: vk::ShaderModule,
    frag: vk::ShaderModule,
    mode: Mode,
    name: &str,
) -> Result<Owned<vk::Pipeline>> {
    let bindings = [vk::VertexInputBindingDescription::default()
        .binding(0)
        .stride(VERTEX_BYTES as u32)
        .input_rate(vk::VertexInputRate::VERTEX)];
    let attr = |location: u32, format, offset: u32| {
        vk::VertexInputAttributeDescription::default()
            .location(location)
            .binding(0)
            .format(format)
            .offset(offset)
    };
    let attributes = [
        attr(0, vk::Format::R32G32B32_SFLOAT, 0),
        attr(1, vk::Format::R32G32B32_SFLOAT, 12),
        attr(2, vk::Format::R32G32_SFLOAT, 24),
        attr(3, vk::Format::R32G32B32A32_SFLOAT, 32),
    ];
    // Reverse-Z: nearer is greater. The accumulation pass re-draws the pre-pass depth exactly,
    // so it tests with GREATER_OR_EQUAL and writes no depth.
    let (compare, write) = match mode {
        Mode::DepthPrepass | Mode::Geometry => (vk::CompareOp::GREATER, true),
        Mode::Accumulate => (vk::CompareOp::GREATER_OR_EQUAL, false),
    };
    graphics_pipeline(
        ctx,
        &PipelineDesc {
            layout,
            vert,
            frag,
            color_format: ACCUM_FORMAT,
            topology: vk::PrimitiveTopology::TRIANGLE_LIST,
            blend: if mode == Mode::Accumulate {
                Blend::Additive
            } else {
                Blend::Replace
            },
            color_write: mode != Mode::DepthPrepass,
            depth: Some(DepthTest {
                format: DEPTH_FORMAT,
                compare,
                write,
            }),
            vertex_bindings: &bindings,
            vertex_attributes: &attributes,
            frag_constants: &[],
        },
        name,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_matches_the_glsl_push_constants() {
        use std::mem::offset_of;
        let glsl = include_str!("../../shaders/mesh_interface.glsl");
        let rust = vec![
            (
                "clip_from_world".to_string(),
                offset_of!(Projection, clip_from_world),
                64,
            ),
            (
                "camera_from_world".to_string(),
                offset_of!(Projection, camera_from_world),
                64,
            ),
        ];
        assert_eq!(crate::gpu::pod::glsl_block(glsl, "uniform MeshPush"), rust);
        assert_eq!(PUSH_BYTES, 128);
    }
    use crate::geometry::camera::intrinsics;

    /// Clip coordinates of a world point under `p`, as the GPU computes them (in f64).
    fn clip(p: &Projection, x: DVec3) -> DVec4 {
        glam::Mat4::from_cols_array(&p.clip_from_world)
            .as_dmat4()
            .mul_vec4(x.extend(1.0))
    }

    #[test]
    fn pixel_centres_land_on_fragment_centres() {
        let cam = Camera::from_centre(
            intrinsics(100.0, 100.0, 31.5, 23.5),
            DMat3::from_rotation_y(0.1),
            DVec3::new(0.1, 0.0, -0.2),
        );
        let (w, h) = (64u32, 48u32);
        let p = Projection::of_camera(&cam, w, h, DVec2::ZERO);
        for (u, v) in [(0.0, 0.0), (10.0, 5.0), (63.0, 47.0)] {
            let x = cam.back_project(DVec2::new(u, v), 2.5);
            let c = clip(&p, x);
            // Framebuffer coordinate = (ndc + 1)/2 · size = pixel index + ½.
            let fx = (c.x / c.w + 1.0) / 2.0 * w as f64;
            let fy = (c.y / c.w + 1.0) / 2.0 * h as f64;
            assert!((fx - (u + 0.5)).abs() < 1e-4 && (fy - (v + 0.5)).abs() < 1e-4);
            // Reverse Z: depth = near / z.
            assert!((c.z / c.w - NEAR / 2.5).abs() < 1e-9);
        }
        // A jitter o renders the image point (i + o) at fragment centre i + ½.
        let o = DVec2::new(0.25, -1.0 / 3.0);
        let pj = Projection::of_camera(&cam, w, h, o);
        let x = cam.back_project(DVec2::new(10.0, 5.0) + o, 3.0);
        let c = clip(&pj, x);
        assert!(((c.x / c.w + 1.0) / 2.0 * w as f64 - 10.5).abs() < 1e-4);
        assert!(((c.y / c.w + 1.0) / 2.0 * h as f64 - 5.5).abs() < 1e-4);
    }
}
