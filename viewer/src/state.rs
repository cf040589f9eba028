//! The interactive camera and light: orbit/pan/zoom around a target point, and a point light on a
//! sphere around the plate centre that can orbit on its own or be dragged. Both convert to and
//! from the engine's [`Camera`] and [`Light`], so a design view can be jumped to exactly.
use glam::DVec3;
use scratchart_model::scene::{Camera, Light, LightKind};

/// Degrees of orbit per pixel of mouse drag.
const DEG_PER_PX: f64 = 0.3;
/// Elevation limits: above the plate (grazing views are legal but useless to look at) and short
/// of the pole, where forward x up degenerates.
const MIN_ELEV: f64 = 3.0;
const MAX_ELEV: f64 = 89.0;

/// A camera on a sphere around `target`, with the design's up vector and field of view.
#[derive(Clone, Debug, PartialEq)]
pub struct OrbitCamera {
    pub target: DVec3,
    pub distance: f64,
    pub azimuth_deg: f64,
    pub elevation_deg: f64,
    pub fov_y_deg: f64,
    pub up: DVec3,
}

fn spherical(distance: f64, az_deg: f64, el_deg: f64) -> DVec3 {
    DVec3::from(scratchart_model::camera::spherical(distance, az_deg, el_deg))
}

fn to_spherical(v: DVec3) -> (f64, f64, f64) {
    let d = v.length().max(1e-9);
    (
        d,
        v.y.atan2(v.x).to_degrees(),
        (v.z / d).clamp(-1.0, 1.0).asin().to_degrees(),
    )
}

impl OrbitCamera {
    pub fn from_camera(c: &Camera) -> OrbitCamera {
        let target = DVec3::from(c.target);
        let (distance, azimuth_deg, elevation_deg) = to_spherical(DVec3::from(c.eye) - target);
        OrbitCamera {
            target,
            distance,
            azimuth_deg,
            elevation_deg,
            fov_y_deg: c.fov_y_deg,
            up: DVec3::from(c.up),
        }
    }

    pub fn eye(&self) -> DVec3 {
        self.target + spherical(self.distance, self.azimuth_deg, self.elevation_deg)
    }

    /// The engine camera for an image of `width` x `height` pixels.
    pub fn camera(&self, width: u32, height: u32) -> Camera {
        Camera {
            eye: self.eye().to_array(),
            target: self.target.to_array(),
            up: self.up.to_array(),
            fov_y_deg: self.fov_y_deg,
            width,
            height,
        }
    }

    /// The camera a fraction `t` of the way from `a` to `b` (the walk's in-between cameras):
    /// azimuth along the shorter way round, elevation, distance, field of view, target and up
    /// linearly. `t` = 0 gives `a`'s parameters and `t` = 1 `b`'s (the azimuth possibly 360
    /// degrees off, the same direction).
    pub fn lerp(a: &OrbitCamera, b: &OrbitCamera, t: f64) -> OrbitCamera {
        let mix = |x: f64, y: f64| x * (1.0 - t) + y * t;
        OrbitCamera {
            target: a.target * (1.0 - t) + b.target * t,
            distance: mix(a.distance, b.distance),
            azimuth_deg: a.azimuth_deg + t * short_turn(a.azimuth_deg, b.azimuth_deg),
            elevation_deg: mix(a.elevation_deg, b.elevation_deg),
            fov_y_deg: mix(a.fov_y_deg, b.fov_y_deg),
            up: a.up * (1.0 - t) + b.up * t,
        }
    }

    /// Left drag: turn around the target (drag right = the scene turns right).
    pub fn orbit(&mut self, dx_px: f64, dy_px: f64) {
        self.azimuth_deg -= dx_px * DEG_PER_PX;
        self.elevation_deg = (self.elevation_deg + dy_px * DEG_PER_PX).clamp(MIN_ELEV, MAX_ELEV);
    }

    /// Right/middle drag: move the target in the image plane so the plate follows the cursor.
    pub fn pan(&mut self, dx_px: f64, dy_px: f64, viewport_height_px: f64) {
        let fwd = (self.target - self.eye()).normalize();
        let right = fwd.cross(self.up).normalize();
        let up = right.cross(fwd);
        let mm_per_px = 2.0 * self.distance * (0.5 * self.fov_y_deg.to_radians()).tan() / viewport_height_px.max(1.0);
        self.target += (-dx_px * right + dy_px * up) * mm_per_px;
    }

    /// Wheel: `steps` > 0 moves closer.
    pub fn zoom(&mut self, steps: f64) {
        self.distance = (self.distance * 0.9f64.powf(steps)).clamp(1.0, 1e5);
    }
}

/// The light: a point light on a sphere around the plate centre, or a directional light given by
/// its direction's azimuth and elevation.
#[derive(Clone, Debug, PartialEq)]
pub struct LightRig {
    pub directional: bool,
    pub distance: f64,
    pub azimuth_deg: f64,
    pub elevation_deg: f64,
    pub intensity: f64,
}

impl LightRig {
    pub fn from_light(l: &Light) -> LightRig {
        let (directional, v) = match l.kind {
            LightKind::Point { position } => (false, DVec3::from(position)),
            LightKind::Directional { direction } => (true, DVec3::from(direction)),
        };
        let (distance, azimuth_deg, elevation_deg) = to_spherical(v);
        LightRig {
            directional,
            distance,
            azimuth_deg,
            elevation_deg,
            intensity: l.intensity,
        }
    }

    pub fn light(&self) -> Light {
        let kind = if self.directional {
            LightKind::Directional {
                direction: spherical(1.0, self.azimuth_deg, self.elevation_deg).to_array(),
            }
        } else {
            LightKind::Point {
                position: spherical(self.distance, self.azimuth_deg, self.elevation_deg).to_array(),
            }
        };
        Light {
            kind,
            intensity: self.intensity,
        }
    }

    /// Shift + left drag: move the light over its sphere.
    pub fn drag(&mut self, dx_px: f64, dy_px: f64) {
        self.rotate(-dx_px * DEG_PER_PX);
        self.elevation_deg = (self.elevation_deg + dy_px * DEG_PER_PX).clamp(MIN_ELEV, MAX_ELEV);
    }

    /// Turns the light about the plate normal by `deg` (its own orbit).
    pub fn rotate(&mut self, deg: f64) {
        self.azimuth_deg = (self.azimuth_deg + deg).rem_euclid(360.0);
    }
}

/// The signed turn from azimuth `a` to `b` the shorter way round, in (-180, 180] degrees.
pub fn short_turn(a: f64, b: f64) -> f64 {
    let d = (b - a).rem_euclid(360.0);
    if d > 180.0 {
        d - 360.0
    } else {
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_round_trips() {
        let c = scratchart_design::scenes::orbit_camera(300.0, 45.0, 120.0, 100.0, 256, 256);
        let o = OrbitCamera::from_camera(&c);
        let back = o.camera(256, 256);
        for i in 0..3 {
            assert!((back.eye[i] - c.eye[i]).abs() < 1e-9, "{:?} vs {:?}", back.eye, c.eye);
        }
    }

    #[test]
    fn light_round_trips() {
        let l = scratchart_design::scenes::orbit_light(300.0, 50.0, 200.0, 9e4);
        let back = LightRig::from_light(&l).light();
        let (LightKind::Point { position: a }, LightKind::Point { position: b }) = (l.kind, back.kind) else {
            panic!("kind changed")
        };
        for i in 0..3 {
            assert!((a[i] - b[i]).abs() < 1e-9);
        }
    }
}
