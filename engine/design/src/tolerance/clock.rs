//! Where the tolerance searches' wall time goes: the engine's calls (uploads, renders with their
//! waits, read-backs with the display conversion) and the host's own work (the moved eyes'
//! pictures, the blurs and correlations), with the device round trips counted. summary.json's
//! `wall_s` states it (`set_up_sheet_*`), so a GPU run shows which part to take next.
use serde_json::{json, Value};

/// Seconds and counts of one set-up sheet's searches.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SearchClock {
    /// Scenes uploaded (each a batch of views with its buffers) and their seconds.
    pub uploads: usize,
    pub upload_s: f64,
    /// Renders submitted (each one submission, or more where its lists grew) and their
    /// seconds: recording, the device's work and the wait.
    pub submissions: usize,
    pub render_s: f64,
    /// Images read back and converted to display values.
    pub read_s: f64,
    /// Host: the moved eyes' pictures (`as_seen_from`), and each render's blur and correlation.
    pub pictures_s: f64,
    pub measure_s: f64,
}

impl SearchClock {
    /// The seconds in the engine's calls.
    pub fn engine_s(&self) -> f64 {
        self.upload_s + self.render_s + self.read_s
    }

    /// Runs `f`, adding its wall seconds to the field `pick` chooses.
    pub fn time<R>(&mut self, pick: fn(&mut SearchClock) -> &mut f64, f: impl FnOnce() -> R) -> R {
        let t = std::time::Instant::now();
        let r = f();
        *pick(self) += t.elapsed().as_secs_f64();
        r
    }

    /// summary.json's `wall_s` keys (prefixed `set_up_sheet_`).
    pub fn to_json(&self) -> Value {
        json!({
            "set_up_sheet_uploads": self.uploads,
            "set_up_sheet_upload_s": self.upload_s,
            "set_up_sheet_submissions": self.submissions,
            "set_up_sheet_render_s": self.render_s,
            "set_up_sheet_read_s": self.read_s,
            "set_up_sheet_pictures_s": self.pictures_s,
            "set_up_sheet_measure_s": self.measure_s,
        })
    }
}
