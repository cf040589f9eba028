//! Float64 view geometry exactly as engine/docs/model.md section 4 defines it: the camera basis, pinhole
//! camera rays, pixel footprints on the plate plane z = 0, shading points, the on-plate test and
//! mask, light direction and irradiance. Used by the CPU reference, scene validation, the
//! engine's GPU cameras (`render::layout`, through [`Camera::basis`]) and the optimizer's masks.

use glam::DVec3;

use crate::scene::{Camera, LightKind, Plate, Scene, View};
use crate::surface::{PlateShape, SurfacePoint};

pub(crate) type V3 = [f64; 3];

#[inline]
pub(crate) fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
#[inline]
pub(crate) fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
#[inline]
pub(crate) fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
#[inline]
pub(crate) fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
#[inline]
pub(crate) fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}
#[inline]
pub(crate) fn normalize(a: V3) -> V3 {
    scale(a, 1.0 / norm(a))
}

/// The camera frame of engine/docs/model.md section 4: f = normalize(T - C), r = normalize(f x U),
/// up' = r x f.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraBasis {
    /// f, the unit viewing direction.
    pub fwd: DVec3,
    /// r, unit, to the right of the image.
    pub right: DVec3,
    /// up', unit, towards the top of the image (sy = 0).
    pub up: DVec3,
}

impl Camera {
    /// The camera basis, computed in one place for the float64 reference and the GPU cameras.
    /// The GPU views (`render::layout::view_gpu`, `view_gpu64`) must stay bit-identical to what
    /// they were: keep this exact sequence of glam operations (normalize is `v * (1 / |v|)`).
    /// A degenerate camera (eye = target, or up parallel to the view) gives NaN; scene
    /// validation rejects those.
    pub fn basis(&self) -> CameraBasis {
        let fwd = (DVec3::from(self.target) - DVec3::from(self.eye)).normalize();
        let right = fwd.cross(DVec3::from(self.up)).normalize();
        let up = right.cross(fwd);
        CameraBasis { fwd, right, up }
    }
}

/// Light at a plate point: direction towards the light and irradiance E.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    pub omega_i: [f64; 3],
    pub e: f64,
}

/// The float64 geometry of one view.
#[derive(Clone, Debug)]
pub struct ViewGeom {
    pub eye: [f64; 3],
    /// f = normalize(T - C)
    pub forward: [f64; 3],
    /// r = normalize(f x U)
    pub right: [f64; 3],
    /// up' = r x f
    pub up: [f64; 3],
    pub width: u32,
    pub height: u32,
    /// tan(fov_y / 2)
    pub tan_half: f64,
    pub light_kind: LightKind,
    pub intensity: f64,
    /// The plate's shape: rays hit it, and [`hit`](Self::hit) gives sheet coordinates.
    pub shape: PlateShape,
    /// The sheet's side (mm): what a bent sheet's edges hide (`f64::INFINITY` where unknown:
    /// [`ViewGeom::new`] on a flat plate, where nothing hides anything).
    pub sheet_mm: f64,
}

impl ViewGeom {
    /// Build the geometry of a view. The view should be valid (see `Scene::validate`);
    /// a degenerate camera gives NaN directions.
    pub fn new(view: &View) -> ViewGeom {
        let c = &view.camera;
        let b = c.basis();
        let (forward, right, up) = (b.fwd.to_array(), b.right.to_array(), b.up.to_array());
        let light_kind = match view.light.kind {
            LightKind::Point { position } => LightKind::Point { position },
            LightKind::Directional { direction } => LightKind::Directional {
                direction: normalize(direction),
            },
        };
        ViewGeom {
            eye: c.eye,
            forward,
            right,
            up,
            width: c.width,
            height: c.height,
            tan_half: (0.5 * c.fov_y_deg.to_radians()).tan(),
            light_kind,
            intensity: view.radiance_scale(),
            shape: PlateShape::Flat,
            sheet_mm: f64::INFINITY,
        }
    }

    /// The geometry of a view of `plate` (its shape and size; [`new`](Self::new) is a flat plate).
    pub fn of(view: &View, plate: &Plate) -> ViewGeom {
        ViewGeom {
            shape: plate.shape,
            sheet_mm: plate.size_mm,
            ..ViewGeom::new(view)
        }
    }

    /// Unit ray direction through image point (sx, sy); sy = 0 is the top of the image.
    pub fn ray_dir(&self, sx: f64, sy: f64) -> [f64; 3] {
        let (w, h) = (self.width as f64, self.height as f64);
        let kx = (2.0 * sx / w - 1.0) * self.tan_half * w / h;
        let ky = (1.0 - 2.0 * sy / h) * self.tan_half;
        normalize(add(self.forward, add(scale(self.right, kx), scale(self.up, ky))))
    }

    /// Where the ray through (sx, sy) hits the plate, in sheet coordinates: on a flat plate the
    /// plane z = 0, C + s dir with s = -C.z / dir.z, valid when dir.z != 0 and s > 0; on a bent
    /// one the surface's scratched face (section 10).
    pub fn hit(&self, sx: f64, sy: f64) -> Option<[f64; 2]> {
        self.surface_hit(sx, sy).map(|q| q.uv)
    }

    /// [`hit`](Self::hit) with the world point and the surface frame there.
    pub fn surface_hit(&self, sx: f64, sy: f64) -> Option<SurfacePoint> {
        self.shape.hit(self.eye, self.ray_dir(sx, sy))
    }

    /// Whether the sheet itself hides surface point `x` from the eye (a concave sheet's raised
    /// edges; section 10).
    pub fn hidden(&self, x: &SurfacePoint) -> bool {
        let d = sub(self.eye, x.p);
        let len = norm(d);
        self.shape.blocked(x, scale(d, 1.0 / len), len, self.sheet_mm)
    }

    /// Whether the sheet itself shades surface point `x` from the view's light.
    pub fn shaded(&self, x: &SurfacePoint) -> bool {
        match self.light_kind {
            LightKind::Point { position } => {
                let d = sub(position, x.p);
                let len = norm(d);
                self.shape.blocked(x, scale(d, 1.0 / len), len, self.sheet_mm)
            }
            LightKind::Directional { direction } => self.shape.blocked(x, direction, f64::INFINITY, self.sheet_mm),
        }
    }

    /// Footprint of pixel (i, j): hits of corners (i,j), (i+1,j), (i+1,j+1), (i,j+1).
    pub fn footprint(&self, i: u32, j: u32) -> Option<[[f64; 2]; 4]> {
        let (x, y) = (i as f64, j as f64);
        Some([
            self.hit(x, y)?,
            self.hit(x + 1.0, y)?,
            self.hit(x + 1.0, y + 1.0)?,
            self.hit(x, y + 1.0)?,
        ])
    }

    /// Shading point X: hit of the ray through the pixel centre.
    pub fn shading_point(&self, i: u32, j: u32) -> Option<[f64; 2]> {
        self.hit(i as f64 + 0.5, j as f64 + 0.5)
    }

    /// Whether pixel (i, j) is on the plate (engine/docs/model.md section 4): X in the closed square
    /// [-half, half]^2 and all four corner rays hit with s > 0.
    /// On a bent sheet the sheet must not hide X from the eye either.
    pub fn on_plate(&self, i: u32, j: u32, half: f64) -> bool {
        match self.surface_hit(i as f64 + 0.5, j as f64 + 0.5) {
            Some(x) if x.uv[0].abs() <= half && x.uv[1].abs() <= half => {
                self.footprint(i, j).is_some() && !self.hidden(&x)
            }
            _ => false,
        }
    }

    /// On-plate mask of the whole image (row-major, top row first): [`on_plate`](Self::on_plate)
    /// of every pixel, with `half_plate` half the plate size. Off-plate pixels have value 0 and
    /// no gradient, so losses and reports average over this mask.
    pub fn on_plate_mask(&self, half_plate: f64) -> Vec<bool> {
        let mut m = Vec::with_capacity(self.width as usize * self.height as usize);
        for j in 0..self.height {
            for i in 0..self.width {
                m.push(self.on_plate(i, j, half_plate));
            }
        }
        m
    }

    /// omega_o = normalize(C - X), X the world point of sheet point x (world vectors).
    pub fn omega_o(&self, x: [f64; 2]) -> [f64; 3] {
        self.omega_o_at(self.shape.to_world(x))
    }

    /// omega_o = normalize(C - X) at world point X.
    pub fn omega_o_at(&self, p: [f64; 3]) -> [f64; 3] {
        normalize(sub(self.eye, p))
    }

    /// Light direction (world) and irradiance at sheet point x (no shading by the sheet: see
    /// [`shaded`](Self::shaded)).
    pub fn light_at(&self, x: [f64; 2]) -> LightSample {
        self.light_at_point(self.shape.to_world(x))
    }

    /// Light direction (world) and irradiance at world point p.
    pub fn light_at_point(&self, p: [f64; 3]) -> LightSample {
        match self.light_kind {
            LightKind::Point { position } => {
                let d = sub(position, p);
                let r2 = dot(d, d);
                LightSample {
                    omega_i: scale(d, 1.0 / r2.sqrt()),
                    e: self.intensity / r2,
                }
            }
            LightKind::Directional { direction } => LightSample {
                omega_i: direction,
                e: self.intensity,
            },
        }
    }

    /// Image point (sx, sy) where the world point p projects, if it lies in front of the camera.
    pub fn project(&self, p: [f64; 3]) -> Option<(f64, f64)> {
        let d = sub(p, self.eye);
        let df = dot(d, self.forward);
        if !(df > 0.0) {
            return None;
        }
        let kx = dot(d, self.right) / df;
        let ky = dot(d, self.up) / df;
        let (w, h) = (self.width as f64, self.height as f64);
        let sx = (kx / (self.tan_half * w / h) + 1.0) * 0.5 * w;
        let sy = (1.0 - ky / self.tan_half) * 0.5 * h;
        Some((sx, sy))
    }
}

/// The project's one spherical convention: the point at `distance_mm` from the plate centre,
/// `azimuth_deg` counter-clockwise from +x in the plate's plane and `elevation_deg` above it (the
/// scene's lamps, viewers and default cameras; the set-up sheet; the viewer's orbit).
pub fn spherical(distance_mm: f64, azimuth_deg: f64, elevation_deg: f64) -> [f64; 3] {
    let (az, el) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
    [
        distance_mm * el.cos() * az.cos(),
        distance_mm * el.cos() * az.sin(),
        distance_mm * el.sin(),
    ]
}

/// On-plate mask of view `view` of `scene` (row-major, top row first); see
/// [`ViewGeom::on_plate_mask`].
pub fn on_plate_mask(scene: &Scene, view: usize) -> Vec<bool> {
    ViewGeom::of(&scene.views[view], &scene.plate).on_plate_mask(0.5 * scene.plate.size_mm)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Light, Plate};

    fn view(eye: [f64; 3], target: [f64; 3], up: [f64; 3]) -> View {
        View {
            exposure: 1.0,
            name: "v".into(),
            camera: Camera {
                eye,
                target,
                up,
                fov_y_deg: 30.0,
                width: 24,
                height: 16,
            },
            light: Light {
                kind: LightKind::Point {
                    position: [0.0, 50.0, 80.0],
                },
                intensity: 1000.0,
            },
        }
    }

    /// The basis is engine/docs/model.md's formula evaluated in plain float64 arithmetic, bit for bit
    /// (f = (T - C) / |T - C| as (T - C) * (1 / |T - C|), the same for r; cross products in the
    /// textbook order).
    #[test]
    fn basis_is_the_model_formula_bit_for_bit() {
        let cross = |a: V3, b: V3| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let cams = [
            ([0.0, -250.0, 250.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            ([13.7, -41.3, 3.9], [0.3, 1.1, -0.2], [0.1, 0.2, 1.0]),
            ([-7.0, 2.0, 90.0], [1.0, 0.5, 0.0], [0.0, 1.0, 0.0]),
        ];
        for (eye, target, up) in cams {
            let b = view(eye, target, up).camera.basis();
            let f = normalize(sub(target, eye));
            let r = normalize(cross(f, up));
            let u = cross(r, f);
            assert_eq!(b.fwd.to_array(), f, "forward of eye {eye:?}");
            assert_eq!(b.right.to_array(), r, "right of eye {eye:?}");
            assert_eq!(b.up.to_array(), u, "up of eye {eye:?}");
            let g = ViewGeom::new(&view(eye, target, up));
            assert_eq!((g.forward, g.right, g.up), (f, r, u));
        }
    }

    #[test]
    fn on_plate_mask_is_on_plate_of_every_pixel() {
        let v = view([0.0, -60.0, 40.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
        let scene = Scene {
            plate: Plate {
                size_mm: 30.0,
                roughness: 0.02,
                f0: 0.91,
                shape: Default::default(),
            },
            views: vec![v.clone()],
            scratches: Vec::new(),
        };
        let g = ViewGeom::new(&v);
        let mask = on_plate_mask(&scene, 0);
        assert_eq!(mask.len(), 24 * 16);
        let mut on = 0;
        for j in 0..16 {
            for i in 0..24 {
                assert_eq!(mask[(j * 24 + i) as usize], g.on_plate(i, j, 15.0), "pixel ({i}, {j})");
                on += mask[(j * 24 + i) as usize] as usize;
            }
        }
        assert!(
            on > 0 && on < 24 * 16,
            "the test view should see plate and background ({on} on)"
        );
    }
}
