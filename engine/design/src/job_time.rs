//! A design's job time on a machine, as `scratchart-cal plan` makes it by default (the planner's
//! estimate over the plan's cut order, the +x mark and the registration marks,
//! `scratchart_machine::marks::design_job_time`), used by `design --machine`'s summary and by
//! `--max-job-min`.
use scratchart_machine::marks::{design_job_time, JobTime};
use scratchart_machine::plan::Cut;
use scratchart_model::scene::Scene;
use scratchart_tool::machine::MachineProfile;

/// A design's job time as `plan` makes it by default for machine `m`, its marks included: the
/// planner's estimate, the move-by-move upper bound and the registration marks' part of each.
pub fn job_time(scene: &Scene, depths: &[f64], m: &MachineProfile) -> JobTime {
    let cuts: Vec<Cut> = scene
        .scratches
        .iter()
        .zip(depths)
        .enumerate()
        .map(|(k, (s, &z))| Cut {
            a: s.p0,
            b: s.p1,
            z,
            scratch: k,
            bulge: s.bulge,
        })
        .collect();
    let widths: Vec<f64> = scene
        .scratches
        .iter()
        .map(|s| scratchart_machine::export::visible_width(s.w, s.d))
        .collect();
    design_job_time(&cuts, &widths, scene.plate.size_mm, &scene.views, m)
}
