//! Compiles the GLSL shaders in `shaders/` to SPIR-V in OUT_DIR with shaderc; the crate embeds
//! them with `include_bytes!`. Shader stage comes from the file extension.
//!
//! Also digests the depth estimator's source (`src/depth/`, its GPU pass `src/passes/depth/`,
//! its pipeline `src/jobs/depth.rs`, `shaders/depth_*`) into
//! `TILTFIELD_DEPTH_SOURCE_DIGEST`, part of the depth cache's key: an estimate cached by a
//! build whose estimator differed is never served (a hand-kept version number was once left
//! unbumped, and caches served the old estimates).

use std::path::{Path, PathBuf};
// Linked for its libraries only (glslang and SPIRV-Tools beside a system shaderc, see
// tools/shaderc-link); a crate that is never named is not linked.
use tiltfield_shaderc_link as _;

fn main() {
    let shader_dir = Path::new("shaders");
    println!("cargo:rerun-if-changed=shaders");
    for dir in DEPTH_SOURCE_DIRS {
        println!("cargo:rerun-if-changed={dir}");
    }
    println!("cargo:rerun-if-changed={DEPTH_JOB}");
    println!(
        "cargo:rustc-env=TILTFIELD_DEPTH_SOURCE_DIGEST={:016x}",
        depth_source_digest(shader_dir)
    );
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

/// Folders whose every file is part of the depth estimator.
const DEPTH_SOURCE_DIRS: [&str; 2] = ["src/depth", "src/passes/depth"];
/// The job that runs the estimator's stages in order (the order is part of the estimate).
const DEPTH_JOB: &str = "src/jobs/depth.rs";

/// FNV-1a over the depth estimator's source files (name and bytes, in name order): anything
/// that may change an estimate changes the digest. Comment edits do too, which only costs a
/// fresh estimate.
fn depth_source_digest(shader_dir: &Path) -> u64 {
    let mut files: Vec<PathBuf> = DEPTH_SOURCE_DIRS
        .iter()
        .flat_map(|dir| std::fs::read_dir(dir).expect("depth source folder"))
        .map(|e| e.expect("readable entry").path())
        .collect();
    files.push(PathBuf::from(DEPTH_JOB));
    files.extend(
        std::fs::read_dir(shader_dir)
            .expect("shaders/ folder")
            .map(|e| e.expect("readable entry").path())
            .filter(|p| {
                p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| n.starts_with("depth_"))
            }),
    );
    files.sort();
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for path in files {
        let name = path.to_string_lossy().into_owned();
        let bytes = std::fs::read(&path).expect("readable source");
        for b in name.bytes().chain(bytes) {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    h
}
