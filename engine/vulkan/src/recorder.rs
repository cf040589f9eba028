//! [`Recorder`]: records compute work into one reusable command buffer, submits it and waits,
//! and reads back GPU timestamps as [`Timings`].
//!
//! Usage: `begin()`, then any number of `dispatch`/`barrier`/`fill`/`copy`/`timestamp`, then
//! `submit_and_wait()`. Descriptor sets are allocated per dispatch from growable pools that are
//! reset in `begin()`.
//!
//! Hazards the caller owns: consecutive dispatches are *not* ordered unless a
//! [`barrier`](Recorder::barrier) separates them; and the buffers and pipelines passed in must
//! stay alive until `submit_and_wait` returns (the recorder only stores raw handles).
use std::sync::Arc;

use ash::vk;

use super::{
    buffer::Buffer,
    device::Context,
    error::{vk_err, GpuError},
    pipeline::{ComputePipeline, MAX_TEXEL_BINDINGS},
};

const MAX_QUERIES: u32 = 256;
const SETS_PER_POOL: u32 = 256;
const DESCRIPTORS_PER_POOL: u32 = SETS_PER_POOL * 8;

/// GPU time per labelled section of one submission.
#[derive(Clone, Debug, Default)]
pub struct Timings {
    /// (label, milliseconds since the previous timestamp), in recording order. The first
    /// interval starts at the timestamp `begin()` writes. Empty if timestamps are unsupported.
    pub entries: Vec<(String, f64)>,
}

impl Timings {
    /// Milliseconds of the first section labelled `label`.
    pub fn get(&self, label: &str) -> Option<f64> {
        self.entries.iter().find(|(l, _)| l == label).map(|(_, ms)| *ms)
    }

    pub fn total_ms(&self) -> f64 {
        self.entries.iter().map(|(_, ms)| ms).sum()
    }
}

pub struct Recorder {
    ctx: Arc<Context>,
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    desc_pools: Vec<vk::DescriptorPool>,
    /// Index of the pool currently allocated from.
    desc_cursor: usize,
    query_pool: Option<vk::QueryPool>,
    /// Label of every timestamp after the initial one.
    labels: Vec<String>,
    /// Number of queries written (initial one included).
    queries: u32,
    recording: bool,
    /// Submitted and not yet known complete (e.g. after a timeout); waited for before reuse.
    pending: bool,
    warned_queries: bool,
}

impl Recorder {
    pub fn new(ctx: &Arc<Context>) -> Result<Recorder, GpuError> {
        let d = &ctx.device;
        let pool = unsafe {
            d.create_command_pool(
                &vk::CommandPoolCreateInfo::default()
                    .queue_family_index(ctx.queue_family)
                    .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER),
                None,
            )
        }
        .map_err(vk_err("vkCreateCommandPool"))?;
        // From here `rec`'s Drop cleans up whatever was created if a later step fails.
        let mut rec = Recorder {
            ctx: ctx.clone(),
            pool,
            cmd: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
            desc_pools: Vec::new(),
            desc_cursor: 0,
            query_pool: None,
            labels: Vec::new(),
            queries: 0,
            recording: false,
            pending: false,
            warned_queries: false,
        };
        let ai = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        rec.cmd = unsafe { d.allocate_command_buffers(&ai) }.map_err(vk_err("vkAllocateCommandBuffers"))?[0];
        rec.fence =
            unsafe { d.create_fence(&vk::FenceCreateInfo::default(), None) }.map_err(vk_err("vkCreateFence"))?;
        if ctx.info().timestamps {
            let qp = unsafe {
                d.create_query_pool(
                    &vk::QueryPoolCreateInfo::default()
                        .query_type(vk::QueryType::TIMESTAMP)
                        .query_count(MAX_QUERIES),
                    None,
                )
            }
            .map_err(vk_err("vkCreateQueryPool"))?;
            rec.query_pool = Some(qp);
            ctx.set_object_name(qp, "recorder timestamps");
        }
        rec.add_desc_pool()?;
        ctx.set_object_name(pool, "recorder");
        ctx.set_object_name(rec.cmd, "recorder");
        ctx.set_object_name(rec.fence, "recorder");
        Ok(rec)
    }

    fn add_desc_pool(&mut self) -> Result<(), GpuError> {
        let sizes = [
            vk::DescriptorPoolSize::default()
                .ty(vk::DescriptorType::STORAGE_BUFFER)
                .descriptor_count(DESCRIPTORS_PER_POOL),
            vk::DescriptorPoolSize::default()
                .ty(vk::DescriptorType::UNIFORM_TEXEL_BUFFER)
                .descriptor_count(MAX_TEXEL_BINDINGS as u32 * SETS_PER_POOL),
            vk::DescriptorPoolSize::default()
                .ty(vk::DescriptorType::STORAGE_TEXEL_BUFFER)
                .descriptor_count(MAX_TEXEL_BINDINGS as u32 * SETS_PER_POOL),
        ];
        let p = unsafe {
            self.ctx.device.create_descriptor_pool(
                &vk::DescriptorPoolCreateInfo::default()
                    .max_sets(SETS_PER_POOL)
                    .pool_sizes(&sizes),
                None,
            )
        }
        .map_err(vk_err("vkCreateDescriptorPool"))?;
        self.ctx
            .set_object_name(p, &format!("recorder descriptors {}", self.desc_pools.len()));
        self.desc_pools.push(p);
        Ok(())
    }

    /// Waits for a previous submission that did not complete in time.
    fn wait_pending(&mut self) -> Result<(), GpuError> {
        if self.pending {
            self.ctx.wait_fence(self.fence)?;
            self.pending = false;
        }
        Ok(())
    }

    /// Starts a new recording: resets the command buffer, descriptor pools and timestamps, and
    /// writes the initial timestamp.
    pub fn begin(&mut self) -> Result<(), GpuError> {
        self.wait_pending()?;
        let d = &self.ctx.device;
        unsafe {
            d.reset_command_buffer(self.cmd, vk::CommandBufferResetFlags::empty())
                .map_err(vk_err("vkResetCommandBuffer"))?;
            for &p in &self.desc_pools {
                d.reset_descriptor_pool(p, vk::DescriptorPoolResetFlags::empty())
                    .map_err(vk_err("vkResetDescriptorPool"))?;
            }
            d.begin_command_buffer(
                self.cmd,
                &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
            )
            .map_err(vk_err("vkBeginCommandBuffer"))?;
        }
        self.desc_cursor = 0;
        self.labels.clear();
        self.queries = 0;
        self.recording = true;
        if let Some(qp) = self.query_pool {
            unsafe {
                d.cmd_reset_query_pool(self.cmd, qp, 0, MAX_QUERIES);
                d.cmd_write_timestamp(self.cmd, vk::PipelineStageFlags::BOTTOM_OF_PIPE, qp, 0);
            }
            self.queries = 1;
        }
        Ok(())
    }

    fn assert_recording(&self, what: &str) {
        assert!(
            self.recording,
            "Recorder::{what} called outside begin()/submit_and_wait()"
        );
    }

    fn alloc_set(&mut self, layout: vk::DescriptorSetLayout, name: &str) -> vk::DescriptorSet {
        let layouts = [layout];
        // Whether the current pool was created just now (and so is empty).
        let mut fresh = false;
        loop {
            let pool = self.desc_pools[self.desc_cursor];
            let ai = vk::DescriptorSetAllocateInfo::default()
                .descriptor_pool(pool)
                .set_layouts(&layouts);
            match unsafe { self.ctx.device.allocate_descriptor_sets(&ai) } {
                Ok(s) => return s[0],
                Err(vk::Result::ERROR_OUT_OF_POOL_MEMORY | vk::Result::ERROR_FRAGMENTED_POOL) => {
                    // Pool exhausted: move to the next (creating it if needed).
                    // A set that does not fit an empty pool would loop forever.
                    assert!(
                        !fresh,
                        "pipeline '{name}': descriptor set does not fit an empty descriptor pool"
                    );
                    self.desc_cursor += 1;
                    fresh = false;
                    if self.desc_cursor == self.desc_pools.len() {
                        if let Err(e) = self.add_desc_pool() {
                            panic!("pipeline '{name}': cannot create a descriptor pool: {e}");
                        }
                        fresh = true;
                    }
                }
                Err(e) => panic!("pipeline '{name}': vkAllocateDescriptorSets failed: {e}"),
            }
        }
    }

    /// Binds `buffers` to bindings `0..` of `p`, pushes `push`, dispatches `groups`.
    /// Any zero group count skips the dispatch.
    pub fn dispatch(&mut self, p: &ComputePipeline, buffers: &[&Buffer], push: &[u8], groups: [u32; 3]) {
        self.assert_recording("dispatch");
        let name = p.name();
        let n_storage = p.num_buffers() as usize;
        assert!(
            buffers.len() == n_storage + p.texels().len(),
            "pipeline '{name}' takes {} buffers ({} of them texel buffers), got {}",
            n_storage + p.texels().len(),
            p.texels().len(),
            buffers.len()
        );
        let views: Vec<vk::BufferView> = buffers[n_storage..]
            .iter()
            .map(|b| {
                b.texel_view().unwrap_or_else(|| {
                    panic!(
                        "pipeline '{name}': buffer '{}' has no texel view (Buffer::new_texel, new_u32_texel)",
                        b.name()
                    )
                })
            })
            .collect();
        assert!(
            push.len() == p.push_constant_bytes() as usize,
            "pipeline '{name}' takes {} push-constant bytes, got {}",
            p.push_constant_bytes(),
            push.len()
        );
        if groups.contains(&0) {
            return;
        }
        let max = self.ctx.info().max_workgroup_count;
        assert!(
            (0..3).all(|i| groups[i] <= max[i]),
            "pipeline '{name}': dispatch of {groups:?} workgroups exceeds the device limit {max:?}; split it"
        );
        let set = if buffers.is_empty() {
            None
        } else {
            Some(self.alloc_set(p.set_layout(), name))
        };
        let d = &self.ctx.device;
        if let Some(set) = set {
            if self.ctx.validation_enabled() {
                self.ctx.set_object_name(set, name);
            }
            let infos: Vec<_> = buffers
                .iter()
                .map(|b| {
                    [vk::DescriptorBufferInfo::default()
                        .buffer(b.raw())
                        .offset(0)
                        .range(vk::WHOLE_SIZE)]
                })
                .collect();
            let mut writes: Vec<_> = infos[..n_storage]
                .iter()
                .enumerate()
                .map(|(i, info)| {
                    vk::WriteDescriptorSet::default()
                        .dst_set(set)
                        .dst_binding(i as u32)
                        .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                        .buffer_info(info)
                })
                .collect();
            for (i, (v, t)) in views.iter().zip(p.texels()).enumerate() {
                writes.push(
                    vk::WriteDescriptorSet::default()
                        .dst_set(set)
                        .dst_binding((n_storage + i) as u32)
                        .descriptor_type(t.descriptor_type())
                        .texel_buffer_view(std::slice::from_ref(v)),
                );
            }
            unsafe { d.update_descriptor_sets(&writes, &[]) };
        }
        unsafe {
            d.cmd_bind_pipeline(self.cmd, vk::PipelineBindPoint::COMPUTE, p.raw());
            if let Some(set) = set {
                d.cmd_bind_descriptor_sets(self.cmd, vk::PipelineBindPoint::COMPUTE, p.layout(), 0, &[set], &[]);
            }
            if !push.is_empty() {
                d.cmd_push_constants(self.cmd, p.layout(), vk::ShaderStageFlags::COMPUTE, 0, push);
            }
            d.cmd_dispatch(self.cmd, groups[0], groups[1], groups[2]);
        }
    }

    /// Dispatches `n_groups` workgroups as `[min(n, 65535), ceil(n / gx), 1]`. Shaders compute
    /// the flat group id as `gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x` and must
    /// bounds-check (the grid can overshoot `n_groups` by up to `gx - 1` groups).
    pub fn dispatch_1d(&mut self, p: &ComputePipeline, buffers: &[&Buffer], push: &[u8], n_groups: u32) {
        if n_groups == 0 {
            // Still validate the call's contract.
            return self.dispatch(p, buffers, push, [0, 0, 0]);
        }
        let gx = n_groups.min(65535);
        let gy = n_groups.div_ceil(gx);
        self.dispatch(p, buffers, push, [gx, gy, 1]);
    }

    /// The command buffer being recorded, for commands this type does not wrap (image barriers
    /// and buffer-to-image copies of the viewer's swapchain). Only valid between `begin()` and
    /// `submit_and_wait()`; what is recorded into it follows the same hazard rules as above.
    pub fn raw_cmd(&self) -> vk::CommandBuffer {
        self.assert_recording("raw_cmd");
        self.cmd
    }

    /// Global memory barrier: all prior compute/transfer writes become visible to later
    /// compute, transfer and host accesses.
    pub fn barrier(&mut self) {
        self.assert_recording("barrier");
        let mb = [vk::MemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(
                vk::AccessFlags::SHADER_READ
                    | vk::AccessFlags::SHADER_WRITE
                    | vk::AccessFlags::TRANSFER_READ
                    | vk::AccessFlags::TRANSFER_WRITE
                    | vk::AccessFlags::HOST_READ,
            )];
        unsafe {
            self.ctx.device.cmd_pipeline_barrier(
                self.cmd,
                vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::COMPUTE_SHADER
                    | vk::PipelineStageFlags::TRANSFER
                    | vk::PipelineStageFlags::HOST,
                vk::DependencyFlags::empty(),
                &mb,
                &[],
                &[],
            )
        };
    }

    /// Fills the whole buffer with the 32-bit `value` (bytes past the last multiple of 4 are
    /// left untouched).
    pub fn fill(&mut self, buf: &Buffer, value: u32) {
        self.assert_recording("fill");
        unsafe {
            self.ctx
                .device
                .cmd_fill_buffer(self.cmd, buf.raw(), 0, vk::WHOLE_SIZE, value)
        };
    }

    /// Copies the first `bytes` bytes of `src` to the start of `dst`.
    pub fn copy(&mut self, src: &Buffer, dst: &Buffer, bytes: u64) {
        self.assert_recording("copy");
        assert!(
            bytes <= src.size() && bytes <= dst.size(),
            "copy of {bytes} bytes from '{}' ({} bytes) to '{}' ({} bytes) is out of range",
            src.name(),
            src.size(),
            dst.name(),
            dst.size()
        );
        if bytes == 0 {
            return;
        }
        let region = [vk::BufferCopy::default().size(bytes)];
        unsafe { self.ctx.device.cmd_copy_buffer(self.cmd, src.raw(), dst.raw(), &region) };
    }

    /// Records a timestamp ending the section `label`. No-op without timestamp support; past
    /// 255 labels per submission further ones are dropped (with a warning).
    pub fn timestamp(&mut self, label: &str) {
        self.assert_recording("timestamp");
        let Some(qp) = self.query_pool else { return };
        if self.queries >= MAX_QUERIES {
            if !self.warned_queries {
                self.ctx.warn(&format!(
                    "more than {} timestamps in one submission; dropping '{label}'",
                    MAX_QUERIES - 1
                ));
                self.warned_queries = true;
            }
            return;
        }
        unsafe {
            self.ctx
                .device
                .cmd_write_timestamp(self.cmd, vk::PipelineStageFlags::BOTTOM_OF_PIPE, qp, self.queries)
        };
        self.queries += 1;
        self.labels.push(label.to_string());
    }

    /// Ends recording, submits, waits (up to 60 s) and returns the timestamps.
    pub fn submit_and_wait(&mut self) -> Result<Timings, GpuError> {
        self.assert_recording("submit_and_wait");
        self.recording = false;
        let d = &self.ctx.device;
        // Make every write visible to the host, so buffers can be read right after the fence.
        let mb = [vk::MemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(vk::AccessFlags::HOST_READ)];
        unsafe {
            d.cmd_pipeline_barrier(
                self.cmd,
                vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::HOST,
                vk::DependencyFlags::empty(),
                &mb,
                &[],
                &[],
            );
            d.end_command_buffer(self.cmd).map_err(vk_err("vkEndCommandBuffer"))?;
            d.reset_fences(&[self.fence]).map_err(vk_err("vkResetFences"))?;
        }
        self.ctx.queue_submit(self.cmd, self.fence)?;
        self.pending = true;
        self.ctx.wait_fence(self.fence)?;
        self.pending = false;

        let mut timings = Timings::default();
        if let (Some(qp), true) = (self.query_pool, self.queries > 1) {
            let mut raw = vec![0u64; self.queries as usize];
            unsafe {
                d.get_query_pool_results(
                    qp,
                    0,
                    &mut raw,
                    vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                )
            }
            .map_err(vk_err("vkGetQueryPoolResults"))?;
            let bits = self.ctx.info().timestamp_valid_bits;
            let mask = if bits >= 64 { u64::MAX } else { (1u64 << bits) - 1 };
            let period = self.ctx.info().timestamp_period_ns;
            timings.entries = self
                .labels
                .iter()
                .zip(raw.windows(2))
                .map(|(l, w)| {
                    // Wrapping difference within the valid bits handles counter wrap-around.
                    let ticks = (w[1] & mask).wrapping_sub(w[0] & mask) & mask;
                    (l.clone(), ticks as f64 * period / 1e6)
                })
                .collect();
        }
        Ok(timings)
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        let d = &self.ctx.device;
        unsafe {
            if self.pending && self.fence != vk::Fence::null() {
                // Timed-out work may still use the command buffer: wait before destroying it.
                let _ = d.wait_for_fences(&[self.fence], true, u64::MAX);
            }
            for &p in &self.desc_pools {
                d.destroy_descriptor_pool(p, None);
            }
            if let Some(qp) = self.query_pool {
                d.destroy_query_pool(qp, None);
            }
            if self.fence != vk::Fence::null() {
                d.destroy_fence(self.fence, None);
            }
            d.destroy_command_pool(self.pool, None);
        }
    }
}
