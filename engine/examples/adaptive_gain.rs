//! What the integrator `adaptive` (the closed form on the pairs that matter, pairs bounded below
//! 5e-4 of their pixel left out) gains over the closed form on whole scenes: both forward kernels
//! in one process, renders alternated, GPU time of the forward (Vulkan timestamps) per repeat;
//! prints the median of each, the median of the per-repeat ratios, the share of pairs left out
//! and the largest change of a pixel against the closed form, relative to the pixel (the bound
//! says at most 5e-4). Run:
//!   cargo run --release -p scratchart --example adaptive_gain -- [SCENE ...] [--repeats N]
//! SCENE: a bench size (S, M, P) or a scene file (a design's `design.json`); default S M.
use scratchart::bench::median;
use scratchart_render::kernels::{Integrator, KernelSet};
use scratchart_render::Renderer;
use scratchart_vulkan::{Context, ContextDesc};

fn main() -> anyhow::Result<()> {
    let (names, reps) = scratchart::bench::example_args(7)?;
    let ctx = Context::new(ContextDesc::default())?;
    println!("device: {}", ctx.info().name);
    let cf = Renderer::with_kernels(&ctx, KernelSet::with_integrator(Integrator::ClosedForm))?;
    let ad = Renderer::with_kernels(&ctx, KernelSet::with_integrator(Integrator::Adaptive))?;
    println!(
        "| scene | pairs | left out | closed form ms | adaptive ms | closed form / adaptive | largest change / pixel |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|");
    for name in &names {
        let scene = scratchart::bench::scene_named(name)?;
        let mut gc = cf.upload(&scene)?;
        let mut ga = ad.upload(&scene)?;
        let fc = cf.render(&mut gc)?;
        let fa = ad.render(&mut ga)?;
        let mut worst = 0.0f64;
        for (ic, ia) in fc.images.iter().zip(&fa.images) {
            let m = ic.iter().fold(0.0f32, |a, &b| a.max(b)) as f64;
            for (&c, &a) in ic.iter().zip(ia) {
                let d = (c as f64 - a as f64).abs() / (c as f64).max(1e-3 * m).max(f64::MIN_POSITIVE);
                worst = worst.max(d);
            }
        }
        let (mut tc, mut ta, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..reps {
            let c = cf.render(&mut gc)?.timings.get("forward").unwrap_or(f64::NAN);
            let a = ad.render(&mut ga)?.timings.get("forward").unwrap_or(f64::NAN);
            tc.push(c);
            ta.push(a);
            ratio.push(c / a);
        }
        let total = fa.stats.pairs + fa.stats.culled;
        println!(
            "| {name} | {total} | {:.2}% | {:.1} | {:.1} | {:.3} | {:.1e} |",
            100.0 * fa.stats.culled as f64 / total.max(1) as f64,
            median(tc),
            median(ta),
            median(ratio),
            worst
        );
    }
    Ok(())
}
