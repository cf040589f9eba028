//! Where a design's lamp goes by default (`engine/design/src/lamp_place.rs`, wired in
//! `spec::problem`): overhead for three views round the ring, 90 degrees round from two views
//! face to face, 20 degrees above the views for one view and for four (where spreading the
//! grooves measured worse), as given where the flags place it; `design` says where and why.
use scratchart_design::spec::{problem, DesignSpec};
use scratchart_model::scene::LightKind;
use scratchart_observe::Collect;
use scratchart_tests::{assert_no_validation, gpu};

/// The lamp of the default design of `views` views (flags as `spec` changes them): its
/// azimuth and elevation in degrees, and what `design` noted.
fn lamp_of(views: usize, change: impl Fn(&mut DesignSpec)) -> (f64, f64, Vec<String>) {
    let ctx = gpu();
    let mut spec = DesignSpec {
        views,
        res: 24,
        scratches: Some(50),
        ..DesignSpec::default()
    };
    change(&mut spec);
    let obs = Collect::default();
    let p = problem(&spec, ctx.info(), &obs).unwrap();
    let LightKind::Point { position: q } = p.scene.views[0].light.kind else {
        panic!("a point lamp")
    };
    assert!(
        p.scene.views.iter().all(|v| v.light == p.scene.views[0].light),
        "one lamp"
    );
    let r = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
    let notes = obs.notes.lock().unwrap().clone();
    assert_no_validation(&ctx);
    (q[1].atan2(q[0]).to_degrees(), (q[2] / r).asin().to_degrees(), notes)
}

#[test]
fn three_views_get_the_lamp_overhead_and_are_told_why() {
    let (_, el, notes) = lamp_of(3, |_| {});
    assert!((el - 90.0).abs() < 1e-6, "elevation {el}");
    assert!(
        notes
            .iter()
            .any(|n| n.contains("elevation 90") && n.contains("differ by at least 60 degrees")),
        "{notes:?}"
    );
}

#[test]
fn two_views_get_it_round_from_both_and_four_keep_it_above_view_0() {
    let (az, el, _) = lamp_of(2, |_| {});
    assert!((az.abs() - 90.0).abs() < 1e-6 && (el - 45.0).abs() < 1e-6, "{az} {el}");
    let (az, el, notes) = lamp_of(4, |_| {});
    assert!(az.abs() < 1e-6 && (el - 65.0).abs() < 1e-6, "{az} {el}");
    assert!(!notes.iter().any(|n| n.contains("differ by at least")), "{notes:?}");
    let (az, el, _) = lamp_of(1, |_| {});
    assert!(az.abs() < 1e-6 && (el - 65.0).abs() < 1e-6, "{az} {el}");
}

#[test]
fn a_lamp_placed_by_the_flags_stays_where_they_put_it() {
    let (az, el, notes) = lamp_of(3, |s| s.light_elevation = Some(65.0));
    assert!(az.abs() < 1e-6 && (el - 65.0).abs() < 1e-6, "{az} {el}");
    assert!(!notes.iter().any(|n| n.contains("differ by at least")), "{notes:?}");
    let (az, el, _) = lamp_of(3, |s| s.light_azimuth = Some(30.0));
    assert!((az - 30.0).abs() < 1e-6 && (el - 65.0).abs() < 1e-6, "{az} {el}");
}
