//! Where the lamp of a ring of views goes by default: where the views' scratches differ most in
//! direction. A groove lights an eye where the half vector h between the lamp and that eye lies
//! in the groove's normal plane, so at a point of the plate every eye is served by grooves
//! across the plate projection of its h; both walls of a groove face out, so directions count
//! modulo 180 degrees. Two eyes whose h project onto one line are served by the same grooves,
//! each lighting both (cross-talk by scratch: engine/docs/worst_view.md). Three views round the
//! ring under a lamp 20 degrees above them (azimuth 0, 65 degrees up) put views 1 and 2 within
//! 13 degrees of each other; a lamp overhead spreads them 60 degrees apart, the most three
//! directions modulo 180 can be.

/// The least separation, degrees (0 to 90), between the directions of the grooves that serve
/// each pair of `eyes` (positions, plate centre at the origin) under a lamp at `lamp`, at the
/// plate centre; 90 for fewer than two eyes.
pub fn least_separation(lamp: [f64; 3], eyes: &[[f64; 3]]) -> f64 {
    let unit = |p: [f64; 3]| {
        let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        [p[0] / n, p[1] / n, p[2] / n]
    };
    let l = unit(lamp);
    let dirs: Vec<f64> = eyes
        .iter()
        .map(|&e| {
            let e = unit(e);
            (l[1] + e[1]).atan2(l[0] + e[0]).to_degrees()
        })
        .collect();
    let mut least = 90.0f64;
    for i in 0..dirs.len() {
        for j in i + 1..dirs.len() {
            let d = (dirs[i] - dirs[j]).rem_euclid(180.0);
            least = least.min(d.min(180.0 - d));
        }
    }
    least
}

/// The angle between two directions from the plate centre, degrees.
fn angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt() * (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
    (dot / n).clamp(-1.0, 1.0).acos().to_degrees()
}

/// The least spread of the groove directions for which the default lamp is placed by
/// [`separating_lamp`] (two views: 90 degrees; three: 60); a ring of four or more views, whose
/// best spread is 45 degrees or less with the lamp at their height between two of them, keeps
/// the lamp 20 degrees above the views (measured in engine/docs/worst_view.md, "The lamp").
pub const LEAST_USEFUL_SEPARATION_DEG: f64 = 59.5;

/// No closer to an eye than this, degrees: the lamp, or its mirror image in the plate (where an
/// eye would see the flat plate's own highlight).
pub const EYE_CLEARANCE_DEG: f64 = 10.0;

/// The lamp's (azimuth, elevation) in degrees, on a 5-degree grid from 10 degrees up to
/// overhead, at least [`EYE_CLEARANCE_DEG`] from every eye and from every eye's mirror, that
/// spreads the eyes' groove directions most ([`least_separation`]); among those within half a
/// degree of the best, the one farthest from the nearest eye (out of everyone's way; then the
/// higher). Returns it with its separation, or None where no place keeps clear of the eyes.
pub fn separating_lamp(eyes: &[[f64; 3]]) -> Option<(f64, f64, f64)> {
    let at = |az: f64, el: f64| scratchart_model::camera::spherical(1.0, az, el);
    let mut cands = Vec::new();
    for el in (10..=90).step_by(5) {
        let azs: Vec<i32> = if el == 90 {
            vec![0]
        } else {
            (0..360).step_by(5).collect()
        };
        for az in azs {
            let p = at(az as f64, el as f64);
            let mirror = [-p[0], -p[1], p[2]];
            let clear = eyes
                .iter()
                .map(|&e| angle(p, e).min(angle(mirror, e)))
                .fold(180.0f64, f64::min);
            if clear < EYE_CLEARANCE_DEG {
                continue;
            }
            cands.push((az as f64, el as f64, least_separation(p, eyes), clear));
        }
    }
    let best = cands.iter().map(|c| c.2).fold(f64::NEG_INFINITY, f64::max);
    cands
        .into_iter()
        .filter(|c| c.2 >= best - 0.5)
        .max_by(|a, b| a.3.total_cmp(&b.3).then(a.1.total_cmp(&b.1)).then(b.0.total_cmp(&a.0)))
        .map(|c| (c.0, c.1, c.2))
}

#[cfg(test)]
mod tests {
    use super::*;
    use scratchart_model::camera::spherical;

    fn ring(n: usize, el: f64) -> Vec<[f64; 3]> {
        (0..n)
            .map(|j| spherical(300.0, 360.0 * j as f64 / n as f64, el))
            .collect()
    }

    #[test]
    fn three_views_under_the_old_lamp_nearly_share_their_grooves() {
        let eyes = ring(3, 45.0);
        let old = least_separation(spherical(300.0, 0.0, 65.0), &eyes);
        assert!(old < 15.0, "views 1 and 2 under a lamp 65 degrees up: {old}");
        assert!((least_separation(spherical(300.0, 0.0, 90.0), &eyes) - 60.0).abs() < 1e-9);
    }

    #[test]
    fn the_lamp_spreads_the_grooves_and_keeps_clear_of_the_eyes() {
        for (n, el) in [(3, 45.0), (2, 45.0), (4, 30.0), (5, 60.0)] {
            let eyes = ring(n, el);
            let (az, e, sep) = separating_lamp(&eyes).unwrap();
            let p = spherical(1.0, az, e);
            for &x in &eyes {
                assert!(angle(p, x) >= EYE_CLEARANCE_DEG && angle([-p[0], -p[1], p[2]], x) >= EYE_CLEARANCE_DEG);
            }
            // The most n directions modulo 180 can be apart, within the grid's step.
            let most = 180.0 / n as f64;
            assert!(
                sep >= 0.85 * most && sep <= most + 1e-9,
                "{n} views at {el}: {sep} of {most}"
            );
            assert!((least_separation(p, &eyes) - sep).abs() < 1e-9);
        }
        // Three views round the ring: the lamp overhead, 45 degrees from every eye.
        assert_eq!(separating_lamp(&ring(3, 45.0)).map(|c| c.1), Some(90.0));
        // Two views face to face under the old lamp share every groove.
        assert!(least_separation(spherical(300.0, 0.0, 65.0), &ring(2, 45.0)) < 1e-6);
    }
}
