//! A scene whose scratches include arcs, uploaded as their chords (`crate::arcs`): what may and
//! may not be read of it.
use super::*;

impl GpuScene {
    /// Whether the scene's scratches include arcs (uploaded as chords: the kernels' scratches,
    /// their gradients and tangents are the chords', so nothing may read them as the scene's).
    pub fn has_arcs(&self) -> bool {
        self.arcs.is_some()
    }

    /// An error for work that needs the scene's own scratches on the device (gradients,
    /// tangents, optimization) when they include arcs.
    pub fn refuse_arcs(&self, what: &str) -> Result<(), GpuError> {
        match self.arcs {
            Some(n) => Err(GpuError::Capacity(format!(
                "{what} of arc scratches is not available yet: the scene's {n} scratches include arcs \
                 (a nonzero `bulge`), which render as {} chords; straighten them (bulge 0) for {what}",
                self.n_scratches
            ))),
            None => Ok(()),
        }
    }
}

/// A size error of a scene with arcs, saying that its scratches are counted as their chords.
pub(super) fn arcs_named(e: GpuError, scratches: usize, chords: usize) -> GpuError {
    let why = format!(
        "the scene's {scratches} scratches include arcs, uploaded as {chords} chords \
         (engine/docs/model.md section 11): fewer or shorter arcs, or larger alpha, take fewer"
    );
    match e {
        GpuError::BufferTooLarge { name, size, limit } => GpuError::BufferTooLarge {
            name: format!("{name}; {why}"),
            size,
            limit,
        },
        GpuError::Capacity(msg) => GpuError::Capacity(format!("{msg}; {why}")),
        other => other,
    }
}
