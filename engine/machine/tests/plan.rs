//! The carving plan without hardware: order, travel, bounds, time, the G-code text (GRBL and
//! Marlin), the orientation mark and levelling by a height map.
use scratchart_machine::depths::depths;
use scratchart_machine::gcode::{self, write_blocks, Options};
use scratchart_machine::level::{compensate, HeightMap};
use scratchart_machine::plan::{
    check_bounds, check_cuts, check_moves, job_time, move_time, nearest_neighbour, orientation_mark, program_time,
    program_time_rest_to_rest, program_time_split, travel, two_opt, Block, Cut, Label,
};
use scratchart_model::scene::Scratch;
use scratchart_tool::machine::MachineProfile;
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
                bulge: 0.0,
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
    assert!(check_bounds(&cuts, 100.0, &m, 0.0).is_ok());
    cuts[3].b = [60.0, 0.0];
    let e = check_bounds(&cuts, 100.0, &m, 0.0).unwrap_err();
    assert!(e.contains("scratch 4") && e.contains("off the 100 mm plate"), "{e}");
    let e = check_bounds(&random_cuts(10, 100.0), 400.0, &m, 0.0).unwrap_err();
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
        bulge: 0.0,
    };
    // From the work zero at the clearance height: the rapid, down to the retract height, the
    // plunge, the cut, the retract; then up to the clearance height and home. Summed move by
    // move from rest to rest, an upper bound of the planner's time; the moves at their top
    // speeds, a lower one. Every junction here turns 90 degrees, where GRBL's planner keeps
    // sqrt(a delta sin45 / (1 - sin45)) = 2.2 mm/s: a little less than the sum.
    // The spindle's dwell after M3 (GRBL with a spindle) is a wait in every one of these.
    let dwell = scratchart_machine::plan::SPINDLE_DWELL_S;
    let moves = [
        (10.0, m.rapid_mm_min),
        (m.clearance_mm - m.retract_mm, m.rapid_mm_min),
        (m.retract_mm + 0.05, m.plunge_mm_min),
        (10.0, m.cut_mm_min),
        (m.retract_mm + 0.05, m.rapid_mm_min),
        (m.clearance_mm - m.retract_mm, m.rapid_mm_min),
        (20.0, m.rapid_mm_min),
    ];
    let rest_to_rest: f64 = dwell + moves.iter().map(|&(d, v)| move_time(d, v, m.accel_mm_s2)).sum::<f64>();
    let cruise: f64 = dwell + moves.iter().map(|&(d, v)| d / (v / 60.0)).sum::<f64>();
    // The plan's own upper bound is this sum (every move here runs along one axis).
    let blocks = [Block::flat(&c)];
    let upper = program_time_rest_to_rest(&blocks, &m);
    assert!((upper - rest_to_rest).abs() < 1e-9, "{upper} vs {rest_to_rest}");
    let t = job_time(&[c], &m);
    eprintln!("one cut: planner {t:.4} s, move by move from rest {rest_to_rest:.4} s, at top speeds {cruise:.4} s");
    assert!(t < rest_to_rest && t > cruise, "{t} outside ({cruise}, {rest_to_rest})");
    // The junctions save at most what a stop costs at each of the 6 junctions.
    let vj = (m.accel_mm_s2 * m.junction_deviation_mm * 0.5f64.sqrt() / (1.0 - 0.5f64.sqrt())).sqrt();
    assert!(
        rest_to_rest - t < 6.0 * 2.0 * vj / m.accel_mm_s2 + 1e-9,
        "{t} vs {rest_to_rest}"
    );
    // More than distance over feed.
    assert!(t > 10.0 / (m.cut_mm_min / 60.0) + 30.0 / (m.rapid_mm_min / 60.0));
}

/// The planner's time against cases worked by hand: a straight line cut in pieces takes the
/// time of the whole; a reversal stops; a corner is passed at the junction speed; pieces shorter
/// than the planner's lookahead can stop in keep the machine slower than one long move; a dwell
/// or spindle command stops it; and it never exceeds a move-by-move sum from rest to rest.
#[test]
fn the_planner_follows_grbls_junctions_and_lookahead() {
    use scratchart_machine::planner::Kinematics;
    use scratchart_machine::planner::{segment_times, Moves, LOOKAHEAD};
    let k = Kinematics {
        rate_mm_min: [600.0; 3],
        accel_mm_s2: [100.0; 3],
        junction_deviation_mm: 0.01,
        source: String::new(),
    };
    let (v, a) = (10.0, 100.0); // 600 mm/min
    let total = |pts: &[[f64; 3]], stops: &[usize]| -> f64 {
        let mut mv = Moves::new([0.0; 3], &k);
        for (i, p) in pts.iter().enumerate() {
            if stops.contains(&i) {
                mv.stop();
            }
            mv.go(*p, None, ());
        }
        mv.times().map(|x| x.1).sum()
    };
    let whole = total(&[[10.0, 0.0, 0.0]], &[]);
    assert!((whole - move_time(10.0, 600.0, a)).abs() < 1e-12);
    let pieces: Vec<[f64; 3]> = (1..=10).map(|i| [i as f64, 0.0, 0.0]).collect();
    assert!(
        (total(&pieces, &[]) - whole).abs() < 1e-9,
        "{} vs {whole}",
        total(&pieces, &[])
    );
    // A stop in the middle: two moves from rest to rest.
    let stopped = total(&pieces, &[5]);
    assert!((stopped - 2.0 * move_time(5.0, 600.0, a)).abs() < 1e-9, "{stopped}");
    // A reversal: a stop.
    let back = total(&[[5.0, 0.0, 0.0], [0.0, 0.0, 0.0]], &[]);
    assert!((back - 2.0 * move_time(5.0, 600.0, a)).abs() < 1e-9);
    // A right angle in X and Y: entered and left at v_j = sqrt(a_j delta sin45 / (1 - sin45)),
    // a_j the acceleration along the junction's direction (-1, 1)/sqrt 2, where no axis goes
    // over its own a: a_j = a sqrt 2.
    let s45 = 0.5f64.sqrt();
    let vj = (a * 2f64.sqrt() * 0.01 * s45 / (1.0 - s45)).sqrt();
    let leg = |l: f64| v / a + (v - vj) / a + (l - v * v / (2.0 * a) - (v * v - vj * vj) / (2.0 * a)) / v;
    let corner = total(&[[5.0, 0.0, 0.0], [5.0, 5.0, 0.0]], &[]);
    assert!((corner - 2.0 * leg(5.0)).abs() < 1e-9, "{corner} vs {}", 2.0 * leg(5.0));
    // Pieces of 0.01 mm: the planner sees LOOKAHEAD of them ahead (0.15 mm) and must be able to
    // stop within them, so it never goes faster than sqrt(2 a 0.15) = 5.5 mm/s.
    let tiny: Vec<[f64; 3]> = (1..=1000).map(|i| [0.01 * i as f64, 0.0, 0.0]).collect();
    let t_tiny = total(&tiny, &[]);
    let v_cap = (2.0 * a * 0.01 * LOOKAHEAD as f64).sqrt();
    assert!(
        t_tiny > 10.0 / v_cap && t_tiny < 10.0 / v_cap + 2.0 * v_cap / a,
        "{t_tiny} vs {}",
        10.0 / v_cap
    );
    // Never more than the move-by-move sum, never less than at the top speed.
    let zigzag: Vec<[f64; 3]> = (1..=50)
        .map(|i| {
            [
                i as f64 * 0.7,
                if i % 2 == 0 { 0.0 } else { 0.4 },
                if i % 3 == 0 { -0.1 } else { 0.0 },
            ]
        })
        .collect();
    let mut mv = Moves::new([0.0; 3], &k);
    for p in &zigzag {
        mv.go(*p, Some(300.0), ());
    }
    let times = segment_times(&mv.segs, &k);
    let (mut sum_rest, mut sum_cruise) = (0.0, 0.0);
    for (s, t) in mv.segs.iter().zip(&times) {
        let rest = move_time(s.len, 60.0 * s.v_max, s.accel);
        assert!(*t <= rest + 1e-12 && *t >= s.len / s.v_max - 1e-12, "{t} vs {rest}");
        sum_rest += rest;
        sum_cruise += s.len / s.v_max;
    }
    let planned: f64 = times.iter().sum();
    eprintln!("zigzag: planner {planned:.3} s, move by move {sum_rest:.3} s, at top speed {sum_cruise:.3} s");
    assert!(planned < sum_rest);
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
                bulge: 0.0,
            }
        })
        .collect();
    for ((z, e), want) in depths(&scratches, &tool, 0.2).into_iter().zip(zs) {
        assert!((z - want).abs() < 1e-5 && e < 1e-4, "{z} vs {want} (mismatch {e})");
    }
}

/// The blocks of a G-code text: each block's comment and the (X, Y, Z) after each of its moves
/// below safe height (the plunge point, then every G1), from the modal position.
fn blocks_of(g: &str) -> Vec<(String, Vec<[f64; 3]>)> {
    let mut out: Vec<(String, Vec<[f64; 3]>)> = Vec::new();
    let mut pos = [0.0f64; 3];
    for line in g.lines() {
        if let Some(c) = line.strip_prefix("; ") {
            if c.starts_with("scratch ") || c.starts_with("mark ") {
                out.push((c.to_string(), Vec::new()));
            }
            continue;
        }
        if !(line.starts_with("G0 ") || line.starts_with("G1 ")) {
            continue;
        }
        let mut moved = false;
        for w in line.split_whitespace() {
            let v = |w: &str| w[1..].parse::<f64>().unwrap();
            match w.as_bytes()[0] {
                b'X' => (pos[0], moved) = (v(w), true),
                b'Y' => (pos[1], moved) = (v(w), true),
                b'Z' => (pos[2], moved) = (v(w), true),
                _ => {}
            }
        }
        if moved && line.starts_with("G1") && pos[2] < 1.0 {
            if let Some(b) = out.last_mut() {
                b.1.push(pos);
            }
        }
    }
    out
}

#[test]
fn marlin_gcode_has_no_spindle_and_homes_only_when_asked() {
    let cuts = two_opt(nearest_neighbour(&random_cuts(30, 100.0)), 200);
    let blocks: Vec<Block> = cuts.iter().map(Block::flat).collect();
    let m = MachineProfile::marlin();
    for home in [false, true] {
        let g = write_blocks(&blocks, &m, 100.0, &[], &Options { home });
        assert!(g.starts_with("; scratchart plan machine=marlin\n"));
        assert!(g.lines().any(|l| l == "G21") && g.lines().any(|l| l == "G90"));
        assert_eq!(g.lines().last(), Some("M400"), "M400 ends the plan");
        let codes: Vec<&str> = g.lines().filter(|l| !l.starts_with(';')).collect();
        for l in &codes {
            let words: Vec<&str> = l.split_whitespace().collect();
            assert!(
                !words
                    .iter()
                    .any(|w| ["M3", "M4", "M5"].contains(w) || w.starts_with('S')),
                "a spindle command in a Marlin plan: {l}"
            );
            // Every move carries its feed; every pure Z move runs at the printer's Z feed.
            if l.starts_with("G0") || l.starts_with("G1") {
                assert!(l.contains(" F"), "no feed: {l}");
                if !l.contains('X') && !l.contains('Y') {
                    assert!(l.ends_with(" F300"), "a Z move not at the Z feed: {l}");
                }
            }
        }
        assert_eq!(codes.iter().any(|l| l.starts_with("G28")), home, "G28 only with --home");
        if home {
            assert!(
                codes.contains(&"G28 X Y") && codes.contains(&"G92 X-110.0000 Y-110.0000"),
                "{g}"
            );
        }
        assert!(g.lines().all(|l| l.len() < 80));
        // The cuts read back as planned.
        let back = blocks_of(&g);
        assert_eq!(back.len(), 30);
        for (i, ((label, pts), c)) in back.iter().zip(&cuts).enumerate() {
            // The design's number, then the place in the cut order.
            assert_eq!(label, &format!("scratch {} (cut {} of 30)", c.scratch + 1, i + 1));
            assert_eq!(pts.len(), 2, "{label}: {pts:?}");
            assert!((pts[0][0] - c.a[0]).abs() < 1e-4 && (pts[1][1] - c.b[1]).abs() < 1e-4);
            assert!((pts[0][2] + c.z).abs() < 1e-4);
        }
    }
}

#[test]
fn every_move_is_checked_against_the_bed() {
    let mut m = MachineProfile::marlin();
    let blocks: Vec<Block> = random_cuts(20, 100.0).iter().map(Block::flat).collect();
    assert!(check_moves(&blocks, &m).is_ok());
    m.travel_mm = [80.0, 220.0, 250.0];
    let e = check_moves(&blocks, &m).unwrap_err();
    assert!(e.contains("leaves the 80 x 220 mm bed"), "{e}");
    // Too deep for the Z travel.
    let mut deep = blocks.clone();
    deep[0].path[0][2] = -300.0;
    assert!(check_moves(&deep, &MachineProfile::marlin())
        .unwrap_err()
        .contains("Z travel"));
}

#[test]
fn card_depths_above_zero_are_allowed_only_where_asked() {
    let m = MachineProfile::grbl();
    let mut cuts = random_cuts(5, 100.0);
    cuts[2].z = -0.02;
    let e = check_bounds(&cuts, 100.0, &m, 0.0).unwrap_err();
    assert!(e.contains("scratch 3") && e.contains(">= 0"), "{e}");
    assert!(check_cuts(&cuts, 100.0, &m, -0.5).is_ok());
    cuts[2].z = -0.6;
    assert!(check_cuts(&cuts, 100.0, &m, -0.5).is_err());
}

#[test]
fn the_mark_points_plus_x_on_the_plate_clear_of_the_scratches() {
    let plate = 100.0;
    // Scratches with room at the +x edge: the mark sits at y = 0, clear of them.
    let sc: Vec<_> = random_cuts(400, 80.0).iter().map(|c| (c.a, c.b, 0.08)).collect();
    let mk = orientation_mark(&sc, plate, 0.05, 0.5);
    assert!(mk.clear);
    assert_eq!((mk.a[1], mk.b[1]), (0.0, 0.0));
    assert!(mk.b[0] > mk.a[0], "it points +x");
    assert!(
        mk.b[0] < 0.5 * plate && mk.b[0] > 0.45 * plate,
        "at the +x edge, on the plate: {mk:?}"
    );
    // A scratch across the middle of the edge: the mark moves along the edge to clear it.
    let blocking = vec![([45.0, -1.0], [49.5, 1.0], 0.1)];
    let mk = orientation_mark(&blocking, plate, 0.05, 0.5);
    assert!(mk.clear && mk.a[1] != 0.0, "{mk:?}");
    assert!(mk.a[1].abs() < 0.5 * plate && mk.b[0] < 0.5 * plate);
    // Scratches filling the whole edge: it goes at y = 0 across them, and says so.
    let full: Vec<_> = (0..200)
        .map(|k| {
            let y = -49.5 + 0.5 * k as f64;
            ([40.0, y], [49.9, y], 0.1)
        })
        .collect();
    let mk = orientation_mark(&full, plate, 0.05, 0.5);
    assert!(!mk.clear && mk.a[1] == 0.0);
    let b = mk.block();
    assert_eq!(b.label, Label::Mark);
    let g = write_blocks(&[b], &MachineProfile::grbl(), plate, &[], &Options::default());
    assert!(g.contains("\n; mark +x edge (cut 1 of 1)\n") && !g.contains("; scratch "));
}

fn tilted_map() -> HeightMap {
    let xs: Vec<f64> = (0..6).map(|i| -50.0 + 20.0 * i as f64).collect();
    let ys: Vec<f64> = (0..6).map(|j| -50.0 + 20.0 * j as f64).collect();
    let z = ys
        .iter()
        .map(|&y| xs.iter().map(|&x| 0.05 + 0.003 * x - 0.002 * y).collect())
        .collect();
    HeightMap::new(xs, ys, z).unwrap()
}

#[test]
fn levelling_keeps_the_depth_below_a_tilted_surface() {
    let map = tilted_map();
    let plane = |x: f64, y: f64| 0.05 + 0.003 * x - 0.002 * y;
    for c in random_cuts(200, 100.0) {
        let path = compensate(&map, c.a, c.b, c.z, 0.001).unwrap();
        assert_eq!(path.len(), 2, "a plane needs no split");
        // Every point of every segment: depth below the surface = the designed depth.
        for w in path.windows(2) {
            for k in 0..=10 {
                let t = k as f64 / 10.0;
                let p: Vec<f64> = (0..3).map(|i| w[0][i] + t * (w[1][i] - w[0][i])).collect();
                let depth = plane(p[0], p[1]) - p[2];
                assert!((depth - c.z).abs() < 1e-12, "depth {depth} vs {}", c.z);
            }
        }
        assert!(close2(path[0], c.a) && close2(path[1], c.b));
    }
}

fn close2(p: [f64; 3], q: [f64; 2]) -> bool {
    (p[0] - q[0]).abs() < 1e-12 && (p[1] - q[1]).abs() < 1e-12
}

#[test]
fn levelling_splits_cuts_over_a_bent_surface() {
    // A saddle z = 0.0004 x y between probes 10 mm apart: bilinear, bent along a diagonal cut.
    let xs: Vec<f64> = (0..11).map(|i| -50.0 + 10.0 * i as f64).collect();
    let z = xs
        .iter()
        .map(|&y| xs.iter().map(|&x| 0.0004 * x * y).collect())
        .collect();
    let map = HeightMap::new(xs.clone(), xs, z).unwrap();
    let tol = 0.001;
    let (a, b, depth) = ([-45.0, -40.0], [42.0, 44.0], 0.03);
    let path = compensate(&map, a, b, depth, tol).unwrap();
    assert!(path.len() > 10, "a bent surface is split: {} points", path.len());
    let mut worst = 0.0f64;
    for w in path.windows(2) {
        for k in 0..=50 {
            let t = k as f64 / 50.0;
            let p: Vec<f64> = (0..3).map(|i| w[0][i] + t * (w[1][i] - w[0][i])).collect();
            worst = worst.max((map.at(p[0], p[1]) - p[2] - depth).abs());
        }
        // Each segment's ends are exactly the designed depth below the surface.
        assert!((map.at(w[0][0], w[0][1]) - w[0][2] - depth).abs() < 1e-12);
    }
    assert!(worst <= tol + 1e-12, "the surface departs {worst} mm from a segment");
    assert!(worst > 0.2 * tol, "the split is not wastefully fine: {worst}");
}

#[test]
fn malformed_height_maps_are_refused_clearly() {
    let dir = std::env::temp_dir().join(format!("scratchart_level_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cases = [
        (r#"{"x_mm":[0,10],"y_mm":[0,10],"z_mm":[[0,0],[0,0]]}"#, None),
        (
            r#"{"x_mm":[10,0],"y_mm":[0,10],"z_mm":[[0,0],[0,0]]}"#,
            Some("x_mm must increase strictly"),
        ),
        (
            r#"{"x_mm":[0,10],"y_mm":[0,10],"z_mm":[[0,0]]}"#,
            Some("z_mm has 1 rows but y_mm has 2"),
        ),
        (
            r#"{"x_mm":[0,10],"y_mm":[0,10],"z_mm":[[0,0],[0]]}"#,
            Some("z_mm row 1 has 1 heights"),
        ),
        (r#"{"x_mm":[],"y_mm":[0],"z_mm":[[]]}"#, Some("x_mm is empty")),
        (
            r#"{"x_mm":[0,10],"y_mm":[0,10],"z_mm":[[0,0],[0,1e999]]}"#,
            Some("height map"),
        ),
        (
            r#"{"x_mm":[0,10],"y_mm":[0,10],"z":[[0,0],[0,0]]}"#,
            Some("unknown field"),
        ),
    ];
    for (k, (text, want)) in cases.iter().enumerate() {
        let p = dir.join(format!("h{k}.json"));
        std::fs::write(&p, text).unwrap();
        match (HeightMap::load(&p), want) {
            (Ok(m), None) => assert_eq!(HeightMap::load(&p).unwrap(), m),
            (Err(e), Some(w)) => {
                let e = e.to_string();
                assert!(e.contains(w) && e.contains(&format!("h{k}.json")), "{e} (wanted {w})");
            }
            (r, w) => panic!("case {k}: {r:?}, wanted {w:?}"),
        }
    }
    let nan = HeightMap::new(vec![0.0], vec![0.0], vec![vec![f64::NAN]]).unwrap_err();
    assert!(nan.to_string().contains("z_mm[0][0] is not a finite number"));
    // A saved map reads back equal.
    let m = tilted_map();
    std::fs::write(dir.join("ok.json"), m.to_json()).unwrap();
    assert_eq!(HeightMap::load(&dir.join("ok.json")).unwrap(), m);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Between neighbouring cuts the tool waits at the retract height (a few tenths of a millimetre);
/// a travel longer than `long_travel_mm` rises to the clearance height first. The G-code does
/// what the time model counts, and the retract halves the time a design spends in the air.
#[test]
fn neighbouring_cuts_hop_at_the_retract_height() {
    let m = MachineProfile::grbl();
    let cut = |x: f64, y: f64, k: usize| Cut {
        a: [x, y],
        b: [x + 1.0, y],
        z: 0.03,
        scratch: k,
        bulge: 0.0,
    };
    // Two neighbours 2 mm apart, then one 40 mm away (a long travel).
    let cuts = [cut(0.0, 0.0, 0), cut(0.0, 2.0, 1), cut(0.0, 42.0, 2)];
    let g = gcode::write(&cuts, &m, 100.0, &[]);
    let body: Vec<&str> = g.lines().skip_while(|l| !l.starts_with("; scratch 1 ")).collect();
    let block = |k: usize| -> Vec<&str> {
        body.iter()
            .skip_while(|l| !l.starts_with(&format!("; scratch {k} ")))
            .skip(1)
            .take_while(|l| !l.starts_with("; "))
            .copied()
            .collect()
    };
    assert_eq!(
        block(1),
        [
            "G0 X0.0000 Y0.0000",
            "G0 Z0.300",
            "G1 Z-0.0300 F100",
            "G1 X1.0000 Y0.0000 F300",
            "G0 Z0.300"
        ]
    );
    assert_eq!(
        block(2),
        [
            "G0 X0.0000 Y2.0000",
            "G1 Z-0.0300 F100",
            "G1 X1.0000 Y2.0000 F300",
            "G0 Z0.300"
        ]
    );
    assert_eq!(
        block(3)[..4],
        ["G0 Z2.000", "G0 X0.0000 Y42.0000", "G0 Z0.300", "G1 Z-0.0300 F100"],
        "a long travel rises to the clearance height"
    );
    assert!(
        g.contains("G0 Z0.300\nG0 Z2.000\nM5"),
        "the end rises to the clearance height:\n{g}"
    );
    // The time model counts those moves: a profile that hops at the clearance height everywhere
    // (the old plans) takes longer, by the Z moves it adds.
    let blocks: Vec<Block> = cuts.iter().map(Block::flat).collect();
    let mut high = m.clone();
    high.retract_mm = high.clearance_mm;
    let (t, t_high) = (program_time(&blocks, &m), program_time(&blocks, &high));
    assert!(t < t_high, "{t} against {t_high}");
    let many = random_cuts(300, 100.0);
    let order = two_opt(nearest_neighbour(&many), 200);
    let blocks: Vec<Block> = order.iter().map(Block::flat).collect();
    let (t, t_high) = (program_time(&blocks, &m), program_time(&blocks, &high));
    eprintln!(
        "300 cuts: {:.1} min at a 0.3 mm retract, {:.1} min at 2 mm",
        t / 60.0,
        t_high / 60.0
    );
    assert!(t < 0.75 * t_high, "{t} against {t_high}");
    // Where the time goes: the parts add up to the job time, and the low retract saves Z time
    // (cutting and travelling change only where the planner's junctions see other neighbours).
    let (s, s_high) = (program_time_split(&blocks, &m), program_time_split(&blocks, &high));
    assert!((s.total() - t).abs() < 1e-9 * t && (s_high.total() - t_high).abs() < 1e-9 * t_high);
    assert!(
        (s.cutting - s_high.cutting).abs() < 0.01 * s.cutting && (s.travel - s_high.travel).abs() < 0.01 * s.travel,
        "{s:?} against {s_high:?}"
    );
    assert!(s.z < 0.5 * s_high.z, "{s:?} against {s_high:?}");
    eprintln!("at 0.3 mm: {}; at 2 mm: {}", s.shares(), s_high.shares());
}

/// A machine.json gives any fields over the built-in profile of its firmware; the old name
/// `safe_z_mm` is the clearance; an unknown key is warned about with the closest known key; a
/// bad value is an error naming the field. `to_json` prints a profile that reads back the same.
#[test]
fn machine_profiles_are_read_over_the_built_in_one() {
    use scratchart_tool::machine::Firmware;
    let (m, w) = MachineProfile::from_json(r#"{"retract_mm": 0.5}"#, Firmware::Grbl).unwrap();
    assert!(w.is_empty());
    assert_eq!(
        m,
        MachineProfile {
            retract_mm: 0.5,
            ..MachineProfile::grbl()
        }
    );
    let (m, w) = MachineProfile::from_json(
        r#"{"firmware": "marlin", "safe_z_mm": 3, "z_stepmm": 0.01}"#,
        Firmware::Grbl,
    )
    .unwrap();
    assert_eq!(m.firmware, Firmware::Marlin);
    assert_eq!(m.clearance_mm, 3.0);
    assert_eq!(m.z_step_mm, MachineProfile::marlin().z_step_mm);
    assert_eq!(w.len(), 1);
    assert!(w[0].contains("z_stepmm") && w[0].contains("z_step_mm"), "{w:?}");
    for (text, needle) in [
        (r#"{"retract_mm": 5}"#, "retract_mm 5 is above clearance_mm"),
        (r#"{"z_step_mm": 0}"#, "z_step_mm is 0"),
        (r#"{"min_cut_depth_mm": -1}"#, "min_cut_depth_mm is -1"),
        (r#"{"firmware": "smoothie"}"#, "expected \"grbl\" or \"marlin\""),
        (r#"{"cut_mm_min": "fast"}"#, "cut_mm_min"),
        (r#"[1, 2]"#, "JSON object"),
    ] {
        let e = MachineProfile::from_json(text, Firmware::Grbl).unwrap_err();
        assert!(e.contains(needle), "{text}: {e}");
    }
    for m in [MachineProfile::grbl(), MachineProfile::marlin()] {
        let (back, w) = MachineProfile::from_json(&m.to_json(), Firmware::Grbl).unwrap();
        assert_eq!(back, m);
        assert!(w.is_empty());
        // Every field is described.
        let v: serde_json::Value = serde_json::from_str(&m.to_json()).unwrap();
        for k in v.as_object().unwrap().keys() {
            assert!(
                MachineProfile::FIELDS.iter().any(|(f, _)| f == k),
                "{k} has no description"
            );
        }
    }
}
