//! The machine a design is carved on: its firmware, travel, feeds, heights between cuts, and
//! the limits a design must keep (the Z step, its repeatability, the shallowest cut the maker
//! trusts). serde only: the engine's `design --machine` and the machine crate's `plan` read
//! machine.json through this module.
use serde::{Deserialize, Serialize};

/// The machine a plan is made for (`--machine-file machine.json`; built-in defaults for a desktop
/// GRBL router and a Marlin printer with an engraving bit). [`MachineProfile::FIELDS`] describes
/// every field; a machine.json may give any of them, the rest come from the built-in profile of
/// its firmware ([`MachineProfile::from_json`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MachineProfile {
    /// "grbl" or "marlin"
    pub firmware: Firmware,
    /// Travel of the X, Y and Z axes, mm.
    pub travel_mm: [f64; 3],
    /// Feeds, mm/min: rapid moves, cuts, plunges.
    pub rapid_mm_min: f64,
    pub cut_mm_min: f64,
    pub plunge_mm_min: f64,
    /// Acceleration, mm/s^2.
    pub accel_mm_s2: f64,
    /// The planner's junction deviation, mm (GRBL `$11`, Marlin `M205 J`; older profiles
    /// without it: the firmware's default).
    #[serde(default = "default_junction_deviation")]
    pub junction_deviation_mm: f64,
    /// Height above the plate surface between neighbouring cuts, mm.
    pub retract_mm: f64,
    /// Height above the plate surface for long travels, the start and the end of the job, mm
    /// (older profiles: `safe_z_mm`).
    #[serde(alias = "safe_z_mm")]
    pub clearance_mm: f64,
    /// A travel between cuts longer than this goes up to the clearance height, mm.
    pub long_travel_mm: f64,
    /// The Z axis's step, mm: commanded depths are multiples of it.
    pub z_step_mm: f64,
    /// How closely the Z axis returns to a commanded height, mm (one standard deviation).
    pub z_repeatability_mm: f64,
    /// How closely X and Y reach a commanded point, mm (one standard deviation, per axis; older
    /// profiles without it: the built-in value).
    #[serde(default = "default_xy_repeatability")]
    pub xy_repeatability_mm: f64,
    /// The shallowest cut below the surface the maker trusts the machine with, mm.
    pub min_cut_depth_mm: f64,
    /// Spindle speed, rpm (`None`: no spindle, e.g. a drag engraver).
    pub spindle_rpm: Option<f64>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Firmware {
    Grbl,
    Marlin,
}

impl MachineProfile {
    /// Every field of a machine.json with what it means (the `--help` of `plan`, `card` and
    /// `carve` lists these, and `plan --print-machine` prints the built-in values).
    pub const FIELDS: &'static [(&'static str, &'static str)] = &[
        (
            "firmware",
            "\"grbl\" (a router) or \"marlin\" (a printer with an engraving bit)",
        ),
        (
            "travel_mm",
            "[X, Y, Z] travel, mm; the plate lies centred on the X/Y travel",
        ),
        ("rapid_mm_min", "feed of rapid moves (G0), mm/min"),
        ("cut_mm_min", "feed of cuts (G1 in the plate), mm/min"),
        (
            "plunge_mm_min",
            "feed of plunges into the plate (and of every Z move on Marlin), mm/min",
        ),
        ("accel_mm_s2", "acceleration of every axis, mm/s^2 (for the job time)"),
        (
            "junction_deviation_mm",
            "the planner's junction deviation (GRBL $11, Marlin M205 J), mm: how fast corners are taken (for the job time)",
        ),
        ("retract_mm", "height above the surface between neighbouring cuts, mm"),
        (
            "clearance_mm",
            "height above the surface for long travels, the start and the end, mm (older name: safe_z_mm)",
        ),
        (
            "long_travel_mm",
            "a travel between cuts longer than this rises to the clearance height, mm",
        ),
        (
            "z_step_mm",
            "the Z axis's step, mm: designs command depths in multiples of it",
        ),
        (
            "z_repeatability_mm",
            "how closely Z returns to a commanded height (1 sigma), mm",
        ),
        (
            "xy_repeatability_mm",
            "how closely X and Y reach a commanded point (1 sigma, per axis), mm",
        ),
        (
            "min_cut_depth_mm",
            "the shallowest cut below the surface the maker trusts, mm",
        ),
        ("spindle_rpm", "spindle speed (GRBL M3 S..), or null for none"),
    ];

    /// A desktop GRBL router (3018 class): 400 steps/mm on Z, about 15 um repeatable.
    pub fn grbl() -> MachineProfile {
        MachineProfile {
            firmware: Firmware::Grbl,
            travel_mm: [300.0, 180.0, 45.0],
            rapid_mm_min: 1000.0,
            cut_mm_min: 300.0,
            plunge_mm_min: 100.0,
            accel_mm_s2: 200.0,
            junction_deviation_mm: 0.01,
            retract_mm: 0.3,
            clearance_mm: 2.0,
            long_travel_mm: 20.0,
            z_step_mm: 0.0025,
            z_repeatability_mm: 0.015,
            xy_repeatability_mm: 0.01,
            min_cut_depth_mm: 0.02,
            spindle_rpm: Some(10_000.0),
        }
    }

    /// A Marlin printer (Ender / Prusa class) with an engraving bit: no spindle; 400 steps/mm on
    /// Z, about 20 um repeatable with a bit in the hot end's place.
    pub fn marlin() -> MachineProfile {
        MachineProfile {
            firmware: Firmware::Marlin,
            travel_mm: [220.0, 220.0, 250.0],
            rapid_mm_min: 3000.0,
            cut_mm_min: 600.0,
            plunge_mm_min: 300.0,
            accel_mm_s2: 500.0,
            junction_deviation_mm: 0.013,
            retract_mm: 0.3,
            clearance_mm: 2.0,
            long_travel_mm: 20.0,
            z_step_mm: 0.0025,
            z_repeatability_mm: 0.02,
            xy_repeatability_mm: 0.02,
            min_cut_depth_mm: 0.03,
            spindle_rpm: None,
        }
    }

    /// The built-in profile of `firmware`.
    pub fn builtin(firmware: Firmware) -> MachineProfile {
        match firmware {
            Firmware::Grbl => MachineProfile::grbl(),
            Firmware::Marlin => MachineProfile::marlin(),
        }
    }

    /// The profile as pretty JSON (what `plan --print-machine` prints).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a profile always serializes")
    }

    /// Reads a machine.json: the fields it gives over the built-in profile of its `firmware`
    /// (or `default` where it names none). Returns the profile and a warning for every key it
    /// does not know (naming the closest known one); an error names the field and what to fix.
    pub fn from_json(text: &str, default: Firmware) -> Result<(MachineProfile, Vec<String>), String> {
        let v: serde_json::Value = serde_json::from_str(text).map_err(|e| format!("not valid JSON: {e}"))?;
        let obj = v.as_object().ok_or("expected a JSON object of profile fields")?;
        let firmware = match obj.get("firmware") {
            None => default,
            Some(f) => serde_json::from_value(f.clone())
                .map_err(|_| format!("firmware {f}: expected \"grbl\" or \"marlin\""))?,
        };
        let mut merged = serde_json::to_value(MachineProfile::builtin(firmware)).expect("serializes");
        let mut warnings = Vec::new();
        for (k, val) in obj {
            let key = if k == "safe_z_mm" { "clearance_mm" } else { k.as_str() };
            if Self::FIELDS.iter().any(|(f, _)| *f == key) {
                merged[key] = val.clone();
            } else {
                let closest = Self::FIELDS
                    .iter()
                    .map(|(f, _)| *f)
                    .min_by_key(|f| edit_distance(k, f))
                    .unwrap_or("");
                warnings.push(format!(
                    "unknown key `{k}` is ignored (the closest known key is `{closest}`)"
                ));
            }
        }
        let m: MachineProfile = serde_json::from_value(merged).map_err(|e| {
            // Name the field: the first given one that fails on its own.
            let base = serde_json::to_value(MachineProfile::builtin(firmware)).expect("serializes");
            obj.iter()
                .find_map(|(k, val)| {
                    let key = if k == "safe_z_mm" { "clearance_mm" } else { k.as_str() };
                    let mut one = base.clone();
                    one.get(key)?;
                    one[key] = val.clone();
                    serde_json::from_value::<MachineProfile>(one)
                        .err()
                        .map(|e| format!("{k}: {e} (got {val})"))
                })
                .unwrap_or_else(|| e.to_string())
        })?;
        m.check()?;
        Ok((m, warnings))
    }

    /// Every number finite and in range, with the field named where one is not.
    pub fn check(&self) -> Result<(), String> {
        let positive = [
            ("travel_mm[0]", self.travel_mm[0]),
            ("travel_mm[1]", self.travel_mm[1]),
            ("travel_mm[2]", self.travel_mm[2]),
            ("rapid_mm_min", self.rapid_mm_min),
            ("cut_mm_min", self.cut_mm_min),
            ("plunge_mm_min", self.plunge_mm_min),
            ("accel_mm_s2", self.accel_mm_s2),
            ("retract_mm", self.retract_mm),
            ("clearance_mm", self.clearance_mm),
            ("z_step_mm", self.z_step_mm),
        ];
        for (name, v) in positive {
            if !(v > 0.0 && v.is_finite()) {
                return Err(format!("{name} is {v}: it must be a number > 0"));
            }
        }
        for (name, v) in [
            ("long_travel_mm", self.long_travel_mm),
            ("junction_deviation_mm", self.junction_deviation_mm),
            ("z_repeatability_mm", self.z_repeatability_mm),
            ("xy_repeatability_mm", self.xy_repeatability_mm),
            ("min_cut_depth_mm", self.min_cut_depth_mm),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(format!("{name} is {v}: it must be a number >= 0"));
            }
        }
        if self.retract_mm > self.clearance_mm {
            return Err(format!(
                "retract_mm {} is above clearance_mm {}: the retract between cuts must not be higher than the clearance",
                self.retract_mm, self.clearance_mm
            ));
        }
        if let Some(r) = self.spindle_rpm {
            if !(r > 0.0 && r.is_finite()) {
                return Err(format!("spindle_rpm is {r}: a speed > 0, or null for none"));
            }
        }
        Ok(())
    }
}

fn default_junction_deviation() -> f64 {
    MachineProfile::grbl().junction_deviation_mm
}

fn default_xy_repeatability() -> f64 {
    MachineProfile::grbl().xy_repeatability_mm
}

/// Edit distance of two keys, ignoring case and underscores.
fn edit_distance(a: &str, b: &str) -> usize {
    let norm = |s: &str| s.to_ascii_lowercase().replace('_', "").into_bytes();
    let (a, b) = (norm(a), norm(b));
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.iter().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            cur[j + 1] = (prev[j] + usize::from(ca != cb)).min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}
