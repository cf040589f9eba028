//! How far the optics' model of a photo depends on the render's resolution: the guide's capture
//! of a tool rendered at 2, 4 and 8 times the photo's resolution, each blurred by the same blur
//! (in photo pixels) and added up into the photo's pixels (`simulate::optics_blur`), with and
//! without each pixel's moments of light (`SCRATCHART_MOMENTS`); rms of each against the 8
//! times render, over the card's pixels, relative to the rms of the light there.
//! `cargo run --release -p scratchart-calibration --example moments_probe -- CARD.json TOOL.json BLUR_PX`
use scratchart_calibration::card::Card;
use scratchart_calibration::simulate::{cut_scene, light_at, moments_on};
use scratchart_render::Renderer;
use scratchart_tool::Tool;
use scratchart_vulkan::{Context, ContextDesc};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (card, capture) = Card::load(std::path::Path::new(&args[0]))?;
    let tool = Tool::load(std::path::Path::new(&args[1]))?;
    let blur_px: f64 = args[2].parse()?;
    let ctx = Context::new(ContextDesc::default())?;
    let renderer = Renderer::new(&ctx)?;
    let scene = cut_scene(&card, &capture, &tool);
    let photo = |k: u32| -> anyhow::Result<Vec<Vec<f64>>> {
        (0..scene.views.len())
            .map(|v| light_at(&renderer, &scene, v, k, blur_px, moments_on()))
            .collect()
    };
    if std::env::var("PROBE_TIME").is_ok() {
        // A render against a render with moments, of the capture at twice its resolution.
        let mut s = scene.clone();
        for v in &mut s.views {
            v.camera.width *= 2;
            v.camera.height *= 2;
        }
        let mut gs = renderer.upload(&s)?;
        for _ in 0..2 {
            renderer.render(&mut gs)?;
            renderer.moments(&mut gs)?;
        }
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for _ in 0..5 {
            let t = std::time::Instant::now();
            renderer.render(&mut gs)?;
            a.push(t.elapsed().as_secs_f64());
            let t = std::time::Instant::now();
            renderer.moments(&mut gs)?;
            b.push(t.elapsed().as_secs_f64());
        }
        a.sort_by(f64::total_cmp);
        b.sort_by(f64::total_cmp);
        println!(
            "render {:.1} ms, with moments {:.1} ms (medians of 5)",
            1e3 * a[2],
            1e3 * b[2]
        );
        return Ok(());
    }
    if std::env::var("PROBE_REF").is_ok() {
        // The engine's moments at 2x against the light of a render at 12x (6 times finer).
        let v = &scene.views[0];
        let (k, f) = (2u32, 6usize);
        let at = |scale: u32, bare: bool| -> anyhow::Result<Vec<f32>> {
            let mut s = scene.clone();
            if bare {
                s.scratches.clear();
            }
            s.views = vec![v.clone()];
            s.views[0].camera.width *= scale;
            s.views[0].camera.height *= scale;
            let mut gs = renderer.upload(&s)?;
            Ok(renderer.render(&mut gs)?.images.remove(0))
        };
        let mut s = scene.clone();
        s.views = vec![v.clone()];
        s.views[0].camera.width *= k;
        s.views[0].camera.height *= k;
        let mut gs = renderer.upload(&s)?;
        let (_, m) = renderer.moments(&mut gs)?;
        let (fine, bare) = (at(k * f as u32, false)?, at(k * f as u32, true)?);
        let (cw, fw) = ((v.camera.width * k) as usize, (v.camera.width * k) as usize * f);
        let mut want = vec![[0f64; 2]; cw * cw];
        for y in 0..fw {
            for x in 0..fw {
                let g = (fine[y * fw + x] - bare[y * fw + x]) as f64 / (f * f) as f64;
                let off = |i: usize| ((i % f) as f64 + 0.5) / f as f64 - 0.5;
                let c = (y / f) * cw + x / f;
                want[c][0] += g * off(x);
                want[c][1] += g * off(y);
            }
        }
        for a in 0..2 {
            let (mut gw, mut ww, mut gg, mut dd) = (0.0, 0.0, 0.0, 0.0);
            for (g, w) in m[0].iter().zip(&want) {
                gw += g[a] as f64 * w[a];
                ww += w[a] * w[a];
                gg += (g[a] as f64).powi(2);
                dd += (g[a] as f64 - w[a]).powi(2);
            }
            println!(
                "axis {a}: corr {:.3}, scale {:.3}, |M - M_fine| / |M_fine| {:.3}",
                gw / (gg * ww).sqrt(),
                gw / ww,
                (dd / ww).sqrt()
            );
        }
        return Ok(());
    }
    let truth = photo(8)?;
    for k in [2, 4] {
        let p = photo(k)?;
        for (v, (a, t)) in p.iter().zip(&truth).enumerate() {
            let mask = scratchart_calibration::fit_cmd::fit_mask(&card, &scene.views[v], 0.5 * card.plate_mm);
            let d: f64 = a
                .iter()
                .zip(t)
                .zip(&mask)
                .filter(|q| *q.1)
                .map(|((x, y), _)| (x - y).powi(2))
                .sum::<f64>();
            let n: f64 = t.iter().zip(&mask).filter(|q| *q.1).map(|(y, _)| y * y).sum::<f64>();
            println!(
                "moments {}, x{k}, view {v}: rms difference / rms light = {:.5}",
                scratchart_calibration::simulate::moments_on(),
                (d / n).sqrt()
            );
        }
    }
    Ok(())
}
