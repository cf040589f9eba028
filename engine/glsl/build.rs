//! Links Debian's static glslang and SPIRV-Tools archives (Debian's `libshaderc_combined.a` does
//! not bundle them, unlike the Vulkan SDK's) into everything that uses this crate: the engine and
//! the engine's build script, which compiles the kernels to SPIR-V ahead of time.
use std::{env, path::Path};

fn main() {
    if let Ok(dir) = env::var("SHADERC_LIB_DIR") {
        println!("cargo:rustc-link-search=native={dir}");
        for lib in [
            "glslang",
            "MachineIndependent",
            "GenericCodeGen",
            "OSDependent",
            "OGLCompiler",
            "SPIRV",
            "glslang-default-resource-limits",
            "SPIRV-Tools-opt",
            "SPIRV-Tools",
        ] {
            if Path::new(&dir).join(format!("lib{lib}.a")).exists() {
                println!("cargo:rustc-link-lib=static={lib}");
            }
        }
    }
    println!("cargo:rerun-if-env-changed=SHADERC_LIB_DIR");
    println!("cargo:rerun-if-changed=build.rs");
}
