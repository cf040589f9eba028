//! Scenes over the device's limits and bad command-line input give clear errors (and the right
//! exit codes), not crashes. Lavapipe binds at most 128 MiB per storage buffer.
use std::process::Command;

use scratchart_model::scene::Scene;
use scratchart_render::Renderer;
use scratchart_tests::*;
use scratchart_vulkan::GpuError;

fn small_scene() -> Scene {
    random_scene(
        21,
        10,
        20.0,
        0.2,
        0.2,
        0.1,
        vec![orbit_view("a", 16, 45.0, 0.0, 45.0, 180.0, 20.0)],
    )
}

#[test]
fn too_many_pixels_is_a_clear_error() {
    let ctx = gpu();
    let limit = ctx.info().max_storage_buffer_range;
    let mut scene = small_scene();
    // One f32 per pixel: pick a square image just over the per-buffer limit.
    let side = ((limit / 4) as f64).sqrt() as u32 + 64;
    scene.views[0].camera.width = side;
    scene.views[0].camera.height = side;
    let r = Renderer::new(&ctx).unwrap();
    match r.upload(&scene) {
        Err(GpuError::BufferTooLarge { name, size, limit: l }) => {
            assert!(size > l);
            let msg = GpuError::BufferTooLarge {
                name: name.clone(),
                size,
                limit: l,
            }
            .to_string();
            assert!(msg.contains("reduce"), "message should say what to do: {msg}");
        }
        Err(e) => panic!("expected BufferTooLarge, got {e}"),
        Ok(_) => panic!("a {side}x{side} view must not fit a {limit}-byte buffer"),
    }
    assert_no_validation(&ctx);
}

#[test]
fn too_many_scratches_is_a_clear_error() {
    let ctx = gpu();
    let limit = ctx.info().max_storage_buffer_range;
    let mut scene = small_scene();
    let s = scene.scratches[0];
    // 64 bytes of records per scratch for the shading kernels (a storage and a texel buffer),
    // the largest per-scratch buffer of a one-view scene.
    scene.scratches = vec![s; (limit / 64) as usize + 1000];
    let r = Renderer::new(&ctx).unwrap();
    let err = r.upload(&scene).err().expect("over the limit");
    assert!(matches!(err, GpuError::BufferTooLarge { .. }), "got {err}");
    assert!(err.to_string().contains("scratch records"), "names the buffer: {err}");
    assert_no_validation(&ctx);
}

fn scratchart_bin() -> std::path::PathBuf {
    workspace_bin("scratchart", "scratchart")
}

#[test]
fn cli_bad_scene_exit_codes() {
    let dir = std::env::temp_dir().join(format!("scratchart-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bin = scratchart_bin();
    assert!(bin.exists(), "build the engine binary first ({})", bin.display());
    let cases: [(&str, &str, &str); 4] = [
        ("malformed.json", "{ \"plate\": ", "malformed.json"),
        (
            "alpha.json",
            r#"{"plate":{"size_mm":20},"views":[{"name":"v","camera":{"eye":[0,-40,40],"target":[0,0,0],"up":[0,0,1],"fov_y_deg":30,"width":8,"height":8},"light":{"kind":"point","position":[0,40,40],"intensity":1}}],"scratches":[[0,0,1,1,0.1,0.1,1.5]]}"#,
            "alpha",
        ),
        (
            "offplate.json",
            r#"{"plate":{"size_mm":20},"views":[{"name":"v","camera":{"eye":[0,-40,40],"target":[0,0,0],"up":[0,0,1],"fov_y_deg":30,"width":8,"height":8},"light":{"kind":"point","position":[0,40,40],"intensity":1}}],"scratches":[[0,0,11,1,0.1,0.1,0.1]]}"#,
            "plate",
        ),
        (
            "blind.json",
            r#"{"plate":{"size_mm":20},"views":[{"name":"v","camera":{"eye":[0,-40,40],"target":[0,-80,80],"up":[0,0,1],"fov_y_deg":10,"width":8,"height":8},"light":{"kind":"point","position":[0,40,40],"intensity":1}}],"scratches":[]}"#,
            "see",
        ),
    ];
    for (name, text, needle) in cases {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        let out = Command::new(&bin)
            .args(["render", p.to_str().unwrap(), "--out"])
            .arg(dir.join("out"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(
            out.status.code(),
            Some(3),
            "{name}: exit code for bad input; stderr: {err}"
        );
        assert!(err.contains(needle), "{name}: message should mention '{needle}': {err}");
    }
    // A missing file, and a bad flag (exit 2).
    let out = Command::new(&bin)
        .args(["render", "/nonexistent/scene.json"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(3));
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/scene.json"));
    let out = Command::new(&bin).args(["render", "--no-such-flag"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn cli_devices_lists_the_default() {
    let out = Command::new(scratchart_bin()).arg("devices").output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    let defaults: Vec<&str> = text.lines().filter(|l| l.starts_with('*')).collect();
    assert_eq!(defaults.len(), 1, "exactly one default device expected:\n{text}");
    // The default is the device a context picks with no selector.
    let ctx = gpu();
    assert!(
        defaults[0].contains(&ctx.info().name),
        "{} vs {}",
        defaults[0],
        ctx.info().name
    );
}

/// The device memory a job states before it starts (`SceneDims::device_bytes`) is what an
/// upload takes from the allocator, at least and within a few percent, in both binning modes.
#[test]
fn the_stated_device_memory_is_what_an_upload_takes() {
    use scratchart_render::limits::SceneDims;
    use scratchart_render::BinMode;
    let ctx = gpu();
    let r = Renderer::new(&ctx).unwrap();
    for (n, side, views) in [(10usize, 16u32, 1usize), (5000, 128, 3), (40000, 256, 2)] {
        let vs = (0..views)
            .map(|k| orbit_view(&format!("v{k}"), side, 45.0, 120.0 * k as f64, 45.0, 180.0, 20.0))
            .collect();
        let scene = random_scene(5, n, 20.0, 0.2, 0.2, 0.1, vs);
        let sizes = vec![(side, side); views];
        let dims = SceneDims::new(&sizes, n as u64, false);
        let before = ctx.allocated_bytes();
        let mut gs = r.upload(&scene).unwrap();
        for mode in [BinMode::Groups, BinMode::Pairs] {
            gs.force_binning_mode(&ctx, mode).unwrap();
            let took = ctx.allocated_bytes() - before;
            let stated = dims.device_bytes_in(ctx.info(), mode);
            println!("{n} scratches, {views} x {side}^2, {mode:?}: stated {stated}, took {took}");
            assert!(stated <= took, "{n} scratches {mode:?}: stated {stated} > took {took}");
            assert!(
                took <= stated + stated / 20 + (1 << 20),
                "{n} scratches {mode:?}: took {took}, stated only {stated}"
            );
        }
        drop(gs);
    }
    assert_no_validation(&ctx);
}
