//! Build-time only. tiltfield's build script compiles the shaders with the `shaderc` crate; this
//! crate exists for its build script's side effect (see `build.rs`): when shaderc-sys links a
//! system `libshaderc_combined.a` that holds shaderc's own code only, as Debian 12's
//! `libshaderc-dev` does, it adds the glslang and SPIRV-Tools static libraries that archive
//! needs. A build script that depends on this crate must name it (`use tiltfield_shaderc_link
//! as _;`): crates that are never named are not linked, and neither are their libraries.
