//! Arc scratches on the GPU (engine/docs/model.md section 11): each arc is uploaded as straight
//! scratches along its chords, endpoints on the arc at equal angles, each turning by at most
//! [`max_turn`] from the last: the shading kernels see only straight scratches. What the chords
//! leave out, and its measured size against the float64 reference's exact arc, is written in
//! the model's documentation: the direction of the groove is constant along a chord (the
//! reason the turn per chord follows the groove's roughness), and the chords' rectangles weigh
//! the groove's inner side by r / rho against the annulus (e / r of a footprint that sees one
//! side only) unless weighted: each chord carries the weight that restores the annulus's area
//! element (`shaders/arc_map.comp`), which the closed-form integrator applies.
use crate::model::scene::Scratch;
use crate::vulkan::GpuError;

/// The most chords one arc is cut into.
pub const MAX_CHORDS_PER_ARC: usize = 4096;

/// The largest turn of one chord (radians) for a groove of roughness `alpha`: alpha / 20 (the
/// groove's lobe, seen along the plate, is about alpha / |h_xy| wide in the direction of
/// travel), from 1e-4 to 0.25 degree.
pub fn max_turn(alpha: f64) -> f64 {
    (alpha / 20.0).clamp(1e-4, std::f64::consts::PI / 720.0)
}

/// The longest chord (mm): a footprint's edge cuts a chord, which holds one direction where the
/// arc turns, so chords are kept under a pixel's footprint.
pub const MAX_CHORD_MM: f64 = 0.05;

/// How many chords scratch `s` is uploaded as (1 for a straight scratch); more than
/// [`MAX_CHORDS_PER_ARC`] is refused by [`expand`].
pub fn chord_count(s: &Scratch) -> usize {
    match s.arc() {
        None => 1,
        Some(a) => {
            let by_turn = a.sweep.abs() / max_turn(s.alpha);
            let by_length = a.length() / MAX_CHORD_MM;
            by_turn.max(by_length).ceil().max(1.0) as usize
        }
    }
}

/// The kernels' scratches: straight ones as they are, each arc as its chords (what sizes the
/// scene on the device; `shaders/arc_map.comp` writes the chords again from the arcs before every
/// render, with each one's area weight k = sign(bulge) w / (2 r)). An arc that needs more than
/// [`MAX_CHORDS_PER_ARC`] chords is refused, naming it.
pub fn expand(scratches: &[Scratch]) -> Result<Vec<Scratch>, GpuError> {
    let mut out = Vec::with_capacity(scratches.len());
    for (k, s) in scratches.iter().enumerate() {
        let n = chord_count(s);
        if n > MAX_CHORDS_PER_ARC {
            return Err(GpuError::Capacity(format!(
                "arc scratch {} (0-based; bulge {}, {:.2} mm long, alpha {}) needs {n} chords to render \
                 within the accuracy bar, over the renderer's {MAX_CHORDS_PER_ARC} per arc \
                 (engine/render/src/arcs.rs); split it into shorter arcs or give it a larger alpha, or render \
                 each arc as fewer chords than the bar asks (`scratchart render --arc-chords N`; a design made \
                 with --arcs is rendered as its summary.json's arcs.judged_chords_per_arc)",
                k,
                s.bulge,
                s.path_length(),
                s.alpha
            )));
        }
        out.extend(s.chords(n));
    }
    Ok(out)
}

/// Whether any scratch is an arc.
pub fn any_arc(scratches: &[Scratch]) -> bool {
    scratches.iter().any(Scratch::is_arc)
}

/// The kernels' scratches of a scene whose every scratch may bend (`design --arcs`): each as `n`
/// chords, a straight one cut into `n` equal pieces (the arc map writes them again from the
/// scratches before every render). More than [`MAX_CHORDS_PER_ARC`] is refused.
pub fn expand_bendable(scratches: &[Scratch], n: usize) -> Result<Vec<Scratch>, GpuError> {
    if n == 0 || n > MAX_CHORDS_PER_ARC {
        return Err(GpuError::Capacity(format!(
            "{n} chords per scratch: the renderer takes 1 to {MAX_CHORDS_PER_ARC} (engine/render/src/arcs.rs)"
        )));
    }
    let mut out = Vec::with_capacity(scratches.len() * n);
    for s in scratches {
        if s.is_arc() {
            out.extend(s.chords(n));
            continue;
        }
        let at = |t: f64| [s.p0[0] + t * (s.p1[0] - s.p0[0]), s.p0[1] + t * (s.p1[1] - s.p0[1])];
        out.extend((0..n).map(|k| Scratch {
            p0: at(k as f64 / n as f64),
            p1: at((k + 1) as f64 / n as f64),
            ..*s
        }));
    }
    Ok(out)
}
