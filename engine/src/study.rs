//! `scratchart study`: speed against accuracy of the per-pair integral.
//!
//! Every method of [`Integrator::STUDY`] renders the same small scenes, one per regime (sharp and
//! wide lobes, grazing views, footprints much smaller and much larger than a scratch, the half
//! vector nearly along the scratches, many scratches per footprint), with the engine's forward
//! kernel; each render is compared pixel by pixel with the float64 reference of engine/docs/model.md.
//!
//! Error of a pixel: `|L - L_ref| / max(L_ref, 1e-3 M)`, M the reference view's largest L. So a
//! pixel meets engine/docs/model.md section 8's forward bar (within 1e-3 relative, or within 1e-6 M, whichever
//! is looser) exactly when its error is at most 1e-3, and a method meets the bar on a regime when
//! the 99th percentile over the on-plate pixels is. Off-plate pixels are not counted (every
//! method writes exactly 0 there).
//!
//! Time: the forward kernel's GPU time (Vulkan timestamps, median of the repeats after a
//! warm-up render) divided by the overlapping (pixel, scratch) pairs, on the same regime drawn at
//! a higher resolution (`time_res`; scratch widths and lengths scale with the footprint, so the
//! pairs per pixel stay alike), large enough that timer noise does not decide. It includes the tile loop
//! that every method shares (on a CPU driver about two thirds of the forward; see
//! engine/BENCHMARKS.md), so the differences between methods are their own.
use std::path::Path;
use std::sync::Arc;

use anyhow::{Context as _, Result};
use plotters::prelude::*;

use crate::bench::median;
use scratchart_design::scenes::{orbit_camera, orbit_light, Rng};
use scratchart_model::reference::render_view;
use scratchart_model::scene::{Plate, Scene, Scratch, View};
use scratchart_render::kernels::{Integrator, KernelSet};
use scratchart_render::Renderer;
use scratchart_vulkan::Context;

/// engine/docs/model.md section 8's forward bar on this study's error measure.
pub const BAR: f64 = 1e-3;

/// One regime: a scene of one view and what it stresses.
pub struct Regime {
    pub name: &'static str,
    pub what: &'static str,
    pub scene: Scene,
}

/// One method on one regime.
#[derive(Clone, Debug)]
pub struct Row {
    pub method: String,
    pub regime: String,
    pub err_max: f64,
    pub err_p99: f64,
    pub err_median: f64,
    pub ns_per_pair: f64,
    pub pairs: u64,
    /// Of `pairs`, those the method left out by their error bound (`adaptive` only).
    pub culled: u64,
    pub pixels: usize,
    /// No NaN or infinity in the render.
    pub finite: bool,
}

impl Row {
    pub fn meets_bar(&self) -> bool {
        self.finite && self.err_p99 <= BAR
    }
}

#[allow(clippy::too_many_arguments)] // a regime's camera and lamp, named at every call
fn view(
    name: &str,
    res: u32,
    plate: f64,
    elev: f64,
    az: f64,
    light_elev: f64,
    light_az: f64,
    fov: Option<f64>,
) -> View {
    let mut camera = orbit_camera(3.0 * plate, elev, az, plate, res, res);
    if let Some(f) = fov {
        camera.fov_y_deg = f;
    }
    View {
        exposure: 1.0,
        name: name.into(),
        camera,
        light: orbit_light(3.0 * plate, light_elev, light_az, 1.0e4),
    }
}

/// `n` scratches in the square of side `patch` about the plate centre, directions within
/// `spread` radians of `dir` (radians), lengths in [lo, hi].
#[allow(clippy::too_many_arguments)]
fn scratches(
    rng: &mut Rng,
    n: usize,
    patch: f64,
    dir: f64,
    spread: f64,
    lo: f64,
    hi: f64,
    w: f64,
    d: f64,
    alpha: [f64; 2],
) -> Vec<Scratch> {
    let h = 0.5 * patch;
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let p0 = [rng.range(-h, h), rng.range(-h, h)];
        let a = dir + rng.range(-spread, spread);
        let l = rng.range(lo, hi);
        let p1 = [p0[0] + l * a.cos(), p0[1] + l * a.sin()];
        if p1[0].abs() <= h && p1[1].abs() <= h {
            // alpha log-uniform in the range
            let al = (alpha[0].ln() + rng.f64() * (alpha[1].ln() - alpha[0].ln())).exp();
            out.push(Scratch {
                p0,
                p1,
                w,
                d,
                alpha: al,
                bulge: 0.0,
            });
        }
    }
    out
}

/// The study's regimes; `res` is the view resolution (the footprint is about 1.5 plate / res),
/// `more` multiplies the scratch counts (the timed renders use more pairs than the checked ones).
pub fn regimes(res: u32, more: usize) -> Vec<Regime> {
    let mut r = light_regimes(res, more);
    r.extend(geometry_regimes(res, more));
    r
}

/// The plate of every regime, 20 mm.
const REGIME_PLATE_MM: f64 = 20.0;

/// A regime: one view of `REGIME_PLATE_MM`'s plate and the scratches `sc` draws (seeded).
fn regime(name: &'static str, what: &'static str, seed: u64, v: View, sc: &dyn Fn(&mut Rng) -> Vec<Scratch>) -> Regime {
    let mut rng = Rng::new(seed);
    Regime {
        name,
        what,
        scene: Scene {
            plate: Plate {
                size_mm: REGIME_PLATE_MM,
                roughness: 0.02,
                f0: 0.91,
                shape: Default::default(),
            },
            views: vec![v],
            scratches: sc(&mut rng),
        },
    }
}

/// The regimes of roughness and light: moderate, sharp, wide, grazing.
fn light_regimes(res: u32, more: usize) -> Vec<Regime> {
    let plate = REGIME_PLATE_MM;
    let fp = 1.5 * plate / res as f64; // rough footprint size, mm
    let any = std::f64::consts::PI;
    vec![
        regime(
            "moderate",
            "alpha 0.03 to 0.3, eye and lamp 45 degrees up",
            11,
            view("v", res, plate, 45.0, 0.0, 45.0, 180.0, None),
            &|r| {
                scratches(
                    r,
                    300 * more,
                    plate,
                    0.0,
                    any,
                    1.0,
                    6.0,
                    0.4 * fp,
                    0.3 * fp,
                    [0.03, 0.3],
                )
            },
        ),
        regime(
            "sharp",
            "alpha 1e-3 to 3e-3",
            12,
            view("v", res, plate, 45.0, 0.0, 50.0, 170.0, None),
            &|r| {
                scratches(
                    r,
                    300 * more,
                    plate,
                    0.0,
                    any,
                    1.0,
                    6.0,
                    0.4 * fp,
                    0.3 * fp,
                    [1e-3, 3e-3],
                )
            },
        ),
        regime(
            "wide",
            "alpha 0.2 to 0.3",
            13,
            view("v", res, plate, 45.0, 0.0, 45.0, 120.0, None),
            &|r| scratches(r, 300 * more, plate, 0.0, any, 1.0, 6.0, 0.4 * fp, 0.3 * fp, [0.2, 0.3]),
        ),
        regime(
            "grazing",
            "eye and lamp 5 degrees above the plate",
            14,
            view("v", res, plate, 5.0, 0.0, 5.0, 180.0, Some(4.0)),
            &|r| {
                scratches(
                    r,
                    300 * more,
                    plate,
                    0.0,
                    any,
                    1.0,
                    6.0,
                    0.4 * fp,
                    0.3 * fp,
                    [0.01, 0.1],
                )
            },
        ),
    ]
}

/// The regimes of geometry: the footprint small and large against a scratch, the half vector
/// along the scratches, and dense scratches.
fn geometry_regimes(res: u32, more: usize) -> Vec<Regime> {
    let plate = REGIME_PLATE_MM;
    let fp = 1.5 * plate / res as f64; // rough footprint size, mm
    let any = std::f64::consts::PI;
    vec![
        regime(
            "small-footprint",
            "footprint about 1/8 of the scratch width",
            15,
            view("v", res, plate, 45.0, 0.0, 45.0, 180.0, None),
            &|r| {
                scratches(
                    r,
                    120 * more,
                    plate,
                    0.0,
                    any,
                    2.0,
                    8.0,
                    8.0 * fp,
                    6.0 * fp,
                    [0.01, 0.1],
                )
            },
        ),
        regime(
            "large-footprint",
            "footprint about 25 times the scratch width",
            16,
            view("v", res, plate, 45.0, 0.0, 45.0, 180.0, None),
            &|r| {
                scratches(
                    r,
                    600 * more,
                    plate,
                    0.0,
                    any,
                    1.0,
                    6.0,
                    fp / 25.0,
                    fp / 30.0,
                    [0.01, 0.1],
                )
            },
        ),
        regime(
            "along-axis",
            "half vector within 10 degrees of the scratch axis",
            17,
            view("v", res, plate, 12.0, 0.0, 12.0, 8.0, Some(12.0)),
            &|r| {
                scratches(
                    r,
                    300 * more,
                    plate,
                    0.0,
                    0.08,
                    1.0,
                    6.0,
                    0.4 * fp,
                    0.3 * fp,
                    [0.01, 0.1],
                )
            },
        ),
        regime(
            "dense",
            "about 30 scratches per footprint",
            18,
            view("v", res, plate, 45.0, 0.0, 45.0, 180.0, None),
            &|r| {
                scratches(
                    r,
                    6000 * more,
                    0.3 * plate,
                    0.0,
                    any,
                    0.3,
                    2.0,
                    0.1 * fp,
                    0.08 * fp,
                    [0.02, 0.2],
                )
            },
        ),
    ]
}

/// Errors of `img` against `reference` on the on-plate pixels: (max, p99, median, pixels, finite).
pub fn errors(img: &[f32], reference: &[f64], on_plate: &[bool]) -> (f64, f64, f64, usize, bool) {
    let m = reference.iter().cloned().fold(0.0f64, f64::max);
    let floor = 1e-3 * m;
    let finite = img.iter().all(|x| x.is_finite());
    let mut e: Vec<f64> = img
        .iter()
        .zip(reference)
        .zip(on_plate)
        .filter(|(_, &on)| on)
        .map(|((&l, &r), _)| {
            let d = (l as f64 - r).abs();
            if d.is_finite() {
                d / r.max(floor).max(f64::MIN_POSITIVE)
            } else {
                f64::INFINITY
            }
        })
        .collect();
    if e.is_empty() {
        return (0.0, 0.0, 0.0, 0, finite);
    }
    e.sort_by(|a, b| a.total_cmp(b));
    let q = |p: f64| e[((p * (e.len() - 1) as f64).round() as usize).min(e.len() - 1)];
    (*e.last().unwrap(), q(0.99), q(0.5), e.len(), finite)
}

/// Options of one study run.
pub struct StudyOptions {
    /// Resolution of the accuracy renders (and their float64 reference).
    pub res: u32,
    /// Resolution of the timed renders.
    pub time_res: u32,
    pub repeats: usize,
    pub methods: Vec<Integrator>,
    pub regimes: Option<Vec<String>>,
}

/// Runs the study: one row per (method, regime). `progress` gets a line per step.
pub fn run(ctx: &Arc<Context>, opt: &StudyOptions, progress: &mut dyn FnMut(&str)) -> Result<Vec<Row>> {
    let mut rows = Vec::new();
    let mut renderers = Vec::new();
    for &m in &opt.methods {
        anyhow::ensure!(m.is_valid(), "method {m:?} cannot be built");
        progress(&format!("building the forward kernel of {}", m.name()));
        renderers.push((m, Renderer::with_kernels(ctx, KernelSet::with_integrator(m))?));
    }
    for (reg, timed) in regimes(opt.res, 1).into_iter().zip(regimes(opt.time_res, 16)) {
        if let Some(only) = &opt.regimes {
            if !only.iter().any(|r| r == reg.name) {
                continue;
            }
        }
        progress(&format!("{}: float64 reference ({})", reg.name, reg.what));
        let reference = render_view(&reg.scene, 0);
        let on_plate = scratchart_model::camera::on_plate_mask(&reg.scene, 0);
        // Every method renders the checked scene once and the timed one after a warm-up; then
        // the timed renders go round the methods, repeat after repeat, so that a machine whose
        // speed drifts slows every method alike.
        let mut runs = Vec::new();
        for (m, r) in &renderers {
            let mut gs = r.upload(&reg.scene)?;
            let first = r.render(&mut gs)?;
            let mut gt = r.upload(&timed.scene)?;
            let warm = r.render(&mut gt)?;
            runs.push((*m, r, first, gt, warm, Vec::new()));
        }
        for _ in 0..opt.repeats.max(1) {
            for (_, r, _, gt, _, ms) in runs.iter_mut() {
                let f = r.render(gt)?;
                ms.push(f.timings.get("forward").unwrap_or(f64::NAN));
            }
        }
        for (m, _, first, _, warm, ms) in runs {
            let (err_max, err_p99, err_median, pixels, finite) = errors(&first.images[0], &reference, &on_plate);
            // Every overlapping pair of the scene, integrated or left out by a bound.
            let pairs = (warm.stats.pairs + warm.stats.culled).max(1);
            let row = Row {
                method: m.name(),
                regime: reg.name.to_string(),
                err_max,
                err_p99,
                err_median,
                ns_per_pair: median(ms) * 1e6 / pairs as f64,
                pairs: warm.stats.pairs + warm.stats.culled,
                culled: warm.stats.culled,
                pixels,
                finite,
            };
            progress(&format!(
                "{:>16} {:>18}: err p99 {:.2e} max {:.2e}, {:.0} ns/pair{}{}",
                row.regime,
                row.method,
                row.err_p99,
                row.err_max,
                row.ns_per_pair,
                if row.culled > 0 {
                    format!(
                        " ({:.1}% of the pairs left out)",
                        100.0 * row.culled as f64 / row.pairs.max(1) as f64
                    )
                } else {
                    String::new()
                },
                if row.meets_bar() { "" } else { "  (misses the bar)" }
            ));
            rows.push(row);
        }
    }
    Ok(rows)
}

/// `study.csv`: one row per method and regime.
pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from("method,regime,err_max,err_p99,err_median,ns_per_pair,pairs,culled,pixels,meets_bar\n");
    for r in rows {
        s += &format!(
            "{},{},{:.6e},{:.6e},{:.6e},{:.1},{},{},{},{}\n",
            r.method,
            r.regime,
            r.err_max,
            r.err_p99,
            r.err_median,
            r.ns_per_pair,
            r.pairs,
            r.culled,
            r.pixels,
            r.meets_bar()
        );
    }
    s
}

/// The verdict: per regime the cheapest method meeting the bar, and the methods that miss it.
pub fn verdict(rows: &[Row]) -> String {
    let mut regimes: Vec<&str> = Vec::new();
    for r in rows {
        if !regimes.contains(&r.regime.as_str()) {
            regimes.push(&r.regime);
        }
    }
    let mut s = format!(
        "Speed against accuracy of the per-pair integral. Bar: engine/docs/model.md section 8 (99% of on-plate pixels within\n\
         1e-3 relative or 1e-6 of the view's maximum): the 99th-percentile error here at most {BAR:.0e}.\n\n"
    );
    for reg in &regimes {
        let mut ok: Vec<&Row> = rows.iter().filter(|r| r.regime == *reg && r.meets_bar()).collect();
        ok.sort_by(|a, b| a.ns_per_pair.total_cmp(&b.ns_per_pair));
        let miss: Vec<String> = rows
            .iter()
            .filter(|r| r.regime == *reg && !r.meets_bar())
            .map(|r| {
                if r.finite {
                    format!("{} ({:.1e})", r.method, r.err_p99)
                } else {
                    format!("{} (NaN or infinity)", r.method)
                }
            })
            .collect();
        match ok.first() {
            Some(best) => {
                s += &format!(
                    "{reg}: cheapest within the bar: {} ({:.0} ns/pair, p99 {:.1e})",
                    best.method, best.ns_per_pair, best.err_p99
                )
            }
            None => s += &format!("{reg}: no method within the bar"),
        }
        if let Some(cf) = rows.iter().find(|r| r.regime == *reg && r.method == "closed-form") {
            s += &format!("; closed form {:.0} ns/pair, p99 {:.1e}", cf.ns_per_pair, cf.err_p99);
        }
        s += ".\n";
        if !miss.is_empty() {
            s += &format!("  misses the bar: {}\n", miss.join(", "));
        }
    }
    // The adaptive choice (closed form, pairs bounded below 5e-4 of their pixel left out)
    // against the closed form it refines, regime by regime.
    let pairs_of = |m: &str| -> Vec<(&Row, &Row)> {
        rows.iter()
            .filter(|a| a.method == m)
            .filter_map(|a| {
                rows.iter()
                    .find(|c| c.method == "closed-form" && c.regime == a.regime)
                    .map(|c| (a, c))
            })
            .collect()
    };
    let ad = pairs_of("adaptive");
    if !ad.is_empty() {
        let share = |r: &Row| 100.0 * r.culled as f64 / r.pairs.max(1) as f64;
        let ratio = |(a, c): &(&Row, &Row)| a.ns_per_pair / c.ns_per_pair;
        let lo_s = ad.iter().map(|(a, _)| share(a)).fold(f64::INFINITY, f64::min);
        let hi_s = ad.iter().map(|(a, _)| share(a)).fold(0.0, f64::max);
        let lo_r = ad.iter().map(ratio).fold(f64::INFINITY, f64::min);
        let hi_r = ad.iter().map(ratio).fold(0.0, f64::max);
        let faster = ad.iter().filter(|p| ratio(p) < 1.0 && p.0.meets_bar()).count();
        s += &format!(
            "\nadaptive (the closed form; a pair whose bound is below 5e-4 of its pixel's value so far is left out):\n  \
             leaves out {lo_s:.1}% to {hi_s:.1}% of the pairs, takes {lo_r:.2} to {hi_r:.2} times the closed form's \
             time per pair, and is faster within the bar on {faster} of {} regimes.\n",
            ad.len()
        );
    }
    let all_cf = rows.iter().filter(|r| r.method == "closed-form").all(|r| r.meets_bar());
    s += &format!(
        "\nThe closed form {} the bar on every regime{}.\n",
        if all_cf { "meets" } else { "does not meet" },
        if all_cf { ", and is the engine's default" } else { "" }
    );
    s
}

/// Error against time, one panel per regime, log axes, one labelled mark per method, the bar as
/// a line.
pub fn chart(rows: &[Row], path: &Path) -> Result<()> {
    let mut regimes: Vec<String> = Vec::new();
    for r in rows {
        if !regimes.contains(&r.regime) {
            regimes.push(r.regime.clone());
        }
    }
    let cols = 4usize.min(regimes.len().max(1));
    let nrows = regimes.len().div_ceil(cols).max(1);
    let (w, h) = (380 * cols as u32, 330 * nrows as u32 + 40);
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE)?;
        let font = scratchart_design::report::plot_font();
        let text = font.is_some();
        let font = font.unwrap_or("sans-serif");
        let (title, body) = root.split_vertically(40);
        if text {
            title.draw_text(
                "error (99th percentile) against GPU time per pair; dashed: the model's bar",
                &TextStyle::from((font, 18)).color(&BLACK),
                (10, 10),
            )?;
        }
        let panels = body.split_evenly((nrows, cols));
        let palette = [
            RGBColor(31, 119, 180),
            RGBColor(255, 127, 14),
            RGBColor(44, 160, 44),
            RGBColor(214, 39, 40),
            RGBColor(148, 103, 189),
            RGBColor(140, 86, 75),
            RGBColor(227, 119, 194),
            RGBColor(127, 127, 127),
            RGBColor(188, 189, 34),
            RGBColor(23, 190, 207),
            RGBColor(0, 0, 0),
            RGBColor(128, 0, 0),
            RGBColor(0, 110, 110),
        ];
        let mut methods: Vec<String> = Vec::new();
        for r in rows {
            if !methods.contains(&r.method) {
                methods.push(r.method.clone());
            }
        }
        for (reg, area) in regimes.iter().zip(panels.iter()) {
            let pts: Vec<&Row> = rows.iter().filter(|r| &r.regime == reg).collect();
            let clampe = |e: f64| if e.is_finite() { e.clamp(1e-8, 10.0) } else { 10.0 };
            let (mut x0, mut x1) = (f64::MAX, 0.0f64);
            for p in &pts {
                x0 = x0.min(p.ns_per_pair);
                x1 = x1.max(p.ns_per_pair);
            }
            // Room on the right for the rightmost mark's label.
            let (x0, x1) = ((x0 / 1.5).max(1e-3), (x1 * 3.0).max(x0 * 2.0));
            let mut cb = ChartBuilder::on(area);
            cb.margin(8);
            if text {
                cb.caption(reg, (font, 16)).x_label_area_size(30).y_label_area_size(50);
            }
            let mut chart = cb.build_cartesian_2d((x0..x1).log_scale(), (1e-8f64..10.0).log_scale())?;
            if text {
                chart
                    .configure_mesh()
                    .x_desc("ns per pair")
                    .y_desc("error")
                    .x_labels(4)
                    .y_labels(5)
                    .y_label_formatter(&|v| format!("{v:.0e}"))
                    .draw()?;
            } else {
                chart.configure_mesh().disable_mesh().draw()?;
            }
            chart.draw_series(DashedLineSeries::new(
                vec![(x0, BAR), (x1, BAR)],
                6,
                4,
                BLACK.stroke_width(1),
            ))?;
            // Labels beside their marks, moved up or down in steps of a line where they would
            // cover a label already placed (methods with the same cost and error, such as the
            // closed form and `adaptive`, sit on one spot).
            let mut placed: Vec<(i32, i32, i32)> = Vec::new(); // (x, y, width) in pixels
            for p in pts {
                let k = methods.iter().position(|m| m == &p.method).unwrap_or(0);
                let c = palette[k % palette.len()];
                let at = (p.ns_per_pair, clampe(p.err_p99));
                chart.draw_series(std::iter::once(Circle::new(at, 4, c.filled())))?;
                if text {
                    let (x, y) = chart.backend_coord(&at);
                    let width = 6 * p.method.len() as i32;
                    let overlaps = |dy: i32| {
                        placed
                            .iter()
                            .any(|&(px, py, pw)| x + 6 < px + pw && px < x + 6 + width && (y + dy - py).abs() < 11)
                    };
                    let dy = [0, 11, 22, -11, 33, -22, 44]
                        .into_iter()
                        .find(|&d| !overlaps(d))
                        .unwrap_or(0);
                    placed.push((x + 6, y + dy, width));
                    chart.draw_series(std::iter::once(
                        EmptyElement::at(at)
                            + Text::new(p.method.clone(), (6, dy - 5), (font, 11).into_font().color(&c)),
                    ))?;
                }
            }
        }
        root.present()?;
    }
    scratchart_render::io::write_png_rgb(path, w, h, &buf).with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}
