//! Build script: links Debian's static glslang and SPIRV-Tools archives (Debian's
//! `libshaderc_combined.a` does not bundle them, unlike the Vulkan SDK's), and embeds the
//! GLSL sources of `../shaders` so the binaries run from any directory.
use std::{env, fs, path::Path};

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

    // Embed every shader under ../shaders as (relative path, source).
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders");
    let mut entries = Vec::new();
    collect(&root, &root, &mut entries);
    entries.sort();
    let mut out = String::from("pub static EMBEDDED_SHADERS: &[(&str, &str)] = &[\n");
    for rel in &entries {
        let abs = root.join(rel).canonicalize().unwrap();
        out += &format!("    ({rel:?}, include_str!({:?})),\n", abs.display().to_string());
    }
    out += "];\n";
    let dest = Path::new(&env::var("OUT_DIR").unwrap()).join("embedded_shaders.rs");
    fs::write(dest, out).unwrap();
    println!("cargo:rerun-if-changed={}", root.display());
}

fn collect(root: &Path, dir: &Path, out: &mut Vec<String>) {
    let Ok(rd) = fs::read_dir(dir) else { return };
    for e in rd.flatten() {
        let p = e.path();
        println!("cargo:rerun-if-changed={}", p.display());
        if p.is_dir() {
            collect(root, &p, out);
        } else if matches!(p.extension().and_then(|s| s.to_str()), Some("glsl" | "comp")) {
            out.push(p.strip_prefix(root).unwrap().to_string_lossy().replace('\\', "/"));
        }
    }
}
