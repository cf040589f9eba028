//! Levelling probes against the fakes: a tilted plate is recovered from a grid of G38.2 probes
//! (GRBL `[PRB:...]`; Marlin G38.2 with M114, or G30 without G38), and a probe that finds no
//! plate stops with a clear error.
// The fakes sit behind pseudo-terminals, which only Unix has.
#![cfg(unix)]
mod common;

use std::time::Duration;

use scratchart_machine::fake::{FakeGrbl, FakeMarlin, GrblConfig, MarlinConfig, Plane};
use scratchart_machine::level::HeightMap;
use scratchart_machine::probe::{probe_grid, ProbeOptions};
use scratchart_machine::stream::Control;

const PLANE: Plane = Plane {
    z0: 0.05,
    dzdx: 0.002,
    dzdy: -0.0015,
};

fn options(port: &str) -> ProbeOptions {
    ProbeOptions {
        port: port.into(),
        baud: 115200,
        plate_mm: 100.0,
        grid: (5, 4),
        margin_mm: 5.0,
        safe_z_mm: 2.0,
        depth_mm: 1.0,
        feed_mm_min: 50.0,
        detect_timeout: Duration::from_secs(3),
    }
}

fn assert_recovers(map: &HeightMap, tol: f64) {
    assert_eq!((map.x_mm.len(), map.y_mm.len()), (5, 4));
    assert_eq!((map.x_mm[0], map.x_mm[4]), (-45.0, 45.0));
    for (j, y) in map.y_mm.iter().enumerate() {
        for (i, x) in map.x_mm.iter().enumerate() {
            let e = (map.z_mm[j][i] - PLANE.at(*x, *y)).abs();
            assert!(e <= tol, "({x}, {y}): {} vs {}", map.z_mm[j][i], PLANE.at(*x, *y));
        }
    }
    // Bilinear between probes reproduces a plane.
    for (x, y) in [(0.0, 0.0), (12.3, -31.0), (-44.0, 40.0)] {
        assert!((map.at(x, y) - PLANE.at(x, y)).abs() <= tol);
    }
}

#[test]
fn grbl_probes_recover_a_tilted_plate() {
    let fake = FakeGrbl::start(GrblConfig {
        plane: Some(PLANE),
        ..GrblConfig::default()
    })
    .unwrap();
    let map = probe_grid(&options(fake.path()), &Control::default(), &common::Log::default()).unwrap();
    // GRBL 1.1h reports [PRB:...] with three decimals: each height is rounded to 0.5 um.
    assert_recovers(&map, 0.5e-3 + 1e-9);
    let r = fake.record();
    assert_eq!(r.probes.len(), 20);
    assert_eq!(r.pos, [0.0, 0.0, 2.0], "ends raised over the centre");
}

#[test]
fn marlin_probes_recover_a_tilted_plate_with_g38_or_g30() {
    for g38 in [true, false] {
        let fake = FakeMarlin::start(MarlinConfig {
            plane: Some(PLANE),
            g38,
            ..MarlinConfig::default()
        })
        .unwrap();
        let map = probe_grid(&options(fake.path()), &Control::default(), &common::Log::default()).unwrap();
        assert_recovers(&map, 1e-3);
        assert_eq!(fake.record().probes.len(), 20);
    }
}

#[test]
fn a_probe_that_finds_no_plate_stops() {
    // The plate lies lower than the probe searches.
    let fake = FakeGrbl::start(GrblConfig {
        plane: Some(Plane {
            z0: -3.0,
            dzdx: 0.0,
            dzdy: 0.0,
        }),
        ..GrblConfig::default()
    })
    .unwrap();
    let e = probe_grid(&options(fake.path()), &Control::default(), &common::Log::default()).unwrap_err();
    assert_eq!(e.exit_code(), 1, "{e}");
    assert!(
        e.to_string().contains("ALARM:5")
            && e.to_string().contains("X-45.000 Y-45.000")
            && !e.to_string().contains("Machine("),
        "{e}"
    );
    let mut o = options(fake.path());
    o.margin_mm = 60.0;
    assert_eq!(
        probe_grid(&o, &Control::default(), &common::Log::default())
            .unwrap_err()
            .exit_code(),
        2
    );
}
