//! How far a design with arcs, judged at its own chords per arc (`design --arcs`, summary.json's
//! `arcs.chords_per_arc`), is from the same arcs laid out finer: renders every view of DESIGN.json
//! with each arc as N chords for each N given and prints, per view, the correlation of each
//! render with the finest one and its relative L2 difference. Run:
//!   cargo run --release -p scratchart --example arc_chords -- out/design.json 8 32 128
use scratchart_model::scene::Scene;
use scratchart_render::Renderer;
use scratchart_vulkan::{Context, ContextDesc};

fn corr(a: &[f32], b: &[f32]) -> (f64, f64) {
    let n = a.len() as f64;
    let (ma, mb) = (
        a.iter().map(|&x| x as f64).sum::<f64>() / n,
        b.iter().map(|&x| x as f64).sum::<f64>() / n,
    );
    let (mut sab, mut saa, mut sbb, mut d2) = (0.0, 0.0, 0.0, 0.0);
    for (&x, &y) in a.iter().zip(b) {
        let (x, y) = (x as f64, y as f64);
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
        d2 += (x - y) * (x - y);
    }
    let nb: f64 = b.iter().map(|&y| (y as f64) * (y as f64)).sum();
    (sab / (saa * sbb).sqrt().max(1e-300), (d2 / nb.max(1e-300)).sqrt())
}

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .ok_or_else(|| anyhow::anyhow!("usage: arc_chords DESIGN.json N [N ...]"))?;
    let counts: Vec<u32> = args.map(|a| a.parse()).collect::<Result<_, _>>()?;
    anyhow::ensure!(!counts.is_empty(), "give the chords per arc to compare, e.g. 8 32 128");
    let scene = Scene::load(std::path::Path::new(&path))?;
    let ctx = Context::new(ContextDesc::default())?;
    let r = Renderer::new(&ctx)?;
    let mut renders = Vec::new();
    for &n in &counts {
        r.set_arc_chords(Some(n));
        let mut gs = r.upload(&scene)?;
        renders.push(r.render(&mut gs)?.images);
    }
    let finest = renders.last().expect("at least one count");
    for (n, imgs) in counts.iter().zip(&renders) {
        let per_view: Vec<String> = imgs
            .iter()
            .zip(finest)
            .map(|(a, b)| {
                let (c, d) = corr(a, b);
                format!("{c:.4}/{d:.3}")
            })
            .collect();
        println!(
            "{n:>5} chords per arc: correlation / relative L2 against {} chords, per view: {}",
            counts.last().unwrap(),
            per_view.join(" ")
        );
    }
    Ok(())
}
