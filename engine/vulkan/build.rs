//! Build script: embeds the GLSL sources of the workspace's `shaders/` so the binaries run from any directory,
//! and compiles the kernel variants of `scratchart_glsl::PRECOMPILED` to SPIR-V, so a run
//! compiles no GLSL (the viewer's hot reload and unlisted variants still compile at run time).
//! Linking Debian's static glslang is the `scratchart-glsl` crate's job.
use std::{env, fs, path::Path};

fn main() {
    // Embed every shader under shaders/ as (relative path, source).
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders");
    let mut entries = Vec::new();
    collect(&root, &root, &mut entries);
    entries.sort();
    let mut out = String::from("pub static EMBEDDED_SHADERS: &[(&str, &str)] = &[\n");
    for rel in &entries {
        let abs = root.join(rel).canonicalize().unwrap();
        out += &format!("    ({rel:?}, include_str!({:?})),\n", abs.display().to_string());
    }
    out += "];\n";
    let out_dir = env::var("OUT_DIR").unwrap();
    let dest = Path::new(&out_dir).join("embedded_shaders.rs");
    fs::write(dest, out).unwrap();
    println!("cargo:rerun-if-changed={}", root.display());
    precompile(&root, Path::new(&out_dir));
}

/// SPIR-V of every variant in `scratchart_glsl::PRECOMPILED`, as
/// `PRECOMPILED_SPIRV: &[(key, bytes)]` (`scratchart_glsl::variant_key`).
fn precompile(root: &Path, out_dir: &Path) {
    let compiler = scratchart_glsl::shaderc::Compiler::new().expect("cannot initialise the shaderc compiler");
    let load = |rel: &str| fs::read_to_string(root.join(rel)).ok();
    let mut table = String::from("pub static PRECOMPILED_SPIRV: &[(&str, &[u8])] = &[\n");
    for (i, (file, defines)) in scratchart_glsl::PRECOMPILED.iter().enumerate() {
        let rel = scratchart_glsl::normalize(file).unwrap();
        let src =
            load(&rel).unwrap_or_else(|| panic!("shaders/{rel} (listed in scratchart_glsl::PRECOMPILED) is missing"));
        let spirv = scratchart_glsl::compile(&compiler, &load, &rel, &src, defines)
            .unwrap_or_else(|log| panic!("shaders/{rel} with {defines:?} does not compile:\n{log}"));
        let bytes: Vec<u8> = spirv.iter().flat_map(|w| w.to_le_bytes()).collect();
        let spv = out_dir.join(format!("kernel_{i}.spv"));
        fs::write(&spv, bytes).unwrap();
        let key = scratchart_glsl::variant_key(file, defines);
        table += &format!("    ({key:?}, include_bytes!({:?})),\n", spv.display().to_string());
    }
    table += "];\n";
    fs::write(out_dir.join("precompiled_shaders.rs"), table).unwrap();
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
