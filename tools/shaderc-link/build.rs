//! Decides whether the shaderc libraries need glslang and SPIRV-Tools beside them, and links them.
//!
//! shaderc-sys 0.10 (with `prefer-static-linking`, without `build-from-source`) searches one
//! folder for shaderc: `$SHADERC_LIB_DIR`, else `$VULKAN_SDK/lib`, else the folder pkg-config
//! gives for `shaderc`, else Debian's multiarch library folder. If that folder holds
//! `libshaderc_combined.a` it links it statically; otherwise it builds shaderc (with glslang and
//! SPIRV-Tools) from source. This script repeats that search. A combined archive from shaderc's
//! own build (the Vulkan SDK's) contains glslang and SPIRV-Tools, and then nothing is added.
//! Debian's contains shaderc's code only (its symbol index defines no glslang symbol); then the
//! glslang 12 (`glslang-dev`) and SPIRV-Tools (`spirv-tools`) static libraries from the same
//! folder are linked, each as a whole archive, so the link does not depend on where the linker
//! meets them among the build script's other libraries. If they are missing, the build stops
//! with the packages to install rather than with a page of undefined symbols.

use std::path::{Path, PathBuf};

/// What glslang 12 and SPIRV-Tools split into on Debian 12, in dependency order.
const SYSTEM_LIBS: &[&str] = &[
    "glslang",
    "SPIRV",
    "MachineIndependent",
    "OSDependent",
    "GenericCodeGen",
    "OGLCompiler",
    "glslang-default-resource-limits",
    "SPIRV-Tools-opt",
    "SPIRV-Tools",
];

/// A symbol only glslang defines (`glslang::TShader::TShader(EShLanguage)`, mangled).
const GLSLANG_SYMBOL: &[u8] = b"_ZN7glslang7TShaderC";

fn main() {
    println!("cargo:rerun-if-env-changed=SHADERC_LIB_DIR");
    println!("cargo:rerun-if-env-changed=VULKAN_SDK");
    let Some(dir) = search_dir() else { return };
    let combined = dir.join("libshaderc_combined.a");
    let Ok(archive) = std::fs::read(&combined) else {
        // No system shaderc: shaderc-sys builds it from source, glslang included. No
        // rerun-if-changed on the missing file (cargo would rerun this script, and rebuild
        // everything after it, on every build); like shaderc-sys, a later install of the
        // packages takes effect on a clean build.
        return;
    };
    println!("cargo:rerun-if-changed={}", combined.display());
    if defines_symbol(&archive, GLSLANG_SYMBOL) {
        return; // a complete combined library
    }
    let missing: Vec<&str> = SYSTEM_LIBS
        .iter()
        .copied()
        .filter(|lib| !dir.join(format!("lib{lib}.a")).is_file())
        .collect();
    if !missing.is_empty() {
        panic!(
            "{} holds shaderc without glslang and SPIRV-Tools (Debian's libshaderc-dev), but \
             {} lacks the static libraries {}: install the Debian packages glslang-dev and \
             spirv-tools (tools/setup.sh does), or remove libshaderc-dev to build shaderc from \
             source",
            combined.display(),
            dir.display(),
            missing.join(", ")
        );
    }
    println!("cargo:rustc-link-search=native={}", dir.display());
    for lib in SYSTEM_LIBS {
        println!("cargo:rustc-link-lib=static:+whole-archive={lib}");
    }
    // glslang and SPIRV-Tools are C++.
    println!("cargo:rustc-link-lib=dylib=stdc++");
}

/// The folder shaderc-sys 0.10.1 searches (its `get_search_dir`), or None where it would build
/// from source without searching.
fn search_dir() -> Option<PathBuf> {
    if let Some(dir) = std::env::var_os("SHADERC_LIB_DIR") {
        return Some(PathBuf::from(dir));
    }
    if let Some(sdk) = std::env::var_os("VULKAN_SDK") {
        return Some(Path::new(&sdk).join("lib"));
    }
    let probe = pkg_config::Config::new()
        .cargo_metadata(false)
        .env_metadata(false)
        .probe("shaderc");
    if let Ok(lib) = probe {
        if let Some(dir) = lib.link_paths.first() {
            return Some(dir.clone());
        }
    }
    if std::env::var("CARGO_CFG_TARGET_OS").ok()? != "linux" {
        return None;
    }
    let arch = match std::env::var("CARGO_CFG_TARGET_ARCH").ok()?.as_str() {
        "x86" => "i386".to_owned(),
        arch => arch.to_owned(),
    };
    let debian = PathBuf::from(format!("/usr/lib/{arch}-linux-gnu"));
    if debian.exists() {
        Some(debian)
    } else if arch == "x86_64" && Path::new("/usr/lib64").exists() {
        Some(PathBuf::from("/usr/lib64"))
    } else {
        Some(PathBuf::from("/usr/lib"))
    }
}

/// Whether a System V / GNU `ar` archive's symbol index (its first member, named `/`) lists a
/// defined symbol starting with `prefix`. The index holds a big-endian count, that many
/// offsets, then the NUL-terminated names of the symbols the archive defines.
fn defines_symbol(archive: &[u8], prefix: &[u8]) -> bool {
    const MAGIC: &[u8] = b"!<arch>\n";
    const HEADER: usize = 60;
    if !archive.starts_with(MAGIC) || archive.len() < MAGIC.len() + HEADER {
        return false;
    }
    let header = &archive[MAGIC.len()..MAGIC.len() + HEADER];
    if !header.starts_with(b"/ ") {
        return false;
    }
    let size: usize = match std::str::from_utf8(&header[48..58])
        .ok()
        .and_then(|s| s.trim().parse().ok())
    {
        Some(size) => size,
        None => return false,
    };
    let start = MAGIC.len() + HEADER;
    let Some(index) = archive.get(start..start + size) else {
        return false;
    };
    let Some(count) = index.get(..4) else {
        return false;
    };
    let count = u32::from_be_bytes([count[0], count[1], count[2], count[3]]) as usize;
    let Some(names) = index.get(4 + 4 * count..) else {
        return false;
    };
    names
        .split(|&b| b == 0)
        .any(|name| name.starts_with(prefix))
}
