//! The photos `inspect` compares: which view each shows, the camera that took it and the pixels
//! it compares. A photo of its view's exact size is taken as that view's own camera (as
//! `simulate-plate` takes them); any other is located by the plate's registration marks as the
//! tool fit locates a card photo (`fit_cmd::inspect::inspect_photo` with the plate's marks as
//! the card's: shrunk by a whole factor to about the view's height, the marks matched, the camera
//! recovered from their homography, refused when too small, saturated, noisy or far off the
//! view), the lamp the view's.
use super::*;

use crate::card::Card;

/// One photo, as the fit compares it.
pub(super) struct Photo {
    pub(super) file: PathBuf,
    /// The design view it shows.
    pub(super) view: usize,
    /// The camera that took it, at `pixels`' size, with the view's lamp.
    pub(super) camera: scratchart_model::scene::View,
    /// Display values.
    pub(super) pixels: Vec<f32>,
    /// The pixels the fit compares: on the plate, off the marks, not clipped.
    pub(super) used: Vec<bool>,
    /// How it was placed, in words.
    pub(super) how: String,
    /// Located by the marks (not the view's own camera): its registration is refined per
    /// evaluation ([`registered`]).
    pub(super) located: bool,
    /// The photo seen on its view's raster (through the plate: each view pixel's plate point
    /// where the photo shows it), for the comparison with the view's picture.
    pub(super) on_view: Vec<f32>,
}

/// Where the marks are: the plans' cuts that are not scratches when plans are given, else the
/// registration marks' squares and the +x mark that `plan` carves for this design. Each with
/// the pad its own shape needs beyond the cut, mm.
pub(super) fn mark_cuts(design: &Scene, grooves: &[CarvedCut], from_plans: bool) -> Vec<(Cut, f64)> {
    if from_plans {
        return grooves
            .iter()
            .filter(|g| !g.label.starts_with("scratch"))
            .map(|g| (g.cut, 0.0))
            .collect();
    }
    let flat = |a: [f64; 2], b: [f64; 2]| Cut {
        a,
        b,
        z: 0.0,
        scratch: 0,
        bulge: 0.0,
    };
    let mut out = Vec::new();
    for m in crate::card::plate_marks(design.plate.size_mm, &design.views).marks {
        // The square as its two diagonals, padded by half its side (every point of the square
        // lies within that of one).
        let (c, r) = (m.centre, m.half_mm);
        out.push((flat([c[0] - r, c[1] - r], [c[0] + r, c[1] + r]), r));
        out.push((flat([c[0] - r, c[1] + r], [c[0] + r, c[1] - r]), r));
    }
    let cuts: Vec<Cut> = grooves.iter().map(|g| g.cut).collect();
    let widths: Vec<f64> = design.scratches.iter().map(|s| s.w.min(0.5)).collect();
    let segs = scratchart_machine::plan::mark_segments(&cuts, &widths);
    let mk = scratchart_machine::plan::orientation_mark(
        &segs,
        design.plate.size_mm,
        0.1,
        scratchart_machine::plan::MARK_CLEAR_MM,
    );
    out.push((flat(mk.a, mk.b), 0.0));
    out
}

/// Whether plate point `q` lies within `pad` of the segment a-b.
fn near_segment(q: [f64; 2], c: &Cut, pad: f64) -> bool {
    let (d, e) = ([c.b[0] - c.a[0], c.b[1] - c.a[1]], [q[0] - c.a[0], q[1] - c.a[1]]);
    let l2 = d[0] * d[0] + d[1] * d[1];
    let t = if l2 > 0.0 {
        ((e[0] * d[0] + e[1] * d[1]) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (e[0] - t * d[0]).hypot(e[1] - t * d[1]) <= pad
}

/// The plate as a card whose only features are its registration marks (what the card photos'
/// registration needs).
fn plate_card(design: &Scene) -> Card {
    let pm = crate::card::plate_marks(design.plate.size_mm, &design.views);
    Card {
        plate_mm: design.plate.size_mm,
        depths_mm: vec![],
        orientations_deg: pm.orientations_deg,
        repeats: 0,
        cut_mm: 0.0,
        alpha: 0.1,
        cuts: vec![],
        marks: pm.marks,
    }
}

/// Bilinear sample of a `w` x `h` image at pixel coordinates (x, y) (pixel centres at +0.5).
fn sample(img: &[f32], w: u32, h: u32, x: f64, y: f64) -> f32 {
    let (fx, fy) = (x - 0.5, y - 0.5);
    let (x0, y0) = (fx.floor(), fy.floor());
    let (tx, ty) = ((fx - x0) as f32, (fy - y0) as f32);
    let at = |i: f64, j: f64| {
        let (i, j) = (
            i.clamp(0.0, w as f64 - 1.0) as usize,
            j.clamp(0.0, h as f64 - 1.0) as usize,
        );
        img[j * w as usize + i]
    };
    let top = at(x0, y0) * (1.0 - tx) + at(x0 + 1.0, y0) * tx;
    let bottom = at(x0, y0 + 1.0) * (1.0 - tx) + at(x0 + 1.0, y0 + 1.0) * tx;
    top * (1.0 - ty) + bottom * ty
}

/// The photo seen on `view`'s raster: each view pixel's plate point where the photo's camera
/// sees it (0 where it does not).
fn on_view(
    pixels: &[f32],
    camera: &scratchart_model::scene::View,
    view: &scratchart_model::scene::View,
    design: &Scene,
) -> Vec<f32> {
    let (gv, gp) = (ViewGeom::of(view, &design.plate), ViewGeom::of(camera, &design.plate));
    let (w, h) = (view.camera.width, view.camera.height);
    let (pw, ph) = (camera.camera.width, camera.camera.height);
    let mut out = Vec::with_capacity((w * h) as usize);
    for j in 0..h {
        for i in 0..w {
            let v = gv
                .shading_point(i, j)
                .and_then(|q| gp.project([q[0], q[1], 0.0]))
                .filter(|(x, y)| *x >= 0.0 && *y >= 0.0 && *x <= pw as f64 && *y <= ph as f64)
                .map_or(0.0, |(x, y)| sample(pixels, pw, ph, x, y));
            out.push(v);
        }
    }
    out
}

/// Reads photo `file` of design view `view` (see the module doc).
fn read_photo(file: &Path, view: usize, design: &Scene, marks: &[(Cut, f64)], blur_px: f64) -> Result<Photo> {
    let (w, h, px) = scratchart_render::io::read_image_gray(file)?;
    let v = &design.views[view];
    let (camera, pixels, how) = if (w, h) == (v.camera.width, v.camera.height) {
        (
            v.clone(),
            px,
            "the view's own camera (the photo is the view's size)".to_string(),
        )
    } else {
        let card = plate_card(design);
        let ins = crate::fit_cmd::inspect::inspect_photo(&card, design, v, file).map_err(|e| {
            // The card's registration, told of the plate.
            let e = e
                .to_string()
                .replace("from the capture position of card.json with the lamp where it says (see capture_guide.png beside card.json)", "from the view's place in the design's setup.txt with the lamp where it says")
                .replace("card.json", "the design")
                .replace("the card's", "the plate's")
                .replace("card", "plate");
            InputError(format!(
                "{e} (inspect locates a photo of the plate by the registration marks `plan` carves in its corners; a \
                 photo of exactly the view's size, {} x {}, is taken as the view's own camera)",
                v.camera.width, v.camera.height
            ))
        })?;
        let how = format!(
            "located by {} of the plate's {} marks, {} x {} after a shrink by {}, the camera {:.0} mm from the view's",
            ins.found.count(),
            card.marks.len(),
            ins.image.width,
            ins.image.height,
            ins.shrink,
            ins.moved_mm
        );
        (ins.view, ins.image.data, how)
    };
    // The photo's pixels are encoded as a phone encodes them (sRGB); the comparison is in the
    // engine's display values of the same light.
    let pixels: Vec<f32> = pixels.into_iter().map(crate::encoding::to_display).collect();
    let (cw, ch) = (camera.camera.width, camera.camera.height);
    let geom = ViewGeom::of(&camera, &design.plate);
    let half = 0.5 * design.plate.size_mm;
    // A pixel adds up the light of its footprint (and the blur spreads it): the marks' light
    // reaches pixels whose centre lies a footprint or two off the mark.
    let (si, sj) = ((cw / 8).max(1) as usize, (ch / 8).max(1) as usize);
    let foot = (0..ch)
        .step_by(sj)
        .flat_map(|j| (0..cw).step_by(si).map(move |i| (i, j)))
        .filter(|&(i, j)| geom.on_plate(i, j, half))
        .filter_map(|(i, j)| geom.footprint(i, j))
        .map(|f| {
            (0..4)
                .map(|e| (f[e][0] - f[(e + 1) % 4][0]).hypot(f[e][1] - f[(e + 1) % 4][1]))
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max);
    let pad = MARK_PAD_MM + (2.0 + 3.0 * blur_px) * foot;
    let mut used = Vec::with_capacity(pixels.len());
    for j in 0..ch {
        for i in 0..cw {
            let ok = geom.on_plate(i, j, half)
                && geom
                    .shading_point(i, j)
                    .is_some_and(|q| !marks.iter().any(|(c, r)| near_segment(q, c, pad + r)))
                && pixels[(j * cw + i) as usize] < 0.999;
            used.push(ok);
        }
    }
    let on_view = if (cw, ch) == (v.camera.width, v.camera.height) && camera.camera == v.camera {
        pixels.clone()
    } else {
        on_view(&pixels, &camera, v, design)
    };
    Ok(Photo {
        file: file.to_path_buf(),
        view,
        camera,
        pixels,
        used,
        located: (cw, ch) != (v.camera.width, v.camera.height),
        how,
        on_view,
    })
}

/// The largest shift [`registered`] applies anywhere in the image, pixels.
const MAX_SHIFT_PX: f64 = 3.0;

/// A small affine warp of the image plane: the shift at pixel (x, y) is
/// (a[0] + a[1] u + a[2] v, a[3] + a[4] u + a[5] v), u and v the pixel's place from the image's
/// centre in image heights.
type Warp = [f64; 6];

fn warp_at(a: &Warp, u: f64, v: f64) -> [f64; 2] {
    [a[0] + a[1] * u + a[2] * v, a[3] + a[4] * u + a[5] * v]
}

/// `m` (a render at `photo`'s camera, `w` x `h`) warped by `a`: m(x - d(x)), bilinear, edges
/// clamped.
fn warped(m: &[f32], w: usize, h: usize, a: &Warp) -> Vec<f32> {
    let mut out = Vec::with_capacity(m.len());
    for j in 0..h {
        for i in 0..w {
            let (u, v) = uv(i, j, w, h);
            let d = warp_at(a, u, v);
            out.push(sample(
                m,
                w as u32,
                h as u32,
                i as f64 + 0.5 - d[0],
                j as f64 + 0.5 - d[1],
            ));
        }
    }
    out
}

fn uv(i: usize, j: usize, w: usize, h: usize) -> (f64, f64) {
    (
        (i as f64 + 0.5 - 0.5 * w as f64) / h as f64,
        (j as f64 + 0.5 - 0.5 * h as f64) / h as f64,
    )
}

/// A render of a photo located by the marks, moved onto the photo: the marks' homography places
/// the camera to a fraction of a pixel, and a fraction of a pixel of a thin groove's light is
/// much of the residual. The small affine warp of the image (a shift, and the turn, scale and
/// shear left by the homography) minimizing |c m(x - d(x)) - photo| over the used pixels, by
/// three Gauss-Newton steps on the render's gradient (each a linear regression of the photo on
/// the warped render and its gradients times 1, u and v: the exposure c with it), at most
/// [`MAX_SHIFT_PX`] anywhere. Returns the warped render and its shift at the image's centre.
pub(super) fn registered(m: &[f32], w: usize, h: usize, photo: &Photo) -> (Vec<f32>, [f64; 2]) {
    let mut a: Warp = [0.0; 6];
    for _ in 0..3 {
        let ms = warped(m, w, h, &a);
        let at = |i: usize, j: usize| ms[j.min(h - 1) * w + i.min(w - 1)] as f64;
        let mut ata = [[0.0f64; 7]; 7];
        let mut atb = [0.0f64; 7];
        for j in 0..h {
            for i in 0..w {
                let k = j * w + i;
                if !photo.used[k] {
                    continue;
                }
                let gx = 0.5 * (at(i + 1, j) - at(i.saturating_sub(1), j));
                let gy = 0.5 * (at(i, j + 1) - at(i, j.saturating_sub(1)));
                let (u, v) = uv(i, j, w, h);
                let f = [ms[k] as f64, gx, gx * u, gx * v, gy, gy * u, gy * v];
                for r in 0..7 {
                    for c in 0..7 {
                        ata[r][c] += f[r] * f[c];
                    }
                    atb[r] += f[r] * photo.pixels[k] as f64;
                }
            }
        }
        let Some(x) = super::fit::solve(ata, atb) else { break };
        if !(x[0] > 0.0) {
            break;
        }
        // photo = c ms(x - delta) = c ms - c delta . grad ms: delta = -(x1..x6) / c.
        let step: Warp = std::array::from_fn(|q| -x[q + 1] / x[0]);
        let next: Warp = std::array::from_fn(|q| a[q] + step[q]);
        // Within the largest shift at the image's corners.
        let (cu, cv) = (0.5 * w as f64 / h as f64, 0.5);
        let worst = [(-cu, -cv), (cu, -cv), (-cu, cv), (cu, cv)]
            .iter()
            .map(|&(u, v)| {
                let d = warp_at(&next, u, v);
                d[0].abs().max(d[1].abs())
            })
            .fold(0.0, f64::max);
        if !(worst <= MAX_SHIFT_PX) {
            break;
        }
        a = next;
        if step.iter().all(|v| v.abs() < 1e-3) {
            break;
        }
    }
    (warped(m, w, h, &a), [a[0], a[3]])
}

/// Reads photo `file`, of view `view` by its name, or by its place among the photos
/// (`by_name` false): then, when the marks do not place it as that view, as whichever other
/// view they do place it as (a phone's or a messenger's names keep no order), said so; a
/// photo no view places is refused with the first view's reason and the hint to name it.
pub(super) fn read_photo_of_any(
    file: &Path,
    view: usize,
    by_name: bool,
    design: &Scene,
    marks: &[(Cut, f64)],
    blur_px: f64,
) -> Result<Photo> {
    let first = match read_photo(file, view, design, marks, blur_px) {
        Ok(p) => return Ok(p),
        Err(e) => e,
    };
    if !by_name {
        for other in (0..design.views.len()).filter(|&o| o != view) {
            if let Ok(mut p) = read_photo(file, other, design, marks, blur_px) {
                if p.located {
                    p.how = format!(
                        "{} (view {} by its marks, not {} as its place among the photos says)",
                        p.how, design.views[other].name, design.views[view].name
                    );
                    return Ok(p);
                }
            }
        }
    }
    Err(InputError(format!(
        "{first}{}",
        if by_name {
            String::new()
        } else {
            " (no other view of the design places it either; name each photo after its view, v0.jpg, v1.jpg, ..., \
             if you know which is which)"
                .to_string()
        }
    ))
    .into())
}

/// Which view each photo shows: by its file name (`v1.png` is view v1), else in the views' order
/// (the bool: whether by name).
pub(super) fn photo_views(photos: &[PathBuf], design: &Scene) -> Result<(Vec<usize>, bool)> {
    let by_name: Vec<Option<usize>> = photos
        .iter()
        .map(|p| {
            let stem = p
                .file_stem()
                .map(|s| s.to_string_lossy().to_string())
                .unwrap_or_default();
            design.views.iter().position(|v| v.name == stem)
        })
        .collect();
    if by_name.iter().all(|v| v.is_some()) {
        return Ok((by_name.into_iter().flatten().collect(), true));
    }
    if photos.len() > design.views.len() {
        return Err(UsageError(format!(
            "{} photos for a design of {} views, and their names do not name the views ({}): give one photo per \
             view, named after it",
            photos.len(),
            design.views.len(),
            design
                .views
                .iter()
                .map(|v| v.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ))
        .into());
    }
    Ok(((0..photos.len()).collect(), false))
}
