//! The physical set-up of a design, as the set-up sheet (`scratchart setup`) gives it: the lamp
//! and every viewer's eye as azimuth, elevation, distance and x, y, z in the plate's frame, and
//! the +x edge that carries the orientation mark. The numbers come from the engine's own
//! [`scratchart_design::setup`] (the sheet's [`Place`] and `summary.json`'s `setup`), so the
//! viewer shows exactly what the sheet prints. The overlay that draws them is `overlay.rs`.
use scratchart_design::setup::setup_json;
use scratchart_design::tolerance::Place;
use scratchart_model::scene::{LightKind, Scene};

/// What a marker stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Lamp,
    Eye,
}

/// One lamp or eye of the set-up.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    pub kind: Kind,
    /// "lamp", "lamp for NAME" (one lamp per view when the views' lights differ) or "eye NAME".
    pub label: String,
    pub place: Place,
    /// A directional lamp: `place.xyz` is its unit direction and it has no distance.
    pub directional: bool,
}

/// The set-up of one design.
#[derive(Clone, Debug, PartialEq)]
pub struct SetupInfo {
    pub half_plate_mm: f64,
    /// The plate's shape (the +x edge is drawn on the bent sheet).
    pub shape: scratchart_model::surface::PlateShape,
    pub points: Vec<Point>,
    /// `summary.json`'s `setup` of this design.
    pub json: serde_json::Value,
}

impl SetupInfo {
    pub fn of(scene: &Scene) -> SetupInfo {
        // One lamp per distinct light, named after its first view, as on the set-up sheet.
        let lamps = scene.lamps();
        let single = lamps.len() == 1;
        let mut points: Vec<Point> = lamps
            .into_iter()
            .map(|lamp| {
                let name = lamp.name;
                let (p, directional) = match lamp.kind {
                    LightKind::Point { position } => (position, false),
                    LightKind::Directional { direction } => (direction, true),
                };
                Point {
                    kind: Kind::Lamp,
                    label: if single {
                        "lamp".into()
                    } else {
                        format!("lamp for {name}")
                    },
                    place: Place::of(p),
                    directional,
                }
            })
            .collect();
        points.extend(scene.views.iter().map(|v| Point {
            kind: Kind::Eye,
            label: format!("eye {}", v.name),
            place: Place::of(v.camera.eye),
            directional: false,
        }));
        SetupInfo {
            half_plate_mm: 0.5 * scene.plate.size_mm,
            shape: scene.plate.shape,
            points,
            json: setup_json(scene),
        }
    }

    /// The numbers for stdout, one line per lamp and eye (mm to 0.1 micrometre), then the
    /// sheet's `setup` JSON.
    pub fn report(&self) -> String {
        let mut s = format!(
            "set-up: {} mm plate, scratched face up, the orientation mark on its +x edge; azimuth from +x towards +y, elevation above the plate, distance from the plate centre\n",
            2.0 * self.half_plate_mm
        );
        for p in &self.points {
            let q = &p.place;
            if p.directional {
                s += &format!(
                    "set-up {}: directional, from azimuth {:.4} deg, elevation {:.4} deg, direction x {:.6} y {:.6} z {:.6}\n",
                    p.label, q.azimuth_deg, q.elevation_deg, q.xyz[0], q.xyz[1], q.xyz[2]
                );
            } else {
                s += &format!(
                    "set-up {}: azimuth {:.4} deg, elevation {:.4} deg, distance {:.4} mm, x {:.4} y {:.4} z {:.4} mm\n",
                    p.label, q.azimuth_deg, q.elevation_deg, q.distance_mm, q.xyz[0], q.xyz[1], q.xyz[2]
                );
            }
        }
        s += &format!("set-up json: {}", self.json);
        s
    }

    /// A short form for the window title.
    pub fn title(&self) -> String {
        let parts: Vec<String> = self
            .points
            .iter()
            .map(|p| {
                let q = &p.place;
                if p.directional {
                    format!(
                        "{} az {:.1} el {:.1} (directional)",
                        p.label, q.azimuth_deg, q.elevation_deg
                    )
                } else {
                    format!(
                        "{} az {:.1} el {:.1} {:.0} mm ({:.1}, {:.1}, {:.1})",
                        p.label, q.azimuth_deg, q.elevation_deg, q.distance_mm, q.xyz[0], q.xyz[1], q.xyz[2]
                    )
                }
            })
            .collect();
        format!("set-up (mark +x): {}", parts.join("; "))
    }

    /// The label drawn in the frame: two short lines.
    pub fn label_lines(p: &Point) -> [String; 2] {
        let q = &p.place;
        if p.directional {
            [
                format!("{} AZ {:.1}° EL {:.1}°", p.label, q.azimuth_deg, q.elevation_deg),
                format!("DIRECTIONAL ({:.3}, {:.3}, {:.3})", q.xyz[0], q.xyz[1], q.xyz[2]),
            ]
        } else {
            [
                format!(
                    "{} AZ {:.1}° EL {:.1}° {:.1} MM",
                    p.label, q.azimuth_deg, q.elevation_deg, q.distance_mm
                ),
                format!("X {:.1} Y {:.1} Z {:.1} MM", q.xyz[0], q.xyz[1], q.xyz[2]),
            ]
        }
    }
}
