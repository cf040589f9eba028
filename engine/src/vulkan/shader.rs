//! [`ShaderCompiler`]: GLSL compute shaders -> SPIR-V with shaderc, at run time.
//!
//! Sources come either from the copy embedded at build time (`build.rs` writes
//! `EMBEDDED_SHADERS`, so binaries run from any directory) or from a directory on disk (the
//! viewer's hot reload). Paths are relative to the shaders root, e.g. `"forward.comp"`;
//! `#include "inc/x.glsl"` resolves against the root first, then the including file's folder.
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use super::error::GpuError;

mod embedded {
    include!(concat!(env!("OUT_DIR"), "/embedded_shaders.rs"));
}

/// Set by [`ShaderCompiler::override_embedded`]: when `Some`, [`ShaderCompiler::embedded`] reads
/// from this directory instead of the built-in copy.
static EMBEDDED_OVERRIDE: Mutex<Option<PathBuf>> = Mutex::new(None);

enum Source {
    Embedded,
    Dir(PathBuf),
}

pub struct ShaderCompiler {
    compiler: shaderc::Compiler,
    source: Source,
}

/// Normalises `a/./b/../c` to `a/c` with forward slashes; `None` if it escapes the root.
fn normalize(path: &str) -> Option<String> {
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

impl ShaderCompiler {
    fn with_source(source: Source) -> Result<Self, GpuError> {
        let compiler = shaderc::Compiler::new().ok_or_else(|| GpuError::Shader {
            path: String::new(),
            log: "cannot initialise the shaderc compiler".into(),
        })?;
        Ok(ShaderCompiler { compiler, source })
    }

    /// Compiles the sources embedded in the binary at build time (or, after
    /// [`override_embedded`](Self::override_embedded)`(Some(dir))`, the sources in `dir`).
    pub fn embedded() -> Result<Self, GpuError> {
        let dir = EMBEDDED_OVERRIDE.lock().unwrap_or_else(|e| e.into_inner()).clone();
        match dir {
            Some(d) => Self::with_source(Source::Dir(d)),
            None => Self::with_source(Source::Embedded),
        }
    }

    /// Makes every later [`embedded`](Self::embedded) call in this process read its sources from
    /// `dir` (`None` restores the built-in copy). This is how the viewer hot-reloads the engine's
    /// own kernels: `Renderer::new` compiles through `embedded()`, so building a new `Renderer`
    /// after an edit picks up the edited files without a second copy of the renderer.
    pub fn override_embedded(dir: Option<PathBuf>) {
        *EMBEDDED_OVERRIDE.lock().unwrap_or_else(|e| e.into_inner()) = dir;
    }

    /// Reads sources from `dir` at every [`compile`](Self::compile) (hot reload).
    pub fn from_dir(dir: impl Into<PathBuf>) -> Result<Self, GpuError> {
        Self::with_source(Source::Dir(dir.into()))
    }

    /// Source text of `rel` (normalised, relative to the shaders root), if it exists.
    fn load(&self, rel: &str) -> Option<String> {
        let rel = normalize(rel)?;
        match &self.source {
            Source::Embedded => embedded::EMBEDDED_SHADERS
                .iter()
                .find(|(p, _)| *p == rel)
                .map(|(_, s)| s.to_string()),
            Source::Dir(dir) => std::fs::read_to_string(dir.join(&rel)).ok(),
        }
    }

    /// Compiles the compute shader at `path` with `#define NAME VALUE` for each of `defines`.
    /// Target: Vulkan 1.1 / SPIR-V 1.3, entry point `main`, optimised, warnings are errors.
    pub fn compile(&self, path: &str, defines: &[(&str, &str)]) -> Result<Vec<u32>, GpuError> {
        let err = |log: String| GpuError::Shader {
            path: path.to_string(),
            log,
        };
        let rel = normalize(path).ok_or_else(|| err("path escapes the shaders root".into()))?;
        let src = self.load(&rel).ok_or_else(|| {
            err(match &self.source {
                Source::Embedded => "no such embedded shader (is it under shaders/ at build time?)".into(),
                Source::Dir(d) => format!("cannot read {}", d.join(&rel).display()),
            })
        })?;

        let mut opts = shaderc::CompileOptions::new().ok_or_else(|| err("cannot create shaderc options".into()))?;
        opts.set_source_language(shaderc::SourceLanguage::GLSL);
        opts.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_1 as u32);
        opts.set_target_spirv(shaderc::SpirvVersion::V1_3);
        opts.set_optimization_level(shaderc::OptimizationLevel::Performance);
        opts.set_warnings_as_errors();
        for (k, v) in defines {
            opts.add_macro_definition(k, Some(v));
        }
        // The resolved name is the root-relative path: it shows up in error messages and is
        // what nested relative includes are resolved against.
        opts.set_include_callback(|requested, _ty, includer, _depth| {
            let includer_dir = Path::new(includer).parent().map(|p| p.to_string_lossy().into_owned());
            let mut tries = vec![requested.to_string()];
            if let Some(d) = includer_dir.filter(|d| !d.is_empty()) {
                tries.push(format!("{d}/{requested}"));
            }
            for t in &tries {
                if let Some(n) = normalize(t) {
                    if let Some(content) = self.load(&n) {
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

        let artifact = self
            .compiler
            .compile_into_spirv(&src, shaderc::ShaderKind::Compute, &rel, "main", Some(&opts))
            .map_err(|e| {
                err(match e {
                    shaderc::Error::CompilationError(_, log) => log,
                    e => e.to_string(),
                })
            })?;
        Ok(artifact.as_binary().to_vec())
    }
}
