//! CPU time of the forward and of each backward kernel on a CPU Vulkan driver (lavapipe), for
//! comparing kernels on a machine that is busy with other work: the process's own CPU time
//! (user + system, all threads, from /proc/self/stat) does not count time spent waiting for the
//! cores, which GPU timestamps (wall time) do. Run:
//!   cargo run --release -p scratchart --example backward_cpu -- M 3 [--no-dual]
use scratchart::bench::{median, perturbed_target_dl};
use scratchart::render::kernels::{Integrator, KernelSet, Mode};
use scratchart::render::Renderer;
use scratchart::vulkan::{Context, ContextDesc, Recorder};

/// Process CPU time in seconds (utime + stime; 10 ms ticks).
fn cpu_s() -> f64 {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap();
    let rest = &s[s.rfind(')').unwrap() + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    // fields after ')' start at field 3 (state); utime is field 14, stime 15
    let ut: f64 = f[11].parse().unwrap();
    let st: f64 = f[12].parse().unwrap();
    (ut + st) / 100.0
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let size = args.get(1).map(String::as_str).unwrap_or("S");
    let reps: usize = args.get(2).map(|s| s.parse().unwrap()).unwrap_or(3);
    let with_dual = args.get(3).map(String::as_str) != Some("--no-dual");
    let scene = scratchart::scenes::bench_scene(size).expect("size S, M or P");
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
        "{size}: CPU s per pass (median of {reps}): render {f:.2}, backward alone {b:.2}, backward (with render) {r:.2}, backward dual {d:.2}; backward/render {:.2}, dual/backward {:.2}",
        b / f,
        d / r
    );
    Ok(())
}
