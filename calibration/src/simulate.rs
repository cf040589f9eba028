//! The card as a tool would cut it, photographed from each capture view: every cut becomes the
//! scratch model's groove for that tool at its commanded depth (`scratchart_tool::Tool::model`),
//! the engine renders each capture view (at 4 times its resolution: a camera's optics are
//! continuous), and the image is degraded as a camera would: a Gaussian blur of the light
//! (optics, before the sensor), the pixels adding up the light over their area, an exposure
//! factor, the display encoding and Gaussian noise on the encoded values (seeded, so
//! reproducible). `crate::phone` goes further: a hand-held phone's pose, size, JPEG and more.
use scratchart_design::scenes::Rng;
use scratchart_model::scene::{Scene, Scratch};
use scratchart_render::Renderer;
use scratchart_tool::Tool;

use super::card::Card;

/// How much finer than the capture view the photos (`simulate`'s and `phone`'s) are rendered:
/// a camera's optics are continuous, and the fit models them at `fit::SUPERSAMPLE` (2) times the
/// view's resolution, so the photos are made finer than that.
pub const RENDER_SCALE: u32 = 4;

/// How the photos are degraded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Linear exposure factor applied to L before the display transform.
    pub exposure: f64,
    /// Sigma of the Gaussian blur, pixels (0: none).
    pub blur_px: f64,
    /// Standard deviation of the noise on display values in [0, 1] (0: none).
    pub noise: f64,
    pub seed: u64,
}

impl Default for Camera {
    fn default() -> Camera {
        Camera {
            exposure: 1.0,
            blur_px: 0.0,
            noise: 0.0,
            seed: 1,
        }
    }
}

/// The card's scene as `tool` cuts it: cuts that do not reach the plate are left out.
pub fn cut_scene(card: &Card, capture: &Scene, tool: &Tool) -> Scene {
    let scratches = card
        .cuts
        .iter()
        .filter_map(|c| {
            let m = tool.model(c.z_mm)?;
            // A groove too narrow to see (a measured profile's zero width) is no scratch.
            if !(m.width > 1e-6 && m.w > 0.0 && m.d > 0.0) {
                return None;
            }
            Some(Scratch {
                p0: c.p0,
                p1: c.p1,
                w: m.w,
                d: m.d,
                alpha: card.alpha,
                bulge: 0.0,
            })
        })
        .collect();
    Scene {
        plate: capture.plate.clone(),
        views: capture.views.clone(),
        scratches,
    }
}

/// Separable Gaussian blur of a `w` x `h` image (clamped edges).
pub fn blur(img: &[f32], w: usize, h: usize, sigma: f64) -> Vec<f32> {
    blur_shifted(img, w, h, sigma, 0.0, 0.0)
}

/// Gaussian blur whose kernel is centred at (dx, dy) pixels: the blurred image moved by a
/// sub-pixel amount with no interpolation (the fit's registration shift; a resampled photo
/// would be blurred by an amount that changes with the sub-pixel phase). out(p) =
/// sum_o k(o - d) img(p + o) / sum_o k(o - d). Sigma below 0.25 px is taken as 0.25 when shifted.
pub fn blur_shifted(img: &[f32], w: usize, h: usize, sigma: f64, dx: f64, dy: f64) -> Vec<f32> {
    if sigma <= 0.0 && dx == 0.0 && dy == 0.0 {
        return img.to_vec();
    }
    let sigma = if dx == 0.0 && dy == 0.0 { sigma } else { sigma.max(0.25) };
    let kernel = |d: f64| {
        let r = (3.0 * sigma + d.abs()).ceil() as i64;
        let k: Vec<f64> = (-r..=r)
            .map(|x| (-((x as f64 - d) * (x as f64 - d)) / (2.0 * sigma * sigma)).exp())
            .collect();
        let s: f64 = k.iter().sum();
        (r, k, s)
    };
    let pass = |src: &[f32], horizontal: bool, d: f64| -> Vec<f32> {
        let (r, k, s) = kernel(d);
        let mut out = vec![0f32; src.len()];
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let mut acc = 0.0;
                for (i, kv) in k.iter().enumerate() {
                    let o = i as i64 - r;
                    let (xx, yy) = if horizontal {
                        ((x + o).clamp(0, w as i64 - 1), y)
                    } else {
                        (x, (y + o).clamp(0, h as i64 - 1))
                    };
                    acc += kv * src[(yy * w as i64 + xx) as usize] as f64;
                }
                out[(y * w as i64 + x) as usize] = (acc / s) as f32;
            }
        }
        out
    };
    pass(&pass(img, true, dx), false, dy)
}

/// Renders the card cut by `tool` from every capture view: display images in [0, 1], one per
/// view, as `camera` would take them.
pub fn photos(
    renderer: &Renderer,
    card: &Card,
    capture: &Scene,
    tool: &Tool,
    camera: &Camera,
) -> anyhow::Result<Vec<Vec<f32>>> {
    // Rendered at RENDER_SCALE times each view's resolution, blurred there and each pixel's
    // light added up over its area: a camera's optics are continuous, and a render at the
    // photo's own resolution has already added up the light of a groove a pixel wide before the
    // blur (the fit models that at twice the resolution; photos made at its own would flatter it).
    photos_of(renderer, &cut_scene(card, capture, tool), camera)
}

/// Renders every view of `scene` as `camera` would take it (see [`photos`]): display images in
/// [0, 1], one per view, each the view's size.
pub fn photos_of(renderer: &Renderer, scene: &Scene, camera: &Camera) -> anyhow::Result<Vec<Vec<f32>>> {
    let hi = render_fine(renderer, scene)?;
    let mut rng = Rng::new(camera.seed);
    Ok(hi
        .iter()
        .zip(&scene.views)
        .map(|(img, v)| {
            develop(img, v.camera.width as usize, v.camera.height as usize, camera.blur_px)
                .into_iter()
                .map(|l| crate::encoding::encode_f32((l as f64 * camera.exposure) as f32))
                .map(|x| {
                    // The project's generator (reproducible).
                    let n = if camera.noise > 0.0 { rng.normal() } else { 0.0 };
                    (x as f64 + camera.noise * n).clamp(0.0, 1.0) as f32
                })
                .collect()
        })
        .collect())
}

/// Every view of `scene` rendered at [`RENDER_SCALE`] times its resolution (linear light).
pub fn render_fine(renderer: &Renderer, scene: &Scene) -> anyhow::Result<Vec<Vec<f32>>> {
    // Rendered at RENDER_SCALE times each view's resolution, blurred there and each pixel's
    // light added up over its area: a camera's optics are continuous, and a render at the
    // photo's own resolution has already added up the light of a groove a pixel wide before the
    // blur (the fit models that at twice the resolution; photos made at its own would flatter it).
    let k = RENDER_SCALE;
    let mut scene = scene.clone();
    for v in &mut scene.views {
        v.camera.width *= k;
        v.camera.height *= k;
    }
    let mut gs = renderer.upload(&scene)?;
    Ok(renderer.render(&mut gs)?.images)
}

/// A fine render ([`render_fine`]) of a `w` x `h` view as its camera records the light: the
/// optics' blur (`blur_px` in the view's pixels), then each pixel adding up its light (linear).
pub fn develop(fine: &[f32], w: usize, h: usize, blur_px: f64) -> Vec<f32> {
    let ku = RENDER_SCALE as usize;
    let b = blur(fine, ku * w, ku * h, ku as f64 * blur_px);
    let mut small = vec![0f32; w * h];
    for (i, l) in b.iter().enumerate() {
        let (x, y) = ((i % (ku * w)) / ku, (i / (ku * w)) / ku);
        small[y * w + x] += l / (ku * ku) as f32;
    }
    small
}
