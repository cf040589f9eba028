//! Scratches drawn facing the views. A groove lights an eye only where the half vector h
//! between that eye and the lamp lies within its roughness lobe of the groove's normal plane
//! (`crate::reach`): across a plate point, the grooves that serve a view run across the plate
//! projection of its h. Drawn in uniformly random directions, a scratch faces a view only by
//! chance, mostly near its lobe's edge; as the optimizer sharpens the lobes, those it does not
//! turn round fall out of every view: of a finished default design's 16,000 scratches, 9,000
//! to 11,000 face no view (engine/docs/worst_view.md).
//!
//! [`aim`] turns a share of the drawn scratches to face one view each, across its h within a
//! random half of the lobe. The view is drawn in proportion to the light its picture asks for
//! over the plate (its target in linear light, plus a floor so a dark view still gets some),
//! the midpoint where that view asks for light (rejection on the view's own low-discrepancy
//! sequence, so each view's scratches are placed by its own picture alone and do not clump).
//! Each keeps its drawn length where its view asks for light along all of it, and is shortened
//! to the stretch that does where the picture darkens sooner (a stroke of text, a small bright
//! patch): a scratch lights its view along its whole length, so one drawn across a dark stroke
//! lights the stroke (engine/docs/worst_view.md, "Lengths fitted to the picture"). The rest keep
//! their random places, directions and lengths.
use scratchart_model::camera::ViewGeom;
use scratchart_model::display::{display, linear};

use crate::problem::Problem;
use crate::reach::{half_vector, lobe};
use crate::scenes::Rng;

/// What every view is asked for at least, in linear light, when a scratch's view is drawn: a
/// view dark at a point still gets a few of its scratches (its picture may brighten as the
/// design runs, and the exposure is free in some modes).
const FLOOR: f64 = 0.02;

/// How many aimed and how many of each view: the counts `aim` reports.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Aimed {
    pub per_view: Vec<usize>,
}

/// The R3 sequence's steps (1 / g, 1 / g^2, 1 / g^3, g the root of x^4 = x + 1).
const R3: [f64; 3] = [
    0.819_172_513_396_164_4,
    0.671_043_606_703_789_2,
    0.549_700_477_901_970_3,
];

/// Points per side of the grid on which each view's asked light is summed.
const GRID: usize = 64;

/// Turns `share` (0 to 1) of `problem`'s scratches to face a view (module docs), each drawn
/// from the random stream `seed`: the view in proportion to the light its picture asks for over
/// the whole plate, then the scratch's midpoint where that view asks for light (by rejection:
/// uniform points kept in proportion to the light asked there), so each view's scratches are
/// placed by its own picture alone, not where the other views ask for less. Each keeps its
/// drawn length or the stretch of it where its view asks for light ([`fit_run`]). Views without
/// targets keep none.
pub fn aim(problem: &mut Problem, share: f64, seed: u64) -> Aimed {
    let scene = &mut problem.scene;
    let m = scene.views.len().min(problem.targets.len());
    let mut aimed = Aimed { per_view: vec![0; m] };
    if m == 0 || !(share > 0.0) {
        return aimed;
    }
    let geoms: Vec<ViewGeom> = scene.views[..m].iter().map(|v| ViewGeom::of(v, &scene.plate)).collect();
    let half = 0.5 * scene.plate.size_mm;
    // Each view's light asked over the plate, and its largest on the grid.
    let grid = |k: usize| -half + (k as f64 + 0.5) * 2.0 * half / GRID as f64;
    let (mut total, mut peak) = (vec![0.0f64; m], vec![0.0f64; m]);
    for (j, g) in geoms.iter().enumerate() {
        for y in 0..GRID {
            for x in 0..GRID {
                let a = asked(g, &problem.targets[j], [grid(x), grid(y)]);
                total[j] += a;
                peak[j] = peak[j].max(a);
            }
        }
    }
    let sum: f64 = total.iter().sum();
    if !(sum > 0.0) {
        return aimed;
    }
    let mut rng = Rng::new(seed ^ 0xA1A1_5C2A_7C4E_5EED);
    let mut next = vec![1u64; m];
    let offs: Vec<[f64; 3]> = (0..m).map(|_| [rng.f64(), rng.f64(), rng.f64()]).collect();
    // Each aimed scratch's index, view, midpoint, direction and drawn length; their stretches
    // are fitted afterwards on all cores.
    let mut drawn: Vec<(usize, usize, [f64; 2], [f64; 2], f64)> = Vec::new();
    for (i, s) in scene.scratches.iter().enumerate() {
        if rng.f64() >= share {
            continue;
        }
        let mut r = rng.f64() * sum;
        let j = total
            .iter()
            .position(|&w| {
                r -= w;
                r < 0.0
            })
            .unwrap_or(m - 1);
        let l = (s.p1[0] - s.p0[0]).hypot(s.p1[1] - s.p0[1]);
        // A midpoint where view j asks for light, by rejection on the view's own R3 sequence
        // (x, y and the acceptance level): stratified, so the view's scratches do not clump
        // as independent draws do (clumps are streaks of light a smooth picture cannot
        // lose in the default's iterations). At most 1000 tries (a view that asks for light
        // on a sliver of the plate), else the scratch keeps its own place and direction.
        let mid = (0..1000).find_map(|_| {
            let k = next[j] as f64;
            next[j] += 1;
            let f = |i: usize| (offs[j][i] + k * R3[i]).fract();
            let x = [-half + 2.0 * half * f(0), -half + 2.0 * half * f(1)];
            (f(2) * peak[j] < asked(&geoms[j], &problem.targets[j], x)).then_some(x)
        });
        let Some(mid) = mid else { continue };
        let h = half_vector(&geoms[j], mid);
        if !(h[0].hypot(h[1]) > 1e-9) {
            continue; // h along the normal: every direction faces it
        }
        // Along the groove: perpendicular to h's plate projection, turned by up to half the lobe.
        let a = (-h[0]).atan2(h[1]) + 0.5 * rng.range(-1.0, 1.0) * lobe(s.alpha);
        drawn.push((i, j, mid, [a.cos(), a.sin()], l));
    }
    let fitted = scratchart_model::par::par_map(drawn.len(), |k| {
        let (_, j, mid, t, l) = drawn[k];
        fit_run(&geoms[j], &problem.targets[j], mid, t, l, scene.plate.size_mm)
    });
    for (&(i, j, _, t, _), (mid, l)) in drawn.iter().zip(fitted) {
        let reach = [0.5 * l * t[0].abs(), 0.5 * l * t[1].abs()];
        let c = [
            mid[0].clamp(-half + reach[0], half - reach[0]),
            mid[1].clamp(-half + reach[1], half - reach[1]),
        ];
        let s = &mut scene.scratches[i];
        s.p0 = [c[0] - 0.5 * l * t[0], c[1] - 0.5 * l * t[1]];
        s.p1 = [c[0] + 0.5 * l * t[0], c[1] + 0.5 * l * t[1]];
        aimed.per_view[j] += 1;
    }
    aimed
}

/// Where a fitted scratch ends: where its view asks for less than this share of the light it
/// asks for at the scratch's midpoint (where the picture turns dark, not where a gradient
/// dims it: 0.25 and 0.5 lift the page of text alike at the paper's scale, 0.8 less; at the
/// default's size 0.25 lifts the clock set where 0.5 lost it 0.005 (engine/docs/worst_view.md).
const RUN_LEVEL: f64 = 0.25;

/// The stretch of a scratch of drawn length `l` through `mid` along `t` that stays where view
/// `g` asks for light: from `mid` each way, in steps of half a pixel's size on the plate, while
/// the light asked is at least [`RUN_LEVEL`] of what it is at `mid`; the scratch keeps its
/// drawn length where the run holds it (moved along itself to lie within the run), else takes
/// the run's length (at least two pixels' size, never more than drawn) and its middle. Returns
/// the midpoint and the length. Each side walks at most the drawn length: at most 82 samples of
/// the target a side at 512 px, 23 at the default's 144 (scratches drawn up to 8% of the plate).
fn fit_run(g: &ViewGeom, target: &[f32], mid: [f64; 2], t: [f64; 2], l: f64, plate_mm: f64) -> ([f64; 2], f64) {
    let px = plate_mm / g.width.max(g.height).max(1) as f64;
    let step = 0.5 * px;
    // The light asked, FLOOR + linear(d), is at least the level where the display value d is at
    // least `dark` (one power here rather than one a sample).
    let need = RUN_LEVEL * asked(g, target, mid) - FLOOR;
    let dark = if need > 0.0 { display(need) } else { f64::NEG_INFINITY };
    let walk = |sign: f64| -> f64 {
        let mut s = 0.0;
        while s < l {
            let x = [mid[0] + sign * (s + step) * t[0], mid[1] + sign * (s + step) * t[1]];
            if !seen(g, target, x).is_some_and(|d| d >= dark) {
                break;
            }
            s += step;
        }
        s
    };
    let (a, b) = (walk(-1.0), walk(1.0));
    let len = l.min((a + b).max(2.0 * px));
    // Along itself by as little as keeps it within the run (the run's middle where it fills it).
    let (lo, hi) = (-a + 0.5 * len, b - 0.5 * len);
    let o = if lo <= hi { 0.0f64.clamp(lo, hi) } else { 0.5 * (b - a) };
    ([mid[0] + o * t[0], mid[1] + o * t[1]], len)
}

/// The light view `g`'s target asks for at sheet point `x` (its display value made linear, at
/// most 1, plus [`FLOOR`]); 0 where the view does not see it.
fn asked(g: &ViewGeom, target: &[f32], x: [f64; 2]) -> f64 {
    seen(g, target, x).map_or(0.0, |d| FLOOR + linear(d))
}

/// View `g`'s target at sheet point `x` (its display value, at most 1), or None where the view
/// does not see it.
fn seen(g: &ViewGeom, target: &[f32], x: [f64; 2]) -> Option<f64> {
    let p = g.shape.at_sheet(x).p;
    let (sx, sy) = g.project(p)?;
    let (w, h) = (g.width as usize, g.height as usize);
    if !(sx >= 0.0 && sy >= 0.0) || sx as usize >= w || sy as usize >= h || target.len() != w * h {
        return None;
    }
    Some(f64::from(target[sy as usize * w + sx as usize]).min(1.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes::{orbit_light, random_scratches, ring_views};
    use scratchart_model::scene::{Plate, Scene};

    /// Three views of a 100 mm plate (32 px), the lamp 65 degrees up between views 0 and 1, and
    /// 3000 random scratches; view 0's picture bright on the plate's right half (x > 0) and
    /// black elsewhere, the others mid grey.
    fn problem() -> Problem {
        problem_with(2.0, 8.0, |p| p[0] > 0.0)
    }

    /// [`problem`] with scratches drawn `lo` to `hi` mm long and view 0's picture bright where
    /// `bright` holds for the sheet point.
    fn problem_with(lo: f64, hi: f64, bright: impl Fn([f64; 2]) -> bool) -> Problem {
        let light = orbit_light(300.0, 65.0, 60.0, 1.0e4);
        let views = ring_views(3, 45.0, 300.0, 100.0, 32, &light);
        let mut rng = Rng::new(7);
        let scratches = random_scratches(&mut rng, 3000, 100.0, lo, hi, 0.05, 0.05, 0.06);
        let scene = Scene {
            plate: Plate::flat(100.0),
            views,
            scratches,
        };
        let half: Vec<f32> = (0..32 * 32)
            .map(|k| {
                let g = ViewGeom::of(&scene.views[0], &scene.plate);
                let x = g.hit((k % 32) as f64 + 0.5, (k / 32) as f64 + 0.5);
                if x.is_some_and(|x| bright([x[0], x[1]])) {
                    1.0
                } else {
                    0.0
                }
            })
            .collect();
        let grey = vec![0.5f32; 32 * 32];
        Problem::new(scene, vec![half, grey.clone(), grey])
    }

    fn length(s: &scratchart_model::scene::Scratch) -> f64 {
        (s.p1[0] - s.p0[0]).hypot(s.p1[1] - s.p0[1])
    }

    /// Which views each scratch faces (`reach::service` bits), judged with a lobe 0.6 times the
    /// drawn one (alpha 0.035 for 0.06): an aimed scratch is turned by at most half its lobe
    /// from facing.
    fn facing_sharply(p: &Problem) -> Vec<u64> {
        let mut s = p.scene.clone();
        s.scratches.iter_mut().for_each(|s| s.alpha = 0.035);
        crate::reach::service(&s)
    }

    /// Each aimed scratch faces the view it was drawn for (`reach::service`: h of that view
    /// within its lobe of the scratch's normal plane), lies on the plate, keeps its length where
    /// its view's picture is even (views 1 and 2), never grows, and is at least two pixels long;
    /// view 0's land where its picture is bright; the random ones face a view far less often.
    #[test]
    fn aimed_scratches_face_their_view_where_it_asks_for_light() {
        let before = problem();
        let mut p = before.clone();
        let aimed = aim(&mut p, 1.0, 3);
        assert_eq!(aimed.per_view.iter().sum::<usize>(), 3000, "{aimed:?}");
        // View 0 asks for light on half the plate at 1.0, the others everywhere at 0.5^2.2.
        let expect0 = 0.5 * (1.0 + FLOOR) + 0.5 * FLOOR;
        let expect = [expect0, FLOOR + linear(0.5), FLOOR + linear(0.5)];
        let share0 = expect[0] / expect.iter().sum::<f64>();
        let got0 = aimed.per_view[0] as f64 / 3000.0;
        assert!(
            (got0 - share0).abs() < 0.05,
            "view 0 drew {got0}, expected about {share0}"
        );
        let (bits, random_bits) = (facing_sharply(&p), facing_sharply(&before));
        let facing = |b: &[u64]| b.iter().filter(|&&b| b != 0).count();
        assert!(facing(&random_bits) < 2500, "random: {}", facing(&random_bits));
        assert_eq!(facing(&bits), 3000, "every aimed scratch faces a view");
        let (mut right, mut of0) = (0, 0);
        let (mut kept, mut of12) = (0, 0);
        for (s, (s0, b)) in p.scene.scratches.iter().zip(before.scene.scratches.iter().zip(&bits)) {
            let (l, l0) = (length(s), length(s0));
            assert!(l <= l0 + 1e-9 && l >= l0.min(2.0 * 100.0 / 32.0) - 1e-9, "{l0} -> {l}");
            if *b == 2 || *b == 4 {
                of12 += 1;
                kept += usize::from((l - l0).abs() < 1e-9);
            }
            assert!(s.p0.iter().chain(&s.p1).all(|c| c.abs() <= 50.0 + 1e-9), "{s:?}");
            // Facing view 0 alone: drawn for it.
            if *b == 1 {
                of0 += 1;
                right += usize::from(s.p0[0] + s.p1[0] > 0.0);
            }
        }
        assert!(of0 > 500, "{of0}");
        assert!(right as f64 > 0.9 * of0 as f64, "{right} of {of0} on the bright half");
        assert!(of12 > 500 && kept == of12, "{kept} of {of12} kept their lengths");
    }

    /// View 0's picture is a bright band 16 mm wide across its scratches (|y| < 8) and the
    /// scratches are drawn 20 to 30 mm long: those aimed at view 0 with their middle in the band
    /// end within about two pixels (6.25 mm) of it wherever they cross it, so most are shorter
    /// than drawn; views 1 and 2 (even grey) keep their lengths.
    #[test]
    fn aimed_scratches_end_where_their_picture_darkens() {
        let before = problem_with(20.0, 30.0, |p| p[1].abs() < 8.0);
        let mut p = before.clone();
        aim(&mut p, 1.0, 3);
        let bits = facing_sharply(&p);
        let (mut of0, mut shorter, mut of12, mut kept) = (0, 0, 0, 0);
        for (s, (s0, b)) in p.scene.scratches.iter().zip(before.scene.scratches.iter().zip(&bits)) {
            let (l, l0) = (length(s), length(s0));
            // (A few of view 0's are drawn where it is dark, for the floor of light every view
            // asks for: the floor holds along them, and they keep their lengths.)
            if *b == 1 && (s.p0[1] + s.p1[1]).abs() < 16.0 {
                of0 += 1;
                shorter += usize::from(l < l0 - 1e-6);
                for y in [s.p0[1], s.p1[1]] {
                    assert!(y.abs() <= 8.0 + 6.25, "an end at y = {y}: {s:?}");
                }
            } else if *b == 2 || *b == 4 {
                of12 += 1;
                kept += usize::from((l - l0).abs() < 1e-9);
            }
        }
        assert!(of0 > 200, "{of0}");
        assert!(shorter as f64 > 0.5 * of0 as f64, "{shorter} of {of0} shortened");
        assert!(of12 > 200 && kept == of12, "{kept} of {of12} kept their lengths");
    }

    /// Share 0 changes nothing; share 0.5 about half; the same seed the same scratches.
    #[test]
    fn the_share_and_the_seed_decide() {
        let before = problem();
        let mut p = before.clone();
        assert_eq!(aim(&mut p, 0.0, 3).per_view, vec![0; 3]);
        assert_eq!(p.scene.scratches, before.scene.scratches);
        let n = aim(&mut p, 0.5, 3).per_view.iter().sum::<usize>();
        assert!((1300..1700).contains(&n), "{n}");
        let moved = p
            .scene
            .scratches
            .iter()
            .zip(&before.scene.scratches)
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(moved, n);
        let mut q = before.clone();
        aim(&mut q, 0.5, 3);
        assert_eq!(p.scene.scratches, q.scene.scratches);
    }
}
