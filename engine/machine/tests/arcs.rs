//! Arc scratches in the plan (`scratchart_model::arc`): one G2 or G3 move each, timed and
//! bounded along the arc. The real firmware carving them is `grbl_sim.rs`'s; the drawings,
//! `export.rs`'s.
use scratchart_machine::plan::{check_cuts, job_time, program_time, Block, Cut};
use scratchart_tool::machine::MachineProfile;

/// An arc is one G2 (clockwise) or G3 move whose I and J put the centre at the arc's radius from
/// both ends; the job's time follows the arc's length, not its chord's; the plan's bounds hold
/// its bulge, and a bulge that leaves the plate is refused.
#[test]
fn arcs_are_one_g2_or_g3_move() {
    use scratchart_machine::program::Program;
    let m = MachineProfile::grbl();
    let arc = |bulge: f64| Cut {
        a: [-5.0, 0.0],
        b: [5.0, 0.0],
        z: 0.03,
        scratch: 0,
        bulge,
    };
    for bulge in [0.4, -0.4, 1.0, -2.0] {
        let g = scratchart_machine::gcode::write(&[arc(bulge)], &m, 30.0, &[]);
        let line = g
            .lines()
            .find(|l| l.starts_with("G2 ") || l.starts_with("G3 "))
            .expect("an arc move");
        assert!(line.starts_with(if bulge > 0.0 { "G3 " } else { "G2 " }), "{line}");
        let w = |c: char| -> f64 {
            line.split_whitespace().find(|x| x.starts_with(c)).unwrap()[1..]
                .parse()
                .unwrap()
        };
        let centre = [-5.0 + w('I'), w('J')];
        let geom = scratchart_model::arc::ArcGeom::of([-5.0, 0.0], [5.0, 0.0], bulge).unwrap();
        for p in [[-5.0, 0.0], [w('X'), w('Y')]] {
            let r = (p[0] - centre[0]).hypot(p[1] - centre[1]);
            assert!((r - geom.radius).abs() < 1e-4, "bulge {bulge}: {r} vs {}", geom.radius);
        }
        // The time: longer than the chord's by about the extra length at the cut feed.
        let straight = job_time(&[arc(0.0)], &m);
        let t = job_time(&[arc(bulge)], &m);
        let extra = (geom.length() - 10.0) / (m.cut_mm_min / 60.0);
        assert!(
            (t - straight - extra).abs() < 0.05 * extra + 0.05,
            "bulge {bulge}: {t} - {straight} vs {extra}"
        );
        // The plan as the sender reads it: the same time, and the bulge inside its bounds.
        let p = Program::parse(&g).unwrap();
        let k = scratchart_machine::planner::Kinematics::of_profile(&m);
        let block = Block::flat(&arc(bulge));
        let want = program_time(&[block], &m);
        assert!(
            (p.timing(&k).from(0) - want).abs() < 1e-6,
            "{} vs {want}",
            p.timing(&k).from(0)
        );
        let b = p.xy_bounds().unwrap();
        let reach = geom.band_bbox(0.0);
        assert!(
            (b[1] - reach[1]).abs() < 0.01 && (b[3] - reach[3]).abs() < 0.01,
            "{b:?} vs {reach:?}"
        );
    }
    // A half circle of radius 5 about the centre of a 12 mm plate stays on it; of a 10 mm
    // one, its top leaves.
    assert!(check_cuts(&[arc(-1.0)], 12.0, &m, 0.001).is_ok());
    let err = check_cuts(&[arc(-1.5)], 12.0, &m, 0.001).unwrap_err();
    assert!(err.contains("off the 12 mm plate"), "{err}");
}
