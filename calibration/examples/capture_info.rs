//! How well candidate captures pin a tool: the Cramér-Rao bound of every tool parameter
//! (`fit::information`, the fit's own Jacobian at the truth) for captures that differ in the
//! camera's height, the lamp (a desk lamp or the phone's flash), the distance and the number of
//! photos, over tools of every kind.
//! `cargo run --release -p scratchart-calibration --example capture_info -- [res] [noise] [capture]
//! [brightest groove level, 0.8] [srgb]`
use scratchart_calibration::card::{Card, CardSpec};
use scratchart_calibration::encoding;
use scratchart_calibration::fit::information::{information, Truth};
use scratchart_calibration::fit::Data;
use scratchart_calibration::fit_cmd::fit_mask;
use scratchart_calibration::simulate;
use scratchart_model::camera::spherical;
use scratchart_model::scene::{Camera, Light, LightKind, Plate, Scene, View};
use scratchart_render::Renderer;
use scratchart_tool::Tool;
use scratchart_vulkan::{Context, ContextDesc};

#[derive(Clone, Copy)]
enum Lamp {
    /// A lamp a quarter turn round from the camera at this elevation.
    Quarter(f64),
    /// The phone's flash beside the lens.
    Flash,
    /// A lamp opposite the camera (mirror side) at this elevation.
    Opposite(f64),
}

fn view(name: &str, plate: f64, dist: f64, az: f64, el: f64, lamp: Lamp, res: u32) -> View {
    let eye = spherical(dist, az, el);
    let position = match lamp {
        Lamp::Quarter(e) => spherical(dist, az + 90.0, e),
        Lamp::Opposite(e) => spherical(dist, az + 180.0, e),
        Lamp::Flash => {
            // 10 mm beside the lens, across the line of sight.
            let r = [(az + 90.0).to_radians().cos(), (az + 90.0).to_radians().sin()];
            [eye[0] + 10.0 * r[0], eye[1] + 10.0 * r[1], eye[2]]
        }
    };
    View {
        exposure: 1.0,
        name: name.into(),
        camera: Camera {
            eye,
            target: [0.0, 0.0, 0.0],
            up: [0.0, 0.0, 1.0],
            fov_y_deg: 2.0 * (0.8 * plate / dist).atan().to_degrees(),
            width: res,
            height: res,
        },
        light: Light {
            kind: LightKind::Point { position },
            intensity: 1.0e5,
        },
    }
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let res: u32 = args.first().and_then(|s| s.parse().ok()).unwrap_or(256);
    let noise: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(0.01);
    let only: Option<String> = args.get(2).cloned();
    // `srgb` as the fifth argument: photos encoded, and the model reading them, with sRGB's curve.
    if args.get(4).is_some_and(|a| a == "srgb") {
        encoding::set(encoding::Encoding::Srgb);
    }
    let ctx = Context::new(ContextDesc::default())?;
    let renderer = Renderer::new(&ctx)?;
    let card = Card::new(&CardSpec::default());
    let plate = Plate {
        size_mm: card.plate_mm,
        roughness: 0.02,
        f0: 0.91,
        shape: Default::default(),
    };
    let d = 4.0 * card.plate_mm;
    println!(
        "res {res}, noise {noise}; each cell: the tool parameters' bounds (deg, um) [limit 0.5 deg, 2.5 um, 1.5 um]"
    );
    for (cname, views) in &captures(card.plate_mm, d, res) {
        if only.as_deref().is_some_and(|o| !cname.contains(o)) {
            continue;
        }
        let capture = Scene {
            plate: plate.clone(),
            views: views.clone(),
            scratches: vec![],
        };
        println!("\n== {cname}");
        let pick = std::env::var("CAPTURE_INFO_TOOLS").ok();
        for (tname, tool) in &tools(&card) {
            // CAPTURE_INFO_TOOLS=profile,V 60: only the tools whose names contain one of these.
            if pick
                .as_deref()
                .is_some_and(|p| !p.split(',').any(|t| tname.contains(t)))
            {
                continue;
            }
            let t0 = std::time::Instant::now();
            let cells = bounds(&renderer, &card, &capture, tool, noise)?;
            println!(
                "  {tname:<11} tone fixed: {} | tone free: {}  ({:.1} s)",
                cells[0],
                cells[1],
                t0.elapsed().as_secs_f64()
            );
        }
    }
    Ok(())
}

/// The candidate captures at `d` mm (views `res` pixels square), named.
fn captures(p: f64, d: f64, res: u32) -> Vec<(String, Vec<View>)> {
    let mut c = vec![(
        "guide: el 50, lamp quarter 35, S+W".to_string(),
        vec![
            view("s", p, d, -90.0, 50.0, Lamp::Quarter(35.0), res),
            view("w", p, d, 180.0, 50.0, Lamp::Quarter(35.0), res),
        ],
    )];
    for el in [25.0, 35.0, 45.0, 60.0, 75.0] {
        c.push((
            format!("flash el {el}, S+W"),
            vec![
                view("s", p, d, -90.0, el, Lamp::Flash, res),
                view("w", p, d, 180.0, el, Lamp::Flash, res),
            ],
        ));
    }
    c.push((
        "flash el 30 + 60, S+W".to_string(),
        vec![
            view("s", p, d, -90.0, 30.0, Lamp::Flash, res),
            view("w", p, d, 180.0, 30.0, Lamp::Flash, res),
            view("s2", p, d, -90.0, 60.0, Lamp::Flash, res),
            view("w2", p, d, 180.0, 60.0, Lamp::Flash, res),
        ],
    ));
    c.push((
        "guide + flash el 30, S+W".to_string(),
        vec![
            view("s", p, d, -90.0, 50.0, Lamp::Quarter(35.0), res),
            view("w", p, d, 180.0, 50.0, Lamp::Quarter(35.0), res),
            view("s2", p, d, -90.0, 30.0, Lamp::Flash, res),
            view("w2", p, d, 180.0, 30.0, Lamp::Flash, res),
        ],
    ));
    c.push((
        "el 50, lamp opposite 20, S+W".to_string(),
        vec![
            view("s", p, d, -90.0, 50.0, Lamp::Opposite(20.0), res),
            view("w", p, d, 180.0, 50.0, Lamp::Opposite(20.0), res),
        ],
    ));
    c
}

/// The tools of the table, named.
fn tools(card: &Card) -> Vec<(String, Tool)> {
    vec![
        (
            "V 30".into(),
            Tool::VBit {
                angle_deg: 30.0,
                tip_flat_mm: 0.015,
                z_offset_mm: 0.007,
            },
        ),
        (
            "V 60".into(),
            Tool::VBit {
                angle_deg: 60.0,
                tip_flat_mm: 0.015,
                z_offset_mm: 0.007,
            },
        ),
        (
            "V 90".into(),
            Tool::VBit {
                angle_deg: 90.0,
                tip_flat_mm: 0.015,
                z_offset_mm: 0.007,
            },
        ),
        (
            "V 120".into(),
            Tool::VBit {
                angle_deg: 120.0,
                tip_flat_mm: 0.015,
                z_offset_mm: 0.007,
            },
        ),
        (
            "V 60 f0".into(),
            Tool::VBit {
                angle_deg: 60.0,
                tip_flat_mm: 0.0,
                z_offset_mm: 0.007,
            },
        ),
        (
            "V 60 f40".into(),
            Tool::VBit {
                angle_deg: 60.0,
                tip_flat_mm: 0.04,
                z_offset_mm: 0.007,
            },
        ),
        (
            "ball 0.05".into(),
            Tool::Ball {
                radius_mm: 0.05,
                z_offset_mm: 0.007,
            },
        ),
        (
            "ball 0.3".into(),
            Tool::Ball {
                radius_mm: 0.3,
                z_offset_mm: 0.007,
            },
        ),
        (
            "ball 1.0".into(),
            Tool::Ball {
                radius_mm: 1.0,
                z_offset_mm: 0.007,
            },
        ),
        (
            "tb 0.05/30".into(),
            Tool::TaperedBall {
                radius_mm: 0.05,
                angle_deg: 30.0,
                z_offset_mm: 0.007,
            },
        ),
        (
            // The widths a V 60 (flat 15 um, offset 7 um) cuts at the card's depths.
            "profile".into(),
            scratchart_calibration::study::profile_cut_by(
                &Tool::VBit {
                    angle_deg: 60.0,
                    tip_flat_mm: 0.015,
                    z_offset_mm: 0.007,
                },
                card,
                1.5,
            ),
        ),
    ]
}

/// The light (over full scale) at which each view's brightest groove pixels sit: the fourth
/// argument, 0.8 without it (above 1 they clip).
fn top_level() -> f64 {
    std::env::args().nth(4).and_then(|s| s.parse().ok()).unwrap_or(0.8)
}

/// One row's cells: the tool parameters' bounds for `capture` with each photo's tone curve
/// fixed and free, each view exposed so its brightest groove pixels sit near 0.8 of full scale.
fn bounds(renderer: &Renderer, card: &Card, capture: &Scene, tool: &Tool, noise: f64) -> anyhow::Result<Vec<String>> {
    let cam = simulate::Camera {
        exposure: 1.0,
        blur_px: 0.6,
        noise: 0.0,
        seed: 1,
    };
    // Expose each view so its brightest groove pixels sit near 0.8 of full scale.
    let raw = simulate::photos(renderer, card, capture, tool, &cam)?;
    let masks: Vec<Vec<bool>> = capture
        .views
        .iter()
        .map(|v| fit_mask(card, v, 0.5 * card.plate_mm))
        .collect();
    let exposure: Vec<f64> = raw
        .iter()
        .zip(&masks)
        .map(|(img, m)| {
            let mut lit: Vec<f64> = img
                .iter()
                .zip(m)
                .filter(|(_, m)| **m)
                .map(|(d, _)| encoding::decode(*d as f64))
                .collect();
            lit.sort_by(f64::total_cmp);
            let top = lit[(lit.len() as f64 * 0.998) as usize].max(1e-9);
            top_level() / top
        })
        .collect();
    let photos: Vec<Vec<f32>> = raw
        .iter()
        .zip(&exposure)
        .map(|(img, e)| {
            img.iter()
                .map(|d| encoding::encode(encoding::decode(*d as f64) * e).min(1.0) as f32)
                .collect()
        })
        .collect();
    let n = capture.views.len();
    let data = Data {
        card,
        capture,
        photos,
        masks,
        refine_shift: true,
        refine_pose: vec![false; n],
        jpeg: vec![None; n],
        noise: vec![0.0; n],
        shrink: vec![1; n],
        native_noise: vec![0.0; n],
        colour: vec![false; n],
        saved_jpeg: vec![None; n],
        gains: vec![[1.0; 3]; n],
    };
    let mut cells = Vec::new();
    for free_tone in [false, true] {
        let truth = Truth {
            tool,
            alpha: card.alpha,
            exposure: exposure.clone(),
            blur_px: vec![0.6; n],
        };
        let info = information(renderer, &data, &truth, noise, free_tone)?;
        let n_tool = info.iter().position(|p| p.0 == "alpha").unwrap_or(0);
        let c: Vec<String> = info[..n_tool]
            .iter()
            .map(|(name, sd)| {
                let scale = if name.ends_with("_mm") || name.starts_with("W_mm@") {
                    1000.0
                } else {
                    1.0
                };
                let short = name
                    .trim_end_matches("_mm")
                    .trim_end_matches("_deg")
                    .replace("W_mm@", "W@");
                match sd {
                    Some(s) => format!("{short} {:.3}", s * scale),
                    None => format!("{short} -"),
                }
            })
            .collect();
        cells.push(c.join(", "));
    }
    Ok(cells)
}
