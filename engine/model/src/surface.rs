//! The plate's shape (engine/docs/model.md section 10): flat, or the flat sheet bent into a
//! cylinder after carving. Scratches live in the sheet's own (developed) coordinates, the ones the
//! router cuts; the bend maps the sheet onto the surface without stretching it. This module holds
//! that map in float64: sheet point -> world point, the surface frame there, a ray's hit on the
//! surface (in sheet coordinates), and whether the sheet itself blocks a ray leaving it (a
//! concave sheet's raised edges hide and shade its inside). The GPU twin is
//! `shaders/inc/common.glsl` (`surface_hit64`, `surface_hit`).
//!
//! Cylinder about an axis parallel to the sheet's y (`BendAxis::Y`): the sheet's x wraps. With
//! a = world x, b = world y, theta = x_sheet / R and s = +1 (convex: the scratched face outside,
//! the axis at z = -R) or -1 (concave: inside, the axis at z = +R):
//!   a = R sin(theta), z = c + s R cos(theta), c = -s R, b = y_sheet;
//!   normal (a, z) = (s sin theta, cos theta), tangent along x_sheet (a, z) = (cos theta, -s sin theta).
//! `BendAxis::X` is the same with the sheet's y wrapping (a = world y, b = world x).

type V3 = [f64; 3];

fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// Which of the sheet's axes the cylinder's axis runs along: `Y` wraps the sheet's x (the
/// sheet's left and right edges rise or fall), `X` wraps its y.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BendAxis {
    X,
    Y,
}

impl BendAxis {
    pub fn name(self) -> &'static str {
        match self {
            BendAxis::X => "x",
            BendAxis::Y => "y",
        }
    }
}

/// The plate's shape (the scene file's `plate.shape`).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum PlateShape {
    /// Today's plate: the plane z = 0.
    #[default]
    Flat,
    /// The sheet bent into a cylinder of radius `radius_mm` about an axis parallel to its x or y
    /// axis, with its centre staying at the origin and its normal +z there; `convex`: the
    /// scratched face on the outside.
    Cylinder {
        radius_mm: f64,
        axis: BendAxis,
        convex: bool,
    },
}

/// The largest angle a bent sheet may span about its axis (radians): 300 degrees, so that the
/// sheet never meets itself and its sheet coordinates are one angle each.
pub const MAX_WRAP_RAD: f64 = 300.0 * std::f64::consts::PI / 180.0;

/// A point of the surface a ray hits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// The world point.
    pub p: V3,
    /// Its sheet (developed) coordinates.
    pub uv: [f64; 2],
    /// The surface frame there: unit tangents along the sheet's x and y, and the scratched face's
    /// unit normal (tx x ty = n).
    pub tx: V3,
    pub ty: V3,
    pub n: V3,
}

impl SurfacePoint {
    /// A world vector in this point's frame (tx, ty, n components): what a scratch on a flat
    /// plate would see as (x, y, z).
    pub fn local(&self, v: V3) -> V3 {
        [dot(v, self.tx), dot(v, self.ty), dot(v, self.n)]
    }
}

/// The cylinder's numbers: radius, s (+1 convex, -1 concave), the wrapped axis.
#[derive(Clone, Copy)]
struct Cyl {
    r: f64,
    s: f64,
    axis: BendAxis,
}

impl Cyl {
    /// World -> (a, b, z).
    fn abz(&self, p: V3) -> (f64, f64, f64) {
        match self.axis {
            BendAxis::Y => (p[0], p[1], p[2]),
            BendAxis::X => (p[1], p[0], p[2]),
        }
    }
    /// (a, b, z) -> world.
    fn world(&self, a: f64, b: f64, z: f64) -> V3 {
        match self.axis {
            BendAxis::Y => [a, b, z],
            BendAxis::X => [b, a, z],
        }
    }
    /// The axis's height: c = -s R.
    fn c(&self) -> f64 {
        -self.s * self.r
    }
    /// Sheet (wrapped, along-axis) coordinates -> sheet (x, y).
    fn uv(&self, wrapped: f64, along: f64) -> [f64; 2] {
        match self.axis {
            BendAxis::Y => [wrapped, along],
            BendAxis::X => [along, wrapped],
        }
    }
    /// Sheet (x, y) -> (wrapped, along).
    fn split(&self, uv: [f64; 2]) -> (f64, f64) {
        match self.axis {
            BendAxis::Y => (uv[0], uv[1]),
            BendAxis::X => (uv[1], uv[0]),
        }
    }
    /// The surface point at angle (sin, cos) and along-axis b.
    fn point(&self, sin: f64, cos: f64, b: f64, theta: f64) -> SurfacePoint {
        let p = self.world(self.r * sin, b, self.c() + self.s * self.r * cos);
        let n = self.world(self.s * sin, 0.0, cos);
        let t_wrap = self.world(cos, 0.0, -self.s * sin);
        let t_along = self.world(0.0, 1.0, 0.0);
        let (tx, ty) = match self.axis {
            BendAxis::Y => (t_wrap, t_along),
            BendAxis::X => (t_along, t_wrap),
        };
        SurfacePoint {
            p,
            uv: self.uv(self.r * theta, b),
            tx,
            ty,
            n,
        }
    }
    /// The two roots (t1 <= t2) of the ray o + t d meeting the cylinder, if any.
    fn roots(&self, o: V3, d: V3) -> Option<(f64, f64)> {
        let (oa, _, oz) = self.abz(o);
        let (da, _, dz) = self.abz(d);
        let oz = oz - self.c();
        let a2 = da * da + dz * dz;
        if !(a2 > 0.0) {
            return None;
        }
        let b = oa * da + oz * dz;
        let c = oa * oa + oz * oz - self.r * self.r;
        let disc = b * b - a2 * c;
        if !(disc >= 0.0) {
            return None;
        }
        // The stable pair: q = -(b + sign(b) sqrt(disc)), roots q / a2 and c / q.
        let q = -(b + b.signum() * disc.sqrt());
        let (r1, r2) = if q != 0.0 { (q / a2, c / q) } else { (0.0, 0.0) };
        Some((r1.min(r2), r1.max(r2)))
    }
    /// The surface point at world point p (on the cylinder).
    fn at(&self, p: V3) -> SurfacePoint {
        let (a, b, z) = self.abz(p);
        let (sin, cos) = (a / self.r, self.s * (z - self.c()) / self.r);
        let theta = sin.atan2(cos);
        // The point itself, not its re-projection: the ray's hit stays where the ray says.
        SurfacePoint {
            p,
            ..self.point(sin, cos, b, theta)
        }
    }
}

impl PlateShape {
    fn cyl(&self) -> Option<Cyl> {
        match *self {
            PlateShape::Flat => None,
            PlateShape::Cylinder {
                radius_mm,
                axis,
                convex,
            } => Some(Cyl {
                r: radius_mm,
                s: if convex { 1.0 } else { -1.0 },
                axis,
            }),
        }
    }

    pub fn is_flat(&self) -> bool {
        matches!(self, PlateShape::Flat)
    }

    /// The surface point at sheet coordinates `uv`.
    pub fn at_sheet(&self, uv: [f64; 2]) -> SurfacePoint {
        match self.cyl() {
            None => SurfacePoint {
                p: [uv[0], uv[1], 0.0],
                uv,
                tx: [1.0, 0.0, 0.0],
                ty: [0.0, 1.0, 0.0],
                n: [0.0, 0.0, 1.0],
            },
            Some(c) => {
                let (w, along) = c.split(uv);
                let theta = w / c.r;
                c.point(theta.sin(), theta.cos(), along, theta)
            }
        }
    }

    /// The world point of sheet point `uv`.
    pub fn to_world(&self, uv: [f64; 2]) -> V3 {
        self.at_sheet(uv).p
    }

    /// Where the ray from `o` along `d` (any length) meets the surface on its scratched face:
    /// the plane z = 0 (from either side, as engine/docs/model.md section 4 has it), or the
    /// cylinder extended past the sheet (a convex sheet's near side, a concave one's far side),
    /// so that footprints at the sheet's edge have all four corners. The sheet's extent and what
    /// hides it are [`blocked`](Self::blocked)'s and the on-plate test's.
    pub fn hit(&self, o: V3, d: V3) -> Option<SurfacePoint> {
        match self.cyl() {
            None => {
                if d[2] == 0.0 {
                    return None;
                }
                let s = -o[2] / d[2];
                if !(s > 0.0) || !s.is_finite() {
                    return None;
                }
                Some(self.at_sheet([o[0] + s * d[0], o[1] + s * d[1]]))
            }
            Some(c) => {
                let (t1, t2) = c.roots(o, d)?;
                // Convex: the ray enters from outside (t1 > 0 means the eye is outside). Concave:
                // it leaves through the inside face (t2), from outside or inside.
                let t = if c.s > 0.0 { t1 } else { t2 };
                if !(t > 0.0) || !t.is_finite() || (c.s > 0.0 && !(t1 > 0.0)) {
                    return None;
                }
                Some(c.at(add(o, scale(d, t))))
            }
        }
    }

    /// Whether sheet point `uv` lies on a sheet of side `size_mm` (the closed square).
    pub fn on_sheet(uv: [f64; 2], size_mm: f64) -> bool {
        let half = 0.5 * size_mm;
        uv[0].abs() <= half && uv[1].abs() <= half
    }

    /// Whether the sheet (side `size_mm`) blocks the ray leaving surface point `x` along unit
    /// `d` before distance `max_t` (infinite for a directional light): the raised edges of a
    /// concave sheet hide its inside from a low eye and shade it from a low lamp. A flat or
    /// convex sheet never blocks a ray that leaves its scratched face.
    pub fn blocked(&self, x: &SurfacePoint, d: V3, max_t: f64, size_mm: f64) -> bool {
        let Some(c) = self.cyl() else { return false };
        if c.s > 0.0 {
            return false;
        }
        // x is on the cylinder: the other root of the ray x + t d is t = -2 B / A.
        let (xa, _, xz) = c.abz(x.p);
        let (da, _, dz) = c.abz(d);
        let a2 = da * da + dz * dz;
        if !(a2 > 0.0) {
            return false;
        }
        let t = -2.0 * (xa * da + (xz - c.c()) * dz) / a2;
        // (A sheet closer than 1 um along the ray is x itself, met by a ray along the surface.)
        if !(t > 1e-3) || !(t < max_t) {
            return false;
        }
        let q = c.at(add(x.p, scale(d, t)));
        PlateShape::on_sheet(q.uv, size_mm)
    }

    /// The angle the sheet (side `size_mm`) spans about the cylinder's axis (radians; 0 flat).
    pub fn wrap_angle(&self, size_mm: f64) -> f64 {
        self.cyl().map_or(0.0, |c| size_mm / c.r)
    }

    /// A description for reports: "flat", "cylinder R 80 mm about y, convex".
    pub fn describe(&self) -> String {
        match *self {
            PlateShape::Flat => "flat".into(),
            PlateShape::Cylinder {
                radius_mm,
                axis,
                convex,
            } => format!(
                "cylinder of radius {radius_mm} mm about the sheet's {} axis, {}",
                axis.name(),
                if convex { "convex" } else { "concave" }
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sub(a: V3, b: V3) -> V3 {
        add(a, scale(b, -1.0))
    }

    fn dist(a: V3, b: V3) -> f64 {
        let d = sub(a, b);
        dot(d, d).sqrt()
    }

    fn shapes() -> Vec<PlateShape> {
        let mut v = Vec::new();
        for axis in [BendAxis::X, BendAxis::Y] {
            for convex in [true, false] {
                v.push(PlateShape::Cylinder {
                    radius_mm: 60.0,
                    axis,
                    convex,
                });
            }
        }
        v
    }

    /// The bend keeps lengths along the sheet (developable, no stretching), puts the sheet's
    /// centre at the origin with normal +z, and its frame is right-handed and orthonormal.
    #[test]
    fn the_bend_is_an_isometry_with_a_right_handed_frame() {
        for shape in shapes() {
            let o = shape.at_sheet([0.0, 0.0]);
            assert!(
                dist(o.p, [0.0; 3]) < 1e-12 && dist(o.n, [0.0, 0.0, 1.0]) < 1e-12,
                "{shape:?}"
            );
            for uv in [[10.0, -20.0], [-37.0, 5.0], [45.0, 45.0]] {
                let q = shape.at_sheet(uv);
                assert!((q.uv[0] - uv[0]).abs() < 1e-12 && (q.uv[1] - uv[1]).abs() < 1e-12);
                // A small step along the sheet's x is that long in the world, along tx.
                let h = 1e-4;
                let q2 = shape.at_sheet([uv[0] + h, uv[1]]);
                let step = sub(q2.p, q.p);
                assert!((dot(step, step).sqrt() - h).abs() < 1e-9, "{shape:?} {uv:?}");
                assert!(dist(scale(step, 1.0 / h), q.tx) < 1e-3);
                let cross = [
                    q.tx[1] * q.ty[2] - q.tx[2] * q.ty[1],
                    q.tx[2] * q.ty[0] - q.tx[0] * q.ty[2],
                    q.tx[0] * q.ty[1] - q.tx[1] * q.ty[0],
                ];
                assert!(dist(cross, q.n) < 1e-12, "{shape:?}: tx x ty = n");
                assert!(dot(q.tx, q.n).abs() < 1e-12 && dot(q.ty, q.n).abs() < 1e-12);
            }
        }
    }

    /// A ray aimed at a sheet point from above its scratched face hits that point.
    #[test]
    fn rays_hit_the_sheet_point_they_aim_at() {
        for shape in shapes().into_iter().chain([PlateShape::Flat]) {
            for uv in [[0.0, 0.0], [20.0, -10.0], [-40.0, 30.0]] {
                let q = shape.at_sheet(uv);
                let eye = add(q.p, scale(add(q.n, [0.1, -0.2, 0.3]), 200.0));
                let hit = shape.hit(eye, sub(q.p, eye)).expect("hit");
                assert!(dist(hit.p, q.p) < 1e-9, "{shape:?} {uv:?}: {:?}", hit.p);
                assert!((hit.uv[0] - uv[0]).abs() < 1e-9 && (hit.uv[1] - uv[1]).abs() < 1e-9);
                assert!(!shape.blocked(&hit, scale(sub(eye, q.p), 1.0 / dist(eye, q.p)), 1e9, 100.0));
            }
        }
    }

    /// A concave sheet's raised edge hides its inside from a low eye; a convex one hides nothing.
    #[test]
    fn a_concave_sheets_edge_hides_its_inside_from_a_low_eye() {
        let concave = PlateShape::Cylinder {
            radius_mm: 40.0,
            axis: BendAxis::Y,
            convex: false,
        };
        // The sheet spans 150 degrees: its edges stand 40 (1 - cos 75) = 29.6 mm high at
        // x = +-38.6 mm. An eye low on the +x side looking at the sheet's centre.
        let x = concave.at_sheet([-10.0, 0.0]);
        let eye = [300.0, 0.0, 40.0];
        let d = sub(eye, x.p);
        let len = dot(d, d).sqrt();
        assert!(concave.blocked(&x, scale(d, 1.0 / len), len, 40.0 * 150f64.to_radians()));
        // From high above it is seen.
        let eye = [30.0, 0.0, 400.0];
        let d = sub(eye, x.p);
        let len = dot(d, d).sqrt();
        assert!(!concave.blocked(&x, scale(d, 1.0 / len), len, 40.0 * 150f64.to_radians()));
    }
}
