//! Compiles the GLSL shaders in `shaders/` to SPIR-V in OUT_DIR with shaderc; the crate embeds
//! them with `include_bytes!`. Shader stage comes from the file extension.

use std::path::{Path, PathBuf};
// Linked for its libraries only (glslang and SPIRV-Tools beside a system shaderc, see
// tools/shaderc-link); a crate that is never named is not linked.
use tiltfield_shaderc_link as _;

fn main() {
    let shader_dir = Path::new("shaders");
    println!("cargo:rerun-if-changed=shaders");
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    let compiler = shaderc::Compiler::new().expect("shaderc compiler");
    let mut entries: Vec<_> = std::fs::read_dir(shader_dir)
        .expect("shaders/ folder")
        .map(|e| e.expect("readable entry").path())
        .collect();
    entries.sort();
    for path in entries {
        println!("cargo:rerun-if-changed={}", path.display());
        let kind = match path.extension().and_then(|e| e.to_str()) {
            Some("vert") => shaderc::ShaderKind::Vertex,
            Some("frag") => shaderc::ShaderKind::Fragment,
            Some("comp") => shaderc::ShaderKind::Compute,
            _ => continue, // includes (.glsl) are compiled as part of their users
        };
        let source = std::fs::read_to_string(&path).expect("shader source");
        let mut options = shaderc::CompileOptions::new().expect("shaderc options");
        options.set_target_env(
            shaderc::TargetEnv::Vulkan,
            shaderc::EnvVersion::Vulkan1_3 as u32,
        );
        options.set_optimization_level(shaderc::OptimizationLevel::Performance);
        options.set_warnings_as_errors();
        options.set_include_callback(|name, _, _, _| {
            let p = shader_dir.join(name);
            let content = std::fs::read_to_string(&p)
                .map_err(|e| format!("cannot include {}: {e}", p.display()))?;
            Ok(shaderc::ResolvedInclude {
                resolved_name: p.display().to_string(),
                content,
            })
        });
        let name = path.file_name().unwrap().to_str().unwrap();
        let spirv = compiler
            .compile_into_spirv(&source, kind, name, "main", Some(&options))
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        std::fs::write(out.join(format!("{name}.spv")), spirv.as_binary_u8())
            .expect("write SPIR-V");
    }
}
