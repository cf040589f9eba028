//! The problem of a specification: its views (a ring framed on the plate, a walk's arc or a
//! view file), the lamp, the seeded initial scratches and the targets fitted into the views,
//! checked against the device's limits before anything is computed.
use std::path::PathBuf;

use scratchart_model::scene::{Light, LightKind, Plate, Scene, View};
use scratchart_observe::Observer;
use scratchart_render::limits::{largest_fitting, SceneDims};
use scratchart_vulkan::DeviceInfo;

use super::walk::{walk_arc, walk_problem};
use super::{
    DesignSpec, SpecError, DEFAULT_SCRATCHES, LIGHT_DISTANCE_FACTOR, LIGHT_ELEVATION_ABOVE_VIEWS, WALK_MIN_SCRATCHES,
};
use crate::problem::Problem;
use crate::scenes::{framed_ring_views, orbit_light, random_scratches, Rng};

/// The lamp of `spec` for views at `distance` (its azimuth `default_azimuth` unless
/// --light-azimuth is given); its intensity a placeholder, calibrated against the targets before
/// the first step.
fn lamp(spec: &DesignSpec, distance: f64, default_azimuth: f64) -> Result<Light, SpecError> {
    let light_elevation = spec
        .light_elevation
        .unwrap_or((spec.elevation + LIGHT_ELEVATION_ABOVE_VIEWS).min(80.0));
    ensure_flag!(
        light_elevation > 0.0 && light_elevation <= 90.0,
        "--light-elevation must lie above 0 and at most 90 degrees"
    );
    let light_distance = spec.light_distance.unwrap_or(LIGHT_DISTANCE_FACTOR * distance);
    ensure_flag!(
        light_distance.is_finite() && light_distance > 0.0,
        "--light-distance must be a distance above 0 mm"
    );
    let azimuth = spec.light_azimuth.unwrap_or(default_azimuth);
    ensure_flag!(azimuth.is_finite(), "--light-azimuth must be a number of degrees");
    Ok(orbit_light(light_distance, light_elevation, azimuth, 1.0e4))
}

/// Builds the problem (views, initial scratches, targets) of `spec`: the scratches drawn at
/// random, then [`DesignSpec::aim_share`] of them turned to face the views ([`crate::aim`]).
pub fn problem(spec: &DesignSpec, info: &DeviceInfo, obs: &dyn Observer) -> Result<Problem, SpecError> {
    let mut problem = drawn(spec, info, obs)?;
    let share = spec.aim_share();
    if share > 0.0 {
        let aimed = crate::aim::aim(&mut problem, share, spec.seed);
        obs.info(&format!(
            "{} of {} scratches drawn facing a view ({} per view; --aim)",
            aimed.per_view.iter().sum::<usize>(),
            problem.scene.scratches.len(),
            aimed
                .per_view
                .iter()
                .map(|n| n.to_string())
                .collect::<Vec<_>>()
                .join(" / ")
        ));
    }
    Ok(problem)
}

/// The problem with every scratch drawn in a random direction.
fn drawn(spec: &DesignSpec, info: &DeviceInfo, obs: &dyn Observer) -> Result<Problem, SpecError> {
    let plate_mm = spec.plate;
    ensure_flag!(plate_mm > 0.0, "--plate must be > 0 mm");
    let walk = walk_arc(spec)?;
    let n_scratches = spec.scratches.unwrap_or_else(|| {
        walk.as_ref()
            .map_or(DEFAULT_SCRATCHES, |a| (1000 * a.views).max(WALK_MIN_SCRATCHES))
    });
    ensure_flag!(n_scratches > 0, "--scratches must be at least 1");
    check_scratch_flags(spec)?;
    let plate = Plate {
        shape: spec.plate_shape()?,
        ..Plate::flat(plate_mm)
    };
    let (mut views, between) = design_views(spec, walk.as_ref(), &plate)?;
    if walk.is_none()
        && spec.view_file.is_none()
        && views.len() >= 2
        && plate.shape.is_flat()
        && spec.light_elevation.is_none()
        && spec.light_azimuth.is_none()
    {
        let eyes: Vec<[f64; 3]> = views.iter().map(|v| v.camera.eye).collect();
        let spread = |p: [f64; 3]| crate::lamp_place::least_separation(p, &eyes);
        let placed = match views[0].light.kind {
            LightKind::Point { position } => {
                Some(position).filter(|&p| spread(p) >= crate::lamp_place::LEAST_USEFUL_SEPARATION_DEG)
            }
            LightKind::Directional { .. } => None,
        };
        if let Some(position) = placed {
            let q = crate::tolerance::Place::of(position);
            obs.info(&format!(
                "lamp at azimuth {:.0} and elevation {:.0} degrees, {:.0} mm from the plate centre: there the \
                 views' grooves differ by at least {:.0} degrees in direction, so few scratches serve two views \
                 (--light-azimuth / --light-elevation place it yourself)",
                q.azimuth_deg,
                q.elevation_deg,
                q.distance_mm,
                spread(position)
            ));
        }
    }
    if !plate.shape.is_flat() && spec.view_file.is_none() && spec.light_azimuth.is_none() {
        // A bent sheet mirrors the lamp along a line for every eye: the lamp goes where no view
        // sees that line (crate::bend).
        let (lamp, margin) = crate::bend::glint_free_lamp(&views, &plate, &views[0].light);
        if let LightKind::Point { position } = lamp.kind {
            let r = (position[0] * position[0] + position[1] * position[1] + position[2] * position[2]).sqrt();
            obs.info(&format!(
                "bent plate: the lamp stands at azimuth {:.0} and elevation {:.0} degrees, where the sheet's own \
                 mirror glint is {margin:.1} degrees from every view's half vector (--light-azimuth sets it)",
                position[1].atan2(position[0]).to_degrees(),
                (position[2] / r).asin().to_degrees()
            ));
        }
        views.iter_mut().for_each(|v| v.light = lamp.clone());
    }
    let dims = check_size(spec, &views, n_scratches, info)?;
    obs.info(&format!(
        "device memory: at least {} of the device's {} (the tile lists grow with the pairs)",
        scratchart_render::limits::mib(dims.device_bytes(info)),
        scratchart_render::limits::mib(info.device_memory)
    ));
    for w in views.iter().flat_map(scratchart_render::limits::view_warnings) {
        obs.warn(&w);
    }
    let mut rng = Rng::new(spec.seed);
    let scratches = random_scratches(
        &mut rng,
        n_scratches,
        plate_mm,
        0.01 * spec.len_min_pct * plate_mm,
        0.01 * spec.len_max_pct * plate_mm,
        spec.init_w(),
        spec.init_d,
        spec.init_alpha,
    );
    let scene = Scene {
        plate,
        views,
        scratches,
    };
    scene.validate()?;
    check_target_flags(spec, &scene, walk.is_some())?;
    if let Some(arc) = walk {
        return walk_problem(spec, scene, arc, between);
    }
    if spec.targets.is_empty() {
        let targets = crate::targets::builtin_targets(&scene);
        return Ok(Problem::new(scene, targets));
    }
    picture_problem(spec, scene, obs)
}

/// The flags of the initial scratches and of the learning rates, each within its range.
fn check_scratch_flags(spec: &DesignSpec) -> Result<(), SpecError> {
    ensure_flag!(spec.init_w() > 0.0, "--init-w must be > 0 mm (it is {})", spec.init_w());
    ensure_flag!(spec.init_d > 0.0, "--init-d must be > 0 mm (it is {})", spec.init_d);
    ensure_flag!(
        spec.init_alpha > 0.0 && spec.init_alpha < 1.0,
        "--init-alpha must lie strictly between 0 and 1 (it is {})",
        spec.init_alpha
    );
    for (flag, v) in [
        ("--lr-end", spec.lr_end),
        ("--lr-w", spec.lr_w),
        ("--lr-d", spec.lr_d),
        ("--lr-alpha", spec.lr_alpha),
        ("--lr-light", spec.lr_light),
    ] {
        if let Some(v) = v {
            ensure_flag!(v.is_finite() && v >= 0.0, "{flag} must be a number >= 0 (it is {v})");
        }
    }
    ensure_flag!(
        spec.len_min_pct > 0.0 && spec.len_max_pct >= spec.len_min_pct && spec.len_max_pct < 100.0,
        "--len-min-pct / --len-max-pct must satisfy 0 < min <= max < 100"
    );
    Ok(())
}

/// The design's views: from `--view-file`, along a walk's arc (with the views between its
/// frames), or a ring of `--views` framed on the plate.
fn design_views(
    spec: &DesignSpec,
    walk: Option<&crate::walk::WalkArc>,
    plate: &Plate,
) -> Result<(Vec<View>, Vec<crate::walk::BetweenView>), SpecError> {
    let plate_mm = plate.size_mm;
    let distance = 3.0 * plate_mm;
    let mut between = Vec::new();
    let views: Vec<View> = match &spec.view_file {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .map_err(|e| SpecError::Input(format!("cannot read view file `{}`: {e}", path.display())))?;
            let arr: serde_json::Value = serde_json::from_str(&text)
                .map_err(|e| SpecError::Input(format!("view file `{}` is not valid JSON: {e}", path.display())))?;
            if !matches!(arr.as_array(), Some(a) if !a.is_empty()) {
                return Err(SpecError::Input(format!(
                    "view file `{}` must hold a non-empty JSON array of view objects (engine/docs/model.md section 6)",
                    path.display()
                )));
            }
            let doc = serde_json::json!({
                "plate": plate.to_value(),
                "views": arr,
                "scratches": [],
            });
            let base = path.parent().map(PathBuf::from).unwrap_or_default();
            Scene::from_json_str(&doc.to_string(), &base, &path.display().to_string())?.views
        }
        None => {
            ensure_flag!(spec.res >= 8, "--res must be at least 8 pixels");
            ensure_flag!(
                spec.elevation > 0.0 && spec.elevation < 90.0,
                "--elevation must lie strictly between 0 and 90 degrees"
            );
            match walk {
                Some(arc) => {
                    let light = lamp(spec, arc.distance_mm, arc.centre_azimuth_deg)?;
                    let (views, b) = crate::walk::arc_views(arc, plate, &light);
                    between = b;
                    views
                }
                None => {
                    ensure_flag!(spec.views >= 1, "--views must be at least 1");
                    // Initial intensity: a placeholder, calibrated against the targets before the first step.
                    let mut light = lamp(spec, distance, 0.0)?;
                    if spec.views >= 2
                        && spec.light_elevation.is_none()
                        && spec.light_azimuth.is_none()
                        && plate.shape.is_flat()
                    {
                        // Where the views' grooves differ most in direction (crate::lamp_place).
                        let eyes: Vec<[f64; 3]> = (0..spec.views)
                            .map(|j| {
                                scratchart_model::camera::spherical(
                                    distance,
                                    360.0 * j as f64 / spec.views as f64,
                                    spec.elevation,
                                )
                            })
                            .collect();
                        // Measured (engine/docs/worst_view.md, "The lamp"): two and three views
                        // gain; four, whose best spread (45 degrees) puts the lamp at their
                        // height between two of them, trade one view for another.
                        let spread = crate::lamp_place::separating_lamp(&eyes)
                            .filter(|c| c.2 >= crate::lamp_place::LEAST_USEFUL_SEPARATION_DEG);
                        if let Some((az, el, _)) = spread {
                            let r = spec.light_distance.unwrap_or(LIGHT_DISTANCE_FACTOR * distance);
                            light = orbit_light(r, el, az, 1.0e4);
                        }
                    }
                    // The plate's silhouette fills 95% of each frame (width or height, whichever binds).
                    framed_ring_views(spec.views, spec.elevation, distance, plate, spec.res, &light, 0.95)
                }
            }
        }
    };
    Ok((views, between))
}

/// The flags of the targets (background, gamma, blank views), against the scene's views.
fn check_target_flags(spec: &DesignSpec, scene: &Scene, walk: bool) -> Result<(), SpecError> {
    ensure_flag!(
        (0.0..=1.0).contains(&spec.background),
        "--background must lie between 0 (black) and 1 (white) (it is {})",
        spec.background
    );

    ensure_flag!(
        spec.gamma > 0.0 && spec.gamma.is_finite(),
        "--gamma must be > 0 (it is {})",
        spec.gamma
    );
    for b in &spec.blank_view {
        ensure_flag!(
            scene.views.iter().any(|v| &v.name == b),
            "--blank-view {b}: no view is named so (the views: {})",
            scene
                .views
                .iter()
                .map(|v| v.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    ensure_flag!(
        spec.blank_view.is_empty() || !spec.targets.is_empty() || walk,
        "--blank-view needs --targets or --walk (the built-in shapes are never blank)"
    );
    Ok(())
}

/// The problem of pictures given with `--targets`: each fitted into its view (`--fit`,
/// `--background`, `--gamma`), blank views left free, the sources kept for steering.
fn picture_problem(spec: &DesignSpec, scene: Scene, obs: &dyn Observer) -> Result<Problem, SpecError> {
    let pictures = crate::targets::read_pictures(&spec.targets, &scene, &spec.blank_view)?;
    let mut fitted = crate::targets::fit_pictures(&pictures, &scene, spec.fit, spec.background);
    for b in &spec.blank_view {
        obs.info(&format!(
            "view {b}: blank on purpose (--blank-view): its picture is not asked to show anything"
        ));
    }
    if spec.gamma != 1.0 {
        for f in &mut fitted {
            for (v, p) in f.image.iter_mut().zip(&f.picture) {
                if *p {
                    *v = v.powf(spec.gamma);
                }
            }
        }
    }
    let mut problem = Problem::new(scene, fitted.iter().map(|f| f.image.clone()).collect());
    problem.picture_rects = fitted.iter().map(|f| f.rect).collect();
    problem.pictures = fitted.into_iter().map(|f| f.picture).collect();
    // Each picture as read, for steering (pictures placed in a rectangle only).
    problem.sources = pictures
        .into_iter()
        .zip(&problem.picture_rects)
        .map(|(p, rect)| {
            Some(crate::steer::Source {
                width: p.width,
                height: p.height,
                data: p.data,
                fit: spec.fit,
                background: spec.background,
                gamma: spec.gamma,
                rect: (*rect)?,
            })
        })
        .collect();
    Ok(problem)
}

/// Checks the job's size against the device and the host before anything is computed, and
/// returns it; the error names the flag to change and the largest value that fits.
fn check_size(
    spec: &DesignSpec,
    views: &[View],
    n_scratches: usize,
    info: &DeviceInfo,
) -> Result<SceneDims, SpecError> {
    let sizes: Vec<(u32, u32)> = views.iter().map(|v| (v.camera.width, v.camera.height)).collect();
    let n = n_scratches as u64;
    let dims = SceneDims::new(&sizes, n, true);
    let Err(why) = dims.check(info) else {
        return Ok(dims);
    };
    let fits = |sizes: &[(u32, u32)], n: u64| SceneDims::new(sizes, n, true).check(info).is_ok();
    let max_n = largest_fitting(n, |k| fits(&sizes, k));
    let hint = if spec.view_file.is_none() {
        let nv = views.len();
        let max_res = largest_fitting(spec.res as u64, |r| fits(&vec![(r as u32, r as u32); nv], n));
        if max_res > 0 && max_res < spec.res as u64 {
            let with = if spec.arc.is_some() {
                format!("the walk's {nv} views (in-between views included; fewer with --between 0)")
            } else {
                format!("--views {nv}")
            };
            format!("use a smaller --res: the largest that fits with {with} and --scratches {n} is {max_res}")
        } else if max_n > 0 {
            format!("use fewer --scratches: at --res {} at most {max_n} fit", spec.res)
        } else {
            "use a smaller --res and fewer --views or --scratches".into()
        }
    } else if max_n > 0 && max_n < n {
        format!("use fewer --scratches: with these views at most {max_n} fit")
    } else {
        "use smaller views in the --view-file (width x height) or fewer views".into()
    };
    Err(SpecError::Usage(format!("this design is too large: {why}; {hint}")))
}
