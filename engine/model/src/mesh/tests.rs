//! Tests of the OBJ reader, the placement and the rasterizer (against an independent ray cast).

use super::render::cross;
use super::*;
use crate::camera::{dot, spherical, sub, ViewGeom, V3};
use crate::scene::{Camera, Light, LightKind, View};
use scratchart_exit::{Class, ExitClass};

fn parse(text: &str) -> Mesh {
    Mesh::parse_obj(text, "t.obj").unwrap_or_else(|e| panic!("{e}"))
}

fn parse_err(text: &str) -> String {
    match Mesh::parse_obj(text, "bad.obj") {
        Ok(m) => panic!("parsed {m:?}"),
        Err(e) => {
            assert_eq!(e.exit_class(), Some(Class::Input), "{e}");
            e.to_string()
        }
    }
}

const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

/// An axis-aligned box from `lo` to `hi`, as 6 quads.
fn box_obj(lo: [f64; 3], hi: [f64; 3]) -> Mesh {
    let mut text = String::new();
    for k in 0..8 {
        let c = |a: usize| if (k >> a) & 1 == 1 { hi[a] } else { lo[a] };
        text += &format!("v {} {} {}\n", c(0), c(1), c(2));
    }
    // Vertex k (1-based k + 1) has bit a set where coordinate a is at `hi`.
    text += "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
    parse(&text)
}

fn cube() -> Mesh {
    box_obj([-1.0; 3], [1.0; 3])
}

/// A view built like the project's orbit cameras (`scenes::orbit_camera`): eye on the
/// sphere, looking at the plate centre, world z up, the plate's half-diagonal in view.
fn orbit_view(distance: f64, elevation_deg: f64, azimuth_deg: f64, plate_mm: f64, size: u32) -> View {
    View {
        exposure: 1.0,
        name: "v".into(),
        camera: Camera {
            eye: spherical(distance, azimuth_deg, elevation_deg),
            target: [0.0; 3],
            up: [0.0, 0.0, 1.0],
            fov_y_deg: 2.0 * ((0.75 * plate_mm) / distance).atan().to_degrees(),
            width: size,
            height: size,
        },
        light: Light {
            kind: LightKind::Point {
                position: spherical(distance, azimuth_deg, elevation_deg),
            },
            intensity: 1000.0,
        },
    }
}

fn place(size_mm: f64, depth_mm: f64, front_azimuth_deg: f64, yaw_deg: f64) -> Placement {
    Placement {
        size_mm,
        depth_mm,
        front_azimuth_deg,
        yaw_deg,
    }
}

fn world_bounds(p: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    Mesh {
        vertices: p.to_vec(),
        triangles: Vec::new(),
    }
    .bounds()
}

fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
    (0..3).all(|k| (a[k] - b[k]).abs() <= tol)
}

#[test]
fn parse_fan_triangulates_polygons_and_ignores_other_records() {
    let text = "# a comment\n\nmtllib m.mtl\no first\ng part\ns 1\nusemtl steel\n\
                v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0 1.0\nv 0.5 1.5 0 0.2 0.3 0.4\n\
                vt 0 0\nvn 0 0 1\nfoo bar\nl 1 2\n\
                f 1 2 3 4 # a quad\no second\nf 1 2 3 5 4\n";
    let m = parse(text);
    assert_eq!(m.vertices.len(), 5);
    assert_eq!(m.vertices[3], [0.0, 1.0, 0.0]);
    assert_eq!(m.vertices[4], [0.5, 1.5, 0.0]);
    assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 1, 2], [0, 2, 4], [0, 4, 3]]);
    assert_eq!(m.bounds(), ([0.0, 0.0, 0.0], [1.0, 1.5, 0.0]));
}

#[test]
fn parse_reads_every_vertex_reference_form_and_negative_indices() {
    let text = format!(
        "{TRI}vt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1\nf 1//1 2//1 3//1\nf 1/1 2/1 3/1\n\
         v 0 0 1\nf -4 -3 -1\nf -2/1/1 -1//1 1\n"
    );
    let m = parse(&text);
    assert_eq!(m.triangles, vec![[0, 1, 2], [0, 1, 2], [0, 1, 2], [0, 1, 3], [2, 3, 0]]);
}

#[test]
fn parse_accepts_a_bom_and_crlf_line_ends() {
    let m = parse("\u{feff}v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\n\r\nf 1 2 3\r\n");
    assert_eq!(m.vertices, vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    assert_eq!(m.triangles, vec![[0, 1, 2]]);
}

#[test]
fn parse_accepts_faces_before_their_vertices() {
    let m = parse("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n");
    assert_eq!(m.triangles, vec![[0, 1, 2]]);
}

#[test]
fn parse_errors_name_the_file_the_line_and_the_fault() {
    let cases: &[(&str, &str)] = &[
        ("v 0 0 0\nv 1 2\n", "line 2: bad vertex: 2 coordinates, 3 needed"),
        ("v 0 0 0\n\nv 1 x 2\n", "line 3: bad vertex: `x` is not a number"),
        ("v nan 0 0\n", "line 1: bad vertex: `nan` is not a finite number"),
        (
            "v 0 0 0\nv 0 inf 0\n",
            "line 2: bad vertex: `inf` is not a finite number",
        ),
        ("v 1 2 3 abc\n", "line 1: bad vertex: `abc` is not a number"),
        (&format!("{TRI}f 0 1 2\n"), "line 4: vertex index 0 does not exist"),
        (
            &format!("{TRI}f 1 2 3\nf 1 2 4\n"),
            "line 5: vertex index 4 is out of range: the file has 3 vertices",
        ),
        (
            &format!("{TRI}f 1 2 99999999999\n"),
            "line 4: vertex index 99999999999 is out of range",
        ),
        (
            &format!("{TRI}f -1 -2 -4\n"),
            "line 4: vertex index -4 counts back past the first vertex (3 read so far)",
        ),
        (
            &format!("{TRI}f 1 2\n"),
            "line 4: a face has 2 vertices; a face needs at least 3",
        ),
        (&format!("{TRI}\nf\n"), "line 5: a face has 0 vertices"),
        (
            &format!("{TRI}f 1 2 c\n"),
            "line 4: bad face: `c` does not start with a vertex index",
        ),
        (
            &format!("{TRI}f 1 2 /3\n"),
            "line 4: bad face: `/3` does not start with a vertex index",
        ),
        (TRI, "the file has no faces: give a mesh, not a point cloud"),
        ("v 1 2 3\nv 1 2 3\nv 1 2 3\nf 1 2 3\n", "zero extent"),
    ];
    for (text, want) in cases {
        let msg = parse_err(text);
        assert!(msg.starts_with("`bad.obj`"), "{msg}");
        assert!(msg.contains(want), "{text:?}: `{msg}` should contain `{want}`");
    }
}

#[test]
fn load_obj_names_a_missing_file() {
    let path = Path::new("/nonexistent/dir/missing.obj");
    let e = Mesh::load_obj(path).unwrap_err();
    assert!(matches!(e, MeshError::Read { .. }), "{e:?}");
    assert!(e.to_string().contains("/nonexistent/dir/missing.obj"), "{e}");
    assert_eq!(e.exit_class(), Some(Class::Input));
}

#[test]
fn the_shipped_torus_stands_up_facing_the_front() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/objects/torus.obj");
    let m = Mesh::load_obj(Path::new(path)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(m.vertices.len(), 32 * 16);
    assert_eq!(m.triangles.len(), 2 * 32 * 16);
    let (lo, hi) = m.bounds();
    assert!(close(lo, [-1.35, -1.35, -0.35], 1e-6), "{lo:?}");
    assert!(close(hi, [1.35, 1.35, 0.35], 1e-6), "{hi:?}");
}

#[test]
fn placement_scales_the_largest_extent_to_size_and_centres_it_at_depth() {
    let m = box_obj([1.0, -2.0, 3.0], [3.0, 2.0, 4.0]);
    for (az, yaw) in [(0.0, 0.0), (90.0, 0.0), (-90.0, 180.0), (30.0, 60.0)] {
        let (lo, hi) = world_bounds(&place(30.0, 12.0, az, yaw).world_vertices(&m));
        let extent = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
        let centre = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])];
        assert!(
            close(centre, [0.0, 0.0, -12.0], 1e-9),
            "az {az} yaw {yaw}: centre {centre:?}"
        );
        // OBJ Y (extent 4, the largest) is world z at every azimuth.
        assert!((extent[2] - 30.0).abs() < 1e-9, "az {az} yaw {yaw}: {extent:?}");
        assert!(extent[0].max(extent[1]) <= 30.0 + 1e-9, "{extent:?}");
    }
    // Negative depth: in front of the plate.
    let (lo, hi) = world_bounds(&place(10.0, -5.0, 0.0, 0.0).world_vertices(&m));
    assert!(
        close(lo, [-1.25, -2.5, 0.0], 1e-9) && close(hi, [1.25, 2.5, 10.0], 1e-9),
        "{lo:?} {hi:?}"
    );
}

#[test]
fn placement_maps_obj_up_to_world_up_and_the_front_to_its_azimuth() {
    // Marker vertices on the OBJ axes of a mesh centred at the origin with extent 2.
    let m = Mesh {
        vertices: vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, -1.0, -1.0]],
        triangles: vec![[0, 1, 2]],
    };
    let at = |p: Placement| p.world_vertices(&m);
    // Front azimuth 0: OBJ (X, Y, Z) -> world (y, z, x).
    let w = at(place(2.0, 0.0, 0.0, 0.0));
    assert!(close(w[0], [0.0, 1.0, 0.0], 1e-12), "OBJ +X: {:?}", w[0]);
    assert!(close(w[1], [0.0, 0.0, 1.0], 1e-12), "OBJ +Y: {:?}", w[1]);
    assert!(close(w[2], [1.0, 0.0, 0.0], 1e-12), "OBJ +Z: {:?}", w[2]);
    // Front azimuth 90 sends the front (OBJ +Z) to world +y, its right (OBJ +X) to -x.
    let w = at(place(2.0, 0.0, 90.0, 0.0));
    assert!(close(w[2], [0.0, 1.0, 0.0], 1e-12), "OBJ +Z: {:?}", w[2]);
    assert!(close(w[0], [-1.0, 0.0, 0.0], 1e-12), "OBJ +X: {:?}", w[0]);
    assert!(close(w[1], [0.0, 0.0, 1.0], 1e-12), "OBJ +Y: {:?}", w[1]);
    // Yaw turns counter-clockwise after the azimuth: azimuth 30 + yaw 60 faces +y too.
    let w = at(place(2.0, 7.0, 30.0, 60.0));
    assert!(close(w[2], [0.0, 1.0, -7.0], 1e-12), "OBJ +Z: {:?}", w[2]);
    // Always a rotation: orthonormal with determinant +1.
    for (az, yaw) in [(0.0, 0.0), (90.0, 0.0), (17.0, -140.0), (-75.0, 33.0)] {
        let [x, y, z] = place(1.0, 0.0, az, yaw).axes();
        let det = dot(x, cross(y, z));
        assert!((det - 1.0).abs() < 1e-12, "az {az} yaw {yaw}: det {det}");
        for (a, b) in [(x, y), (y, z), (z, x)] {
            assert!(dot(a, b).abs() < 1e-12 && (dot(a, a) - 1.0).abs() < 1e-12);
        }
    }
}

#[test]
fn a_cube_covers_its_projection_and_nothing_outside_it() {
    let view = orbit_view(250.0, 30.0, 15.0, 60.0, 64);
    let geom = ViewGeom::new(&view);
    let p = place(20.0, 15.0, 0.0, 25.0);
    let img = render_object(&cube(), &p, &view, [0.3, 0.2, 0.9], 0.5);
    assert_eq!((img.width, img.height), (64, 64));
    assert_eq!((img.shade.len(), img.coverage.len()), (64 * 64, 64 * 64));
    assert!(img.coverage.iter().all(|c| (0.0..=1.0).contains(c)));
    assert!(img.shade.iter().all(|s| (0.0..=1.0).contains(s)));

    // Around where the centre projects: fully covered.
    let (cx, cy) = geom.project([0.0, 0.0, -15.0]).unwrap();
    for dj in -2..=2 {
        for di in -2..=2 {
            let (i, j) = ((cx as i64 + di) as usize, (cy as i64 + dj) as usize);
            assert_eq!(img.coverage[j * 64 + i], 1.0, "pixel ({i}, {j}) near the centre");
        }
    }
    // Outside the projected bounding box of the corners: nothing, and the background.
    let corners: Vec<(f64, f64)> = p
        .world_vertices(&cube())
        .iter()
        .map(|&c| geom.project(c).unwrap())
        .collect();
    let (x0, x1) = corners
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), c| (a.min(c.0), b.max(c.0)));
    let (y0, y1) = corners
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), c| (a.min(c.1), b.max(c.1)));
    let mut covered = 0;
    for j in 0..64 {
        for i in 0..64 {
            let k = j * 64 + i;
            let inside = (i + 1) as f64 > x0 && (i as f64) < x1 && (j + 1) as f64 > y0 && (j as f64) < y1;
            if !inside {
                assert_eq!(img.coverage[k], 0.0, "pixel ({i}, {j}) outside the projected box");
                assert_eq!(img.shade[k], 0.5);
            }
            covered += (img.coverage[k] > 0.0) as usize;
        }
    }
    assert!(covered > 25 && covered < 64 * 64 / 2, "{covered} pixels covered");
}

#[test]
fn a_face_towards_the_light_is_brighter_than_one_edge_on() {
    // Seen from azimuth 0, 30 degrees up: the cube's top (+z) and front (+x) faces.
    let view = orbit_view(250.0, 30.0, 0.0, 60.0, 64);
    let geom = ViewGeom::new(&view);
    let p = place(20.0, 0.0, 0.0, 0.0);
    let pixel_of = |w: [f64; 3]| {
        let (sx, sy) = geom.project(w).unwrap();
        sy as usize * 64 + sx as usize
    };
    let (top, front) = (pixel_of([0.0, 0.0, 10.0]), pixel_of([10.0, 0.0, 0.0]));
    let lit_front = render_object(&cube(), &p, &view, [1.0, 0.0, 0.0], 0.0);
    assert_eq!((lit_front.coverage[top], lit_front.coverage[front]), (1.0, 1.0));
    assert!(
        (lit_front.shade[front] - 1.0).abs() < 1e-6,
        "{}",
        lit_front.shade[front]
    );
    assert!((lit_front.shade[top] - 0.15).abs() < 1e-6, "{}", lit_front.shade[top]);
    // Two-sided, and the light's length does not matter.
    let lit_top = render_object(&cube(), &p, &view, [0.0, 0.0, -3.0], 0.0);
    assert!(lit_top.shade[top] > lit_top.shade[front] + 0.5);
}

/// Where on the plate an object appears: the plate point on the line of sight through its
/// image's coverage centroid.
fn apparent_plate_point(img: &ObjectImage, geom: &ViewGeom) -> [f64; 2] {
    let (mut sum, mut sx, mut sy) = (0.0, 0.0, 0.0);
    for j in 0..img.height as usize {
        for i in 0..img.width as usize {
            let c = img.coverage[j * img.width as usize + i] as f64;
            sum += c;
            sx += c * (i as f64 + 0.5);
            sy += c * (j as f64 + 0.5);
        }
    }
    assert!(sum > 0.0, "the object is not in view");
    geom.hit(sx / sum, sy / sum).unwrap()
}

#[test]
fn parallax_an_object_behind_the_plate_appears_over_the_viewers_side_of_it() {
    let (distance, elevation) = (250.0, 30.0);
    let h = spherical(distance, 0.0, elevation)[2];
    for depth in [30.0, 60.0, -30.0] {
        let p = place(8.0, depth, 0.0, 0.0);
        let mut seen = Vec::new();
        for az in [-20.0f64, 20.0] {
            let view = orbit_view(distance, elevation, az, 100.0, 96);
            let geom = ViewGeom::new(&view);
            let x = apparent_plate_point(&render_object(&cube(), &p, &view, [0.0, 0.0, 1.0], 0.0), &geom);
            // The line of sight from eye E through (0, 0, -depth) crosses the plate at
            // E_xy depth / (E_z + depth): towards the viewer for an object behind the
            // plate, away from the viewer for one in front.
            let eye = spherical(distance, az, elevation);
            let want = [eye[0] * depth / (h + depth), eye[1] * depth / (h + depth)];
            assert!(
                (x[0] - want[0]).hypot(x[1] - want[1]) < 0.25,
                "depth {depth}, azimuth {az}: appears over {x:?}, expected {want:?}"
            );
            seen.push(x);
        }
        // The two viewers see it over plate points on opposite sides of the centre line.
        let side = if depth > 0.0 { 1.0 } else { -1.0 };
        assert!(
            side * seen[0][1] < -1.0 && side * seen[1][1] > 1.0,
            "depth {depth}: {seen:?}"
        );
    }
}

/// The nearest hit of ray `o + t d` (t > 0) with the triangles of `world`: (t, shade).
fn ray_cast(world: &[[f64; 3]], tris: &[[u32; 3]], o: V3, d: V3, light: V3) -> Option<(f64, f32)> {
    let mut best: Option<(f64, f32)> = None;
    for t in tris {
        let [a, b, c] = t.map(|k| world[k as usize]);
        let (e1, e2) = (sub(b, a), sub(c, a));
        let p = cross(d, e2);
        let det = dot(e1, p);
        if det.abs() < 1e-12 {
            continue;
        }
        let s = sub(o, a);
        let u = dot(s, p) / det;
        let q = cross(s, e1);
        let v = dot(d, q) / det;
        let dist = dot(e2, q) / det;
        if u < 0.0 || v < 0.0 || u + v > 1.0 || !(dist > 0.0) || best.is_some_and(|(bt, _)| bt <= dist) {
            continue;
        }
        let n = cross(e1, e2);
        let shade = 0.15 + 0.85 * (dot(n, light) / dot(n, n).sqrt()).abs();
        best = Some((dist, shade as f32));
    }
    best
}

/// Renders `mesh` and compares every pixel with an independent oracle: each of its 16
/// subsamples ray-cast in 3D with the view's own ray directions. Returns the image.
fn assert_matches_ray_cast(mesh: &Mesh, p: &Placement, view: &View, light: V3) -> ObjectImage {
    let geom = ViewGeom::new(view);
    let img = render_object(mesh, p, view, light, 0.1);
    let world = p.world_vertices(mesh);
    let (w, h) = (img.width as usize, img.height as usize);
    for j in 0..h {
        for i in 0..w {
            let (mut sum, mut covered) = (0.0f32, 0);
            for sy in 0..4 {
                for sx in 0..4 {
                    let (x, y) = (i as f64 + (sx as f64 + 0.5) / 4.0, j as f64 + (sy as f64 + 0.5) / 4.0);
                    let hit = ray_cast(&world, &mesh.triangles, geom.eye, geom.ray_dir(x, y), light);
                    sum += hit.map_or(0.1, |h| h.1);
                    covered += hit.is_some() as u32;
                }
            }
            let k = j * w + i;
            assert_eq!(img.coverage[k], covered as f32 / 16.0, "coverage of pixel ({i}, {j})");
            let want = sum / 16.0;
            assert!(
                (img.shade[k] - want).abs() < 1e-5,
                "shade of pixel ({i}, {j}): {} against {want}",
                img.shade[k]
            );
        }
    }
    img
}

/// Self-occlusion, the hole and the silhouette of the shipped torus.
#[test]
fn the_render_of_the_torus_matches_a_ray_cast() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/objects/torus.obj");
    let torus = Mesh::load_obj(Path::new(path)).unwrap_or_else(|e| panic!("{e}"));
    let view = orbit_view(250.0, 35.0, 10.0, 40.0, 40);
    let p = place(36.0, 10.0, 0.0, 30.0);
    let img = assert_matches_ray_cast(&torus, &p, &view, [0.48, 0.6, 0.64]);
    // The hole shows the background around where the centre projects.
    let (cx, cy) = ViewGeom::new(&view).project([0.0, 0.0, -10.0]).unwrap();
    assert_eq!(img.coverage[cy as usize * 40 + cx as usize], 0.0, "the hole");
    assert!(img.coverage.iter().filter(|&&c| c == 1.0).count() > 100);
}

/// Two quads that cut through each other, seen from close by (depths from about 45 to
/// 95 mm): where they cross shows that depth is interpolated perspective-correctly.
#[test]
fn crossing_faces_seen_from_close_by_match_a_ray_cast() {
    let m = parse(
        "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 2 3 4\n\
         v -1 -0.2 -1\nv 1 -0.2 -1\nv 1 0.2 1\nv -1 0.2 1\nf 5 6 7 8\n",
    );
    let view = orbit_view(70.0, 35.0, 20.0, 60.0, 48);
    let img = assert_matches_ray_cast(&m, &place(50.0, 0.0, 0.0, 0.0), &view, [0.8, 0.0, 0.6]);
    let shades: Vec<f32> = img
        .shade
        .iter()
        .zip(&img.coverage)
        .filter(|(_, &c)| c == 1.0)
        .map(|(&s, _)| s)
        .collect();
    let (lo, hi) = shades.iter().fold((1.0f32, 0.0f32), |(a, b), &s| (a.min(s), b.max(s)));
    assert!(hi - lo > 0.05, "both faces should show: shades {lo}..{hi}");
}

#[test]
fn triangles_behind_the_camera_are_skipped() {
    // The camera 60 mm above the plate; the object spans from below the plate to above the
    // eye, so some triangles have vertices behind the camera.
    let view = orbit_view(60.0, 90.0 - 1e-3, 0.0, 60.0, 32);
    let p = place(200.0, 0.0, 0.0, 0.0);
    let img = render_object(&cube(), &p, &view, [0.0, 0.0, 1.0], 0.25);
    assert!(img.shade.iter().all(|s| (0.0..=1.0).contains(s)));
    assert!(img.coverage.iter().all(|c| (0.0..=1.0).contains(c)));
    // Out-of-range indices of a hand-built mesh are skipped too.
    let bad = Mesh {
        vertices: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        triangles: vec![[0, 1, 7]],
    };
    let img = render_object(&bad, &place(10.0, 0.0, 0.0, 0.0), &view, [0.0, 0.0, 1.0], 0.25);
    assert!(img.coverage.iter().all(|&c| c == 0.0));
}
