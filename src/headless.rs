//! Headless offscreen refocus: a context, the uploaded light field and the refocus pass,
//! torn down in the right order (pass → texture → context). What the CLI, the tests and the
//! benchmark drive.

use crate::error::Result;
use crate::gpu::{GpuContext, GpuOptions};
use crate::lightfield::LightField;
use crate::passes::refocus::{GpuImage, PassTimings, RefocusPass, RenderSettings};
use crate::passes::texture::LightFieldTexture;
use crate::refocus::RefocusPlan;

/// A ready-to-render light field on a Vulkan device.
pub struct HeadlessRenderer {
    pass: Option<RefocusPass>,
    texture: Option<LightFieldTexture>,
    ctx: GpuContext,
}

impl HeadlessRenderer {
    /// Creates a context and uploads `lf`.
    pub fn new(lf: &LightField, options: &GpuOptions) -> Result<Self> {
        let ctx = GpuContext::new(options)?;
        Self::with_context(ctx, lf)
    }

    /// Uploads `lf` to an existing context.
    pub fn with_context(ctx: GpuContext, lf: &LightField) -> Result<Self> {
        let texture = LightFieldTexture::upload(&ctx, lf)?;
        let pass = match RefocusPass::new(&ctx, &texture) {
            Ok(p) => p,
            Err(e) => {
                texture.destroy(&ctx);
                return Err(e);
            }
        };
        Ok(HeadlessRenderer {
            pass: Some(pass),
            texture: Some(texture),
            ctx,
        })
    }

    /// The Vulkan context (device name, validation counts).
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Renders `plan` and reads the image back.
    pub fn render(
        &mut self,
        plan: &RefocusPlan,
        settings: &RenderSettings,
    ) -> Result<(GpuImage, Option<PassTimings>)> {
        let (Some(pass), Some(tex)) = (self.pass.as_mut(), self.texture.as_ref()) else {
            unreachable!("pass and texture live until drop")
        };
        pass.render(&self.ctx, tex, plan, settings)
    }

    /// Renders `plan` without readback and returns the GPU timings (for benchmarks).
    pub fn render_timed(
        &mut self,
        plan: &RefocusPlan,
        settings: &RenderSettings,
    ) -> Result<Option<PassTimings>> {
        let (Some(pass), Some(tex)) = (self.pass.as_mut(), self.texture.as_ref()) else {
            unreachable!("pass and texture live until drop")
        };
        pass.render_timed(&self.ctx, tex, plan, settings)
    }
}

impl Drop for HeadlessRenderer {
    fn drop(&mut self) {
        if let Some(p) = self.pass.take() {
            p.destroy(&self.ctx);
        }
        if let Some(t) = self.texture.take() {
            t.destroy(&self.ctx);
        }
    }
}
