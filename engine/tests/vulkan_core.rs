//! Integration tests of the Vulkan layer on the real device (lavapipe in CI): context creation
//! with validation, shader compilation (and its errors), buffers, compute dispatch, timestamps,
//! transfers. Every test that creates a context checks that validation stayed silent, including
//! while the objects, device and instance are destroyed.
use std::sync::Arc;

use scratchart_vulkan::{
    Buffer, ComputePipeline, Context, ContextDesc, GpuError, MemLoc, Recorder, ShaderCompiler, ValidationLog,
};

fn context() -> Arc<Context> {
    let ctx = Context::new(ContextDesc {
        validation: true,
        quiet: true,
        ..Default::default()
    })
    .expect("create Vulkan context");
    assert!(
        ctx.validation_enabled(),
        "validation layer must be installed for these tests"
    );
    ctx
}

/// Drops the context (last reference) and asserts no validation message was ever emitted.
fn finish(ctx: Arc<Context>) {
    let log: ValidationLog = ctx.validation_log();
    assert_eq!(
        Arc::strong_count(&ctx),
        1,
        "some buffer/pipeline/recorder still holds the context"
    );
    drop(ctx);
    let msgs = log.messages();
    assert!(
        msgs.is_empty(),
        "{} validation message(s):\n{}",
        msgs.len(),
        msgs.join("\n")
    );
}

#[test]
fn add_shader_matches_cpu_with_timings() {
    let ctx = context();
    let info = ctx.info().clone();
    assert!(!info.name.is_empty());
    assert!(info.max_storage_buffer_range > 0);
    {
        let compiler = ShaderCompiler::embedded().unwrap();
        let wg = 64u32;
        let pipe = ComputePipeline::new(&ctx, &compiler, "test/add.comp", &[("WG", "64")], 3, 8).unwrap();

        let n = 1_000_000u32;
        let a: Vec<f32> = (0..n).map(|i| (i as f32) * 0.25 - 1000.0).collect();
        let b: Vec<f32> = (0..n).map(|i| ((i * 7919) % 1013) as f32 / 7.0).collect();
        let scale = 1.7f32;
        let a_buf = ctx.upload("a", &a).unwrap();
        let b_buf = ctx.upload("b", &b).unwrap();
        let out = Buffer::new(&ctx, "out", n as u64 * 4, MemLoc::GpuOnly).unwrap();

        let mut push = Vec::new();
        push.extend_from_slice(&n.to_le_bytes());
        push.extend_from_slice(&scale.to_le_bytes());

        let mut rec = Recorder::new(&ctx).unwrap();
        for round in 0..2 {
            // Second round checks that begin() really resets pools, queries and the buffer.
            rec.begin().unwrap();
            rec.fill(&out, 0xffff_ffff);
            rec.barrier();
            rec.timestamp("clear");
            rec.dispatch_1d(&pipe, &[&a_buf, &b_buf, &out], &push, n.div_ceil(wg));
            rec.timestamp("add");
            let timings = rec.submit_and_wait().unwrap();

            if info.timestamps {
                let labels: Vec<&str> = timings.entries.iter().map(|(l, _)| l.as_str()).collect();
                assert_eq!(labels, ["clear", "add"], "round {round}");
                let add = timings.get("add").unwrap();
                assert!(add >= 0.0 && add.is_finite(), "add took {add} ms");
                assert!((timings.total_ms() - timings.entries.iter().map(|e| e.1).sum::<f64>()).abs() < 1e-9);
                assert!(timings.get("nope").is_none());
            } else {
                assert!(timings.entries.is_empty());
            }

            let got: Vec<f32> = ctx.download(&out).unwrap();
            assert_eq!(got.len(), n as usize);
            for i in 0..n as usize {
                let want = a[i] + b[i] * scale;
                assert!(
                    got[i].to_bits() == want.to_bits(),
                    "round {round}: first mismatch at index {i}: gpu {} vs cpu {want} (a={}, b={})",
                    got[i],
                    a[i],
                    b[i]
                );
            }
        }
        // Small dispatch through dispatch() with an explicit grid, and a copy.
        let copy = Buffer::new(&ctx, "copy", n as u64 * 4, MemLoc::GpuToCpu).unwrap();
        rec.begin().unwrap();
        rec.copy(&out, &copy, 16);
        rec.dispatch(&pipe, &[&a_buf, &b_buf, &out], &push, [0, 1, 1]); // skipped
        let t = rec.submit_and_wait().unwrap();
        assert!(t.entries.is_empty());
        let c: Vec<f32> = copy.read().unwrap();
        assert_eq!(
            c[..4],
            [
                a[0] + b[0] * scale,
                a[1] + b[1] * scale,
                a[2] + b[2] * scale,
                a[3] + b[3] * scale
            ]
        );
    }
    finish(ctx);
}

#[test]
fn shader_compile_error_reports_line() {
    let dir = std::env::temp_dir().join(format!("scratchart-shader-test-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("inc")).unwrap();
    std::fs::write(dir.join("inc/ok.glsl"), "float twice(float x) { return 2.0 * x; }\n").unwrap();
    std::fs::write(
        dir.join("bad.comp"),
        "#version 450\n#extension GL_GOOGLE_include_directive : require\n#include \"inc/ok.glsl\"\nlayout(local_size_x = 1) in;\nvoid main() {\n    float x = undefined_thing;\n}\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("good.comp"),
        "#version 450\n#extension GL_GOOGLE_include_directive : require\n#include \"inc/ok.glsl\"\nlayout(local_size_x = 1) in;\nlayout(binding = 0) buffer B { float v[]; };\nvoid main() { v[0] = twice(v[0]); }\n",
    )
    .unwrap();
    let compiler = ShaderCompiler::from_dir(&dir).unwrap();
    assert!(!compiler.compile("good.comp", &[]).unwrap().is_empty());
    match compiler.compile("bad.comp", &[]) {
        Err(GpuError::Shader { path, log }) => {
            assert_eq!(path, "bad.comp");
            assert!(log.contains("bad.comp:6"), "log should name line 6:\n{log}");
            assert!(log.contains("undefined_thing"), "{log}");
        }
        other => panic!("expected a shader error, got {other:?}"),
    }
    // Missing include and missing file are shader errors too.
    std::fs::write(dir.join("noinc.comp"), "#version 450\n#extension GL_GOOGLE_include_directive : require\n#include \"inc/missing.glsl\"\nvoid main() {}\n").unwrap();
    assert!(matches!(
        compiler.compile("noinc.comp", &[]),
        Err(GpuError::Shader { .. })
    ));
    assert!(matches!(
        compiler.compile("nope.comp", &[]),
        Err(GpuError::Shader { .. })
    ));
    // Embedded sources report a missing file the same way.
    let embedded = ShaderCompiler::embedded().unwrap();
    assert!(matches!(
        embedded.compile("does/not/exist.comp", &[]),
        Err(GpuError::Shader { .. })
    ));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn buffer_over_storage_range_is_rejected() {
    let ctx = context();
    let limit = ctx.info().max_storage_buffer_range;
    match Buffer::new(&ctx, "pairs", limit + 1, MemLoc::GpuOnly) {
        Err(e @ GpuError::BufferTooLarge { .. }) => {
            let msg = e.to_string();
            assert!(msg.starts_with("buffer 'pairs' needs "), "{msg}");
            assert!(msg.contains("per storage buffer; reduce the scene"), "{msg}");
        }
        other => panic!("expected BufferTooLarge, got {other:?}"),
    }
    let e = GpuError::BufferTooLarge {
        name: "pairs".into(),
        size: 300 << 20,
        limit: 128 << 20,
    };
    assert_eq!(
        e.to_string(),
        "buffer 'pairs' needs 300.0 MiB but this device binds at most 128.0 MiB per storage buffer; \
         reduce the scene (fewer scratches, views or pixels)"
    );
    finish(ctx);
}

#[test]
fn unknown_device_lists_devices() {
    let r = Context::new(ContextDesc {
        device: Some("no-such-gpu-xyz".into()),
        quiet: true,
        ..Default::default()
    });
    match r {
        Err(e @ GpuError::NoDevice { .. }) => {
            let GpuError::NoDevice { available, .. } = &e else {
                unreachable!()
            };
            assert!(!available.is_empty());
            let msg = e.to_string();
            assert!(msg.contains("no-such-gpu-xyz"), "{msg}");
            assert!(msg.contains(&available[0]), "{msg}");
        }
        Err(e) => panic!("expected NoDevice, got {e}"),
        Ok(_) => panic!("expected NoDevice, got a context"),
    }
    // Index selection works and out-of-range indices are NoDevice too.
    let ctx = Context::new(ContextDesc {
        device: Some("0".into()),
        quiet: true,
        ..Default::default()
    })
    .unwrap();
    drop(ctx);
    assert!(matches!(
        Context::new(ContextDesc {
            device: Some("99".into()),
            quiet: true,
            ..Default::default()
        }),
        Err(GpuError::NoDevice { .. })
    ));
}

#[test]
fn upload_download_round_trip() {
    let ctx = context();
    {
        let data: Vec<u32> = (0..12345u32).map(|i| i.wrapping_mul(2654435761)).collect();
        let buf = ctx.upload("roundtrip", &data).unwrap();
        assert_eq!(buf.size(), data.len() as u64 * 4);
        assert_eq!(buf.name(), "roundtrip");
        let back: Vec<u32> = ctx.download(&buf).unwrap();
        assert_eq!(back, data);

        // Empty uploads allocate a minimal buffer.
        let empty = ctx.upload::<f32>("empty", &[]).unwrap();
        assert_eq!(empty.size(), 16);

        // Host-visible buffers: write/read directly; also download through them.
        let host = Buffer::new(&ctx, "host", 64, MemLoc::CpuToGpu).unwrap();
        host.write(8, &[1.5f32, 2.5]).unwrap();
        let v: Vec<f32> = host.read().unwrap();
        assert_eq!(v[2..4], [1.5, 2.5]);
        let v2: Vec<f32> = ctx.download(&host).unwrap();
        assert_eq!(v, v2);

        // GPU -> GPU copy then download of a GpuOnly buffer.
        let dst = Buffer::new(&ctx, "dst", buf.size(), MemLoc::GpuOnly).unwrap();
        let mut rec = Recorder::new(&ctx).unwrap();
        rec.begin().unwrap();
        rec.copy(&buf, &dst, buf.size());
        rec.submit_and_wait().unwrap();
        assert_eq!(ctx.download::<u32>(&dst).unwrap(), data);
    }
    finish(ctx);
}
