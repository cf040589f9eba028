//! A design as the viewer sees it: the engine's [`Scene`] plus optional per-view target images,
//! and the files to watch for hot reload.
//!
//! Targets: a view may carry `"target": "relative/path.png"` in the design file (the engine's
//! parser ignores unknown fields, so we read it here); otherwise `NAME_target.png` next to the
//! design is used when it exists.
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use anyhow::{Context as _, Result};
use scratchart_model::scene::Scene;

/// A target image as display values in [0, 1], top row first.
#[derive(Clone, Debug)]
pub struct Target {
    pub path: PathBuf,
    pub width: u32,
    pub height: u32,
    pub data: Vec<f32>,
}

pub struct Design {
    /// `None` for the built-in demo plate.
    pub path: Option<PathBuf>,
    pub scene: Scene,
    /// One entry per view.
    pub targets: Vec<Option<Target>>,
    /// The design file and a scratch CSV it names: reloaded when one of their mtimes changes.
    pub watched: Vec<PathBuf>,
    /// Arcs rendered as this many chords each: a design made with `--arcs` as its summary.json
    /// says it was judged (None: the accuracy bar's rule).
    pub arc_chords: Option<u32>,
}

/// Resolution of the built-in demo's views (only `--view N` screenshots use it).
pub const DEMO_RES: u32 = 256;

impl Design {
    pub fn demo() -> Design {
        let scene = scratchart_design::scenes::demo_scene(DEMO_RES);
        Design {
            path: None,
            targets: vec![None; scene.views.len()],
            scene,
            watched: Vec::new(),
            arc_chords: None,
        }
    }

    /// A live design's problem as the viewer shows it: its views, its initial scratches, and
    /// each view's target as the loss uses it.
    pub fn live(problem: &scratchart_design::Problem) -> Design {
        let scene = problem.scene.clone();
        let targets = scene
            .views
            .iter()
            .zip(&problem.targets)
            .map(|(v, t)| {
                Some(Target {
                    path: PathBuf::from(format!("(the target of {})", v.name)),
                    width: v.camera.width,
                    height: v.camera.height,
                    data: t.clone(),
                })
            })
            .collect();
        Design {
            path: None,
            scene,
            targets,
            watched: Vec::new(),
            arc_chords: None,
        }
    }

    pub fn load(path: &Path) -> Result<Design> {
        let (scene, warnings) = Scene::load_with_warnings(path)?;
        for w in warnings {
            eprintln!("warning: {w}");
        }
        let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
        // Scene::load accepted the file, so it is valid JSON.
        let json: serde_json::Value =
            serde_json::from_str(&text).with_context(|| format!("{} is not valid JSON", path.display()))?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let mut watched = vec![path.to_path_buf()];
        if let Some(csv) = json.get("scratches").and_then(|s| s.as_str()) {
            watched.push(dir.join(csv));
        }
        let jviews = json.get("views").and_then(|v| v.as_array());
        let mut targets = Vec::with_capacity(scene.views.len());
        for (i, view) in scene.views.iter().enumerate() {
            let named = jviews
                .and_then(|a| a.get(i))
                .and_then(|v| v.get("target"))
                .and_then(|t| t.as_str())
                .map(|t| dir.join(t));
            let tpath = named
                .clone()
                .unwrap_or_else(|| dir.join(format!("{}_target.png", view.name)));
            let target = if tpath.exists() {
                match scratchart_render::io::read_image_gray(&tpath) {
                    Ok((width, height, data)) => Some(Target {
                        path: tpath,
                        width,
                        height,
                        data,
                    }),
                    Err(e) => {
                        eprintln!("warning: view '{}': {e}; showing no target", view.name);
                        None
                    }
                }
            } else {
                if named.is_some() {
                    eprintln!(
                        "warning: view '{}': target {} does not exist",
                        view.name,
                        tpath.display()
                    );
                }
                None
            };
            targets.push(target);
        }
        Ok(Design {
            path: Some(path.to_path_buf()),
            arc_chords: scratchart_design::arcs::judged_arc_chords(path),
            scene,
            targets,
            watched,
        })
    }

    /// Display name for titles and logs.
    pub fn name(&self) -> String {
        match &self.path {
            Some(p) => p.display().to_string(),
            None => "demo plate".into(),
        }
    }

    /// Index of the view named by `sel`: a 0-based index or a view name.
    pub fn view_index(&self, sel: &str) -> Result<usize> {
        let views = &self.scene.views;
        if let Ok(i) = sel.trim().parse::<usize>() {
            if i < views.len() {
                return Ok(i);
            }
        }
        views.iter().position(|v| v.name == sel).ok_or_else(|| {
            scratchart_exit::UsageError(format!(
                "no view '{sel}' in {} (it has {} views: {})",
                self.name(),
                views.len(),
                views
                    .iter()
                    .enumerate()
                    .map(|(i, v)| format!("{i} = {}", v.name))
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
            .into()
        })
    }
}

/// Modification times of `files` (`None` where a file cannot be read), to poll for changes.
pub fn mtimes(files: &[PathBuf]) -> Vec<Option<SystemTime>> {
    files
        .iter()
        .map(|f| std::fs::metadata(f).and_then(|m| m.modified()).ok())
        .collect()
}

/// Every file under `dir` (recursively) with its mtime, sorted: a cheap fingerprint of a shader
/// directory for hot reload.
pub fn dir_fingerprint(dir: &Path) -> Vec<(PathBuf, Option<SystemTime>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let m = e.metadata().and_then(|m| m.modified()).ok();
                out.push((p, m));
            }
        }
    }
    out.sort();
    out
}
