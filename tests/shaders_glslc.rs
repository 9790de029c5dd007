//! Every shader compiles, with the SPIR-V optimizer on, under Debian 12's shaderc 2023.2
//! (glslang 12, its `glslc` command line) as well as under the shaderc that `build.rs` linked.
//!
//! The build uses whichever shaderc the machine offers: the system's static libraries where
//! Debian's packages are installed, else a from-source build of a newer glslang. The two
//! accept different GLSL (glslang 12's optimizer rejects, for example, a conditional that
//! chooses between structs of two block layouts), so this test keeps the shaders inside what
//! both accept, whichever path this build took. `tools/setup.sh` installs `glslc`.

use std::path::Path;
use std::process::Command;

#[test]
fn every_shader_compiles_with_debian_glslc_and_the_optimizer() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let out = tempfile::tempdir().expect("temporary folder");
    let mut compiled = 0;
    let mut failures = Vec::new();
    let mut entries: Vec<_> = std::fs::read_dir(&dir)
        .expect("shaders/ folder")
        .map(|e| e.expect("readable entry").path())
        .collect();
    entries.sort();
    for path in entries {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        if !matches!(ext, "vert" | "frag" | "comp") {
            continue; // includes are compiled as part of their users
        }
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let result = Command::new("glslc")
            .args(["-O", "--target-env=vulkan1.3", "-Werror", "-I"])
            .arg(&dir)
            .arg("-o")
            .arg(out.path().join(format!("{name}.spv")))
            .arg(&path)
            .output()
            .unwrap_or_else(|e| {
                panic!("cannot run glslc ({e}): install the Debian package glslc (tools/setup.sh)")
            });
        if result.status.success() {
            compiled += 1;
        } else {
            failures.push(format!(
                "{name}: {}",
                String::from_utf8_lossy(&result.stderr).trim()
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "glslc -O failed:\n{}",
        failures.join("\n")
    );
    // The shaders build.rs embeds: one per stage file (see src/gpu/shaders.rs).
    assert!(
        compiled >= 10,
        "only {compiled} shaders found in {}",
        dir.display()
    );
}
