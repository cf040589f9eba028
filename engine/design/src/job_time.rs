//! A design's job time on a machine, as `scratchart-cal plan` makes it (the planner's estimate
//! over the plan's cut order and the +x mark), used by `design --machine`'s summary and by
//! `--max-job-min`.
use scratchart_machine::plan::{design_job_time, Cut, TimeSplit};
use scratchart_model::scene::Scene;
use scratchart_tool::machine::MachineProfile;

/// A design's job time as `plan` makes it for machine `m`: the planner's estimate and the
/// move-by-move upper bound, s.
pub fn job_time(scene: &Scene, depths: &[f64], m: &MachineProfile) -> (TimeSplit, f64) {
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
    design_job_time(&cuts, &widths, scene.plate.size_mm, m)
}
