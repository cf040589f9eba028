//! The calibration card: what to cut and how to photograph it.
//!
//! Layout on a square plate: one row per commanded depth, one column per (orientation, repeat);
//! each cell holds one straight cut through its centre. The depth ladder starts above commanded
//! zero and steps finely near it, so the z offset shows as the first depth at which grooves
//! appear, and the tip flat as their width there; deeper rungs then show how the width grows
//! (the tool's angle or radius). Odd repeats sit at the point mirror of the even ones, so every
//! depth is seen on both sides of the card. Six fiducial marks (hatched squares, cut deep, see
//! [`Mark`]) in the margin register a photo taken from anywhere near a capture view, turned by
//! any angle, with one mark covered. The same six marks go on every design's plate
//! ([`plate_marks`]): `scratchart-cal plan` carves them and `inspect` finds the plate by them.
//! Their geometry lives in `scratchart_machine::marks`, which `plan` and a design's job time
//! share.
use std::path::Path;

use scratchart_machine::gcode::{write_blocks, Options};
use scratchart_machine::marks::{glint_orientations_spread, Mark, PlateMarks};
use scratchart_machine::plan::{self as machine_plan, Block};
use scratchart_model::scene::{Camera, Light, LightKind, Plate, Scene, View};
use scratchart_tool::machine::MachineProfile;
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
    /// The fiducial marks the fit registers photos by (their cuts are the `fiducial` cuts).
    /// Empty in a card.json written before marks were listed: [`Card::load`] then takes the
    /// corner crosses of its fiducial cuts as marks.
    #[serde(default)]
    pub marks: Vec<Mark>,
}

/// The registration marks of a design's plate (`scratchart_machine::marks::plate_marks`, which
/// this calls): where `inspect` finds the plate in photos, as `plan` carves them.
pub fn plate_marks(plate_mm: f64, views: &[View]) -> PlateMarks {
    scratchart_machine::marks::plate_marks(plate_mm, views)
}

/// The cut orientations (degrees, in [0, 180)) that glint at the card's centre in the capture
/// views ([`glint_orientations_in`] of [`Card::views`]).
pub fn glint_orientations(plate_mm: f64) -> Vec<f64> {
    let probe = Card {
        plate_mm,
        depths_mm: vec![],
        orientations_deg: vec![],
        repeats: 0,
        cut_mm: 0.0,
        alpha: 0.1,
        cuts: vec![],
        marks: vec![],
    };
    glint_orientations_in(&probe.views(64))
}

/// The cut orientations (degrees, in [0, 180), to 0.1 degree) that glint at the plate's centre
/// (the origin) in `views`, +- 15 degrees each, in the views' order, orientations within 5
/// degrees of one already taken left out ([`glint_orientations_spread`]): a cut shows where its
/// walls face the half-vector h of the camera and the lamp, i.e. when it runs across h's
/// horizontal direction. A view whose h is (within 0.06 degree) vertical, its camera seeing the
/// lamp's reflection in the plate, has no such direction: every groove then shows dark on the
/// bright plate, and it takes 0 and 90 degrees (a cross-hatch), as do no views at all.
pub fn glint_orientations_in(views: &[View]) -> Vec<f64> {
    glint_orientations_spread(views, &[-15.0, 0.0, 15.0])
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
        let n_or = spec.orientations_deg.len();
        for (r, &z) in spec.depths_mm.iter().enumerate() {
            for c in 0..cols {
                let a = spec.orientations_deg[c % n_or].to_radians();
                // Odd repeats sit at the point mirror of the even ones (through the card's
                // centre, same orientation): each depth then appears both above and below the
                // centre, and on both sides, so a brightness gradient across the photo
                // (vignetting, uneven light) cannot pass for a change of width with depth.
                let (row, col) = if (c / n_or) % 2 == 1 {
                    (rows - 1 - r, (c / n_or) * n_or + (n_or - 1 - c % n_or))
                } else {
                    (r, c)
                };
                let centre = [x0 + (col as f64 + 0.5) * cell, y0 - (row as f64 + 0.5) * cell];
                let h = [0.5 * cut_mm * a.cos(), 0.5 * cut_mm * a.sin()];
                cuts.push(Cut {
                    p0: [centre[0] - h[0], centre[1] - h[1]],
                    p1: [centre[0] + h[0], centre[1] + h[1]],
                    z_mm: z,
                    role: CutRole::Ladder,
                });
            }
        }
        // Fiducial marks in the margin, cut to the deepest rung: hatched squares (see `Mark`).
        let deep = spec.depths_mm.iter().cloned().fold(0.0, f64::max);
        let marks = Mark::layout(spec.plate_mm, margin);
        let orientations = glint_orientations(spec.plate_mm);
        for m in &marks {
            cuts.extend(m.hatch(&orientations).into_iter().map(|(p0, p1)| Cut {
                p0,
                p1,
                z_mm: deep,
                role: CutRole::Fiducial,
            }));
        }
        Card {
            plate_mm: spec.plate_mm,
            depths_mm: spec.depths_mm.clone(),
            orientations_deg: spec.orientations_deg.clone(),
            repeats: spec.repeats,
            cut_mm,
            alpha: 0.1,
            cuts,
            marks,
        }
    }

    /// The capture set-up: two views 90 degrees apart at 50 degrees elevation, each with the lamp
    /// a quarter turn round from its camera and lower (35 degrees): the flat plate then sends the
    /// lamp's light away from the camera (a dark field), and only groove walls tilted towards the
    /// camera light up, more of them the deeper and wider the cut.
    pub fn views(&self, res: u32) -> Vec<View> {
        let d = 4.0 * self.plate_mm;
        let place = |az: f64, el: f64| scratchart_model::camera::spherical(d, az, el);
        [("cam_south", -90.0), ("cam_west", 180.0)]
            .iter()
            .map(|&(name, az)| View {
                exposure: 1.0,
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

    /// card.json: a engine/docs/model.md scene (the bare card plate seen from the capture views) with the
    /// card's fields under `card`.
    pub fn to_json(&self, res: u32) -> Value {
        let scene = Scene {
            plate: Plate {
                size_mm: self.plate_mm,
                roughness: 0.02,
                f0: 0.91,
                shape: Default::default(),
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
                bulge: 0.0,
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
        let mut card: Card = serde_json::from_value(v["card"].clone()).with_context(|| {
            format!(
                "`{}` has no valid `card` fields (write one with `scratchart-cal card`)",
                path.display()
            )
        })?;
        if card.marks.is_empty() {
            // A card written before marks were listed: its fiducials are corner crosses, two
            // cuts each (the arms), in the corners' order.
            let fid: Vec<&Cut> = card.cuts.iter().filter(|c| c.role == CutRole::Fiducial).collect();
            card.marks = fid
                .chunks(2)
                .enumerate()
                .map(|(k, arms)| {
                    let c = arms[0];
                    let centre = [0.5 * (c.p0[0] + c.p1[0]), 0.5 * (c.p0[1] + c.p1[1])];
                    let half = arms
                        .iter()
                        .map(|a| 0.5 * (a.p1[0] - a.p0[0]).hypot(a.p1[1] - a.p0[1]))
                        .fold(0.0, f64::max);
                    Mark {
                        label: format!("cross {}", k + 1),
                        centre,
                        half_mm: half,
                    }
                })
                .collect();
        }
        if card.marks.len() < 4 {
            anyhow::bail!(
                "`{}` lists {} fiducial mark(s); the fit needs at least 4 (write a new card with `scratchart-cal card`)",
                path.display(),
                card.marks.len()
            );
        }
        Ok((card, scene))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The card's capture views, as `glint_orientations` takes them.
    fn card_views(plate_mm: f64) -> Vec<View> {
        Card::new(&CardSpec {
            plate_mm,
            ..CardSpec::default()
        })
        .views(64)
    }

    /// The card's fiducial cuts are its marks' hatches (`scratchart_machine::marks`) at the
    /// card's orientations, cut to the deepest rung; a design's plate seen from the card's views
    /// takes each view's own orientation (the card's, without its +-15 degrees).
    #[test]
    fn the_cards_marks_are_the_machine_crates() {
        let card = Card::new(&CardSpec::default());
        let fid: Vec<&Cut> = card.cuts.iter().filter(|c| c.role == CutRole::Fiducial).collect();
        let hatch: Vec<_> = card
            .marks
            .iter()
            .flat_map(|m| m.hatch(&glint_orientations(70.0)))
            .collect();
        assert_eq!(fid.len(), hatch.len());
        for (c, (p0, p1)) in fid.iter().zip(&hatch) {
            assert!(c.p0 == *p0 && c.p1 == *p1 && c.z_mm == 0.1, "{c:?}");
        }
        let pm = plate_marks(100.0, &card_views(70.0));
        let centres: Vec<f64> = glint_orientations(70.0).into_iter().skip(1).step_by(3).collect();
        assert_eq!(pm.orientations_deg, centres);
        assert_eq!(pm, scratchart_machine::marks::plate_marks(100.0, &card_views(70.0)));
    }

    /// The card's orientations are the general rule's on its views; a view that sees the lamp's
    /// reflection in the plate (no horizontal half-vector), and no view at all, take a cross-hatch.
    #[test]
    fn glint_orientations_follow_the_views() {
        let card = glint_orientations(70.0);
        assert_eq!(card, glint_orientations_in(&card_views(70.0)));
        assert_eq!(card.len(), 6, "{card:?}");
        let mut mirror = card_views(70.0)[0].clone();
        let e = mirror.camera.eye;
        mirror.light.kind = LightKind::Point {
            position: [-e[0], -e[1], e[2]],
        };
        assert_eq!(glint_orientations_in(std::slice::from_ref(&mirror)), vec![0.0, 90.0]);
        assert_eq!(glint_orientations_in(&[]), vec![0.0, 90.0]);
        // A directional lamp is read as the direction towards it, as a point lamp's position.
        let mut dir = card_views(70.0)[0].clone();
        if let LightKind::Point { position } = dir.light.kind {
            dir.light.kind = LightKind::Directional { direction: position };
        }
        assert_eq!(glint_orientations_in(&[dir]), card[..3].to_vec());
    }
}
