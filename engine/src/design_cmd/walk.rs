//! A walk's flags (`--walk`, `--hold`, `--object`, `--arc`, ...): its arc and its problem.
use scratchart::model::scene::Scene;
use scratchart::optim::design::Problem;

use super::DesignArgs;

/// The walk's arc of `--walk / --hold / --object` with `--arc`, or None for a design that is
/// not a walk (whose walk flags are then refused).
pub(super) fn walk_arc(args: &DesignArgs) -> anyhow::Result<Option<scratchart::optim::walk::WalkArc>> {
    use scratchart::optim::walk::{frame_files, WalkArc};
    let kinds = !args.walk.is_empty() as usize + args.hold.is_some() as usize + args.object.is_some() as usize;
    ensure_flag!(kinds <= 1, "give one of --walk, --hold and --object");
    for (set, flag) in [
        (args.object_size.is_some(), "--object-size"),
        (args.object_depth.is_some(), "--object-depth"),
        (args.object_yaw != 0.0, "--object-yaw"),
    ] {
        ensure_flag!(!set || args.object.is_some(), "{flag} belongs to --object MODEL.obj");
    }
    if kinds == 0 {
        for (set, flag) in [
            (args.arc.is_some(), "--arc"),
            (args.azimuth.is_some(), "--azimuth"),
            (args.distance.is_some(), "--distance"),
            (args.walk_views.is_some(), "--walk-views"),
            (args.between != 1, "--between"),
            (args.walk_probes != 3, "--walk-probes"),
        ] {
            ensure_flag!(
                !set,
                "{flag} belongs to a walk: give --walk FRAMES..., --hold PICTURE or --object MODEL.obj with it"
            );
        }
        return Ok(None);
    }
    let Some(arc_deg) = args.arc else {
        return Err(scratchart::exit::UsageError(
            "--walk, --hold and --object need --arc DEG: the total angle from the walk's first view to its last".into(),
        )
        .into());
    };
    let views = if args.walk.is_empty() {
        args.walk_views.unwrap_or(WalkArc::default_views(arc_deg))
    } else {
        ensure_flag!(
            args.walk_views.is_none(),
            "--walk-views is for --hold and --object: a --walk has one view per frame"
        );
        frame_files(&args.walk).map_err(scratchart::exit::UsageError)?.len()
    };
    let arc = WalkArc {
        arc_deg,
        centre_azimuth_deg: args.azimuth.unwrap_or(0.0),
        elevation_deg: args.elevation,
        distance_mm: args.distance.unwrap_or(3.0 * args.plate),
        views,
        between: args.between,
        res: args.res,
    };
    arc.check().map_err(scratchart::exit::UsageError)?;
    ensure_flag!(
        arc.centre_azimuth_deg.is_finite(),
        "--azimuth must be a number of degrees"
    );
    Ok(Some(arc))
}

/// The problem of a walk: its targets (frames, a held picture or an object's views) on the
/// walk's views and in-between views.
pub(super) fn walk_problem(
    args: &DesignArgs,
    scene: Scene,
    arc: scratchart::optim::walk::WalkArc,
    between: Vec<scratchart::optim::walk::BetweenView>,
) -> anyhow::Result<Problem> {
    use scratchart::optim::walk::{frame_files, probe_views, probes, read_pictures, walk_targets, Frames, Walk};
    let mesh;
    let name = |p: &std::path::Path| p.display().to_string();
    let (source, frames_named, frames) = if let Some(obj) = &args.object {
        mesh = scratchart::model::mesh::Mesh::load_obj(obj)?;
        let size_mm = args.object_size.unwrap_or(0.5 * args.plate);
        let depth_mm = args.object_depth.unwrap_or(0.25 * args.plate);
        ensure_flag!(
            size_mm.is_finite() && size_mm > 0.0,
            "--object-size must be a size above 0 mm (it is {size_mm})"
        );
        ensure_flag!(
            depth_mm.is_finite(),
            "--object-depth must be a number of mm (it is {depth_mm})"
        );
        ensure_flag!(args.object_yaw.is_finite(), "--object-yaw must be a number of degrees");
        let placement = scratchart::model::mesh::Placement {
            size_mm,
            depth_mm,
            front_azimuth_deg: arc.centre_azimuth_deg,
            yaw_deg: args.object_yaw,
        };
        // The object's own lamp: above and to one side of the walk's middle, the same for
        // every view, so it is lit as one object.
        let key_light = scratchart::model::camera::spherical(1.0, arc.centre_azimuth_deg + 40.0, 50.0);
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
        let (source, files) = match &args.hold {
            Some(h) => ("hold", vec![h.clone(); arc.views]),
            None => ("frames", frame_files(&args.walk).map_err(scratchart::exit::UsageError)?),
        };
        let pictures = read_pictures(&files, &args.blank_view)?;
        (
            source,
            files.iter().map(|f| name(f)).collect(),
            Frames::Pictures(pictures),
        )
    };
    let probe_views = probe_views(&arc, scene.plate.size_mm, &scene.views[0].light, args.walk_probes);
    let mut walk = Walk {
        arc,
        source: source.into(),
        frames: frames_named,
        between,
        probes: Vec::new(),
    };
    let fitted = walk_targets(&scene, &walk, &frames, args.fit, args.background, args.gamma);
    walk.probes = probes(
        probe_views,
        scene.plate.size_mm,
        &frames,
        args.fit,
        args.background,
        args.gamma,
    );
    let mut problem = Problem::new(scene, fitted.iter().map(|f| f.image.clone()).collect());
    problem.picture_rects = fitted.iter().map(|f| f.rect).collect();
    problem.pictures = fitted.into_iter().map(|f| f.picture).collect();
    problem.walk = Some(walk);
    Ok(problem)
}
