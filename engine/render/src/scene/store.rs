//! The pair store: the forward's pair queues kept for the backward to replay, sized after the
//! first complete submission that asked for it, grown when a replay meets a chunk it lacks, and
//! dropped (backward passes then search: slower, same results) where it does not fit.
use super::*;

impl GpuScene {
    /// After a complete submission: the pair store, if a backward asked for one
    /// ([`want_store`](Self::want_store)), sized by this render's pairs (its queues hold a few
    /// more, pairs whose boxes overlap but not their areas: the slack covers them, and a store
    /// still too small is grown by the replay's check).
    pub(crate) fn after_complete(&mut self, ctx: &std::sync::Arc<Context>, raw: &[u32]) -> Result<(), GpuError> {
        if self.store_wanted.swap(false, std::sync::atomic::Ordering::Relaxed)
            && self.shading.shade.store_cap == 0
            && !self.store_off
        {
            self.size_store(ctx, Self::counters(raw).pairs)?;
        }
        Ok(())
    }

    /// Records that a backward searched the pairs although it could replay them: the next
    /// complete submission sizes the store.
    pub(crate) fn want_store(&self) {
        self.store_wanted.store(true, std::sync::atomic::Ordering::Relaxed);
    }

    /// Whether the forward stores its pair queues, so the backward can replay them.
    pub fn replay_ready(&self) -> bool {
        self.shading.shade.store_cap > 0
    }

    /// Entries the pair store holds (0: none).
    pub fn store_capacity(&self) -> u32 {
        self.shading.shade.store_cap
    }

    /// Test hook: a pair store of `entries` entries, whatever the scene needs (a forward that
    /// needs more leaves chunks out, and a replay that meets one must not be trusted).
    #[doc(hidden)]
    pub fn force_store_capacity(&mut self, ctx: &std::sync::Arc<Context>, entries: u32) -> Result<(), GpuError> {
        self.alloc_store(ctx, entries)
    }

    /// Bytes of the pair store: 2 words per tile-list entry, then `entries` entries.
    pub(super) fn store_bytes(&self, entries: u64) -> u64 {
        (2 * self.bin.capacity as u64 + entries) * 4
    }

    /// A pair store of `entries` entries (the forward stores from the next render).
    pub(super) fn alloc_store(&mut self, ctx: &std::sync::Arc<Context>, entries: u32) -> Result<(), GpuError> {
        let bytes = self.store_bytes(entries as u64);
        self.shading.pair_store = Buffer::new_u32_texel(ctx, "pair store", bytes, MemLoc::GpuOnly)?;
        self.shading.shade.store_cap = entries;
        Ok(())
    }

    /// Bytes the pair store takes on the device (a 16-byte placeholder without a store).
    pub fn store_size(&self) -> u64 {
        self.shading.pair_store.size()
    }

    /// A pair store for `needed` entries (plus slack), or none when it would pass the device's
    /// storage-buffer limit (backward passes then search the pairs: slower, same results).
    pub(super) fn size_store(&mut self, ctx: &std::sync::Arc<Context>, needed: u64) -> Result<(), GpuError> {
        let cap = needed + needed / 4 + 4096;
        // The replay reads it through a texel view too (4-byte texels).
        let limit = ctx
            .info()
            .max_storage_buffer_range
            .min(ctx.info().max_texel_buffer_elements.saturating_mul(4));
        if cap > u32::MAX as u64 || self.store_bytes(cap) > limit {
            return self.drop_store(ctx, true);
        }
        match self.alloc_store(ctx, cap as u32) {
            Ok(()) => Ok(()),
            // Out of device memory: the replay is an optimization, go on without it.
            Err(GpuError::OutOfMemory { .. } | GpuError::Allocation { .. }) => self.drop_store(ctx, true),
            Err(e) => Err(e),
        }
    }

    /// No pair store (`off`: not again for this scene; else until a backward asks for one).
    pub(super) fn drop_store(&mut self, ctx: &std::sync::Arc<Context>, off: bool) -> Result<(), GpuError> {
        self.store_off |= off;
        self.shading.shade.store_cap = 0;
        self.shading.pair_store = Buffer::new_u32_texel(ctx, "pair store (unused)", 16, MemLoc::GpuOnly)?;
        Ok(())
    }
}
