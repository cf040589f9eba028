//! The carving plan without hardware: order, travel, bounds, time and the G-code text.
use scratchart_machine::depths::depths;
use scratchart_machine::gcode;
use scratchart_machine::plan::{
    check_bounds, job_time, move_time, nearest_neighbour, travel, two_opt, Cut, MachineProfile,
};
use scratchart_model::scene::Scratch;
use scratchart_tool::Tool;

/// A small deterministic generator (xorshift), so the test needs nothing else.
struct Xs(u64);
impl Xs {
    fn f(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn random_cuts(n: usize, plate: f64) -> Vec<Cut> {
    let mut r = Xs(0x9E37_79B9_7F4A_7C15);
    let h = 0.45 * plate;
    (0..n)
        .map(|k| {
            let a = [(2.0 * r.f() - 1.0) * h, (2.0 * r.f() - 1.0) * h];
            let t = r.f() * std::f64::consts::TAU;
            let l = 1.0 + 4.0 * r.f();
            Cut {
                a,
                b: [(a[0] + l * t.cos()).clamp(-h, h), (a[1] + l * t.sin()).clamp(-h, h)],
                z: 0.05,
                scratch: k,
            }
        })
        .collect()
}

#[test]
fn ordering_cuts_travel_and_keeps_every_cut() {
    let cuts = random_cuts(2000, 100.0);
    let before = travel(&cuts);
    let nn = nearest_neighbour(&cuts);
    let opt = two_opt(nn.clone(), 200);
    let (t_nn, t_opt) = (travel(&nn), travel(&opt));
    eprintln!("travel: input order {before:.0} mm, nearest neighbour {t_nn:.0} mm, 2-opt {t_opt:.0} mm");
    assert!(t_nn < 0.2 * before, "nearest neighbour: {t_nn} vs {before}");
    assert!(t_opt < t_nn, "2-opt must shorten the tour: {t_opt} vs {t_nn}");
    // Every scratch once, as the same segment (either direction).
    let mut seen = vec![false; cuts.len()];
    for c in &opt {
        assert!(!seen[c.scratch], "scratch {} twice", c.scratch);
        seen[c.scratch] = true;
        let o = cuts[c.scratch];
        assert!((c.a == o.a && c.b == o.b) || (c.a == o.b && c.b == o.a));
    }
    assert!(seen.iter().all(|s| *s));
}

#[test]
fn bounds_are_refused_with_the_scratch_named() {
    let m = MachineProfile::grbl();
    let mut cuts = random_cuts(10, 100.0);
    assert!(check_bounds(&cuts, 100.0, &m).is_ok());
    cuts[3].b = [60.0, 0.0];
    let e = check_bounds(&cuts, 100.0, &m).unwrap_err();
    assert!(e.contains("scratch 4") && e.contains("off the 100 mm plate"), "{e}");
    let e = check_bounds(&random_cuts(10, 100.0), 400.0, &m).unwrap_err();
    assert!(e.contains("does not fit"), "{e}");
}

#[test]
fn time_follows_the_acceleration_model() {
    let a = 200.0;
    // A long move reaches the feed: d / v + v / a.
    assert!((move_time(100.0, 600.0, a) - (100.0 / 10.0 + 10.0 / a)).abs() < 1e-12);
    // A short one does not: 2 sqrt(d / a).
    assert!((move_time(0.1, 600.0, a) - 2.0 * (0.1f64 / a).sqrt()).abs() < 1e-12);
    let m = MachineProfile::grbl();
    let c = Cut {
        a: [10.0, 0.0],
        b: [20.0, 0.0],
        z: 0.05,
        scratch: 0,
    };
    let want = move_time(10.0, m.rapid_mm_min, m.accel_mm_s2)
        + move_time(m.safe_z_mm + 0.05, m.plunge_mm_min, m.accel_mm_s2)
        + move_time(10.0, m.cut_mm_min, m.accel_mm_s2)
        + move_time(m.safe_z_mm + 0.05, m.rapid_mm_min, m.accel_mm_s2)
        + move_time(20.0, m.rapid_mm_min, m.accel_mm_s2);
    assert!((job_time(&[c], &m) - want).abs() < 1e-12);
    // More than distance over feed.
    assert!(job_time(&[c], &m) > 10.0 / (m.cut_mm_min / 60.0) + 30.0 / (m.rapid_mm_min / 60.0));
}

#[test]
fn gcode_names_its_firmware_and_keeps_lines_short() {
    let cuts = two_opt(nearest_neighbour(&random_cuts(50, 100.0)), 200);
    for m in [MachineProfile::grbl(), MachineProfile::marlin()] {
        let g = gcode::write(&cuts, &m, 100.0, &["a summary line that is quite long and has to be folded so that every line stays under eighty characters".into()]);
        let first = g.lines().next().unwrap();
        assert_eq!(
            first,
            format!(
                "; scratchart plan machine={}",
                if m.spindle_rpm.is_some() { "grbl" } else { "marlin" }
            )
        );
        assert!(!g.contains('\r') && g.ends_with('\n'));
        assert!(g.lines().all(|l| l.len() < 80), "a line is 80 characters or more");
        assert_eq!(g.lines().filter(|l| l.starts_with("; scratch ")).count(), 50);
        assert_eq!(g.lines().filter(|l| l.starts_with("G1 Z-")).count(), 50);
        assert!(
            !g.contains("e-") && !g.contains("-0.0000 "),
            "no exponents or negative zeros"
        );
        if m.spindle_rpm.is_some() {
            assert!(g.contains("M3 S10000") && g.contains("M5") && g.contains("G21 G90 G94"));
        } else {
            assert!(!g.contains("M3") && g.trim_end().ends_with("M400"));
        }
    }
}

#[test]
fn depths_come_from_the_tool_curve() {
    let tool = Tool::VBit {
        angle_deg: 60.0,
        tip_flat_mm: 0.01,
        z_offset_mm: 0.002,
    };
    let zs = [0.01, 0.023, 0.047, 0.08];
    let scratches: Vec<Scratch> = zs
        .iter()
        .map(|&z| {
            let m = tool.model(z).unwrap();
            Scratch {
                p0: [0.0, 0.0],
                p1: [1.0, 0.0],
                w: m.w,
                d: m.d,
                alpha: 0.1,
            }
        })
        .collect();
    for ((z, e), want) in depths(&scratches, &tool, 0.2).into_iter().zip(zs) {
        assert!((z - want).abs() < 1e-5 && e < 1e-4, "{z} vs {want} (mismatch {e})");
    }
}
