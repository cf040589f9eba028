//! CPU time of the forward and of each backward kernel on a CPU Vulkan driver (lavapipe), for
//! comparing kernels on a machine that is busy with other work: the process's own CPU time
//! (user + system, all threads, from getrusage) does not count time spent waiting for the
//! cores, which GPU timestamps (wall time) do. Run:
//!   cargo run --release -p scratchart --example backward_cpu -- M 3 [--no-dual]
use scratchart::bench::{median, perturbed_target_dl};
use scratchart_render::kernels::{Integrator, KernelSet, Mode};
use scratchart_render::Renderer;
use scratchart_vulkan::{Context, ContextDesc, Recorder};

#[path = "common/cpu.rs"]
mod cpu;
use cpu::cpu_s;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let size = args.get(1).map(String::as_str).unwrap_or("S");
    let reps: usize = args.get(2).map(|s| s.parse().unwrap()).unwrap_or(3);
    let with_dual = args.get(3).map(String::as_str) != Some("--no-dual");
    let scene = scratchart::bench::bench_scene(size).expect("size S, M, P, L or NxVxR");
    let ctx = Context::new(ContextDesc::default())?;
    let reverse = Renderer::new(&ctx)?;
    reverse.prepare_backward()?;
    let dual = Renderer::with_kernels(&ctx, KernelSet::with_modes(Integrator::ClosedForm, Mode::BackwardDual))?;
    dual.prepare_backward()?;
    let mut gs = reverse.upload(&scene)?;
    let first = reverse.render(&mut gs)?;
    reverse.upload_dl(&mut gs, &perturbed_target_dl(&first.images))?;
    let mut rec = Recorder::new(&ctx)?;
    let (mut f, mut r, mut d, mut b) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for i in 0..reps + 1 {
        let t = cpu_s();
        reverse.submit(&mut rec, &mut gs, |rec, gs| reverse.record_render(rec, gs))?;
        let t_f = cpu_s() - t;
        let t = cpu_s();
        reverse.submit(&mut rec, &mut gs, |rec, gs| {
            reverse.record_render(rec, gs);
            reverse.record_backward(rec, gs);
        })?;
        let t_r = cpu_s() - t;
        let t = cpu_s();
        if with_dual {
            reverse.submit(&mut rec, &mut gs, |rec, gs| {
                reverse.record_render(rec, gs);
                dual.record_backward(rec, gs);
            })?;
        }
        let t_d = cpu_s() - t;
        let t = cpu_s();
        rec.begin()?;
        reverse.record_backward(&mut rec, &gs);
        rec.submit_and_wait()?;
        let t_b = cpu_s() - t;
        if i > 0 {
            f.push(t_f);
            r.push(t_r - t_f);
            d.push(t_d - t_f);
            b.push(t_b);
        }
    }
    let (f, r, d, b) = (median(f), median(r), median(d), median(b));
    println!(
        "{size}: CPU s per pass (median of {reps}): render {f:.3}, backward alone {b:.3}, backward (with render) {r:.3}, backward dual {d:.3}; backward/render {:.3}, dual/backward {:.3}",
        b / f,
        d / r
    );
    Ok(())
}
