//! Built-in scenes: the benchmark scenes S and M (engine/docs/performance.md), the paper-scale scene, and the demo
//! plate. Generated from a seed with a small deterministic generator, so every machine builds the
//! same scene.
use scratchart_model::scene::{Camera, Light, LightKind, Plate, Scene, Scratch, View};

/// SplitMix64: tiny, deterministic, good enough for scene generation.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed ^ 0x9E37_79B9_7F4A_7C15)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.f64()
    }
    /// Standard normal (Box-Muller, the cosine branch: two uniforms per draw).
    pub fn normal(&mut self) -> f64 {
        let (u1, u2) = (self.range(1e-12, 1.0), self.range(0.0, 1.0));
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// A camera on a sphere around the plate centre, looking at it, with the plate filling the view.
pub fn orbit_camera(
    distance: f64,
    elevation_deg: f64,
    azimuth_deg: f64,
    plate_mm: f64,
    width: u32,
    height: u32,
) -> Camera {
    let eye = scratchart_model::camera::spherical(distance, azimuth_deg, elevation_deg);
    // Vertical field of view that holds the plate's half-diagonal with a small margin.
    let fov = 2.0 * ((0.75 * plate_mm) / distance).atan().to_degrees();
    Camera {
        eye,
        target: [0.0, 0.0, 0.0],
        up: [0.0, 0.0, 1.0],
        fov_y_deg: fov,
        width,
        height,
    }
}

/// A point light on the same kind of sphere; `intensity` is chosen by the caller.
pub fn orbit_light(distance: f64, elevation_deg: f64, azimuth_deg: f64, intensity: f64) -> Light {
    Light {
        kind: LightKind::Point {
            position: scratchart_model::camera::spherical(distance, azimuth_deg, elevation_deg),
        },
        intensity,
    }
}

/// `n` random scratches over a square plate of side `plate_mm`: uniform first endpoint, uniform
/// direction, length uniform in [len_lo, len_hi]; redrawn until both ends are on the plate.
#[allow(clippy::too_many_arguments)] // the scratch family's parameters, named at every call
pub fn random_scratches(
    rng: &mut Rng,
    n: usize,
    plate_mm: f64,
    len_lo: f64,
    len_hi: f64,
    w: f64,
    d: f64,
    alpha: f64,
) -> Vec<Scratch> {
    let h = 0.5 * plate_mm;
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let p0 = [rng.range(-h, h), rng.range(-h, h)];
        let a = rng.range(0.0, std::f64::consts::TAU);
        let l = rng.range(len_lo, len_hi);
        let p1 = [p0[0] + l * a.cos(), p0[1] + l * a.sin()];
        if p1[0].abs() <= h && p1[1].abs() <= h {
            out.push(Scratch {
                p0,
                p1,
                w,
                d,
                alpha,
                bulge: 0.0,
            });
        }
    }
    out
}

/// The views of the paper's rule: M views at elevation `elev`, view j at azimuth 360 j / M.
pub fn ring_views(m: usize, elev: f64, distance: f64, plate_mm: f64, res: u32, light: &Light) -> Vec<View> {
    (0..m)
        .map(|j| View {
            exposure: 1.0,
            name: format!("v{j}"),
            camera: orbit_camera(distance, elev, 360.0 * j as f64 / m as f64, plate_mm, res, res),
            light: light.clone(),
        })
        .collect()
}

/// [`ring_views`] with each camera re-aimed at the middle of the plate's silhouette and its field
/// of view narrowed so that the silhouette's bounding box fills `fill` (e.g. 0.95) of the frame's
/// width or height, whichever binds: a target picture then gets as many pixels as the resolution
/// allows. Eyes stay where the ring puts them.
pub fn framed_ring_views(
    m: usize,
    elev: f64,
    distance: f64,
    plate: &Plate,
    res: u32,
    light: &Light,
    fill: f64,
) -> Vec<View> {
    let mut views = ring_views(m, elev, distance, plate.size_mm, res, light);
    for v in &mut views {
        frame_plate(v, plate, fill);
    }
    views
}

/// The plate's silhouette's bounding box in `view` (pixels: x0, y0, x1, y1), if every corner is
/// in front of the camera: its four corners' on a flat plate, a bent sheet's outline's (its
/// edges, 64 points each; the sheet's straight edges along the axis are straight in the world).
pub fn silhouette_box(view: &View, plate: &Plate) -> Option<[f64; 4]> {
    let g = scratchart_model::camera::ViewGeom::new(view);
    let half = 0.5 * plate.size_mm;
    let n = if plate.shape.is_flat() { 1 } else { 64 };
    let mut b = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
    let corners = [[-half, -half], [half, -half], [half, half], [-half, half]];
    for (k, c) in corners.iter().enumerate() {
        let e = corners[(k + 1) % 4];
        for i in 0..n {
            let f = i as f64 / n as f64;
            let q = [c[0] + f * (e[0] - c[0]), c[1] + f * (e[1] - c[1])];
            let (x, y) = g.project(plate.shape.to_world(q))?;
            b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
        }
    }
    Some(b)
}

/// Re-aims `view`'s camera at the middle of the plate's silhouette and sets its field of view so
/// that the silhouette's bounding box fills `fill` of the binding frame dimension (a few fixed
/// point steps: aiming moves the perspective a little). Leaves the camera as it is when a plate
/// corner is behind it.
pub fn frame_plate(view: &mut View, plate: &Plate, fill: f64) {
    for _ in 0..6 {
        let Some(b) = silhouette_box(view, plate) else {
            return;
        };
        let cam = &mut view.camera;
        let (w, h) = (cam.width as f64, cam.height as f64);
        // The plate point seen at the box's middle becomes the new target.
        let (sx, sy) = (0.5 * (b[0] + b[2]), 0.5 * (b[1] + b[3]));
        let t = (0.5 * cam.fov_y_deg.to_radians()).tan();
        let basis = cam.basis();
        let kx = (2.0 * sx / w - 1.0) * t * w / h;
        let ky = (1.0 - 2.0 * sy / h) * t;
        let dir = basis.fwd + kx * basis.right + ky * basis.up;
        if dir.z >= 0.0 {
            return;
        }
        let s = -cam.eye[2] / dir.z;
        cam.target = [cam.eye[0] + s * dir.x, cam.eye[1] + s * dir.y, 0.0];
        let frac = ((b[2] - b[0]) / w).max((b[3] - b[1]) / h);
        let t_new = t * frac / fill;
        cam.fov_y_deg = 2.0 * t_new.atan().to_degrees();
    }
}

/// The demo plate: scratches tangent to concentric circles (a turned finish). Under a point
/// light it shows the classic bright arc that swings round as the light or the eye moves.
pub fn demo_scene(res: u32) -> Scene {
    let plate = 100.0;
    let mut rng = Rng::new(7);
    let mut scratches = Vec::new();
    let mut r = 3.0;
    while r < 48.0 {
        let n = (std::f64::consts::TAU * r / 2.5) as usize;
        for k in 0..n {
            let a = std::f64::consts::TAU * (k as f64 + 0.5 * rng.f64()) / n as f64;
            let (c, s) = (a.cos(), a.sin());
            let l = 2.0;
            let p = [r * c, r * s];
            let t = [-s, c];
            scratches.push(Scratch {
                p0: [p[0] - 0.5 * l * t[0], p[1] - 0.5 * l * t[1]],
                p1: [p[0] + 0.5 * l * t[0], p[1] + 0.5 * l * t[1]],
                w: 0.06,
                d: 0.04,
                alpha: 0.05,
                bulge: 0.0,
            });
        }
        r += 0.35;
    }
    let light = orbit_light(300.0, 60.0, 100.0, 250_000.0);
    Scene {
        plate: Plate {
            size_mm: plate,
            roughness: 0.02,
            f0: 0.91,
            shape: Default::default(),
        },
        views: ring_views(3, 45.0, 300.0, plate, res, &light),
        scratches,
    }
}
