//! One-off transfers through staging buffers: [`Context::upload`] and [`Context::download`], on
//! a throwaway command buffer. Device-only buffers are always read back through a staging copy,
//! even where their memory happens to be mappable, so lavapipe runs the path a GPU takes.
use std::sync::Arc;

use ash::vk;

use super::{
    buffer::{Buffer, MemLoc},
    device::Context,
    error::{vk_err, GpuError},
};

impl Context {
    /// Records `f` into a throwaway command buffer, submits it and waits. Used for the rare
    /// staging transfers; hot paths use a [`super::Recorder`].
    pub(crate) fn one_shot(&self, f: impl FnOnce(vk::CommandBuffer)) -> Result<(), GpuError> {
        let d = &self.device;
        let pool_ci = vk::CommandPoolCreateInfo::default()
            .queue_family_index(self.queue_family)
            .flags(vk::CommandPoolCreateFlags::TRANSIENT);
        let pool = unsafe { d.create_command_pool(&pool_ci, None) }.map_err(vk_err("vkCreateCommandPool"))?;
        let result = (|| {
            let ai = vk::CommandBufferAllocateInfo::default()
                .command_pool(pool)
                .level(vk::CommandBufferLevel::PRIMARY)
                .command_buffer_count(1);
            let cmd = unsafe { d.allocate_command_buffers(&ai) }.map_err(vk_err("vkAllocateCommandBuffers"))?[0];
            let bi = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            unsafe { d.begin_command_buffer(cmd, &bi) }.map_err(vk_err("vkBeginCommandBuffer"))?;
            f(cmd);
            // Make transfer results visible to host reads after the fence.
            let mb = [vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                .dst_access_mask(vk::AccessFlags::HOST_READ)];
            unsafe {
                d.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::PipelineStageFlags::HOST,
                    vk::DependencyFlags::empty(),
                    &mb,
                    &[],
                    &[],
                )
            };
            unsafe { d.end_command_buffer(cmd) }.map_err(vk_err("vkEndCommandBuffer"))?;
            let fence =
                unsafe { d.create_fence(&vk::FenceCreateInfo::default(), None) }.map_err(vk_err("vkCreateFence"))?;
            let r = self.queue_submit(cmd, fence).and_then(|_| self.wait_fence(fence));
            if r.is_ok() {
                unsafe { d.destroy_fence(fence, None) };
            } else {
                // Hazard: after a timeout the work may still be pending; idle the device before
                // destroying what it uses.
                self.wait_idle();
                unsafe { d.destroy_fence(fence, None) };
            }
            r
        })();
        unsafe { d.destroy_command_pool(pool, None) };
        result
    }

    /// Creates a device-local storage buffer holding `data` (via a staging buffer).
    pub fn upload<T: bytemuck::Pod>(self: &Arc<Self>, name: &str, data: &[T]) -> Result<Buffer, GpuError> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let buf = Buffer::new(self, name, bytes.len() as u64, MemLoc::GpuOnly)?;
        if !bytes.is_empty() {
            let staging = Buffer::new(self, &format!("{name} (staging)"), bytes.len() as u64, MemLoc::CpuToGpu)?;
            staging.write(0, bytes)?;
            let region = [vk::BufferCopy::default().size(bytes.len() as u64)];
            self.one_shot(|cmd| unsafe { self.device.cmd_copy_buffer(cmd, staging.raw(), buf.raw(), &region) })?;
        }
        Ok(buf)
    }

    /// Reads back a whole buffer: device-only buffers through a staging copy, host-visible ones
    /// directly.
    pub fn download<T: bytemuck::Pod>(self: &Arc<Self>, buf: &Buffer) -> Result<Vec<T>, GpuError> {
        // Device-only buffers always go through a staging copy, even where their memory happens
        // to be mappable (lavapipe, resizable BAR): reading device-local memory from the host is
        // slow on real GPUs, and this way every test on lavapipe runs the path a GPU takes.
        if buf.is_host_visible() && !matches!(buf.location(), MemLoc::GpuOnly) {
            return buf.read();
        }
        let staging = Buffer::new(
            self,
            &format!("{} (readback)", buf.name()),
            buf.size(),
            MemLoc::GpuToCpu,
        )?;
        let region = [vk::BufferCopy::default().size(buf.size())];
        self.one_shot(|cmd| unsafe { self.device.cmd_copy_buffer(cmd, buf.raw(), staging.raw(), &region) })?;
        staging.read()
    }
}
