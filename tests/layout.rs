//! Every #[repr(C)] twin of a GLSL struct or push-constant block agrees with the GLSL
//! declaration the kernels compile: a test shader includes the same header, reads the struct
//! through it and writes every field back in order, and the words must equal the Rust bytes.
//! - `rust_and_glsl_struct_layouts_agree` (test/layout.comp): ViewGpu, ViewGpu64, ScratchGpu
//!   (inc/common.glsl) and ShadePush (inc/shade_push.glsl).
//! - `push_constant_layouts_agree` (test/layout_push.comp): BinPush (inc/bin_push.glsl),
//!   ScanPush (inc/scan_push.glsl), LossPush and LossSeg (inc/loss_push.glsl) and the viewer's
//!   PresentPush (inc/present_push.glsl), and the optimizer's AdamPush, AdamGroupGpu,
//!   ProjectPush, CheckPush and ToolMapPush (inc/tool_map_push.glsl), and the radix sort's
//!   RadixPush (inc/radix_push.glsl).
use std::sync::Arc;

use scratchart_optim::adam::{AdamGroupGpu, AdamPush};
use scratchart_optim::check::CheckPush;
use scratchart_optim::loss::{LossPush, LossSeg};
use scratchart_optim::scene_params::ProjectPush;
use scratchart_optim::tool_params::ToolMapPush;
use scratchart_render::layout::{BinPush, RadixPush, ReducePush, ScanPush, ScratchGpu, ShadePush, ViewGpu, ViewGpu64};
use scratchart_render::present::PresentPush;
use scratchart_tests::*;
use scratchart_vulkan::{Buffer, ComputePipeline, Context, MemLoc, Recorder, ShaderCompiler};

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
        chunks_per_pass: f() as u32,
        pass: f() as u32,
        n_passes: f() as u32,
        sentinel: f() as u32,
        store_cap: f() as u32,
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

/// Runs test/layout_push.comp with `define` and the push constants `push` (plus, for LOSS, the
/// segments `segs` at binding 1) and checks that it writes back `push` then `segs`, word for word.
/// `records`: the std430 records the shader reads from binding 1 (LossSeg or AdamGroupGPU), as bytes.
fn check_push(ctx: &Arc<Context>, define: &str, push: &[u8], records: &[u8]) {
    let words = |b: &[u8]| -> Vec<u32> { b.chunks(4).map(|c| u32::from_le_bytes(c.try_into().unwrap())).collect() };
    let mut expected = words(push);
    expected.extend(words(records));
    let segs = records;
    let sc = ShaderCompiler::embedded().unwrap();
    let n_buffers = if segs.is_empty() { 1 } else { 2 };
    let p = ComputePipeline::new(
        ctx,
        &sc,
        "test/layout_push.comp",
        &[(define, "1")],
        n_buffers,
        push.len() as u32,
    )
    .unwrap();
    let out = Buffer::new(ctx, "layout out", expected.len() as u64 * 4, MemLoc::GpuToCpu).unwrap();
    let seg_buf = (!segs.is_empty()).then(|| ctx.upload::<u8>("layout records", segs).unwrap());
    let mut bufs = vec![&out];
    bufs.extend(seg_buf.as_ref());
    let mut rec = Recorder::new(ctx).unwrap();
    rec.begin().unwrap();
    rec.dispatch(&p, &bufs, push, [1, 1, 1]);
    rec.submit_and_wait().unwrap();
    let got: Vec<u32> = out.read().unwrap();
    assert_eq!(got.len(), expected.len());
    for (i, (g, e)) in got.iter().zip(&expected).enumerate() {
        assert_eq!(
            g, e,
            "{define}: word {i}: the shader read {g:#x}, Rust wrote {e:#x} (a field is misplaced)"
        );
    }
}

#[test]
fn push_constant_layouts_agree() {
    let ctx = gpu();
    // Distinct bit patterns in every field (f32 fields get small integers as floats).
    let mut next = 100u32;
    let mut u = || {
        next += 1;
        next
    };
    let bin = BinPush {
        n_scratches: u(),
        n_views: u(),
        n_groups: u(),
        group_size: u(),
        capacity: u(),
        sentinel: u(),
        n_bands: u(),
        pad: u(),
    };
    let scan = ScanPush {
        n: u(),
        n_blocks: u(),
        flag_index: u(),
        pad: u(),
    };
    let loss = LossPush {
        n_views: u(),
        n_levels: u(),
        level: u(),
        n_blocks: u(),
        lvl_begin: u(),
        lvl_end: u(),
        lambda_p: u() as f32,
        lambda_g: u() as f32,
        g_c: u() as f32,
        g_s: u() as f32,
        n_segs: u(),
        n_pairs: u(),
    };
    let segs: Vec<LossSeg> = (0..2)
        .map(|_| LossSeg {
            off: u(),
            w: u(),
            h: u(),
            view: u(),
            level: u(),
            blk0: u(),
            nblk: u(),
            weight: u() as f32,
        })
        .collect();
    let present = PresentPush {
        dims: [u(), u(), u(), u()],
        view_rect: [u(), u(), u(), u()],
        tgt_rect: [u(), u(), u(), u()],
        misc: [u(), u(), u(), u()],
        params: [u() as f32, u() as f32, u() as f32, u() as f32],
    };
    assert_eq!(std::mem::size_of::<BinPush>(), 32);
    assert_eq!(std::mem::size_of::<ScanPush>(), 16);
    assert_eq!(std::mem::size_of::<LossPush>(), 48);
    assert_eq!(std::mem::size_of::<LossSeg>(), 32);
    assert_eq!(std::mem::size_of::<PresentPush>(), 80);
    let reduce = ReducePush {
        n_scratches: u(),
        capacity: u(),
        n_parts: u(),
        pad: u(),
    };
    let adam = AdamPush {
        n: u(),
        stride: u(),
        check_objective: u(),
        objective_index: u(),
        capacity: u(),
        beta1: u() as f32,
        beta2: u() as f32,
        eps: u() as f32,
        bc1: u() as f32,
        bc2: u() as f32,
        loss_limit: u() as f32,
        pad0: u(),
    };
    let groups: Vec<AdamGroupGpu> = (0..2)
        .map(|_| AdamGroupGpu {
            lr_lo_hi: [u() as f32, u() as f32, u() as f32, u() as f32],
            mode_frozen: [u(), u(), u(), u()],
        })
        .collect();
    let project = ProjectPush {
        n_scratches: u(),
        half_plate: u() as f32,
        min_len: u() as f32,
        pad0: u(),
    };
    let check = CheckPush {
        n_views: u(),
        n_pixels: u(),
        pad: [u(), u()],
    };
    assert_eq!(std::mem::size_of::<ReducePush>(), 16);
    assert_eq!(std::mem::size_of::<AdamPush>(), 48);
    assert_eq!(std::mem::size_of::<AdamGroupGpu>(), 32);
    assert_eq!(std::mem::size_of::<ProjectPush>(), 16);
    assert_eq!(std::mem::size_of::<CheckPush>(), 16);
    let tool_map = ToolMapPush {
        n_scratches: u(),
        n_table: u(),
        mode: u(),
        seed: u(),
        z_first: u() as f32,
        s_lo: u() as f32,
        inv_ds: u() as f32,
        alpha: u() as f32,
        sigma_z: u() as f32,
        sigma_xy: u() as f32,
        pad0: u(),
        pad1: u(),
    };
    assert_eq!(std::mem::size_of::<ToolMapPush>(), 48);
    let radix = RadixPush {
        n_blocks: u(),
        shift: u(),
        total_index: u(),
        capacity: u(),
        first: u(),
        pad: [u(), u(), u()],
    };
    assert_eq!(std::mem::size_of::<RadixPush>(), 32);
    check_push(&ctx, "BIN", bytemuck::bytes_of(&bin), &[]);
    check_push(&ctx, "SCAN", bytemuck::bytes_of(&scan), &[]);
    check_push(&ctx, "LOSS", bytemuck::bytes_of(&loss), bytemuck::cast_slice(&segs));
    check_push(&ctx, "PRESENT", bytemuck::bytes_of(&present), &[]);
    check_push(&ctx, "REDUCE", bytemuck::bytes_of(&reduce), &[]);
    check_push(&ctx, "ADAM", bytemuck::bytes_of(&adam), bytemuck::cast_slice(&groups));
    check_push(&ctx, "PROJECT", bytemuck::bytes_of(&project), &[]);
    check_push(&ctx, "CHECK", bytemuck::bytes_of(&check), &[]);
    check_push(&ctx, "TOOLMAP", bytemuck::bytes_of(&tool_map), &[]);
    check_push(&ctx, "RADIX", bytemuck::bytes_of(&radix), &[]);
    assert_no_validation(&ctx);
}
