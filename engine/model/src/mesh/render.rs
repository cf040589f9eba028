//! Where a mesh stands ([`Placement`]) and what a view's camera sees of it ([`render_object`]).

use super::Mesh;
use crate::camera::{dot, sub, ViewGeom, V3};
use crate::scene::View;

/// Where and how a mesh stands in the plate's world frame (millimetres; the plate in z = 0,
/// viewers at z > 0; azimuths counter-clockwise from +x, as [`crate::camera::spherical`]).
///
/// In order:
/// 1. the mesh is scaled uniformly so that the largest extent of its bounding box (in its own
///    axes, [`Mesh::bounds`]) is `size_mm`;
/// 2. OBJ's usual axes are mapped to the world: OBJ +Y (up) becomes world +z, OBJ +Z (the
///    model's front) points horizontally towards azimuth `front_azimuth_deg`, that is along
///    (cos a, sin a, 0), and OBJ +X becomes the right of a viewer who faces the model's front.
///    For front azimuth 0, OBJ (X, Y, Z) goes to world (y, z, x): a rotation, never a mirror;
/// 3. the object turns by `yaw_deg` (counter-clockwise seen from above) about the vertical axis
///    through its bounding box centre;
/// 4. the bounding box centre goes to (0, 0, -depth_mm).
///
/// Positive depth puts the object behind (below) the plate, as a scratch hologram shows it;
/// negative depth in front of it. The bounding box of steps 1 and 4 is the mesh's own, so the
/// object keeps its size and centre as it turns; for front azimuths and yaws that are multiples
/// of 90 degrees it is also the world bounding box of the placed object.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Largest extent of the mesh's bounding box after scaling, mm (> 0).
    pub size_mm: f64,
    /// Depth of the bounding box centre behind the plate, mm (negative: in front of it).
    pub depth_mm: f64,
    /// Azimuth the model's front (OBJ +Z) faces, degrees counter-clockwise from world +x.
    pub front_azimuth_deg: f64,
    /// Turn about the vertical axis through the object's centre, degrees counter-clockwise seen
    /// from above, applied after the front azimuth.
    pub yaw_deg: f64,
}

impl Placement {
    /// The world directions of OBJ +X, +Y and +Z (unit vectors, a rotation: determinant +1),
    /// with the front azimuth and the yaw applied.
    pub fn axes(&self) -> [[f64; 3]; 3] {
        let (s, c) = (self.front_azimuth_deg + self.yaw_deg).to_radians().sin_cos();
        [[-s, c, 0.0], [0.0, 0.0, 1.0], [c, s, 0.0]]
    }

    /// The mesh's vertices in the world frame (mm), in the mesh's order. A mesh of zero extent
    /// collapses to its centre.
    pub fn world_vertices(&self, mesh: &Mesh) -> Vec<[f64; 3]> {
        let (lo, hi) = mesh.bounds();
        let centre = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])];
        let extent = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
        let s = if extent > 0.0 { self.size_mm / extent } else { 0.0 };
        let [ax, ay, az] = self.axes();
        mesh.vertices
            .iter()
            .map(|v| {
                let p = [s * (v[0] - centre[0]), s * (v[1] - centre[1]), s * (v[2] - centre[2])];
                [
                    p[0] * ax[0] + p[1] * ay[0] + p[2] * az[0],
                    p[0] * ax[1] + p[1] * ay[1] + p[2] * az[1],
                    p[0] * ax[2] + p[1] * ay[2] + p[2] * az[2] - self.depth_mm,
                ]
            })
            .collect()
    }
}

/// One view of a placed object: row-major, top row first, like every image of the project.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectImage {
    pub width: u32,
    pub height: u32,
    /// Display value in [0, 1] per pixel: the mean over its 4 x 4 subsamples of the shade of
    /// the nearest triangle, or the background where none covers the subsample.
    pub shade: Vec<f32>,
    /// Fraction of the pixel's 4 x 4 subsamples that the object covers, in [0, 1].
    pub coverage: Vec<f32>,
}

/// Subsamples per pixel along each image axis.
const SUPERSAMPLE: usize = 4;
/// Shade of a face edge-on to the key light (the ambient part).
const AMBIENT: f64 = 0.15;
/// Vertices nearer the camera than this (mm along its forward axis) count as behind it.
const NEAR_MM: f64 = 1e-6;

/// Renders the placed mesh as `view`'s pinhole camera sees it (the view's image size, camera
/// and image convention of [`ViewGeom::project`]: pixel (i, j) covers [i, i+1) x [j, j+1)).
///
/// Each subsample (4 x 4 per pixel, at the centres of a regular grid) shows the nearest
/// triangle (a z-buffer on the depth along the camera's forward axis, interpolated
/// perspective-correctly as 1/depth). Faces are flat-shaded and two-sided:
/// shade = 0.15 + 0.85 |n . key_light| with n the face normal and `key_light` the unit world
/// direction towards the light (normalized here; the same for every view, so the object is lit
/// as one real object). Subsamples no triangle covers take `background`. Triangles with a vertex
/// behind the camera (or in its eye plane) are skipped, not clipped.
pub fn render_object(
    mesh: &Mesh,
    placement: &Placement,
    view: &View,
    key_light: [f64; 3],
    background: f32,
) -> ObjectImage {
    let geom = ViewGeom::new(view);
    let (width, height) = (geom.width as usize, geom.height as usize);
    let (sw, sh) = (width * SUPERSAMPLE, height * SUPERSAMPLE);
    let ss = SUPERSAMPLE as f64;

    let light_norm = dot(key_light, key_light).sqrt();
    let light = if light_norm > 0.0 {
        [
            key_light[0] / light_norm,
            key_light[1] / light_norm,
            key_light[2] / light_norm,
        ]
    } else {
        [0.0; 3]
    };

    // Every vertex once: its world position, and its subsample-grid position (subsample k's
    // centre at k + 0.5) with 1/depth, or None behind the camera.
    let world = placement.world_vertices(mesh);
    let projected: Vec<Option<([f64; 2], f64)>> = world
        .iter()
        .map(|&p| {
            let depth = dot(sub(p, geom.eye), geom.forward);
            if !(depth > NEAR_MM) {
                return None;
            }
            let (sx, sy) = geom.project(p)?;
            let q = [sx * ss, sy * ss];
            (q[0].is_finite() && q[1].is_finite()).then_some((q, 1.0 / depth))
        })
        .collect();

    // 1/depth of the nearest surface per subsample (0: none; anything drawn has 1/depth > 0).
    let mut inv_depth = vec![0.0f64; sw * sh];
    let mut sample_shade = vec![background; sw * sh];

    for tri in &mesh.triangles {
        let corner = |k: usize| projected.get(tri[k] as usize).copied().flatten();
        let (Some((p0, iz0)), Some((p1, iz1)), Some((p2, iz2))) = (corner(0), corner(1), corner(2)) else {
            continue;
        };
        let area = edge(p0, p1, p2);
        if area == 0.0 || !area.is_finite() {
            continue;
        }
        let normal = cross(
            sub(world[tri[1] as usize], world[tri[0] as usize]),
            sub(world[tri[2] as usize], world[tri[0] as usize]),
        );
        let n_len = dot(normal, normal).sqrt();
        if !(n_len > 0.0) {
            continue;
        }
        let lambert = (dot(normal, light) / n_len).abs();
        let shade = (AMBIENT + (1.0 - AMBIENT) * lambert).clamp(0.0, 1.0) as f32;

        // Subsamples whose centres k + 0.5 lie in the triangle's bounding box, clipped to the image.
        let range = |lo: f64, hi: f64, n: usize| -> Option<(usize, usize)> {
            let first = (lo - 0.5).ceil().max(0.0);
            let last = (hi - 0.5).floor().min(n as f64 - 1.0);
            (first <= last).then_some((first as usize, last as usize))
        };
        let Some((x0, x1)) = range(p0[0].min(p1[0]).min(p2[0]), p0[0].max(p1[0]).max(p2[0]), sw) else {
            continue;
        };
        let Some((y0, y1)) = range(p0[1].min(p1[1]).min(p2[1]), p0[1].max(p1[1]).max(p2[1]), sh) else {
            continue;
        };

        let inv_area = 1.0 / area;
        for ky in y0..=y1 {
            let row = ky * sw;
            for kx in x0..=x1 {
                let q = [kx as f64 + 0.5, ky as f64 + 0.5];
                // Barycentric weights; all >= 0 inside, whichever way the triangle winds.
                let b0 = edge(p1, p2, q) * inv_area;
                let b1 = edge(p2, p0, q) * inv_area;
                let b2 = edge(p0, p1, q) * inv_area;
                if b0 < 0.0 || b1 < 0.0 || b2 < 0.0 {
                    continue;
                }
                let iz = b0 * iz0 + b1 * iz1 + b2 * iz2;
                if iz > inv_depth[row + kx] {
                    inv_depth[row + kx] = iz;
                    sample_shade[row + kx] = shade;
                }
            }
        }
    }

    // Resolve: the mean shade and the covered fraction of each pixel's subsamples.
    let per_pixel = (SUPERSAMPLE * SUPERSAMPLE) as f32;
    let mut shade = Vec::with_capacity(width * height);
    let mut coverage = Vec::with_capacity(width * height);
    for j in 0..height {
        for i in 0..width {
            let (mut sum, mut covered) = (0.0f32, 0u32);
            for ky in j * SUPERSAMPLE..(j + 1) * SUPERSAMPLE {
                for kx in i * SUPERSAMPLE..(i + 1) * SUPERSAMPLE {
                    sum += sample_shade[ky * sw + kx];
                    covered += (inv_depth[ky * sw + kx] > 0.0) as u32;
                }
            }
            shade.push(sum / per_pixel);
            coverage.push(covered as f32 / per_pixel);
        }
    }
    ObjectImage {
        width: geom.width,
        height: geom.height,
        shade,
        coverage,
    }
}

/// Twice the signed area of triangle (a, b, p) in the image plane.
#[inline]
fn edge(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

#[inline]
pub(super) fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
