//! A walk's fields (`--walk`, `--hold`, `--object`, `--arc`, ...): its arc and its problem.
use scratchart_model::scene::Scene;

use super::{DesignSpec, SpecError};
use crate::problem::Problem;

/// The walk's arc of `--walk / --hold / --object` with `--arc`, or None for a design that is
/// not a walk (whose walk flags are then refused).
pub(super) fn walk_arc(spec: &DesignSpec) -> Result<Option<crate::walk::WalkArc>, SpecError> {
    use crate::walk::{frame_files, WalkArc};
    let kinds = !spec.walk.is_empty() as usize + spec.hold.is_some() as usize + spec.object.is_some() as usize;
    ensure_flag!(kinds <= 1, "give one of --walk, --hold and --object");
    for (set, flag) in [
        (spec.object_size.is_some(), "--object-size"),
        (spec.object_depth.is_some(), "--object-depth"),
        (spec.object_yaw != 0.0, "--object-yaw"),
    ] {
        ensure_flag!(!set || spec.object.is_some(), "{flag} belongs to --object MODEL.obj");
    }
    if kinds == 0 {
        for (set, flag) in [
            (spec.arc.is_some(), "--arc"),
            (spec.azimuth.is_some(), "--azimuth"),
            (spec.distance.is_some(), "--distance"),
            (spec.walk_views.is_some(), "--walk-views"),
            (spec.between != 1, "--between"),
            (spec.walk_probes != 3, "--walk-probes"),
        ] {
            ensure_flag!(
                !set,
                "{flag} belongs to a walk: give --walk FRAMES..., --hold PICTURE or --object MODEL.obj with it"
            );
        }
        return Ok(None);
    }
    let Some(arc_deg) = spec.arc else {
        return Err(SpecError::Usage(
            "--walk, --hold and --object need --arc DEG: the total angle from the walk's first view to its last".into(),
        ));
    };
    let views = if spec.walk.is_empty() {
        spec.walk_views.unwrap_or(WalkArc::default_views(arc_deg))
    } else {
        ensure_flag!(
            spec.walk_views.is_none(),
            "--walk-views is for --hold and --object: a --walk has one view per frame"
        );
        frame_files(&spec.walk).map_err(SpecError::Usage)?.len()
    };
    let arc = WalkArc {
        arc_deg,
        centre_azimuth_deg: spec.azimuth.unwrap_or(0.0),
        elevation_deg: spec.elevation,
        distance_mm: spec.distance.unwrap_or(3.0 * spec.plate),
        views,
        between: spec.between,
        res: spec.res,
    };
    arc.check().map_err(SpecError::Usage)?;
    ensure_flag!(
        arc.centre_azimuth_deg.is_finite(),
        "--azimuth must be a number of degrees"
    );
    Ok(Some(arc))
}

/// The problem of a walk: its targets (frames, a held picture or an object's views) on the
/// walk's views and in-between views.
pub(super) fn walk_problem(
    spec: &DesignSpec,
    scene: Scene,
    arc: crate::walk::WalkArc,
    between: Vec<crate::walk::BetweenView>,
) -> Result<Problem, SpecError> {
    use crate::walk::{frame_files, probe_views, probes, read_pictures, walk_targets, Frames, Walk};
    let mesh;
    let name = |p: &std::path::Path| p.display().to_string();
    let (source, frames_named, frames) = if let Some(obj) = &spec.object {
        mesh = scratchart_model::mesh::Mesh::load_obj(obj)?;
        let size_mm = spec.object_size.unwrap_or(0.5 * spec.plate);
        let depth_mm = spec.object_depth.unwrap_or(0.25 * spec.plate);
        ensure_flag!(
            size_mm.is_finite() && size_mm > 0.0,
            "--object-size must be a size above 0 mm (it is {size_mm})"
        );
        ensure_flag!(
            depth_mm.is_finite(),
            "--object-depth must be a number of mm (it is {depth_mm})"
        );
        ensure_flag!(spec.object_yaw.is_finite(), "--object-yaw must be a number of degrees");
        let placement = scratchart_model::mesh::Placement {
            size_mm,
            depth_mm,
            front_azimuth_deg: arc.centre_azimuth_deg,
            yaw_deg: spec.object_yaw,
        };
        // The object's own lamp: above and to one side of the walk's middle, the same for
        // every view, so it is lit as one object.
        let key_light = scratchart_model::camera::spherical(1.0, arc.centre_azimuth_deg + 40.0, 50.0);
        (
            "object",
            vec![name(obj)],
            Frames::Object {
                mesh: &mesh,
                placement,
                key_light,
            },
        )
    } else {
        let (source, files) = match &spec.hold {
            Some(h) => ("hold", vec![h.clone(); arc.views]),
            None => ("frames", frame_files(&spec.walk).map_err(SpecError::Usage)?),
        };
        let pictures = read_pictures(&files, &spec.blank_view)?;
        (
            source,
            files.iter().map(|f| name(f)).collect(),
            Frames::Pictures(pictures),
        )
    };
    let probe_views = probe_views(&arc, &scene.plate, &scene.views[0].light, spec.walk_probes);
    let mut walk = Walk {
        arc,
        source: source.into(),
        frames: frames_named,
        between,
        probes: Vec::new(),
    };
    let fitted = walk_targets(&scene, &walk, &frames, spec.fit, spec.background, spec.gamma);
    walk.probes = probes(
        probe_views,
        &scene.plate,
        &frames,
        spec.fit,
        spec.background,
        spec.gamma,
    );
    let mut problem = Problem::new(scene, fitted.iter().map(|f| f.image.clone()).collect());
    problem.picture_rects = fitted.iter().map(|f| f.rect).collect();
    problem.pictures = fitted.into_iter().map(|f| f.picture).collect();
    problem.walk = Some(walk);
    Ok(problem)
}
