//! Unit tests of the walk: the arc's cameras, bad arcs, in-between targets, smooth placement.

use super::*;

fn arc(views: usize, between: usize) -> WalkArc {
    WalkArc {
        arc_deg: 60.0,
        centre_azimuth_deg: 10.0,
        elevation_deg: 40.0,
        distance_mm: 300.0,
        views,
        between,
        res: 32,
    }
}

/// The cameras stand where the flags put them: evenly along the arc about its centre, at
/// the elevation and distance asked, the in-between views between their neighbours.
#[test]
fn the_arcs_cameras_stand_where_the_flags_put_them() {
    let a = arc(5, 2);
    let light = crate::scenes::orbit_light(300.0, 60.0, 10.0, 1e4);
    let (views, between) = arc_views(&a, &Plate::flat(100.0), &light);
    assert_eq!(views.len(), 5 + 4 * 2);
    assert_eq!(between.len(), 8);
    let names: Vec<&str> = views.iter().map(|v| v.name.as_str()).collect();
    assert_eq!(&names[..6], &["v0", "v1", "v2", "v3", "v4", "v0-v1.1"]);
    let walk = Walk {
        arc: a.clone(),
        source: "frames".into(),
        frames: vec![],
        between: between.clone(),
        probes: vec![],
    };
    for (v, view) in views.iter().enumerate() {
        let e = view.camera.eye;
        let d = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        let az = e[1].atan2(e[0]).to_degrees();
        let el = (e[2] / d).asin().to_degrees();
        let want = a.azimuth_at(walk.position(v));
        assert!((d - 300.0).abs() < 1e-9, "view {v}: distance {d}");
        assert!((el - 40.0).abs() < 1e-9, "view {v}: elevation {el}");
        assert!((az - want).abs() < 1e-9, "view {v}: azimuth {az}, want {want}");
    }
    // The design views span the arc about its centre, 15 degrees apart.
    assert!((a.azimuth_at(0.0) - (-20.0)).abs() < 1e-12);
    assert!((a.azimuth_at(4.0) - 40.0).abs() < 1e-12);
    assert!((a.step_deg() - 15.0).abs() < 1e-12);
    // In arc order, azimuths grow and design view k sits between its in-between views.
    let order = walk.arc_order();
    let az: Vec<f64> = order.iter().map(|&v| a.azimuth_at(walk.position(v))).collect();
    assert!(az.windows(2).all(|p| p[1] > p[0]), "{az:?}");
    assert_eq!(order[0], 0);
    assert_eq!(order[3], 1);
    assert!(between.iter().all(|b| b.t > 0.0 && b.t < 1.0));
}

/// Along a walk a picture stays on the same part of the plate: its rectangle moves by a
/// fraction of a pixel per half degree, also where the view passes the symmetric one (the
/// largest rectangle of a near-symmetric silhouette jumps there from one end to the other).
#[test]
fn a_walks_pictures_move_smoothly_along_the_arc() {
    let light = crate::scenes::orbit_light(300.0, 65.0, 0.0, 1e4);
    let a = arc(3, 0);
    let centre = |az: f64| {
        let mut a = a.clone();
        a.res = 64;
        let v = arc_view("x".into(), &a, az, &Plate::flat(100.0), &light);
        let f = fit_picture_walk(&[1.0; 4], 2, 2, &v, &Plate::flat(100.0), Fit::Contain, 0.0);
        let r = f.rect.expect("a rectangle");
        (r.x0 + 0.5 * r.w, r.y0 + 0.5 * r.h, r.w)
    };
    let mut last = centre(-6.0);
    for i in -11..=12 {
        let now = centre(0.5 * i as f64);
        let moved = (now.0 - last.0).hypot(now.1 - last.1);
        assert!(moved < 1.0, "at {} deg the picture moved {moved} px", 0.5 * i as f64);
        assert!(
            now.2 > 30.0,
            "at {} deg the picture is {} px wide",
            0.5 * i as f64,
            now.2
        );
        last = now;
    }
}

#[test]
fn a_bad_arc_is_refused_with_its_flag() {
    let mut a = arc(5, 1);
    a.arc_deg = 0.0;
    assert!(a.check().unwrap_err().contains("--arc"));
    let mut a = arc(1, 1);
    a.arc_deg = 30.0;
    assert!(a.check().unwrap_err().contains("at least 2 views"));
    let mut a = arc(3, 1);
    a.elevation_deg = 95.0;
    assert!(a.check().unwrap_err().contains("--elevation"));
    assert_eq!(WalkArc::default_views(30.0), 7);
    assert_eq!(WalkArc::default_views(1.0), 2);
}

/// An in-between view's target is the cross-fade of its neighbours' frames, each placed in
/// the in-between view itself.
#[test]
fn an_in_between_target_is_the_cross_fade_of_its_neighbours() {
    let a = arc(3, 1);
    let light = crate::scenes::orbit_light(300.0, 60.0, 10.0, 1e4);
    let (views, between) = arc_views(&a, &Plate::flat(100.0), &light);
    let scene = Scene {
        plate: scratchart_model::scene::Plate {
            size_mm: 100.0,
            roughness: scratchart_model::scene::DEFAULT_ROUGHNESS,
            f0: scratchart_model::scene::DEFAULT_F0,
            shape: Default::default(),
        },
        views,
        scratches: vec![],
    };
    let pic = |v: f32| Picture {
        path: PathBuf::from("p.png"),
        width: 4,
        height: 4,
        data: vec![v; 16],
    };
    let walk = Walk {
        arc: a,
        source: "frames".into(),
        frames: vec![],
        between,
        probes: vec![],
    };
    let frames = Frames::Pictures(vec![pic(0.2), pic(1.0), pic(0.6)]);
    let t = walk_targets(&scene, &walk, &frames, Fit::Contain, 0.0, 1.0);
    assert_eq!(t.len(), 5);
    for (v, want) in [(0, 0.2f32), (1, 1.0), (2, 0.6), (3, 0.6), (4, 0.8)] {
        let vals: Vec<f32> = t[v]
            .image
            .iter()
            .zip(&t[v].picture)
            .filter(|(_, p)| **p)
            .map(|(x, _)| *x)
            .collect();
        assert!(vals.len() > 100, "view {v}: {} picture pixels", vals.len());
        // Interior pixels carry the blend; edge pixels are partly covered.
        let mut sorted = vals.clone();
        sorted.sort_by(f32::total_cmp);
        let median = sorted[sorted.len() / 2];
        assert!((median - want).abs() < 1e-4, "view {v}: median {median}, want {want}");
    }
}
