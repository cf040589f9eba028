//! The groove a tool cuts: its depth below the plate surface across the cut, D(u) >= 0 for
//! |u| <= width / 2, at a commanded depth z (real depth z + z offset).
use super::Tool;

/// One cut's cross-section.
#[derive(Clone, Debug, PartialEq)]
pub struct Section {
    tool: Tool,
    /// Real depth at the groove's centre, mm (> 0; a measured profile's cut at a commanded depth
    /// of 0 or less: 0).
    pub depth: f64,
    /// Visible width at the plate surface, mm.
    pub width: f64,
}

impl Section {
    /// The cut of `tool` at commanded depth `z`; `None` when it does not reach the plate. A
    /// measured profile cuts wherever its points say it is wider than 0, within them: its widths
    /// are at commanded depths, so a tool that reaches below its commanded zero (a positive z
    /// offset, folded into the points) cuts a groove at a commanded depth of 0 or less, as
    /// photos of its card show (the depth there, unknown, is taken as 0).
    pub fn of(tool: &Tool, z: f64) -> Option<Section> {
        let depth = z + tool.z_offset_mm();
        let listed = matches!(tool, Tool::Profile { points, .. } if points.first().is_some_and(|p| z >= p[0]));
        if !(depth > 0.0 || listed) {
            return None;
        }
        let depth = depth.max(0.0);
        let width = match tool {
            Tool::VBit {
                angle_deg, tip_flat_mm, ..
            } => tip_flat_mm + 2.0 * depth * (0.5 * angle_deg.to_radians()).tan(),
            Tool::Ball { radius_mm: r, .. } => {
                let h = depth.min(*r);
                2.0 * (2.0 * r * h - h * h).sqrt()
            }
            Tool::TaperedBall {
                radius_mm: r,
                angle_deg,
                ..
            } => {
                let (half, u_t, h_t) = tangent(*r, *angle_deg);
                if depth <= h_t {
                    2.0 * (2.0 * r * depth - depth * depth).sqrt()
                } else {
                    2.0 * (u_t + (depth - h_t) * half.tan())
                }
            }
            Tool::Profile { points, .. } => profile_width(points, z),
        };
        (width > 0.0).then(|| Section {
            tool: tool.clone(),
            depth,
            width,
        })
    }

    /// Depth below the surface at lateral offset `u` from the groove's centre (0 outside the cut).
    pub fn depth_at(&self, u: f64) -> f64 {
        let u = u.abs();
        let d = match &self.tool {
            Tool::VBit {
                angle_deg, tip_flat_mm, ..
            } => self.depth - (u - 0.5 * tip_flat_mm).max(0.0) / (0.5 * angle_deg.to_radians()).tan(),
            Tool::Ball { radius_mm: r, .. } => {
                if u >= *r {
                    0.0
                } else {
                    self.depth - (r - (r * r - u * u).sqrt())
                }
            }
            Tool::TaperedBall {
                radius_mm: r,
                angle_deg,
                ..
            } => {
                let (half, u_t, h_t) = tangent(*r, *angle_deg);
                if u <= u_t {
                    self.depth - (r - (r * r - u * u).sqrt())
                } else {
                    self.depth - h_t - (u - u_t) / half.tan()
                }
            }
            // A measured profile has widths only: a V of the same width and depth.
            Tool::Profile { .. } => self.depth * (1.0 - 2.0 * u / self.width),
        };
        if u > 0.5 * self.width {
            0.0
        } else {
            d.max(0.0)
        }
    }
}

/// Where a tapered ball's sphere meets its cone: (half angle in radians, lateral offset u_t,
/// height above the tip h_t).
fn tangent(r: f64, angle_deg: f64) -> (f64, f64, f64) {
    let half = 0.5 * angle_deg.to_radians();
    (half, r * half.cos(), r * (1.0 - half.sin()))
}

/// Width at commanded depth `z` by linear interpolation of `points` ([z, W]), extrapolated
/// linearly from the first two points below the first one (to 0) and flat beyond the last.
fn profile_width(points: &[[f64; 2]], z: f64) -> f64 {
    if points.len() == 1 {
        return if z >= points[0][0] { points[0][1] } else { 0.0 };
    }
    if z >= points[points.len() - 1][0] {
        return points[points.len() - 1][1];
    }
    let k = points.iter().position(|p| p[0] > z).unwrap_or(1).max(1);
    let (a, b) = (points[k - 1], points[k]);
    let t = (z - a[0]) / (b[0] - a[0]);
    (a[1] + t * (b[1] - a[1])).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn widths_follow_the_formulas() {
        let v = Tool::VBit {
            angle_deg: 60.0,
            tip_flat_mm: 0.02,
            z_offset_mm: 0.01,
        };
        let s = v.section(0.04).unwrap();
        assert!((s.depth - 0.05).abs() < 1e-15);
        assert!((s.width - (0.02 + 2.0 * 0.05 * 30f64.to_radians().tan())).abs() < 1e-12);
        assert!((s.depth_at(0.0) - 0.05).abs() < 1e-15 && s.depth_at(0.5 * s.width).abs() < 1e-12);
        assert!(v.section(-0.02).is_none(), "above the plate: no cut");
        let b = Tool::Ball {
            radius_mm: 0.1,
            z_offset_mm: 0.0,
        };
        let s = b.section(0.02).unwrap();
        assert!((s.width - 2.0 * (2.0 * 0.1 * 0.02 - 0.0004f64).sqrt()).abs() < 1e-12);
        assert!(s.depth_at(0.5 * s.width).abs() < 1e-12);
        // A tapered ball is continuous where the ball meets the cone.
        let t = Tool::TaperedBall {
            radius_mm: 0.05,
            angle_deg: 30.0,
            z_offset_mm: 0.0,
        };
        let s = t.section(0.2).unwrap();
        let u_t = 0.05 * 15f64.to_radians().cos();
        assert!((s.depth_at(u_t - 1e-9) - s.depth_at(u_t + 1e-9)).abs() < 1e-7);
        assert!(s.depth_at(0.5 * s.width).abs() < 1e-9);
        let p = Tool::Profile {
            points: vec![[0.01, 0.05], [0.03, 0.09]],
            w_over_w: 1.2,
            z_offset_mm: 0.0,
        };
        assert!((p.section(0.02).unwrap().width - 0.07).abs() < 1e-12);
    }

    /// A measured profile's points at commanded depths of 0 or less (a tool that reaches below
    /// its commanded zero) are cuts; below its first point, above the plate, nothing is.
    #[test]
    fn a_profile_cuts_where_its_points_say_it_does() {
        let p = Tool::Profile {
            points: vec![[-0.01, 0.0], [-0.005, 0.01], [0.0, 0.02], [0.01, 0.04]],
            w_over_w: 1.2,
            z_offset_mm: 0.0,
        };
        assert!(p.section(-0.01).is_none(), "width 0: no cut");
        let s = p.section(-0.005).expect("a listed width above 0 is a cut");
        assert!((s.width - 0.01).abs() < 1e-15 && s.depth == 0.0);
        assert!((p.section(0.0).unwrap().width - 0.02).abs() < 1e-15);
        assert!(p.model(-0.005).is_some_and(|m| m.w > 0.0 && m.d > 0.0));
        let q = Tool::Profile {
            points: vec![[0.01, 0.05], [0.03, 0.09]],
            w_over_w: 1.2,
            z_offset_mm: 0.0,
        };
        assert!(q.section(-0.002).is_none(), "above the plate and below its first point");
        assert!((q.section(0.005).unwrap().depth - 0.005).abs() < 1e-15);
    }
}
