//! The set-up sheet's drawing: labels that never overlap, marks apart, nice scales.
use super::*;
use crate::tolerance::{Moved, Tolerance};
use scratchart_model::scene::{Camera, Light, Plate, View};

fn scene(eyes: &[[f64; 3]], light: LightKind) -> Scene {
    Scene {
        plate: Plate {
            size_mm: 80.0,
            roughness: 0.02,
            f0: 0.9,
            shape: Default::default(),
        },
        views: eyes
            .iter()
            .enumerate()
            .map(|(j, &eye)| View {
                exposure: 1.0,
                name: format!("v{j}"),
                camera: Camera {
                    eye,
                    target: [0.0; 3],
                    up: [0.0, 0.0, 1.0],
                    fov_y_deg: 30.0,
                    width: 8,
                    height: 8,
                },
                light: Light {
                    kind: light.clone(),
                    intensity: 1.0e5,
                },
            })
            .collect(),
        scratches: vec![],
    }
}

/// A search's worth of samples and tolerances for every view.
fn sensitivity(scene: &Scene) -> Sensitivity {
    let mut s = Sensitivity {
        base: vec![0.8; scene.views.len()],
        ..Sensitivity::default()
    };
    for v in &scene.views {
        for moved in ["lamp", "eye"] {
            for axis in ["azimuth", "elevation", "distance"] {
                for d in [-5.0, -2.0, 1.0, 2.0, 5.0, 10.0] {
                    let d = if axis == "distance" { d / 50.0 } else { d };
                    let corr = 0.8 * (1.0 - 0.02 * d * d);
                    s.samples.push(Moved {
                        view: v.name.clone(),
                        moved,
                        axis,
                        delta: d,
                        corr,
                    });
                }
                s.tolerances.push(Tolerance {
                    view: v.name.clone(),
                    moved,
                    axis,
                    safe: [2.0, 2.0],
                    lost: [Some(2.5), Some(2.5)],
                });
            }
        }
    }
    s
}

fn assert_clean(label: &str, scene: &Scene) -> Layout {
    let (w, h) = (1400u32, 940u32);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    let l = draw(&mut buf, (w, h), scene, &sensitivity(scene)).unwrap();
    assert!(l.texts.len() > scene.views.len(), "{label}: {} texts", l.texts.len());
    let image = [0, 0, w as i32, h as i32];
    for (i, (t, r)) in l.texts.iter().enumerate() {
        assert!(inside(r, &image), "{label}: `{t}` {r:?} leaves the image");
        for c in &l.charts {
            assert!(!overlaps(r, c), "{label}: `{t}` {r:?} enters a chart {c:?}");
        }
        for o in &l.obstacles {
            assert!(!overlaps(r, o), "{label}: `{t}` {r:?} covers a mark {o:?}");
        }
        for (u, q) in &l.texts[..i] {
            assert!(!overlaps(r, q), "{label}: `{t}` {r:?} overlaps `{u}` {q:?}");
        }
    }
    // Whatever found no place in the drawing is in the key.
    for u in &l.unplaced {
        let name = u.split(' ').next().unwrap();
        assert!(
            l.texts
                .iter()
                .any(|(t, _)| t.starts_with(&format!("{name}: ")) || t.starts_with("... and")),
            "{label}: `{u}` is neither drawn nor in the key"
        );
    }
    l
}

#[test]
fn no_two_labels_overlap() {
    let ring = |n: usize, r: f64, el: f64| -> Vec<[f64; 3]> {
        (0..n).map(|k| Place::at(360.0 * k as f64 / n as f64, el, r)).collect()
    };
    // The lamp in v0's eye (the old default), three eyes at one distance and elevation.
    let eyes = ring(3, 300.0, 45.0);
    let l = assert_clean("lamp in an eye", &scene(&eyes, LightKind::Point { position: eyes[0] }));
    // Both views to one scale, and the scale fits the furthest point.
    assert!(300.0 / l.mm_per_px < 660.0, "{}", l.mm_per_px);
    // Twelve eyes along an arc at two distances, a directional lamp.
    let mut eyes: Vec<[f64; 3]> = (0..12)
        .map(|k| Place::at(-30.0 + 5.45 * k as f64, 30.0, 250.0))
        .collect();
    eyes.extend(ring(4, 600.0, 60.0));
    assert_clean(
        "an arc of eyes",
        &scene(
            &eyes,
            LightKind::Directional {
                direction: [0.2, 0.3, 1.0],
            },
        ),
    );
    // A lamp high above, just beyond the +x mark in the top view (where the mark's label goes).
    let eyes = ring(3, 300.0, 45.0);
    assert_clean(
        "a lamp by the mark",
        &scene(
            &eyes,
            LightKind::Point {
                position: [52.0, 0.0, 400.0],
            },
        ),
    );
    // Every mark of the side view apart, though the three eyes (and the lamp in v0's eye)
    // stand at one height and distance there.
    for (i, (a, p)) in l.side_marks.iter().enumerate() {
        for (b, q) in &l.side_marks[..i] {
            let d = (p.0 - q.0).abs().max((p.1 - q.1).abs());
            assert!(d >= 18, "{a} at {p:?} and {b} at {q:?} are drawn on one another");
        }
    }
    assert_eq!(l.side_marks.len(), 4);
    // A lamp far away and eyes close by.
    let eyes = ring(2, 120.0, 70.0);
    assert_clean(
        "a far lamp",
        &scene(
            &eyes,
            LightKind::Point {
                position: [2000.0, 0.0, 1500.0],
            },
        ),
    );
}

#[test]
fn scales_are_nice_and_large_enough() {
    for need in [0.013, 0.3, 0.51, 1.0, 2.2, 7.0] {
        let s = nice_scale(need);
        assert!(s >= need && s <= 2.5 * need, "{need} -> {s}");
    }
    assert_eq!(nice_length(230.0), 200.0);
    assert_eq!(nice_length(99.0), 50.0);
}
