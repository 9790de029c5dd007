//! SPIR-V compiled by build.rs from `shaders/`, embedded in the binary.

use ash::vk;

use super::context::GpuContext;
use super::owned::{Owned, OwnedResult};
use crate::error::{Result, VkContext};

macro_rules! spirv {
    ($name:literal) => {
        include_bytes!(concat!(env!("OUT_DIR"), "/", $name, ".spv"))
    };
}

pub const FULLSCREEN_VERT: &[u8] = spirv!("fullscreen.vert");
pub const REFOCUS_FRAG: &[u8] = spirv!("refocus.frag");
pub const REFOCUS_COMP: &[u8] = spirv!("refocus.comp");
pub const REFOCUS_HALF_COMP: &[u8] = spirv!("refocus_half.comp");
pub const DEFOCUS_COMP: &[u8] = spirv!("defocus.comp");
pub const LAYERED_COMP: &[u8] = spirv!("layered.comp");
pub const BOXED_COMP: &[u8] = spirv!("boxed.comp");
pub const LAYERED_HALF_COMP: &[u8] = spirv!("layered_half.comp");
pub const RESOLVE_FRAG: &[u8] = spirv!("resolve.frag");
pub const MESH_VERT: &[u8] = spirv!("mesh.vert");
pub const MESH_ACCUM_FRAG: &[u8] = spirv!("mesh_accum.frag");
pub const MESH_GEOM_FRAG: &[u8] = spirv!("mesh_geom.frag");
pub const SCENE_VERT: &[u8] = spirv!("scene.vert");
pub const SCENE_FRAG: &[u8] = spirv!("scene.frag");
pub const PANEL_FRAG: &[u8] = spirv!("panel.frag");
pub const DEPTH_COST_COMP: &[u8] = spirv!("depth_cost.comp");
pub const DEPTH_BOX_COMP: &[u8] = spirv!("depth_box.comp");
pub const DEPTH_WTA_COMP: &[u8] = spirv!("depth_wta.comp");

/// A shader module; drop it once the pipelines using it are created (they keep their own copy
/// of the code).
pub fn module(ctx: &GpuContext, spirv: &[u8], name: &str) -> Result<Owned<vk::ShaderModule>> {
    // read_spv copies into correctly aligned u32 words and checks the magic number.
    let words = ash::util::read_spv(&mut std::io::Cursor::new(spirv))
        .map_err(|e| crate::error::Error::Vulkan(format!("shader {name} is not SPIR-V: {e}")))?;
    let info = vk::ShaderModuleCreateInfo::default().code(&words);
    // SAFETY: valid SPIR-V produced by shaderc at build time.
    let m = unsafe { ctx.device.create_shader_module(&info, None) }
        .vk("vkCreateShaderModule")
        .owned(ctx)?;
    ctx.name(*m, name);
    Ok(m)
}
