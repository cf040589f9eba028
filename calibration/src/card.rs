//! The calibration card: what to cut and how to photograph it.
//!
//! Layout on a square plate: one row per commanded depth, one column per (orientation, repeat);
//! each cell holds one straight cut through its centre. The depth ladder starts above commanded
//! zero and steps finely near it, so the z offset shows as the first depth at which grooves
//! appear, and the tip flat as their width there; deeper rungs then show how the width grows
//! (the tool's angle or radius). Four fiducial crosses, cut deep, mark the corners for
//! registering a photo that is not square-on.
use std::path::Path;

use scratchart::model::scene::{Camera, Light, LightKind, Plate, Scene, View};
use scratchart_machine::gcode::{write_blocks, Options};
use scratchart_machine::plan::{self as machine_plan, Block, MachineProfile};
use serde::{Deserialize, Serialize};
use serde_json::{json, Value};

/// One cut of the card: endpoints on the plate (mm) and the commanded depth.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cut {
    pub p0: [f64; 2],
    pub p1: [f64; 2],
    /// Commanded depth, mm (negative: above commanded zero).
    pub z_mm: f64,
    /// "ladder" or "fiducial"
    pub role: CutRole,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CutRole {
    Ladder,
    Fiducial,
}

/// The card's own fields (`card` in card.json).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Card {
    pub plate_mm: f64,
    /// The depth ladder, mm, increasing.
    pub depths_mm: Vec<f64>,
    pub orientations_deg: Vec<f64>,
    pub repeats: u32,
    /// Length of each ladder cut, mm.
    pub cut_mm: f64,
    /// Roughness of the cut walls assumed when rendering (the fit estimates it).
    pub alpha: f64,
    pub cuts: Vec<Cut>,
}

/// How far above commanded zero a card's rung may sit, mm. A design's commanded depths start at
/// the plate's surface (`surface_depth_mm`: its grooves are cut into the plate); the card's rungs
/// above zero are commanded at negative depth, so the tool stays above Z0 there and shows where
/// the real surface is.
pub const MAX_ABOVE_ZERO_MM: f64 = 0.5;

/// How a card is laid out.
#[derive(Clone, Debug)]
pub struct CardSpec {
    pub plate_mm: f64,
    pub depths_mm: Vec<f64>,
    pub orientations_deg: Vec<f64>,
    pub repeats: u32,
    /// Resolution of each capture view (square), pixels.
    pub res: u32,
}

impl Default for CardSpec {
    fn default() -> CardSpec {
        CardSpec {
            plate_mm: 70.0,
            // From 20 um above commanded zero, 5 um steps to 20 um below, then coarser.
            depths_mm: vec![
                -0.02, -0.015, -0.01, -0.005, 0.0, 0.005, 0.01, 0.015, 0.02, 0.03, 0.04, 0.06, 0.08, 0.1,
            ],
            orientations_deg: vec![0.0, 45.0, 90.0, 135.0],
            repeats: 2,
            res: 256,
        }
    }
}

impl Card {
    /// Lays out the card of `spec`.
    pub fn new(spec: &CardSpec) -> Card {
        let (rows, cols) = (
            spec.depths_mm.len(),
            spec.orientations_deg.len() * spec.repeats as usize,
        );
        let margin = 0.12 * spec.plate_mm;
        let span = spec.plate_mm - 2.0 * margin;
        let cell = (span / rows.max(cols) as f64).min(span / rows as f64);
        let cut_mm = 0.7 * cell;
        let (x0, y0) = (-0.5 * cell * cols as f64, 0.5 * cell * rows as f64);
        let mut cuts = Vec::new();
        for (r, &z) in spec.depths_mm.iter().enumerate() {
            for c in 0..cols {
                let a = spec.orientations_deg[c % spec.orientations_deg.len()].to_radians();
                let centre = [x0 + (c as f64 + 0.5) * cell, y0 - (r as f64 + 0.5) * cell];
                let h = [0.5 * cut_mm * a.cos(), 0.5 * cut_mm * a.sin()];
                cuts.push(Cut {
                    p0: [centre[0] - h[0], centre[1] - h[1]],
                    p1: [centre[0] + h[0], centre[1] + h[1]],
                    z_mm: z,
                    role: CutRole::Ladder,
                });
            }
        }
        // Fiducial crosses in the corners, cut to the deepest rung.
        let deep = spec.depths_mm.iter().cloned().fold(0.0, f64::max);
        let f = 0.5 * spec.plate_mm - 0.5 * margin;
        let arm = 0.3 * margin;
        for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            let c = [sx * f, sy * f];
            cuts.push(Cut {
                p0: [c[0] - arm, c[1]],
                p1: [c[0] + arm, c[1]],
                z_mm: deep,
                role: CutRole::Fiducial,
            });
            cuts.push(Cut {
                p0: [c[0], c[1] - arm],
                p1: [c[0], c[1] + arm],
                z_mm: deep,
                role: CutRole::Fiducial,
            });
        }
        Card {
            plate_mm: spec.plate_mm,
            depths_mm: spec.depths_mm.clone(),
            orientations_deg: spec.orientations_deg.clone(),
            repeats: spec.repeats,
            cut_mm,
            alpha: 0.1,
            cuts,
        }
    }

    /// The capture set-up: two views 90 degrees apart at 50 degrees elevation, each with the lamp
    /// a quarter turn round from its camera and lower (35 degrees): the flat plate then sends the
    /// lamp's light away from the camera (a dark field), and only groove walls tilted towards the
    /// camera light up, more of them the deeper and wider the cut.
    pub fn views(&self, res: u32) -> Vec<View> {
        let d = 4.0 * self.plate_mm;
        let place = |az: f64, el: f64| {
            let (a, e) = (az.to_radians(), el.to_radians());
            [d * e.cos() * a.cos(), d * e.cos() * a.sin(), d * e.sin()]
        };
        [("cam_south", -90.0), ("cam_west", 180.0)]
            .iter()
            .map(|&(name, az)| View {
                name: name.into(),
                camera: Camera {
                    eye: place(az, 50.0),
                    target: [0.0, 0.0, 0.0],
                    up: [0.0, 0.0, 1.0],
                    fov_y_deg: 2.0 * (0.8 * self.plate_mm / d).atan().to_degrees(),
                    width: res,
                    height: res,
                },
                light: Light {
                    kind: LightKind::Point {
                        position: place(az + 90.0, 35.0),
                    },
                    intensity: 1.0e5,
                },
            })
            .collect()
    }

    /// card.json: a MODEL.md scene (the bare card plate seen from the capture views) with the
    /// card's fields under `card`.
    pub fn to_json(&self, res: u32) -> Value {
        let scene = Scene {
            plate: Plate {
                size_mm: self.plate_mm,
                roughness: 0.02,
                f0: 0.91,
            },
            views: self.views(res),
            scratches: vec![],
        };
        let mut v: Value = serde_json::from_str(&scene.to_json_inline()).expect("a scene serializes");
        v["card"] = json!(self);
        v
    }

    /// The card's G-code (`card.nc`, or `card.gcode` for Marlin) through the one G-code writer:
    /// every cut at its commanded depth (rungs above commanded zero at negative depth: the tool
    /// stays above Z0), in the plan's order (nearest neighbour, then 2-opt). Each cut is a block
    /// `; scratch N`, N its place (from 1) in `cuts` of card.json. Refused when a cut leaves the
    /// card or the machine's travel.
    pub fn gcode(&self, m: &MachineProfile) -> Result<String, String> {
        let cuts: Vec<machine_plan::Cut> = self
            .cuts
            .iter()
            .enumerate()
            .map(|(k, c)| machine_plan::Cut {
                a: c.p0,
                b: c.p1,
                z: c.z_mm,
                scratch: k,
            })
            .collect();
        machine_plan::check_cuts(&cuts, self.plate_mm, m, -MAX_ABOVE_ZERO_MM)?;
        let ordered = machine_plan::two_opt(machine_plan::nearest_neighbour(&cuts), 200);
        let blocks: Vec<Block> = ordered.iter().map(Block::flat).collect();
        machine_plan::check_moves(&blocks, m)?;
        let above = self.cuts.iter().filter(|c| c.z_mm < 0.0).count();
        let summary = vec![
            format!(
                "calibration card: {} ladder cuts ({} depths from {} to {} mm), {} fiducial cuts",
                self.cuts.iter().filter(|c| c.role == CutRole::Ladder).count(),
                self.depths_mm.len(),
                self.depths_mm[0],
                self.depths_mm[self.depths_mm.len() - 1],
                self.cuts.iter().filter(|c| c.role == CutRole::Fiducial).count()
            ),
            format!(
                "{above} cuts are above commanded zero (negative depth): the tool stays above Z0 there; \
                 the first rung that leaves a groove shows the tool's z offset"
            ),
            format!("estimated {:.1} min", machine_plan::program_time(&blocks, m) / 60.0),
        ];
        Ok(write_blocks(&blocks, m, self.plate_mm, &summary, &Options::default()))
    }

    /// Reads the card of a card.json (and its capture views).
    pub fn load(path: &Path) -> anyhow::Result<(Card, Scene)> {
        use anyhow::Context as _;
        let scene = Scene::load(path)?;
        let text = std::fs::read_to_string(path)?;
        let v: Value = serde_json::from_str(&text)?;
        let card: Card = serde_json::from_value(v["card"].clone()).with_context(|| {
            format!(
                "`{}` has no valid `card` fields (write one with `scratchart-cal card`)",
                path.display()
            )
        })?;
        Ok((card, scene))
    }
}
