//! Target images: user files (PNG/JPEG of any size, converted to gray display values in [0, 1] and
//! resized to each view's resolution) or the built-in bold shapes drawn here (no font files).
use std::path::{Path, PathBuf};

use scratchart_model::scene::Scene;

/// A target set does not fit the views.
#[derive(Debug, thiserror::Error)]
pub enum TargetError {
    #[error("{given} target image(s) given for {views} view(s): give exactly one per view, in view order ({names})")]
    Count { given: usize, views: usize, names: String },
    #[error(
        "{path} (the picture of view {view}) is uniform: every pixel is {value:.3}, so there is nothing for \
         the view to show. Give a picture with something in it, or, to leave this view blank on \
         purpose, add --blank-view {view}"
    )]
    Uniform { path: String, view: String, value: f32 },
    #[error(transparent)]
    Image(#[from] scratchart_render::io::IoError),
}

/// A picture whose pixels all lie within half an 8-bit step of one value has nothing to show.
pub fn is_uniform(data: &[f32]) -> Option<f32> {
    let (lo, hi) = data
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    (hi - lo <= 0.5 / 255.0).then_some(0.5 * (lo + hi))
}

/// One picture per view, or an error naming the views.
fn check_count(paths: &[PathBuf], scene: &Scene) -> Result<(), TargetError> {
    if paths.len() != scene.views.len() {
        return Err(TargetError::Count {
            given: paths.len(),
            views: scene.views.len(),
            names: scene
                .views
                .iter()
                .map(|v| v.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        });
    }
    Ok(())
}

/// Reads one target per view (in view order), resized to the view's size.
pub fn load_targets(paths: &[PathBuf], scene: &Scene) -> Result<Vec<Vec<f32>>, TargetError> {
    check_count(paths, scene)?;
    paths
        .iter()
        .zip(&scene.views)
        .map(|(p, v)| load_target(p, v.camera.width, v.camera.height))
        .collect()
}

/// A picture file read as gray display values in [0, 1].
#[derive(Clone, Debug)]
pub struct Picture {
    pub path: PathBuf,
    pub width: u32,
    pub height: u32,
    pub data: Vec<f32>,
}

/// Reads the picture of view `view`; a uniform one (a 1 x 1 image, a blank frame) is refused
/// unless the view is named in `blank` (left blank on purpose).
pub fn read_picture(path: &Path, view: &str, blank: &[String]) -> Result<Picture, TargetError> {
    let (width, height, data) = scratchart_render::io::read_image_gray(path)?;
    let data: Vec<f32> = data.into_iter().map(|x| x.clamp(0.0, 1.0)).collect();
    if let Some(value) = is_uniform(&data).filter(|_| !blank.iter().any(|b| b == view)) {
        return Err(TargetError::Uniform {
            path: path.display().to_string(),
            view: view.to_string(),
            value,
        });
    }
    Ok(Picture {
        path: path.to_path_buf(),
        width,
        height,
        data,
    })
}

/// Reads one picture per view (in view order, [`read_picture`]).
pub fn read_pictures(paths: &[PathBuf], scene: &Scene, blank: &[String]) -> Result<Vec<Picture>, TargetError> {
    check_count(paths, scene)?;
    paths
        .iter()
        .zip(&scene.views)
        .map(|(p, v)| read_picture(p, &v.name, blank))
        .collect()
}

/// Places each view's picture in its view as `fit` says (see [`crate::framing`]): the targets
/// the loss uses, with where each picture went.
pub fn fit_pictures(
    pictures: &[Picture],
    scene: &Scene,
    fit: crate::framing::Fit,
    background: f32,
) -> Vec<crate::framing::Fitted> {
    pictures
        .iter()
        .zip(&scene.views)
        .map(|(p, v)| crate::framing::fit_picture(&p.data, p.width, p.height, v, &scene.plate, fit, background))
        .collect()
}

/// [`read_pictures`] then [`fit_pictures`].
pub fn load_fitted_targets(
    paths: &[PathBuf],
    scene: &Scene,
    fit: crate::framing::Fit,
    background: f32,
    blank: &[String],
) -> Result<Vec<crate::framing::Fitted>, TargetError> {
    Ok(fit_pictures(
        &read_pictures(paths, scene, blank)?,
        scene,
        fit,
        background,
    ))
}

/// One target file as display values, resized to `w` x `h` (antialiased bilinear).
pub fn load_target(path: &Path, w: u32, h: u32) -> Result<Vec<f32>, TargetError> {
    let (sw, sh, data) = scratchart_render::io::read_image_gray(path)?;
    let img = if (sw, sh) == (w, h) {
        data
    } else {
        scratchart_render::io::resize_bilinear(&data, sw, sh, w, h)
    };
    Ok(img.into_iter().map(|v| v.clamp(0.0, 1.0)).collect())
}

/// The built-in shapes, in view order (cycling for more than 6 views).
pub const SHAPES: [&str; 6] = ["circle", "triangle", "star", "square", "cross", "ring"];

/// Inside test of shape `name` in coordinates centred on the shape, radius 1.
fn inside(name: &str, x: f64, y: f64) -> bool {
    let r = (x * x + y * y).sqrt();
    match name {
        "circle" => r <= 1.0,
        "ring" => (0.55..=1.0).contains(&r),
        "square" => x.abs() <= 0.8 && y.abs() <= 0.8,
        "cross" => (x.abs() <= 0.3 && y.abs() <= 1.0) || (y.abs() <= 0.3 && x.abs() <= 1.0),
        // Regular polygons/stars: compare the radius with the boundary's at this angle.
        "triangle" => polygon_inside(x, y, 3, 1.0, 1.0),
        "star" => polygon_inside(x, y, 5, 1.0, 0.45),
        _ => false,
    }
}

/// Inside a star polygon with `n` points of radius `ro` and inner vertices of radius `ri` (a
/// regular polygon when ri = ro cos(pi/n)... handled as ri >= ro: plain polygon), first point up.
fn polygon_inside(x: f64, y: f64, n: usize, ro: f64, ri: f64) -> bool {
    use std::f64::consts::PI;
    let step = PI / n as f64;
    // Vertices alternate outer/inner (for a plain polygon: outer only).
    let verts: Vec<(f64, f64)> = if ri >= ro {
        (0..n)
            .map(|k| {
                let a = -PI / 2.0 + 2.0 * step * k as f64;
                (ro * a.cos(), ro * a.sin())
            })
            .collect()
    } else {
        (0..2 * n)
            .map(|k| {
                let a = -PI / 2.0 + step * k as f64;
                let r = if k % 2 == 0 { ro } else { ri };
                (r * a.cos(), r * a.sin())
            })
            .collect()
    };
    // Even-odd crossing test (y grows downwards in images: "up" is -y).
    let mut inside = false;
    let m = verts.len();
    for i in 0..m {
        let (x0, y0) = verts[i];
        let (x1, y1) = verts[(i + 1) % m];
        if (y0 > y) != (y1 > y) && x < x0 + (y - y0) * (x1 - x0) / (y1 - y0) {
            inside = !inside;
        }
    }
    inside
}

/// Rasterizes `shape` (4x4 supersampled) into a `w` x `h` image: 1 inside, 0 outside, centred at
/// (cx, cy) with radius `r` pixels; the shape's own y axis points up the image.
pub fn draw_shape(shape: &str, w: u32, h: u32, cx: f64, cy: f64, r: f64) -> Vec<f32> {
    let mut out = vec![0f32; (w * h) as usize];
    const SS: u32 = 4;
    for j in 0..h {
        for i in 0..w {
            let mut hits = 0;
            for sy in 0..SS {
                for sx in 0..SS {
                    let px = i as f64 + (sx as f64 + 0.5) / SS as f64;
                    let py = j as f64 + (sy as f64 + 0.5) / SS as f64;
                    if inside(shape, (px - cx) / r, (py - cy) / r) {
                        hits += 1;
                    }
                }
            }
            out[(j * w + i) as usize] = hits as f32 / (SS * SS) as f32;
        }
    }
    out
}

/// The built-in targets: view j shows SHAPES[j % 6], white on black, centred where the plate
/// centre projects, as large as fits inside the plate's image (90% of the largest centred disc of
/// on-plate pixels), so every bright target pixel can be reached by scratches.
pub fn builtin_targets(scene: &Scene) -> Vec<Vec<f32>> {
    scene
        .views
        .iter()
        .enumerate()
        .map(|(j, v)| {
            let (w, h) = (v.camera.width, v.camera.height);
            let geom = scratchart_model::camera::ViewGeom::new(v);
            let (cx, cy) = geom
                .project([0.0, 0.0, 0.0])
                .unwrap_or((w as f64 / 2.0, h as f64 / 2.0));
            let mask = scratchart_model::camera::on_plate_mask(scene, j);
            let mut r2 = f64::INFINITY;
            for y in 0..h {
                for x in 0..w {
                    if !mask[(y * w + x) as usize] {
                        let (dx, dy) = (x as f64 + 0.5 - cx, y as f64 + 0.5 - cy);
                        r2 = r2.min(dx * dx + dy * dy);
                    }
                }
            }
            let r = if r2.is_finite() {
                0.9 * r2.sqrt()
            } else {
                0.4 * w.min(h) as f64
            };
            draw_shape(SHAPES[j % SHAPES.len()], w, h, cx, cy, r.max(2.0))
        })
        .collect()
}
