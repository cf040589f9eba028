//! Hot reload: every [`POLL`](super::POLL), the design's files and the shader directory are
//! checked for changes; a changed design is reloaded (a broken one is reported and the previous
//! scene kept), changed shaders are recompiled (a compile error keeps the last good pipelines).
use std::time::Instant;

use anyhow::Result;
use scratchart_vulkan::{GpuError, ShaderCompiler};

use super::{App, POLL};
use crate::design::{dir_fingerprint, mtimes, Design};

impl App {
    /// Polls the design files and the shader directory (every [`POLL`]).
    pub(super) fn poll_files(&mut self) -> Result<()> {
        let now = Instant::now();
        if now.duration_since(self.last_poll) < POLL {
            return Ok(());
        }
        self.last_poll = now;
        let m = mtimes(&self.design.watched);
        if m != self.design_mtimes {
            self.design_mtimes = m;
            let path = self.design.path.clone().expect("watched files imply a design file");
            match Design::load(&path) {
                Ok(d) => {
                    eprintln!(
                        "reloaded {} ({} scratches, {} views)",
                        path.display(),
                        d.scene.scratches.len(),
                        d.scene.views.len()
                    );
                    self.fr.set_scene(&d.scene);
                    self.design_mtimes = mtimes(&d.watched);
                    self.design = d;
                    self.view_idx = self.view_idx.min(self.design.scene.views.len() - 1);
                    self.rebuild_walk();
                    if self.setup.is_some() {
                        self.setup = None;
                        self.toggle_setup();
                    }
                    if self.show_target {
                        self.show_target = false;
                        self.fr.set_target(None)?;
                        self.toggle_target()?;
                    }
                    self.reload_error = None;
                    self.bump();
                }
                Err(e) => {
                    eprintln!("reload failed, keeping the previous scene: {e:#}");
                    self.reload_error = Some(format!("{e:#}"));
                    self.last_title = None;
                }
            }
        }
        if let Some(dir) = self.shaders.clone() {
            let fp = dir_fingerprint(&dir);
            if fp != self.shader_fp {
                self.shader_fp = fp;
                ShaderCompiler::override_embedded(Some(dir.clone()));
                match self.fr.reload_shaders() {
                    Ok(()) => {
                        eprintln!("shaders recompiled from {}", dir.display());
                        self.fr.set_scene(&self.design.scene);
                        self.bump();
                    }
                    Err(e @ GpuError::Shader { .. }) => {
                        eprintln!("shader reload failed, keeping the last good pipelines:\n{e}")
                    }
                    Err(e) => return Err(e.into()),
                }
            }
        }
        Ok(())
    }
}
