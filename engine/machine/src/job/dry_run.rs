//! The dry run's simulated controller (`--port sim`) and what it did.
use scratchart_observe::clock;
use scratchart_tool::machine::{Firmware, MachineProfile};

use crate::controller::Controller;
use crate::program::Program;
use std::time::Duration;

/// The simulated controller of a dry run: the plan's firmware, answering as the real one does
/// (GRBL's 128-byte buffer, `ok` and `error:N`; Marlin's numbered lines), at full speed, with
/// the machine profile's travel, rates and accelerations as its settings.
pub(super) fn simulated(
    program: &Program,
    profile: Option<&MachineProfile>,
) -> (crate::fake::Fake, crate::transport::PipeEnd) {
    use crate::fake::{FakeGrbl, FakeMarlin, GrblConfig, MarlinConfig};
    let m = profile.cloned().unwrap_or(match program.firmware {
        Firmware::Grbl => MachineProfile::grbl(),
        Firmware::Marlin => MachineProfile::marlin(),
    });
    match program.firmware {
        Firmware::Grbl => {
            let mut cfg = GrblConfig {
                line_delay: Duration::ZERO,
                hold_decel: Duration::from_millis(5),
                ..GrblConfig::default()
            };
            let v = |x: f64| format!("{x:.3}");
            for (k, x) in [
                (110, m.rapid_mm_min),
                (111, m.rapid_mm_min),
                (112, m.rapid_mm_min),
                (120, m.accel_mm_s2),
                (121, m.accel_mm_s2),
                (122, m.accel_mm_s2),
                (130, m.travel_mm[0]),
                (131, m.travel_mm[1]),
                (132, m.travel_mm[2]),
                (30, m.spindle_rpm.or(program.spindle_rpm).unwrap_or(1000.0)),
            ] {
                cfg.settings.insert(k, v(x));
            }
            FakeGrbl::simulated(cfg)
        }
        Firmware::Marlin => FakeMarlin::simulated(MarlinConfig {
            line_delay: Duration::ZERO,
            bed: Some(m.travel_mm),
            m503: Some(([m.rapid_mm_min / 60.0; 3], [m.accel_mm_s2; 3])),
            ..MarlinConfig::default()
        }),
    }
}

/// What a dry run's simulated controller did, for the summary.
pub(super) fn dry_run_note(
    fake: &crate::fake::Fake,
    ctl: &dyn Controller,
    timing: Option<&crate::program::Timing>,
    from: usize,
) -> String {
    let r = fake.record();
    format!(
        "dry run: the simulated {} executed {} motion lines; it ends at X{:.3} Y{:.3} \
             Z{:.3}; {}; the job would take {} on a machine with these rates",
        ctl.describe(),
        r.executed.len(),
        r.pos[0],
        r.pos[1],
        r.pos[2],
        if r.overflows.is_empty() {
            "its receive buffer never overflowed".to_string()
        } else {
            format!("its receive buffer overflowed {} times", r.overflows.len())
        },
        timing.map_or("?".into(), |t| clock(t.from(from)))
    )
}
