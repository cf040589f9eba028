//! Shared helpers of the workspace-level tests: a validated Vulkan context on the real device
//! (lavapipe in CI), scene builders for the test families, and the engine/docs/model.md section 8 comparison.
use std::sync::Arc;

use scratchart_design::scenes::{orbit_camera, orbit_light, random_scratches, Rng};
use scratchart_model::scene::{Camera, Light, LightKind, Plate, Scene, Scratch, View};
use scratchart_render::Renderer;
use scratchart_vulkan::{Context, ContextDesc};

/// A context with the validation layer on. Tests call [`assert_no_validation`] at the end.
pub fn gpu() -> Arc<Context> {
    Context::new(ContextDesc {
        validation: true,
        quiet: true,
        ..Default::default()
    })
    .expect("a Vulkan device (lavapipe in CI)")
}

pub fn assert_no_validation(ctx: &Context) {
    let m = ctx.validation_messages();
    assert!(
        m.is_empty(),
        "{} Vulkan validation message(s), first: {}",
        m.len(),
        m[0]
    );
}

/// Renders every view of `scene` on the GPU.
pub fn gpu_render(ctx: &Arc<Context>, scene: &Scene) -> Vec<Vec<f32>> {
    let r = Renderer::new(ctx).expect("pipelines");
    let mut gs = r.upload(scene).expect("upload");
    r.render(&mut gs).expect("render").images
}

/// Outcome of comparing one view against the reference with the bar of engine/docs/model.md section 8.
#[derive(Debug)]
pub struct Comparison {
    pub on_plate: usize,
    pub within: usize,
    pub worst_rel: f64,
    pub worst_at: (u32, u32, f64, f64),
    pub off_plate_nonzero: usize,
    pub non_finite: usize,
    pub max_ref: f64,
}

impl Comparison {
    pub fn fraction(&self) -> f64 {
        if self.on_plate == 0 {
            1.0
        } else {
            self.within as f64 / self.on_plate as f64
        }
    }
}

/// Compares `gpu` with the float64 reference `reference` of one view.
pub fn compare(scene: &Scene, view: usize, gpu: &[f32], reference: &[f64]) -> Comparison {
    let mask = scratchart_model::camera::on_plate_mask(scene, view);
    let w = scene.views[view].camera.width;
    let max_ref = reference.iter().cloned().fold(0.0, f64::max);
    let abs_tol = 1e-6 * max_ref;
    let mut c = Comparison {
        on_plate: 0,
        within: 0,
        worst_rel: 0.0,
        worst_at: (0, 0, 0.0, 0.0),
        off_plate_nonzero: 0,
        non_finite: 0,
        max_ref,
    };
    for (idx, (&g, &r)) in gpu.iter().zip(reference).enumerate() {
        if !g.is_finite() {
            c.non_finite += 1;
        }
        if !mask[idx] {
            if g != 0.0 {
                c.off_plate_nonzero += 1;
            }
            continue;
        }
        c.on_plate += 1;
        let err = (g as f64 - r).abs();
        let rel = if r != 0.0 {
            err / r.abs()
        } else if err == 0.0 {
            0.0
        } else {
            f64::INFINITY
        };
        if rel <= 1e-3 || err <= abs_tol {
            c.within += 1;
        }
        // Worst relative error among pixels above the absolute floor (reported, not asserted).
        if err > abs_tol && rel > c.worst_rel {
            c.worst_rel = rel;
            c.worst_at = ((idx as u32) % w, (idx as u32) / w, g as f64, r);
        }
    }
    c
}

/// Renders on the GPU and with the reference, and asserts the engine/docs/model.md section 8 forward bar on
/// every view. Names the worst pixel and both values on failure.
pub fn assert_matches_reference(label: &str, scene: &Scene) {
    scene.validate().expect("test scene is valid");
    let ctx = gpu();
    let images = gpu_render(&ctx, scene);
    for v in 0..scene.views.len() {
        let reference = scratchart_model::reference::render_view(scene, v);
        let c = compare(scene, v, &images[v], &reference);
        eprintln!(
            "{label} view {v}: {}/{} on-plate pixels within the bar ({:.4}%), worst relative error above the 1e-6 x max floor {:.3e} at (i, j, gpu, ref) = {:?}",
            c.within, c.on_plate, 100.0 * c.fraction(), c.worst_rel, c.worst_at
        );
        assert!(
            c.on_plate > 0,
            "{label} view {v}: no on-plate pixel, the test scene is wrong"
        );
        assert_eq!(c.non_finite, 0, "{label} view {v}: NaN or infinity in the GPU image");
        assert_eq!(
            c.off_plate_nonzero, 0,
            "{label} view {v}: off-plate pixels must be exactly 0"
        );
        assert!(
            c.fraction() >= 0.99,
            "{label} view {v}: only {:.3}% of on-plate pixels within 1e-3 relative / 1e-6 x max; worst at pixel ({}, {}): gpu {:e} vs reference {:e}",
            100.0 * c.fraction(), c.worst_at.0, c.worst_at.1, c.worst_at.2, c.worst_at.3
        );
    }
    assert_no_validation(&ctx);
}

pub fn plate(size: f64) -> Plate {
    Plate {
        size_mm: size,
        roughness: 0.02,
        f0: 0.91,
        shape: Default::default(),
    }
}

/// A view on an orbit around the plate centre with a point light on another orbit.
pub fn orbit_view(name: &str, res: u32, elev: f64, az: f64, light_elev: f64, light_az: f64, plate_mm: f64) -> View {
    View {
        exposure: 1.0,
        name: name.into(),
        camera: orbit_camera(3.0 * plate_mm, elev, az, plate_mm, res, res),
        light: orbit_light(3.0 * plate_mm, light_elev, light_az, 1.0e4),
    }
}

pub fn directional_view(
    name: &str,
    res: u32,
    elev: f64,
    az: f64,
    light_elev: f64,
    light_az: f64,
    plate_mm: f64,
) -> View {
    let (e, a) = (light_elev.to_radians(), light_az.to_radians());
    View {
        exposure: 1.0,
        name: name.into(),
        camera: orbit_camera(3.0 * plate_mm, elev, az, plate_mm, res, res),
        light: Light {
            kind: LightKind::Directional {
                direction: [e.cos() * a.cos(), e.cos() * a.sin(), e.sin()],
            },
            intensity: 1.0,
        },
    }
}

/// A random scene of `n` scratches on a `plate_mm` plate.
pub fn random_scene(seed: u64, n: usize, plate_mm: f64, w: f64, d: f64, alpha: f64, views: Vec<View>) -> Scene {
    let mut rng = Rng::new(seed);
    Scene {
        plate: plate(plate_mm),
        views,
        scratches: random_scratches(&mut rng, n, plate_mm, 0.05 * plate_mm, 0.3 * plate_mm, w, d, alpha),
    }
}

/// `n` random scratches (w 0.2, d 0.15, alpha 0.1) on a 20 mm plate seen from two orbit views of
/// `res_a` and `res_b` pixels: the scene of the tests that split work (passes, binning bands) and
/// compare bits.
pub fn two_view_scene(seed: u64, n: usize, res_a: u32, res_b: u32) -> Scene {
    random_scene(
        seed,
        n,
        20.0,
        0.2,
        0.15,
        0.1,
        vec![
            orbit_view("a", res_a, 45.0, 0.0, 45.0, 180.0, 20.0),
            orbit_view("b", res_b, 60.0, 120.0, 45.0, 180.0, 20.0),
        ],
    )
}

/// A camera `elev` degrees above the plate with a narrow field of view, so that a grazing view
/// still puts many pixels on the plate.
pub fn grazing_view(name: &str, res: u32, elev: f64, az: f64, light_elev: f64, light_az: f64, plate_mm: f64) -> View {
    let mut v = orbit_view(name, res, elev, az, light_elev, light_az, plate_mm);
    v.camera.fov_y_deg = 4.0;
    v
}

pub fn camera(eye: [f64; 3], res: u32, fov: f64) -> Camera {
    Camera {
        eye,
        target: [0.0, 0.0, 0.0],
        up: [0.0, 0.0, 1.0],
        fov_y_deg: fov,
        width: res,
        height: res,
    }
}

pub fn scratch(p0: [f64; 2], p1: [f64; 2], w: f64, d: f64, alpha: f64) -> Scratch {
    Scratch {
        p0,
        p1,
        w,
        d,
        alpha,
        bulge: 0.0,
    }
}

/// The workspace's root directory.
pub fn workspace_root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The binary `name` (a package's `[[bin]]`) of this test's profile, built on first use: `cargo
/// test --workspace` builds binaries only for packages with integration tests of their own.
pub fn workspace_bin(package: &str, name: &str) -> std::path::PathBuf {
    use std::collections::HashMap;
    use std::sync::Mutex;
    static BUILT: Mutex<Option<HashMap<String, std::path::PathBuf>>> = Mutex::new(None);
    let mut built = BUILT.lock().unwrap_or_else(|e| e.into_inner());
    let map = built.get_or_insert_with(HashMap::new);
    if let Some(p) = map.get(name) {
        return p.clone();
    }
    // target/<profile>/deps/TEST-HASH -> target/<profile>/
    let exe = std::env::current_exe().unwrap();
    let profile_dir = exe.parent().unwrap().parent().unwrap().to_path_buf();
    let release = profile_dir.file_name().is_some_and(|n| n == "release");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = std::process::Command::new(cargo);
    cmd.current_dir(workspace_root())
        .args(["build", "-q", "-p", package, "--bin", name]);
    if release {
        cmd.arg("--release");
    }
    let st = cmd.status().expect("run cargo build");
    assert!(st.success(), "cargo build -p {package} failed");
    let bin = profile_dir.join(name);
    assert!(bin.exists(), "{} missing after the build", bin.display());
    map.insert(name.to_string(), bin.clone());
    bin
}

/// The viewer binary of this test's profile, built on first use.
pub fn viewer_bin() -> std::path::PathBuf {
    workspace_bin("scratchart-view", "scratchart-view")
}

/// An X server for the window tests: $DISPLAY when set, else a private Xvfb, killed on drop.
/// Xvfb picks a free display itself and reports it (`-displayfd`), so tests that start servers
/// at the same time never share one (a test that took another's server lost its windows when
/// that test ended), and stale lock files of killed servers are Xvfb's to clear.
pub struct XServer {
    pub display: String,
    xvfb: Option<std::process::Child>,
}

impl XServer {
    pub fn start() -> XServer {
        use std::io::{BufRead, Read};
        if let Some(d) = std::env::var("DISPLAY").ok().filter(|d| !d.is_empty()) {
            return XServer { display: d, xvfb: None };
        }
        let mut child = std::process::Command::new("Xvfb")
            .args(["-displayfd", "1", "-screen", "0", "1280x1024x24", "-nolisten", "tcp"])
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("Xvfb is needed for the window tests (apt install xvfb)");
        let out = child.stdout.take().expect("piped stdout");
        let (tx, rx) = std::sync::mpsc::channel();
        // The first line is the display number, written once the server accepts connections;
        // the pipe is then read to its end, so the server never writes into a closed pipe.
        std::thread::spawn(move || {
            let mut reader = std::io::BufReader::new(out);
            let mut line = String::new();
            let _ = reader.read_line(&mut line);
            let _ = tx.send(line);
            let _ = reader.read_to_end(&mut Vec::new());
        });
        let mut server = XServer {
            display: String::new(),
            xvfb: Some(child),
        };
        let line = rx.recv_timeout(std::time::Duration::from_secs(30)).unwrap_or_default();
        match line.trim().parse::<u32>() {
            Ok(n) => server.display = format!(":{n}"),
            Err(_) => panic!("Xvfb did not report a display within 30 s (-displayfd): {line:?}"),
        }
        server
    }

    /// Runs `prog args` on this display; panics unless it succeeds. Returns its stdout, trimmed.
    pub fn run(&self, prog: &str, args: &[&str]) -> String {
        let out = std::process::Command::new(prog)
            .args(args)
            .env("DISPLAY", &self.display)
            .output()
            .unwrap_or_else(|e| panic!("{prog}: {e}"));
        assert!(out.status.success(), "{prog} {args:?} failed");
        String::from_utf8_lossy(&out.stdout).trim().to_string()
    }
}

impl Drop for XServer {
    fn drop(&mut self) {
        if let Some(c) = self.xvfb.as_mut() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// Runs the `scratchart` binary with `args`.
pub fn run_scratchart(args: &[&str]) -> std::process::Output {
    std::process::Command::new(workspace_bin("scratchart", "scratchart"))
        .args(args)
        .output()
        .unwrap()
}

/// A small `scratchart design --tool TOOL --out OUT` (2 views of 32 px, 200 scratches, 3
/// iterations, no pruning, quiet, validation on): tests change the values they need.
pub fn tool_design_args<'a>(tool: &'a str, out: &'a str) -> Vec<&'a str> {
    vec![
        "design",
        "--views",
        "2",
        "--res",
        "32",
        "--scratches",
        "200",
        "--iters",
        "3",
        "--prune-tol",
        "0",
        "--quiet",
        "--validation",
        "--tool",
        tool,
        "--out",
        out,
    ]
}

/// Writes `text` to `dir/name` and returns the path.
pub fn write_file(dir: &std::path::Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

/// The tool of the machine tests: a 60-degree V-bit with a 10 um flat tip, no z offset, as the
/// tool.json they write.
pub const V60_TOOL_JSON: &str = r#"{ "kind": "v-bit", "angle_deg": 60.0, "tip_flat_mm": 0.01, "z_offset_mm": 0.0 }"#;

/// A design `plan` can carve as designed with `tool`: `n` scratches fanned over a plate of
/// `plate` mm, scratch k the tool's own groove at commanded depth 0.035 + 0.03 k / n mm (deeper
/// than both built-in machine profiles' shallowest cut, 0.02 and 0.03 mm).
pub fn carvable_design(plate: f64, n: usize, tool: &scratchart_tool::Tool) -> Scene {
    let h = 0.4 * plate;
    Scene::bare(
        plate,
        (0..n)
            .map(|k| {
                let t = k as f64 / n as f64;
                let g = tool.model(0.035 + 0.03 * t).expect("the tool reaches the plate");
                Scratch {
                    p0: [-h + 2.0 * h * t, -h],
                    p1: [-h + 2.0 * h * t, h * t],
                    w: g.w,
                    d: g.d,
                    alpha: 0.1,
                    bulge: 0.0,
                }
            })
            .collect(),
    )
}

/// [`V60_TOOL_JSON`] as a tool.
pub fn v60_tool() -> scratchart_tool::Tool {
    serde_json::from_str(V60_TOOL_JSON).expect("a valid tool")
}

/// dE_lin/dL per pixel for GPU images `l` and targets `t` (off-plate pixels: 0).
pub fn dl_of(scene: &Scene, l: &[Vec<f32>], t: &[Vec<f64>]) -> Vec<f32> {
    let mut out = Vec::new();
    for v in 0..scene.views.len() {
        let mask = scratchart_model::camera::on_plate_mask(scene, v);
        let n = mask.iter().filter(|m| **m).count().max(1) as f64;
        for (i, &m) in mask.iter().enumerate() {
            out.push(if m {
                (2.0 * (l[v][i] as f64 - t[v][i]) / n) as f32
            } else {
                0.0
            });
        }
    }
    out
}

/// ||a - b|| / ||b||.
pub fn rel(a: &[f64], b: &[f64]) -> f64 {
    let num: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt();
    let den: f64 = b.iter().map(|y| y * y).sum::<f64>().sqrt();
    num / den
}
