//! Sanity checks of the float64 reference (engine/docs/model.md sections 2-5) against independent
//! computations: brute-force 2D quadrature, closed forms, symmetry, and a substitution-based
//! quadrature for a sharp lobe.

use std::f64::consts::PI;

use scratchart_model::reference::{check_loss, pixel, render_view, scratch_patch_integral};
use scratchart_model::scene::{Camera, Light, LightKind, Plate, Scene, Scratch, View};
use scratchart_model::ViewGeom;

fn scene(eye: [f64; 3], light: [f64; 3], size: u32, scratches: Vec<Scratch>) -> Scene {
    let s = Scene {
        plate: Plate {
            size_mm: 20.0,
            roughness: 0.02,
            f0: 0.91,
            shape: Default::default(),
        },
        views: vec![View {
            exposure: 1.0,
            name: "v".into(),
            camera: Camera {
                eye,
                target: [0.0, 0.0, 0.0],
                up: [0.0, 0.0, 1.0],
                fov_y_deg: 20.0,
                width: size,
                height: size,
            },
            light: Light {
                kind: LightKind::Point { position: light },
                intensity: 5000.0,
            },
        }],
        scratches,
    };
    s.validate().unwrap();
    s
}

/// Literal point NDF of engine/docs/model.md section 3 (fine in float64 for moderate alpha).
fn d_literal(c: f64, alpha: f64) -> f64 {
    if c <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let q = (a2 - 1.0) * c * c + 1.0;
    a2 / (PI * q * q)
}

/// n(u) . h for a scratch, straight from engine/docs/model.md section 2.
fn n_dot_h(s: &Scratch, q: [f64; 2], h: [f64; 3]) -> (f64, bool) {
    let l = s.length();
    let t = [(s.p1[0] - s.p0[0]) / l, (s.p1[1] - s.p0[1]) / l];
    let b = [-t[1], t[0]];
    let d = [q[0] - s.p0[0], q[1] - s.p0[1]];
    let u = d[0] * b[0] + d[1] * b[1];
    let v = d[0] * t[0] + d[1] * t[1];
    let inside = u.abs() <= s.half_width() && (0.0..=l).contains(&v);
    let th = 2.0 * (2.0 * u / s.w).atan();
    let n = [-th.sin() * b[0], -th.sin() * b[1], th.cos()];
    (n[0] * h[0] + n[1] * h[1] + n[2] * h[2], inside)
}

/// Brute-force midpoint integration over the footprint quad via its bilinear parametrisation.
fn brute(sc: &Scene, i: u32, j: u32, k: usize, n: usize) -> (f64, f64) {
    let g = ViewGeom::new(&sc.views[0]);
    let f = g.footprint(i, j).unwrap();
    let h = pixel(sc, 0, i, j).h;
    let s = &sc.scratches[k];
    let (mut int, mut area) = (0.0, 0.0);
    for bi in 0..n {
        let b = (bi as f64 + 0.5) / n as f64;
        for ai in 0..n {
            let a = (ai as f64 + 0.5) / n as f64;
            let mut q = [0.0; 2];
            let mut da = [0.0; 2];
            let mut db = [0.0; 2];
            for c in 0..2 {
                q[c] = (1.0 - a) * (1.0 - b) * f[0][c]
                    + a * (1.0 - b) * f[1][c]
                    + a * b * f[2][c]
                    + (1.0 - a) * b * f[3][c];
                da[c] = (1.0 - b) * (f[1][c] - f[0][c]) + b * (f[2][c] - f[3][c]);
                db[c] = (1.0 - a) * (f[3][c] - f[0][c]) + a * (f[2][c] - f[1][c]);
            }
            let jac = (da[0] * db[1] - da[1] * db[0]).abs() / (n * n) as f64;
            let (c, inside) = n_dot_h(s, q, h);
            if inside {
                int += d_literal(c, s.alpha) * jac;
                area += jac;
            }
        }
    }
    (int, area)
}

const EYE: [f64; 3] = [-40.0, -20.0, 60.0];
const LIGHT: [f64; 3] = [25.0, 10.0, 70.0];

#[test]
fn patch_integral_matches_brute_force_full_cover() {
    // A wide scratch (e ~ 2.3 mm) covering the centre footprint (~0.5 mm) entirely.
    let s = Scratch {
        p0: [0.3, -5.0],
        p1: [-0.2, 5.0],
        w: 5.0,
        d: 5.0,
        alpha: 0.3,
        bulge: 0.0,
    };
    let sc = scene(EYE, LIGHT, 48, vec![s]);
    let (i, j) = (24, 23);
    let (int, area) = scratch_patch_integral(&sc, 0, i, j, 0);
    let p = pixel(&sc, 0, i, j);
    assert!(p.on_plate);
    assert!(
        (area / p.s_p - 1.0).abs() < 1e-12,
        "footprint inside the groove: {area} vs {}",
        p.s_p
    );
    // (b) coverage of a footprint fully inside a carved region is 1.
    assert!((p.cov - 1.0).abs() < 1e-12, "cov {}", p.cov);
    let (bi, ba) = brute(&sc, i, j, 0, 1500);
    assert!((ba / area - 1.0).abs() < 1e-5, "area {ba} vs {area}");
    assert!((int / bi - 1.0).abs() < 1e-4, "integral {int} vs brute {bi}");
    assert!(int > 0.0 && (p.d_p - int / p.s_p).abs() <= 1e-12 * p.d_p);
}

#[test]
fn patch_integral_matches_brute_force_partial() {
    // The groove edge u = e and the scratch end v = l both cut the footprint.
    let g = ViewGeom::new(&scene(EYE, LIGHT, 48, vec![]).views[0]);
    let x = g.shading_point(20, 30).unwrap();
    let s = Scratch {
        p0: [x[0] - 3.0, x[1] - 3.1],
        p1: [x[0] + 0.05, x[1] + 0.12],
        w: 0.8,
        d: 0.3,
        alpha: 0.3,
        bulge: 0.0,
    };
    let e = s.half_width();
    // Shift sideways so the groove's edge passes near X.
    let l = s.length();
    let b = [-(s.p1[1] - s.p0[1]) / l, (s.p1[0] - s.p0[0]) / l];
    let off = 0.85 * e;
    let s = Scratch {
        p0: [s.p0[0] + off * b[0], s.p0[1] + off * b[1]],
        p1: [s.p1[0] + off * b[0], s.p1[1] + off * b[1]],
        ..s
    };
    let sc = scene(EYE, LIGHT, 48, vec![s]);
    let (int, area) = scratch_patch_integral(&sc, 0, 20, 30, 0);
    let p = pixel(&sc, 0, 20, 30);
    assert!(
        area > 0.05 * p.s_p && area < 0.95 * p.s_p,
        "partial overlap expected: {}",
        area / p.s_p
    );
    let (bi, ba) = brute(&sc, 20, 30, 0, 3000);
    assert!((ba / area - 1.0).abs() < 2e-3, "area {ba} vs {area}");
    assert!((bi / int - 1.0).abs() < 2e-3, "integral {int} vs brute {bi}");
    assert!((p.cov - area / p.s_p).abs() < 1e-14);
}

/// Independent camera + shading for a bare plate, straight from engine/docs/model.md section 4-5.
#[test]
fn flat_plate_closed_form() {
    let sc = scene(EYE, LIGHT, 32, vec![]);
    let img = render_view(&sc, 0);
    let cam = &sc.views[0].camera;
    let norm = |v: [f64; 3]| {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        [v[0] / n, v[1] / n, v[2] / n]
    };
    let crs = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let f = norm([-cam.eye[0], -cam.eye[1], -cam.eye[2]]);
    let r = norm(crs(f, cam.up));
    let u = crs(r, f);
    let t = (cam.fov_y_deg.to_radians() / 2.0).tan();
    let mut checked = 0;
    for (j, i) in [
        (0u32, 0u32),
        (5, 7),
        (16, 16),
        (31, 2),
        (20, 29),
        (10, 12),
        (22, 18),
        (12, 25),
        (26, 9),
    ] {
        let kx = (2.0 * (i as f64 + 0.5) / 32.0 - 1.0) * t;
        let ky = (1.0 - 2.0 * (j as f64 + 0.5) / 32.0) * t;
        let d = norm([
            f[0] + kx * r[0] + ky * u[0],
            f[1] + kx * r[1] + ky * u[1],
            f[2] + kx * r[2] + ky * u[2],
        ]);
        let s = -cam.eye[2] / d[2];
        let x = [cam.eye[0] + s * d[0], cam.eye[1] + s * d[1], 0.0];
        let wo = norm([cam.eye[0] - x[0], cam.eye[1] - x[1], cam.eye[2]]);
        let pl = [LIGHT[0] - x[0], LIGHT[1] - x[1], LIGHT[2]];
        let r2 = pl[0] * pl[0] + pl[1] * pl[1] + pl[2] * pl[2];
        let wi = norm(pl);
        let e = 5000.0 / r2;
        let h = norm([wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]]);
        let fr = 0.91 + 0.09 * (1.0 - (wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2])).powi(5);
        let l = e * fr * d_literal(h[2], 0.02) / (4.0 * wo[2]);
        let got = img[(j * 32 + i) as usize];
        if x[0].abs() > 10.0 || x[1].abs() > 10.0 {
            assert_eq!(got, 0.0);
            continue;
        }
        assert!((got / l - 1.0).abs() < 1e-9, "pixel ({i},{j}): {got} vs {l}");
        checked += 1;
    }
    assert!(checked >= 4, "{checked}");
    let p = pixel(&sc, 0, 16, 16);
    assert_eq!((p.cov, p.d_p, p.n_pairs), (0.0, 0.0, 0));
}

#[test]
fn off_plate_pixels_are_exactly_zero() {
    // A wide view: the plate covers only part of the image.
    let mut sc = scene(
        [0.0, -30.0, 40.0],
        [0.0, 30.0, 40.0],
        40,
        vec![Scratch {
            p0: [-9.9, -9.9],
            p1: [9.9, 9.9],
            w: 0.2,
            d: 0.1,
            alpha: 0.05,
            bulge: 0.0,
        }],
    );
    sc.views[0].camera.fov_y_deg = 60.0;
    let img = render_view(&sc, 0);
    let mask = scratchart_model::camera::on_plate_mask(&sc, 0);
    let (mut on, mut off) = (0, 0);
    for (v, m) in img.iter().zip(&mask) {
        assert!(v.is_finite());
        if *m {
            on += 1;
            assert!(*v > 0.0);
        } else {
            off += 1;
            assert_eq!(v.to_bits(), 0.0f64.to_bits());
        }
    }
    assert!(on > 100 && off > 100, "{on} on, {off} off");
}

fn mirror_x(sc: &Scene) -> Scene {
    let mut m = sc.clone();
    for v in &mut m.views {
        v.camera.eye[0] = -v.camera.eye[0];
        v.camera.target[0] = -v.camera.target[0];
        v.camera.up[0] = -v.camera.up[0];
        if let LightKind::Point { position } = &mut v.light.kind {
            position[0] = -position[0];
        }
    }
    for s in &mut m.scratches {
        s.p0[0] = -s.p0[0];
        s.p1[0] = -s.p1[0];
    }
    m
}

fn some_scratches(n: usize) -> Vec<Scratch> {
    (0..n)
        .map(|k| {
            let a = k as f64 * 2.399;
            let c = [6.0 * (0.7 * a).sin(), 6.0 * (1.3 * a).cos()];
            let dir = [a.cos(), a.sin()];
            let len = 0.5 + 3.0 * ((k * 7 % 11) as f64 / 11.0);
            Scratch {
                p0: [c[0] - 0.5 * len * dir[0], c[1] - 0.5 * len * dir[1]],
                p1: [c[0] + 0.5 * len * dir[0], c[1] + 0.5 * len * dir[1]],
                w: 0.05 + 0.3 * ((k * 3 % 7) as f64 / 7.0),
                d: 0.02 + 0.1 * ((k * 5 % 9) as f64 / 9.0),
                alpha: [0.001, 0.01, 0.1, 0.5][k % 4],
                bulge: 0.0,
            }
        })
        .collect()
}

#[test]
fn mirror_symmetry() {
    let sc = scene(EYE, LIGHT, 24, some_scratches(40));
    let m = mirror_x(&sc);
    m.validate().unwrap();
    let a = render_view(&sc, 0);
    let b = render_view(&m, 0);
    let max = a.iter().cloned().fold(0.0, f64::max);
    assert!(max > 0.0);
    let mut nonflat = 0;
    for j in 0..24 {
        for i in 0..24 {
            let (x, y) = (a[j * 24 + i], b[j * 24 + 23 - i]);
            assert!((x - y).abs() <= 1e-9 * x.abs() + 1e-14 * max, "({i},{j}): {x} vs {y}");
            if pixel(&sc, 0, i as u32, j as u32).n_pairs > 0 {
                nonflat += 1;
            }
        }
    }
    assert!(nonflat > 20, "scratched pixels: {nonflat}");
}

/// ∫_{-e}^{e} D(n(u) . h; alpha) du for h in the (z, b) plane, computed independently:
/// u = (w/2) tan(theta/2), delta = theta - theta*, tan(delta) = alpha tan(phi), which turns the
/// lobe into the smooth integrand (w/4)(1 + s^2)(cos^2 phi + alpha^2 sin^2 phi) / (pi alpha).
fn analytic_width_integral(w: f64, e: f64, alpha: f64, hz: f64, hb: f64) -> f64 {
    let th_star = -hb.atan2(hz);
    let th_e = 2.0 * (2.0 * e / w).atan();
    let d_lo = (-th_e - th_star).max(-PI / 2.0);
    let d_hi = (th_e - th_star).min(PI / 2.0);
    let phi = |d: f64| (d.tan() / alpha).atan();
    let (p_lo, p_hi) = (
        if d_lo <= -PI / 2.0 { -PI / 2.0 } else { phi(d_lo) },
        if d_hi >= PI / 2.0 { PI / 2.0 } else { phi(d_hi) },
    );
    let f = |p: f64| {
        let delta = (alpha * p.tan()).atan();
        let s = (0.5 * (th_star + delta)).tan();
        let (c, sn) = (p.cos(), p.sin());
        0.25 * w * (1.0 + s * s) * (c * c + alpha * alpha * sn * sn) / (PI * alpha)
    };
    // Composite Simpson, many points (the integrand is smooth in phi).
    let n = 2_000_000usize;
    let hstep = (p_hi - p_lo) / n as f64;
    let mut acc = f(p_lo) + f(p_hi);
    for k in 1..n {
        acc += f(p_lo + k as f64 * hstep) * if k % 2 == 1 { 4.0 } else { 2.0 };
    }
    acc * hstep / 3.0
}

#[test]
fn sharp_lobe_matches_substitution() {
    // Camera and light in the plane y = 0; odd image size so the centre pixel's ray passes
    // through the target (0, 0, 0): h lies in the (z, b) plane of a scratch along y.
    for (d, tag) in [(0.005, "no chi+ cut"), (0.02, "chi+ cut inside")] {
        let s = Scratch {
            p0: [0.0, -0.025],
            p1: [0.0, 0.025],
            w: 0.02,
            d,
            alpha: 1e-3,
            bulge: 0.0,
        };
        let sc = scene([-40.0, 0.0, 60.0], [20.0, 0.0, 70.0], 49, vec![s]);
        let p = pixel(&sc, 0, 24, 24);
        assert!(p.x[0].abs() < 1e-12 && p.x[1].abs() < 1e-12, "{:?}", p.x);
        assert!(p.h[1].abs() < 1e-12);
        let (int, area) = scratch_patch_integral(&sc, 0, 24, 24, 0);
        let e = s.half_width();
        assert!(
            (area / (2.0 * e * s.length()) - 1.0).abs() < 1e-12,
            "scratch inside footprint"
        );
        // b = (-t.y, t.x, 0) = (-1, 0, 0).
        let hb = -p.h[0];
        let th_star = -hb.atan2(p.h[2]);
        let th_e = 2.0 * (2.0 * e / s.w).atan();
        assert!(th_star.abs() < th_e, "lobe peak inside the groove");
        let cut = th_e + th_star.abs() > PI / 2.0;
        assert_eq!(cut, d == 0.02, "{tag}");
        let exact = s.length() * analytic_width_integral(s.w, e, s.alpha, p.h[2], hb);
        assert!(
            (int / exact - 1.0).abs() < 1e-8,
            "{tag}: {int} vs {exact}, rel {}",
            int / exact - 1.0
        );
        assert!((p.d_p - int / p.s_p).abs() <= 1e-12 * p.d_p);
    }
}

#[test]
fn many_overlapping_scratches_and_check_loss() {
    // 2000 scratches crossing the centre footprint, plus scattered ones.
    let g = ViewGeom::new(&scene(EYE, LIGHT, 48, vec![]).views[0]);
    let x = g.shading_point(24, 24).unwrap();
    let mut list: Vec<Scratch> = (0..2000)
        .map(|k| {
            let a = k as f64 * PI / 2000.0;
            let (c, s) = (a.cos(), a.sin());
            Scratch {
                p0: [x[0] - 2.0 * c, x[1] - 2.0 * s],
                p1: [x[0] + 2.0 * c, x[1] + 2.0 * s],
                w: 0.01 + 0.002 * (k % 5) as f64,
                d: 0.003,
                alpha: [0.001, 0.003, 0.03][k % 3],
                bulge: 0.0,
            }
        })
        .collect();
    list.extend(some_scratches(300));
    let sc = scene(EYE, LIGHT, 48, list);
    let t0 = std::time::Instant::now();
    let img = render_view(&sc, 0);
    let dt = t0.elapsed().as_secs_f64();
    eprintln!("48x48 view with 2300 scratches: {dt:.2} s");
    assert!(img.iter().all(|v| v.is_finite() && *v >= 0.0));
    let p = pixel(&sc, 0, 24, 24);
    assert!(p.n_pairs >= 2000 && p.n_pairs < 2010, "{}", p.n_pairs);
    assert!(p.cov <= 1.0 && p.cov > 0.0);
    assert!((img[24 * 48 + 24] - p.l).abs() <= 1e-15 * p.l);
    // check_loss: zero against itself; against zeros it is the mean of L^2 over on-plate pixels.
    assert_eq!(check_loss(&sc, std::slice::from_ref(&img)), 0.0);
    let mask = scratchart_model::camera::on_plate_mask(&sc, 0);
    let n = mask.iter().filter(|m| **m).count() as f64;
    let want: f64 = img
        .iter()
        .zip(&mask)
        .filter(|(_, m)| **m)
        .map(|(v, _)| v * v)
        .sum::<f64>()
        / n;
    let got = check_loss(&sc, &[vec![0.0; 48 * 48]]);
    assert!((got / want - 1.0).abs() < 1e-12);
}
