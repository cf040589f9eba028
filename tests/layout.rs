//! The #[repr(C)] twins in engine/src/render/layout.rs agree with the GLSL declarations in
//! shaders/inc/common.glsl and the kernels' push-constant blocks: a shader reads them through
//! its own declarations and writes every field back in order.
use scratchart::render::layout::{ScratchGpu, ShadePush, ViewGpu, ViewGpu64};
use scratchart::vulkan::{Buffer, ComputePipeline, MemLoc, Recorder, ShaderCompiler};
use scratchart_tests::*;

#[test]
fn rust_and_glsl_struct_layouts_agree() {
    let ctx = gpu();
    // Distinct bit patterns in every field (f32 fields get small integers as floats).
    let mut next = 1u32;
    let mut f = || {
        next += 1;
        next as f32
    };
    let mut views = Vec::new();
    for _ in 0..2 {
        views.push(ViewGpu {
            eye: [f(), f(), f(), f()],
            fwd: [f(), f(), f(), f()],
            right: [f(), f(), f(), f()],
            up: [f(), f(), f(), f()],
            light: [f(), f(), f(), f()],
            dims: [f() as u32, f() as u32, f() as u32, f() as u32],
            base: [f() as u32, f() as u32, f() as u32, f() as u32],
        });
    }
    let scr: Vec<ScratchGpu> = (0..2)
        .map(|_| ScratchGpu {
            ends: [f(), f(), f(), f()],
            shape: [f(), f(), f(), f()],
        })
        .collect();
    let mut g = 0.0f64;
    let mut d = || {
        g += 1.0;
        g + 1.0 / 3.0
    };
    let views64: Vec<ViewGpu64> = (0..2)
        .map(|_| ViewGpu64 {
            eye: [d(), d(), d(), d()],
            fwd: [d(), d(), d(), d()],
            right: [d(), d(), d(), d()],
            up: [d(), d(), d(), d()],
        })
        .collect();
    let push = ShadePush {
        half_plate: f(),
        alpha_s: f(),
        f0: f(),
        n_views: f() as u32,
        n_groups: f() as u32,
        n_tiles: f() as u32,
        capacity: f() as u32,
        pad0: f() as u32,
    };
    // Expected words: the Rust structs' own bytes, in field order.
    let mut expected: Vec<u32> = Vec::new();
    for v in &views {
        expected.extend_from_slice(bytemuck::cast_slice(bytemuck::bytes_of(v)));
    }
    for s in &scr {
        expected.extend_from_slice(bytemuck::cast_slice(bytemuck::bytes_of(s)));
    }
    for v in &views64 {
        expected.extend_from_slice(bytemuck::cast_slice(bytemuck::bytes_of(v)));
    }
    expected.extend_from_slice(bytemuck::cast_slice(bytemuck::bytes_of(&push)));
    assert_eq!(std::mem::size_of::<ViewGpu64>(), 128);
    assert_eq!(std::mem::size_of::<ViewGpu>(), 112);
    assert_eq!(std::mem::size_of::<ScratchGpu>(), 32);

    assert!(
        ctx.info().float64,
        "the layout test needs shaderFloat64 (lavapipe has it)"
    );
    let sc = ShaderCompiler::embedded().unwrap();
    let p = ComputePipeline::new(
        &ctx,
        &sc,
        "test/layout.comp",
        &[],
        4,
        std::mem::size_of::<ShadePush>() as u32,
    )
    .unwrap();
    let vb = ctx.upload("layout views", &views).unwrap();
    let sb = ctx.upload("layout scratches", &scr).unwrap();
    let vb64 = ctx.upload("layout views64", &views64).unwrap();
    let out = Buffer::new(&ctx, "layout out", expected.len() as u64 * 4, MemLoc::GpuToCpu).unwrap();
    let mut rec = Recorder::new(&ctx).unwrap();
    rec.begin().unwrap();
    rec.dispatch(&p, &[&vb, &sb, &out, &vb64], bytemuck::bytes_of(&push), [1, 1, 1]);
    rec.submit_and_wait().unwrap();
    let got: Vec<u32> = out.read().unwrap();
    for (i, (g, e)) in got.iter().zip(&expected).enumerate() {
        assert_eq!(
            g, e,
            "word {i}: the shader read {g:#x}, Rust wrote {e:#x} (a field is misplaced)"
        );
    }
    assert_no_validation(&ctx);
}
