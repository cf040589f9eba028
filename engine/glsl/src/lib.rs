//! GLSL compute shaders to SPIR-V with shaderc (glslang), with the options every scratchart
//! kernel is built with, shared by the engine's build script (which compiles the kernels listed in
//! [`PRECOMPILED`] ahead of time, so a run compiles no GLSL) and by the engine at run time (any
//! other variant, and the viewer's hot reload from a directory).
pub use shaderc;

/// The kernel variants compiled at build time: (file under `shaders/`, defines). A variant that
/// is not here is compiled at run time (`ShaderCompiler` counts those); a test checks that the
/// design job, rendering and the viewer need none. The device-dependent defines of the shading
/// kernels (`SA_NO_F64` without float64, `GRAD_QCAP` by shared-memory size) are listed for both.
pub const PRECOMPILED: &[(&str, &[(&str, &str)])] = &[
    ("bin.comp", &[("COUNT", "1")]),
    ("bin.comp", &[("SCATTER", "1")]),
    ("bin.comp", &[("PAIRS", "1"), ("COUNT", "1")]),
    ("bin.comp", &[("PAIRS", "1"), ("SCATTER", "1")]),
    ("radix.comp", &[("HIST", "1")]),
    ("radix.comp", &[("SCATTER", "1")]),
    ("radix.comp", &[("FINAL", "1")]),
    ("scan.comp", &[("REDUCE", "1")]),
    ("scan.comp", &[("SUMS", "1")]),
    ("scan.comp", &[("APPLY", "1")]),
    ("grad_reduce.comp", &[]),
    ("scratch_records.comp", &[]),
    ("arc_map.comp", &[]),
    ("pixel_records.comp", &[]),
    ("grad_light.comp", &[]),
    ("light_tie.comp", &[]),
    ("forward.comp", &[("SA_INTEGRATOR_CLOSED_FORM", "1")]),
    (
        "forward.comp",
        &[("SA_INTEGRATOR_CLOSED_FORM", "1"), ("SA_NO_F64", "1")],
    ),
    (
        "grad.comp",
        &[
            ("SA_INTEGRATOR_CLOSED_FORM", "1"),
            ("SA_EDGE_ADJOINT", "1"),
            ("GRAD_QCAP", "256"),
        ],
    ),
    (
        "grad.comp",
        &[
            ("SA_INTEGRATOR_CLOSED_FORM", "1"),
            ("SA_EDGE_ADJOINT", "1"),
            ("GRAD_QCAP", "512"),
        ],
    ),
    (
        "grad.comp",
        &[
            ("SA_INTEGRATOR_CLOSED_FORM", "1"),
            ("SA_EDGE_ADJOINT", "1"),
            ("GRAD_QCAP", "256"),
            ("SA_NO_F64", "1"),
        ],
    ),
    (
        "grad.comp",
        &[
            ("SA_INTEGRATOR_CLOSED_FORM", "1"),
            ("SA_EDGE_ADJOINT", "1"),
            ("GRAD_QCAP", "512"),
            ("SA_NO_F64", "1"),
        ],
    ),
    (
        "grad.comp",
        &[
            ("SA_INTEGRATOR_CLOSED_FORM", "1"),
            ("SA_EDGE_ADJOINT", "1"),
            ("GRAD_QCAP", "256"),
            ("SA_REPLAY", "1"),
        ],
    ),
    (
        "grad.comp",
        &[
            ("SA_INTEGRATOR_CLOSED_FORM", "1"),
            ("SA_EDGE_ADJOINT", "1"),
            ("GRAD_QCAP", "256"),
            ("SA_NO_F64", "1"),
            ("SA_REPLAY", "1"),
        ],
    ),
    (
        "grad.comp",
        &[
            ("SA_INTEGRATOR_CLOSED_FORM", "1"),
            ("SA_EDGE_ADJOINT", "1"),
            ("GRAD_QCAP", "512"),
            ("SA_REPLAY", "1"),
        ],
    ),
    (
        "grad.comp",
        &[
            ("SA_INTEGRATOR_CLOSED_FORM", "1"),
            ("SA_EDGE_ADJOINT", "1"),
            ("GRAD_QCAP", "512"),
            ("SA_NO_F64", "1"),
            ("SA_REPLAY", "1"),
        ],
    ),
    // A GPU's backward: each round's entries in masks set by every thread, walked by two threads
    // per scratch (kernels::Walk::Split).
    (
        "grad.comp",
        &[
            ("SA_INTEGRATOR_CLOSED_FORM", "1"),
            ("SA_EDGE_ADJOINT", "1"),
            ("GRAD_QCAP", "512"),
            ("SA_PARALLEL_LINKS", "1"),
            ("SA_WALK_SPLIT", "1"),
        ],
    ),
    (
        "grad.comp",
        &[
            ("SA_INTEGRATOR_CLOSED_FORM", "1"),
            ("SA_EDGE_ADJOINT", "1"),
            ("GRAD_QCAP", "512"),
            ("SA_PARALLEL_LINKS", "1"),
            ("SA_WALK_SPLIT", "1"),
            ("SA_REPLAY", "1"),
        ],
    ),
    (
        "grad.comp",
        &[
            ("SA_INTEGRATOR_CLOSED_FORM", "1"),
            ("SA_EDGE_ADJOINT", "1"),
            ("GRAD_QCAP", "512"),
            ("SA_PARALLEL_LINKS", "1"),
            ("SA_WALK_SPLIT", "1"),
            ("SA_NO_F64", "1"),
        ],
    ),
    (
        "grad.comp",
        &[
            ("SA_INTEGRATOR_CLOSED_FORM", "1"),
            ("SA_EDGE_ADJOINT", "1"),
            ("GRAD_QCAP", "512"),
            ("SA_PARALLEL_LINKS", "1"),
            ("SA_WALK_SPLIT", "1"),
            ("SA_NO_F64", "1"),
            ("SA_REPLAY", "1"),
        ],
    ),
    (
        "tangent.comp",
        &[("SA_INTEGRATOR_CLOSED_FORM", "1"), ("SA_EDGE_ADJOINT", "1")],
    ),
    (
        "tangent.comp",
        &[
            ("SA_INTEGRATOR_CLOSED_FORM", "1"),
            ("SA_EDGE_ADJOINT", "1"),
            ("SA_NO_F64", "1"),
        ],
    ),
    ("loss_fwd.comp", &[("DISPLAY", "1")]),
    ("loss_fwd.comp", &[("POOL", "1")]),
    ("loss_fwd.comp", &[("FEAT", "1")]),
    ("loss_fwd.comp", &[("PARTIAL", "1")]),
    ("loss_fwd.comp", &[("GRAM", "1")]),
    ("loss_fwd.comp", &[("FINAL", "1")]),
    ("loss_fwd.comp", &[("XPART", "1")]),
    ("loss_fwd.comp", &[("XSUM", "1")]),
    ("loss_bwd.comp", &[("XGRAD", "1")]),
    ("loss_bwd.comp", &[("PRE_GRAD", "1")]),
    ("loss_bwd.comp", &[("LEVEL_GRAD", "1")]),
    ("adam.comp", &[("CHECK", "1")]),
    ("adam.comp", &[("APPLY", "1")]),
    ("check_loss.comp", &[("VALUE", "1")]),
    ("check_loss.comp", &[("TOTAL", "1")]),
    ("check_loss.comp", &[("GRAD", "1")]),
    ("scratch_project.comp", &[]),
    ("tool_map.comp", &[]),
    ("view_present.comp", &[]),
];

/// The name of a variant: the file and its defines in sorted order (`forward.comp|A=1|B=2`), so
/// the order in which a caller lists its defines does not matter.
pub fn variant_key(path: &str, defines: &[(&str, &str)]) -> String {
    let mut d: Vec<String> = defines.iter().map(|(k, v)| format!("{k}={v}")).collect();
    d.sort();
    let mut key = normalize(path).unwrap_or_else(|| path.to_string());
    for x in d {
        key.push('|');
        key.push_str(&x);
    }
    key
}

/// Normalises `a/./b/../c` to `a/c` with forward slashes; `None` if it escapes the root.
pub fn normalize(path: &str) -> Option<String> {
    let mut parts: Vec<&str> = Vec::new();
    for p in path.split(['/', '\\']) {
        match p {
            "" | "." => {}
            ".." => {
                parts.pop()?;
            }
            p => parts.push(p),
        }
    }
    Some(parts.join("/"))
}

/// Compiles the compute shader `rel` (a normalised path under the shaders root, whose text
/// `load` returns) with `#define NAME VALUE` for each of `defines`. Target: Vulkan 1.1 /
/// SPIR-V 1.3, entry point `main`, optimised for performance, warnings are errors.
/// `#include "x"` resolves against the root first, then the including file's folder.
/// The error is the compiler's log.
pub fn compile(
    compiler: &shaderc::Compiler,
    load: &dyn Fn(&str) -> Option<String>,
    rel: &str,
    src: &str,
    defines: &[(&str, &str)],
) -> Result<Vec<u32>, String> {
    let mut opts = shaderc::CompileOptions::new().ok_or("cannot create shaderc options")?;
    opts.set_source_language(shaderc::SourceLanguage::GLSL);
    opts.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_1 as u32);
    opts.set_target_spirv(shaderc::SpirvVersion::V1_3);
    opts.set_optimization_level(shaderc::OptimizationLevel::Performance);
    opts.set_warnings_as_errors();
    for (k, v) in defines {
        opts.add_macro_definition(k, Some(v));
    }
    // The resolved name is the root-relative path: it shows up in error messages and is what
    // nested relative includes are resolved against.
    opts.set_include_callback(|requested, _ty, includer, _depth| {
        let includer_dir = std::path::Path::new(includer)
            .parent()
            .map(|p| p.to_string_lossy().into_owned());
        let mut tries = vec![requested.to_string()];
        if let Some(d) = includer_dir.filter(|d| !d.is_empty()) {
            tries.push(format!("{d}/{requested}"));
        }
        for t in &tries {
            if let Some(n) = normalize(t) {
                if let Some(content) = load(&n) {
                    return Ok(shaderc::ResolvedInclude {
                        resolved_name: n,
                        content,
                    });
                }
            }
        }
        Err(format!(
            "cannot find include \"{requested}\" (tried {})",
            tries.join(", ")
        ))
    });
    let artifact = compiler
        .compile_into_spirv(src, shaderc::ShaderKind::Compute, rel, "main", Some(&opts))
        .map_err(|e| match e {
            shaderc::Error::CompilationError(_, log) => log,
            e => e.to_string(),
        })?;
    Ok(artifact.as_binary().to_vec())
}
