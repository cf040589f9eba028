//! Two versions of the shading kernels side by side in one process: the built-in sources (A)
//! and the sources in a directory (B, e.g. an older revision: `git archive REV shaders | tar -x
//! -C /tmp/old`), timed alternately on the same scene, pass after pass, so that a machine whose
//! speed drifts (a shared VM) slows both alike. Prints per pass the median of the per-repeat
//! ratios B/A of wall time and of process CPU time, and whether the images and gradients of the
//! two versions are bit-identical. Run:
//!   cargo run --release -p scratchart --example ab_kernels -- DIR [SIZE [REPEATS]]
//! (DIR holds a `shaders` tree or is one; SIZE as `bench --sizes`, default M).
use scratchart::bench::{median, perturbed_target_dl};
use scratchart_render::Renderer;
use scratchart_vulkan::{Context, ContextDesc, Recorder, ShaderCompiler};
use std::path::PathBuf;
use std::time::Instant;

#[path = "common/cpu.rs"]
mod cpu;
use cpu::cpu_s;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let Some(dir) = args.get(1).map(PathBuf::from) else {
        anyhow::bail!("usage: ab_kernels DIR [SIZE [REPEATS]] (DIR: the B version's shaders)");
    };
    let dir = if dir.join("shaders").is_dir() {
        dir.join("shaders")
    } else {
        dir
    };
    let size = args.get(2).map(String::as_str).unwrap_or("M");
    let reps: usize = args.get(3).map(|s| s.parse()).transpose()?.unwrap_or(5);
    let scene = scratchart::bench::bench_scene(size).ok_or_else(|| anyhow::anyhow!("unknown size {size}"))?;
    let ctx = Context::new(ContextDesc::default())?;
    let a = Renderer::new(&ctx)?;
    a.prepare_backward()?;
    ShaderCompiler::override_embedded(Some(dir.clone()));
    let b = Renderer::new(&ctx)?;
    b.prepare_backward()?;
    ShaderCompiler::override_embedded(None);

    let mut ga = a.upload(&scene)?;
    let mut gb = b.upload(&scene)?;
    let first = a.render(&mut ga)?;
    let dl = perturbed_target_dl(&first.images);
    let (ia, da) = a.gradients(&mut ga, &dl)?;
    let (ib, db) = b.gradients(&mut gb, &dl)?;
    let same_img = ia == ib;
    let same_grad = da.scratches == db.scratches && da.lights == db.lights;
    println!(
        "{size}: A built-in, B {}: images {}, gradients {}",
        dir.display(),
        if same_img { "bit-identical" } else { "DIFFER" },
        if same_grad { "bit-identical" } else { "DIFFER" }
    );
    if !same_grad {
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for (x, y) in da.scratches.iter().zip(&db.scratches) {
            for k in 0..7 {
                num += (x[k] as f64 - y[k] as f64).powi(2);
                den += (x[k] as f64).powi(2);
            }
        }
        println!(
            "  gradient difference |gA - gB| / |gA| = {:.3e}",
            (num / den.max(1e-300)).sqrt()
        );
    }

    let mut rec = Recorder::new(&ctx)?;
    // per pass (forward, backward): ratios B/A of wall and CPU time, and A's own times
    let mut ratio = [[Vec::new(), Vec::new()], [Vec::new(), Vec::new()]];
    let mut own = [[Vec::new(), Vec::new()], [Vec::new(), Vec::new()]];
    for rep in 0..reps + 1 {
        let mut t = [[[0.0f64; 2]; 2]; 2]; // [version][pass][wall, cpu]
        for (v, (r, gs)) in [(&a, &mut ga), (&b, &mut gb)].into_iter().enumerate() {
            let (w0, c0) = (Instant::now(), cpu_s());
            r.submit(&mut rec, gs, |rec, gs| r.record_render(rec, gs))?;
            t[v][0] = [w0.elapsed().as_secs_f64(), cpu_s() - c0];
            let (w0, c0) = (Instant::now(), cpu_s());
            rec.begin()?;
            r.record_backward(&mut rec, gs);
            rec.submit_and_wait()?;
            t[v][1] = [w0.elapsed().as_secs_f64(), cpu_s() - c0];
        }
        if rep == 0 {
            continue; // warm-up
        }
        for p in 0..2 {
            for m in 0..2 {
                ratio[p][m].push(t[1][p][m] / t[0][p][m]);
                own[p][m].push(t[0][p][m]);
            }
        }
    }
    for (p, name) in ["forward", "backward"].iter().enumerate() {
        println!(
            "  {name:8}: B/A wall {:.3}, CPU {:.3} (median of {reps}; A: {:.1} ms wall, {:.2} s CPU)",
            median(ratio[p][0].clone()),
            median(ratio[p][1].clone()),
            1e3 * median(own[p][0].clone()),
            median(own[p][1].clone())
        );
    }
    Ok(())
}
