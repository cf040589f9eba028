//! The walk (`--walk`, key W): the camera moves along the design views' cameras in order,
//! v0 -> v1 -> ... -> v{N-1} and back, as a viewer walking past a walk-past plate
//! (`scratchart design --walk`) sees it. Between two neighbouring views the orbit parameters are
//! interpolated ([`OrbitCamera::lerp`]: azimuth the shorter way round, elevation, distance, field
//! of view, target); each frame has the light of the view it is nearest to.
//!
//! Positions along the walk are real numbers: view k stands at `k`, a fraction `t` of the way
//! from view k to view k+1 at `k + t`. In the window the walk is timed: a gap takes
//! `|delta azimuth| / speed` seconds (a gap without an azimuth change takes 1 s), and the ping-pong
//! is a function of the time into a cycle, so it runs 0 -> N-1 -> 0 with no drift.
use scratchart_model::scene::View;

use crate::state::{short_turn, OrbitCamera};

/// Below this many degrees a gap counts as one without an azimuth change.
const NO_TURN_DEG: f64 = 1e-6;

/// A walk along a design's views.
#[derive(Clone, Debug)]
pub struct Walk {
    views: Vec<View>,
    cams: Vec<OrbitCamera>,
    /// Seconds each gap (view k to k+1) takes.
    durations: Vec<f64>,
    /// Seconds from view 0 to view k, one way (`starts[N-1]` is the one-way time).
    starts: Vec<f64>,
    /// Time into the current ping-pong cycle, in [0, 2 x one-way time).
    t: f64,
}

impl Walk {
    /// The walk along `views` at `speed_deg_s` degrees of azimuth per second; `None` with fewer
    /// than 2 views.
    pub fn new(views: &[View], speed_deg_s: f64) -> Option<Walk> {
        if views.len() < 2 {
            return None;
        }
        let cams: Vec<OrbitCamera> = views.iter().map(|v| OrbitCamera::from_camera(&v.camera)).collect();
        let durations: Vec<f64> = cams
            .windows(2)
            .map(|p| {
                let turn = short_turn(p[0].azimuth_deg, p[1].azimuth_deg).abs();
                if turn > NO_TURN_DEG {
                    turn / speed_deg_s
                } else {
                    1.0
                }
            })
            .collect();
        let mut starts = vec![0.0];
        for d in &durations {
            starts.push(starts.last().unwrap() + d);
        }
        Some(Walk {
            views: views.to_vec(),
            cams,
            durations,
            starts,
            t: 0.0,
        })
    }

    /// Number of views.
    fn len(&self) -> usize {
        self.views.len()
    }

    fn one_way(&self) -> f64 {
        self.starts[self.len() - 1]
    }

    /// Moves `dt` seconds on, turning at either end.
    pub fn advance(&mut self, dt: f64) {
        self.t = (self.t + dt.max(0.0)).rem_euclid(2.0 * self.one_way());
    }

    /// Puts the walk at view `idx`, heading towards the last view (towards the first from the
    /// last view).
    pub fn start_at(&mut self, idx: usize) {
        let idx = idx.min(self.len() - 1);
        self.t = if idx == self.len() - 1 {
            self.one_way()
        } else {
            self.starts[idx]
        };
    }

    /// True on the way from the first view to the last.
    pub fn forward(&self) -> bool {
        self.t < self.one_way()
    }

    /// The position along the walk now, in [0, N-1] (see the module's notes).
    pub fn position(&self) -> f64 {
        let one = self.one_way();
        let t = if self.t <= one { self.t } else { 2.0 * one - self.t };
        // The last gap starting at or before t.
        let g = self.starts[..self.len() - 1].iter().rposition(|&s| s <= t).unwrap_or(0);
        (g as f64 + (t - self.starts[g]) / self.durations[g]).clamp(0.0, (self.len() - 1) as f64)
    }

    /// The view nearest to position `pos` (ties go to the higher one).
    pub fn nearest(&self, pos: f64) -> usize {
        (pos.max(0.0).round() as usize).min(self.len() - 1)
    }

    /// The gap that `pos` lies in (k for a position in [k, k+1); the last gap at the end) and the
    /// fraction of the way through it.
    fn gap(&self, pos: f64) -> (usize, f64) {
        let g = (pos.max(0.0).floor() as usize).min(self.len() - 2);
        (g, pos - g as f64)
    }

    /// The orbit camera at position `pos`.
    pub fn camera_at(&self, pos: f64) -> OrbitCamera {
        let (g, t) = self.gap(pos);
        OrbitCamera::lerp(&self.cams[g], &self.cams[g + 1], t)
    }

    /// The view at position `pos`: at a whole number exactly that design view (camera, light,
    /// exposure, resolution); in between, the interpolated camera at the nearest view's
    /// resolution with the nearest view's light and exposure.
    pub fn view_at(&self, pos: f64) -> View {
        let near = &self.views[self.nearest(pos)];
        if pos.fract() == 0.0 {
            return near.clone();
        }
        let (g, t) = self.gap(pos);
        View {
            name: format!("{}-{} {:.0}%", self.views[g].name, self.views[g + 1].name, 100.0 * t),
            camera: self.camera_at(pos).camera(near.camera.width, near.camera.height),
            ..near.clone()
        }
    }

    /// Where the walk is, for the title: "walk v3 -> v4 41%" (the gap in the direction of
    /// travel and how far along it).
    pub fn label(&self) -> String {
        let pos = self.position();
        let (g, t) = self.gap(pos);
        let (a, b, f) = if self.forward() {
            (g, g + 1, t)
        } else {
            (g + 1, g, 1.0 - t)
        };
        format!(
            "walk {} -> {} {:.0}%",
            self.views[a].name,
            self.views[b].name,
            100.0 * f
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use scratchart_design::scenes::{orbit_camera, orbit_light};

    /// A view at azimuth `az`, elevation `el`, distance `dist` around the plate centre.
    fn view(name: &str, az: f64, el: f64, dist: f64) -> View {
        View {
            name: name.into(),
            camera: orbit_camera(dist, el, az, 40.0, 64, 48),
            light: orbit_light(400.0, 50.0, 200.0 + az, 9e4),
            exposure: 1.0,
        }
    }

    fn assert_same_eye(what: &str, a: &scratchart_model::scene::Camera, b: &scratchart_model::scene::Camera) {
        for i in 0..3 {
            assert!(
                (a.eye[i] - b.eye[i]).abs() < 1e-9,
                "{what}: eye {:?} vs {:?}",
                a.eye,
                b.eye
            );
            assert!((a.target[i] - b.target[i]).abs() < 1e-9, "{what}: target");
            assert!((a.up[i] - b.up[i]).abs() < 1e-9, "{what}: up");
        }
        assert!((a.fov_y_deg - b.fov_y_deg).abs() < 1e-9, "{what}: fov");
    }

    #[test]
    fn interpolation_ends_are_the_views() {
        let mut views = vec![view("v0", 10.0, 30.0, 300.0), view("v1", 50.0, 40.0, 350.0)];
        views[0].camera.fov_y_deg = 40.0;
        // v1 looks at a point off the centre, from the same angles and distance.
        views[1].camera.target = [5.0, -3.0, 0.0];
        views[1].camera.eye[0] += 5.0;
        views[1].camera.eye[1] -= 3.0;
        views[1].camera.fov_y_deg = 25.0;
        let cams: Vec<OrbitCamera> = views.iter().map(|v| OrbitCamera::from_camera(&v.camera)).collect();
        for (k, t) in [(0, 0.0), (1, 1.0)] {
            let c = OrbitCamera::lerp(&cams[0], &cams[1], t).camera(64, 48);
            assert_same_eye(&format!("t = {t}"), &c, &views[k].camera);
        }
        // Halfway: every parameter halfway.
        let m = OrbitCamera::lerp(&cams[0], &cams[1], 0.5);
        assert!((m.azimuth_deg - 30.0).abs() < 1e-9, "{m:?}");
        assert!((m.elevation_deg - 35.0).abs() < 1e-9, "{m:?}");
        assert!((m.distance - 0.5 * (cams[0].distance + cams[1].distance)).abs() < 1e-9);
        assert!((m.fov_y_deg - 32.5).abs() < 1e-9);
        assert!((m.target.x - 2.5).abs() < 1e-9 && (m.target.y + 1.5).abs() < 1e-9);
        // The walk gives the views themselves at whole positions.
        let w = Walk::new(&views, 10.0).unwrap();
        for k in 0..2 {
            assert_eq!(w.view_at(k as f64), views[k]);
            assert_same_eye(
                "walk camera_at",
                &w.camera_at(k as f64).camera(64, 48),
                &views[k].camera,
            );
        }
        // In between: the nearest view's light.
        assert_eq!(w.view_at(0.4).light, views[0].light);
        assert_eq!(w.view_at(0.6).light, views[1].light);
    }

    #[test]
    fn azimuth_takes_the_short_way_across_180() {
        let views = [view("a", 170.0, 30.0, 300.0), view("b", -170.0, 30.0, 300.0)];
        let (a, b) = (
            OrbitCamera::from_camera(&views[0].camera),
            OrbitCamera::from_camera(&views[1].camera),
        );
        assert!((short_turn(a.azimuth_deg, b.azimuth_deg) - 20.0).abs() < 1e-9);
        assert!((short_turn(b.azimuth_deg, a.azimuth_deg) + 20.0).abs() < 1e-9);
        for k in 0..=10 {
            let t = k as f64 / 10.0;
            let m = OrbitCamera::lerp(&a, &b, t);
            let want = 170.0 + 20.0 * t;
            assert!(
                short_turn(want, m.azimuth_deg).abs() < 1e-9,
                "t {t}: azimuth {} instead of {want}",
                m.azimuth_deg
            );
        }
        let c = OrbitCamera::lerp(&a, &b, 1.0).camera(64, 48);
        assert_same_eye("across 180 at t = 1", &c, &views[1].camera);
        // 20 degrees at 10 degrees per second: 2 s, not 34 s the long way round.
        let mut w = Walk::new(&views, 10.0).unwrap();
        w.advance(1.0);
        assert!((w.position() - 0.5).abs() < 1e-9, "{}", w.position());
    }

    #[test]
    fn ping_pong_runs_to_the_last_view_and_back() {
        // Gaps of 10, 30 and 0 degrees (the last differs in elevation only: 1 s).
        let views = [
            view("v0", 0.0, 30.0, 300.0),
            view("v1", 10.0, 30.0, 300.0),
            view("v2", 40.0, 30.0, 300.0),
            view("v3", 40.0, 45.0, 300.0),
        ];
        let mut w = Walk::new(&views, 10.0).unwrap();
        let one_way = 1.0 + 3.0 + 1.0;
        assert!((w.one_way() - one_way).abs() < 1e-9);
        let dt = 0.01;
        let steps = (2.0 * one_way / dt).round() as usize;
        let mut pos = vec![w.position()];
        for _ in 0..steps {
            w.advance(dt);
            pos.push(w.position());
        }
        assert_eq!(pos[0], 0.0);
        let top = pos
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map(|(i, _)| i)
            .unwrap();
        assert!((pos[top] - 3.0).abs() < 1e-6, "turns at {}", pos[top]);
        assert!(
            (top as f64 * dt - one_way).abs() < 1.5 * dt,
            "turned after {} s",
            top as f64 * dt
        );
        assert!(pos[..=top].windows(2).all(|p| p[1] >= p[0]), "not rising to N-1");
        assert!(pos[top..].windows(2).all(|p| p[1] <= p[0]), "not falling back to 0");
        assert!(pos.last().unwrap().abs() < 1e-6, "ends at {}", pos.last().unwrap());
        // Speeds: 1 s for the 10-degree gap, 3 s for the 30-degree one, 1 s for the last.
        let at = |s: f64| {
            let mut w = Walk::new(&views, 10.0).unwrap();
            w.advance(s);
            w.position()
        };
        for (s, p) in [
            (0.5, 0.5),
            (1.0, 1.0),
            (2.5, 1.5),
            (4.0, 2.0),
            (4.5, 2.5),
            (6.0, 2.0),
            (9.5, 0.5),
        ] {
            assert!((at(s) - p).abs() < 1e-9, "after {s} s: {} instead of {p}", at(s));
        }
        // Direction and label.
        let mut w = Walk::new(&views, 10.0).unwrap();
        w.advance(2.5);
        assert!(w.forward());
        assert_eq!(w.label(), "walk v1 -> v2 50%");
        w.advance(4.6); // 7.1 s: 2.1 s on the way back from v3, 1.1 s of the 3 s past v2
        assert!(!w.forward());
        assert_eq!(w.label(), "walk v2 -> v1 37%");
        w.start_at(3);
        assert_eq!(w.position(), 3.0);
        w.start_at(1);
        assert_eq!(w.position(), 1.0);
        assert!(w.forward());
    }

    #[test]
    fn one_view_is_no_walk() {
        assert!(Walk::new(&[view("v0", 0.0, 30.0, 300.0)], 10.0).is_none());
    }
}
