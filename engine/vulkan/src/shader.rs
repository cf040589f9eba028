//! [`ShaderCompiler`]: GLSL compute shaders -> SPIR-V.
//!
//! Sources come either from the copy embedded at build time (`build.rs` writes
//! `EMBEDDED_SHADERS`, so binaries run from any directory) or from a directory on disk (the
//! viewer's hot reload). The kernel variants the engine and viewer use are compiled by
//! `build.rs` too (`scratchart_glsl::PRECOMPILED`): from the built-in sources they are not
//! compiled again, any other variant is compiled at run time with the same options. Paths are relative to the shaders root, e.g. `"forward.comp"`;
//! `#include "inc/x.glsl"` resolves against the root first, then the including file's folder.
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, OnceLock};

use super::error::GpuError;
use scratchart_glsl::{normalize, shaderc};

mod embedded {
    include!(concat!(env!("OUT_DIR"), "/embedded_shaders.rs"));
}

mod precompiled {
    include!(concat!(env!("OUT_DIR"), "/precompiled_shaders.rs"));
}

/// Set by [`ShaderCompiler::override_embedded`]: when `Some`, [`ShaderCompiler::embedded`] reads
/// from this directory instead of the built-in copy.
static EMBEDDED_OVERRIDE: Mutex<Option<PathBuf>> = Mutex::new(None);

/// GLSL compilations done at run time in this process (see [`ShaderCompiler::runtime_compiles`]).
static RUNTIME_COMPILES: AtomicUsize = AtomicUsize::new(0);

enum Source {
    Embedded,
    Dir(PathBuf),
}

pub struct ShaderCompiler {
    /// Created on the first compilation that needs it (precompiled kernels need none).
    compiler: OnceLock<Option<shaderc::Compiler>>,
    source: Source,
}

impl ShaderCompiler {
    fn with_source(source: Source) -> Result<Self, GpuError> {
        Ok(ShaderCompiler {
            compiler: OnceLock::new(),
            source,
        })
    }

    /// How many GLSL compilations this process has done at run time: variants that were not
    /// compiled at build time (`scratchart_glsl::PRECOMPILED`), and every compilation from a
    /// directory (the viewer's hot reload).
    pub fn runtime_compiles() -> usize {
        RUNTIME_COMPILES.load(Ordering::Relaxed)
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

    /// Compiles the compute shader at `path` with `#define NAME VALUE` for each of `defines`
    /// (see `scratchart_glsl::compile` for the options). Built-in sources of a variant compiled at
    /// build time are not compiled again: its SPIR-V is returned as built.
    pub fn compile(&self, path: &str, defines: &[(&str, &str)]) -> Result<Vec<u32>, GpuError> {
        let err = |log: String| GpuError::Shader {
            path: path.to_string(),
            log,
        };
        let rel = normalize(path).ok_or_else(|| err("path escapes the shaders root".into()))?;
        if let Source::Embedded = self.source {
            let key = scratchart_glsl::variant_key(&rel, defines);
            if let Some((_, bytes)) = precompiled::PRECOMPILED_SPIRV.iter().find(|(k, _)| *k == key) {
                return Ok(bytes
                    .chunks_exact(4)
                    .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
                    .collect());
            }
        }
        let src = self.load(&rel).ok_or_else(|| {
            err(match &self.source {
                Source::Embedded => "no such embedded shader (is it under shaders/ at build time?)".into(),
                Source::Dir(d) => format!("cannot read {}", d.join(&rel).display()),
            })
        })?;
        let compiler = self
            .compiler
            .get_or_init(shaderc::Compiler::new)
            .as_ref()
            .ok_or_else(|| err("cannot initialise the shaderc compiler".into()))?;
        RUNTIME_COMPILES.fetch_add(1, Ordering::Relaxed);
        scratchart_glsl::compile(compiler, &|n| self.load(n), &rel, &src, defines).map_err(err)
    }
}
