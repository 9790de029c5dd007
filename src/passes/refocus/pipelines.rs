//! The refocus pass's pipelines, made on first use and kept: one accumulation pipeline per
//! combination of specialisation constants ([`AccumKey`]), one resolve pipeline per output
//! ([`ResolveKey`]).

use ash::vk;

use super::layouts::PassLayouts;
use super::{accumulation_format, ComputeShape};
use crate::error::Result;
use crate::gpu::pipeline::{compute_pipeline, graphics_pipeline, Blend, PipelineDesc};
use crate::gpu::{shaders, GpuContext, Owned};
use crate::refocus::settings::Accumulation;

/// The specialisation of an accumulation pipeline (constant ids of
/// shaders/refocus_accumulate.glsl, in order).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct AccumKey {
    pub compute: bool,
    pub filter: u32,
    pub texel: u32,
    pub format: vk::Format,
    pub uniform_warps: bool,
    pub antialias: u32,
    /// Anti-aliasing reads the views' pyramid (`refocus::prefilter`, binding 7).
    pub prefilter: bool,
    /// Anti-aliasing's occlusion tests are compiled in (`AntialiasSettings::occlusion`).
    pub occlusion: bool,
    /// `SurfaceRule` code (0: the plane alone).
    pub surface: u32,
    /// Anti-aliasing reads the defocused views (binding 9) instead of sub-sampling.
    pub defocus: bool,
    /// Anti-aliasing reads the boxed stage's results (binding 10) first.
    pub boxed: bool,
    /// The compute shader's shape (the default for fragment pipelines, which ignore it).
    pub shape: ComputeShape,
}

impl AccumKey {
    fn constants(&self) -> [u32; 13] {
        [
            self.filter,
            self.texel,
            u32::from(self.uniform_warps),
            self.antialias,
            self.surface,
            u32::from(self.prefilter),
            u32::from(self.occlusion),
            u32::from(self.defocus),
            self.shape.pixels,
            self.shape.unroll,
            self.shape.tile.0,
            self.shape.tile.1,
            u32::from(self.boxed),
        ]
    }

    /// The pipeline's debug name.
    fn name(&self) -> String {
        let flag = |on: bool, what: &'static str| if on { what } else { "" };
        let shape = if self.compute {
            format!(", {:?}", self.shape)
        } else {
            String::new()
        };
        format!(
            "refocus {} pipeline (filter {}, texel {}, {} warps, antialias {}{}{}{}{}, surface {}){shape}",
            if self.compute { "compute" } else { "fragment" },
            self.filter,
            self.texel,
            if self.uniform_warps { "uniform" } else { "storage" },
            self.antialias,
            flag(self.prefilter, " prefiltered"),
            flag(self.occlusion, " occlusion-tested"),
            flag(self.defocus, " defocused"),
            flag(self.boxed, " boxed"),
            self.surface
        )
    }
}

/// The resolve's output: `MODE` of shaders/resolve.frag and the attachment format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct ResolveKey {
    pub mode: u32,
    pub format: vk::Format,
}

/// The pipelines made so far.
#[derive(Default)]
pub(super) struct Pipelines {
    accum: Vec<(AccumKey, Owned<vk::Pipeline>)>,
    resolve: Vec<(ResolveKey, Owned<vk::Pipeline>)>,
}

impl Pipelines {
    /// The accumulation pipeline of `key`, made on first use.
    pub fn accum(
        &mut self,
        ctx: &GpuContext,
        layouts: &PassLayouts,
        key: AccumKey,
    ) -> Result<vk::Pipeline> {
        if let Some((_, p)) = self.accum.iter().find(|(k, _)| *k == key) {
            return Ok(**p);
        }
        let constants = key.constants();
        let pipeline = if key.compute {
            // The storage image's format is part of the shader: one module per format.
            let (spirv, file) = if key.format == accumulation_format(Accumulation::Rgba16f) {
                (shaders::REFOCUS_HALF_COMP, "refocus_half.comp")
            } else {
                (shaders::REFOCUS_COMP, "refocus.comp")
            };
            let module = shaders::module(ctx, spirv, file)?;
            compute_pipeline(ctx, *layouts.compute, *module, &constants, &key.name())?
        } else {
            let desc = PipelineDesc {
                blend: Blend::Additive,
                frag_constants: &constants,
                ..PipelineDesc::fullscreen(
                    *layouts.accum,
                    vk::ShaderModule::null(),
                    vk::ShaderModule::null(),
                    key.format,
                )
            };
            fullscreen(
                ctx,
                desc,
                shaders::REFOCUS_FRAG,
                "refocus.frag",
                &key.name(),
            )?
        };
        let raw = *pipeline;
        self.accum.push((key, pipeline));
        Ok(raw)
    }

    /// The resolve pipeline of `key`, made on first use.
    pub fn resolve(
        &mut self,
        ctx: &GpuContext,
        layouts: &PassLayouts,
        key: ResolveKey,
    ) -> Result<vk::Pipeline> {
        if let Some((_, p)) = self.resolve.iter().find(|(k, _)| *k == key) {
            return Ok(**p);
        }
        let constants = [key.mode];
        let desc = PipelineDesc {
            frag_constants: &constants,
            ..PipelineDesc::fullscreen(
                *layouts.resolve,
                vk::ShaderModule::null(),
                vk::ShaderModule::null(),
                key.format,
            )
        };
        let name = format!("resolve pipeline (mode {}, {:?})", key.mode, key.format);
        let pipeline = fullscreen(ctx, desc, shaders::RESOLVE_FRAG, "resolve.frag", &name)?;
        let raw = *pipeline;
        self.resolve.push((key, pipeline));
        Ok(raw)
    }
}

/// A fullscreen pipeline of `desc` with `fullscreen.vert` and the fragment shader `spirv`
/// (the modules are freed once it exists).
fn fullscreen(
    ctx: &GpuContext,
    mut desc: PipelineDesc,
    spirv: &[u8],
    file: &str,
    name: &str,
) -> Result<Owned<vk::Pipeline>> {
    let vert = shaders::module(ctx, shaders::FULLSCREEN_VERT, "fullscreen.vert")?;
    let frag = shaders::module(ctx, spirv, file)?;
    desc.vert = *vert;
    desc.frag = *frag;
    graphics_pipeline(ctx, &desc, name)
}
