//! [`Buffer`]: a storage buffer with its `gpu-allocator` memory. Every buffer is usable as a
//! storage buffer and as a transfer source/destination, so any buffer can be bound to any
//! compute pipeline, filled, copied or read back. A buffer made with [`Buffer::new_texel`] can
//! also be bound as a uniform texel buffer (`samplerBuffer`, RGBA32F texels): read through
//! `texelFetch`, which CPU drivers (llvmpipe) compile to vector gathers where a storage-buffer or
//! shared-memory load with a per-lane index becomes a scalar loop over the lanes.
use std::sync::Arc;

use ash::vk;
use gpu_allocator::{
    vulkan::{Allocation, AllocationCreateDesc, AllocationScheme},
    AllocationError, MemoryLocation,
};

use super::{
    device::Context,
    error::{vk_err, GpuError},
};

/// Where a buffer's memory lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MemLoc {
    /// Device-local; fill with [`Context::upload`], read with [`Context::download`].
    GpuOnly,
    /// Host-visible, written by the CPU (staging, per-frame parameters).
    CpuToGpu,
    /// Host-visible and cached, read by the CPU (readback).
    GpuToCpu,
}

pub struct Buffer {
    ctx: Arc<Context>,
    raw: vk::Buffer,
    /// `Option` so `Drop` can move it into `Allocator::free`.
    allocation: Option<Allocation>,
    size: u64,
    loc: MemLoc,
    name: String,
    /// The texel view of [`Buffer::new_texel`] (RGBA32F) and [`Buffer::new_u32_texel`] (R32_UINT)
    /// buffers.
    texel_view: Option<vk::BufferView>,
}

impl Buffer {
    /// A buffer that is also a texel buffer of RGBA32F texels (16 bytes each) over its whole
    /// size, to read (uniform texel buffer) or write (storage texel buffer): bind it to a
    /// pipeline's texel bindings (see [`super::ComputePipeline`]). Its size is bounded by the
    /// device's texel count, not by its storage-buffer range (bound as a storage buffer, such a
    /// buffer must fit that range too). Fails with a clear error past the texel limit.
    pub fn new_texel(ctx: &Arc<Context>, name: &str, size: u64, loc: MemLoc) -> Result<Buffer, GpuError> {
        Self::with_view(ctx, name, size, loc, vk::Format::R32G32B32A32_SFLOAT, 16, false)
    }

    /// A storage buffer that can also be read as a uniform texel buffer of 32-bit unsigned
    /// texels (`usamplerBuffer`, R32_UINT) over its whole size: a kernel writes it as a storage
    /// buffer and a later one gathers from it with `texelFetch` (on CPU drivers a vector gather,
    /// where a storage-buffer load with a per-lane index is a scalar loop). Bounded by both the
    /// storage-buffer range and the texel count; fails with a clear error past either.
    pub fn new_u32_texel(ctx: &Arc<Context>, name: &str, size: u64, loc: MemLoc) -> Result<Buffer, GpuError> {
        Self::with_view(ctx, name, size, loc, vk::Format::R32_UINT, 4, true)
    }

    fn with_view(
        ctx: &Arc<Context>,
        name: &str,
        size: u64,
        loc: MemLoc,
        format: vk::Format,
        texel_bytes: u64,
        storage_range: bool,
    ) -> Result<Buffer, GpuError> {
        let size = size.max(16).next_multiple_of(16);
        let limit = ctx.info().max_texel_buffer_elements * texel_bytes;
        if size > limit {
            return Err(GpuError::BufferTooLarge {
                name: format!("{name} (a texel buffer: {} texels)", size / texel_bytes),
                size,
                limit,
            });
        }
        let usage = vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER | vk::BufferUsageFlags::STORAGE_TEXEL_BUFFER;
        let mut b = Self::create(ctx, name, size, loc, usage, storage_range)?;
        let ci = vk::BufferViewCreateInfo::default()
            .buffer(b.raw)
            .format(format)
            .offset(0)
            .range(vk::WHOLE_SIZE);
        let view = unsafe { ctx.device.create_buffer_view(&ci, None) }.map_err(vk_err("vkCreateBufferView"))?;
        ctx.set_object_name(view, name);
        b.texel_view = Some(view);
        Ok(b)
    }

    /// The texel view (buffers made with [`Buffer::new_texel`] or [`Buffer::new_u32_texel`]).
    pub fn texel_view(&self) -> Option<vk::BufferView> {
        self.texel_view
    }

    /// Creates a buffer of `size` bytes (0 becomes 16: Vulkan forbids empty buffers).
    pub fn new(ctx: &Arc<Context>, name: &str, size: u64, loc: MemLoc) -> Result<Buffer, GpuError> {
        Self::create(ctx, name, size, loc, vk::BufferUsageFlags::empty(), true)
    }

    fn create(
        ctx: &Arc<Context>,
        name: &str,
        size: u64,
        loc: MemLoc,
        extra_usage: vk::BufferUsageFlags,
        storage_range: bool,
    ) -> Result<Buffer, GpuError> {
        let size = size.max(16);
        let limit = ctx.info().max_storage_buffer_range;
        if storage_range && size > limit {
            return Err(GpuError::BufferTooLarge {
                name: name.into(),
                size,
                limit,
            });
        }
        let d = &ctx.device;
        let ci = vk::BufferCreateInfo::default()
            .size(size)
            .usage(
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_SRC
                    | vk::BufferUsageFlags::TRANSFER_DST
                    | extra_usage,
            )
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        let raw = unsafe { d.create_buffer(&ci, None) }.map_err(|e| match e {
            vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY => GpuError::OutOfMemory {
                name: name.into(),
                size,
            },
            e => vk_err("vkCreateBuffer")(e),
        })?;
        let requirements = unsafe { d.get_buffer_memory_requirements(raw) };
        let location = match loc {
            MemLoc::GpuOnly => MemoryLocation::GpuOnly,
            MemLoc::CpuToGpu => MemoryLocation::CpuToGpu,
            MemLoc::GpuToCpu => MemoryLocation::GpuToCpu,
        };
        let allocation = ctx.allocator().allocate(&AllocationCreateDesc {
            name,
            requirements,
            location,
            linear: true,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        });
        let allocation = match allocation {
            Ok(a) => a,
            Err(e) => {
                unsafe { d.destroy_buffer(raw, None) };
                return Err(match e {
                    AllocationError::OutOfMemory => GpuError::OutOfMemory {
                        name: name.into(),
                        size,
                    },
                    e => GpuError::Allocation {
                        name: name.into(),
                        msg: e.to_string(),
                    },
                });
            }
        };
        if let Err(e) = unsafe { d.bind_buffer_memory(raw, allocation.memory(), allocation.offset()) } {
            let _ = ctx.allocator().free(allocation);
            unsafe { d.destroy_buffer(raw, None) };
            return Err(vk_err("vkBindBufferMemory")(e));
        }
        ctx.set_object_name(raw, name);
        Ok(Buffer {
            ctx: ctx.clone(),
            raw,
            allocation: Some(allocation),
            size,
            loc,
            name: name.into(),
            texel_view: None,
        })
    }

    /// Size in bytes (at least 16).
    pub fn size(&self) -> u64 {
        self.size
    }

    pub fn raw(&self) -> vk::Buffer {
        self.raw
    }

    pub fn name(&self) -> &str {
        &self.name
    }

    pub fn location(&self) -> MemLoc {
        self.loc
    }

    /// Whether the CPU can read/write the memory directly. Only coherent mappings count: we
    /// never flush/invalidate, so a non-coherent mapping would silently read stale data.
    /// (`GpuOnly` memory is host-visible on UMA devices and lavapipe.)
    pub fn is_host_visible(&self) -> bool {
        let a = self.allocation.as_ref().unwrap();
        a.mapped_ptr().is_some() && a.memory_properties().contains(vk::MemoryPropertyFlags::HOST_COHERENT)
    }

    fn mapped(&self) -> Result<*mut u8, GpuError> {
        let a = self.allocation.as_ref().unwrap();
        match a.mapped_ptr() {
            Some(p) if self.is_host_visible() => Ok(p.as_ptr() as *mut u8),
            _ => Err(GpuError::NotHostVisible(self.name.clone())),
        }
    }

    /// Writes `data` at `offset_bytes`. Host-visible buffers only. Hazard: the caller must make
    /// sure the GPU is not using the range (e.g. write before submitting, or after waiting).
    pub fn write<T: bytemuck::Pod>(&self, offset_bytes: u64, data: &[T]) -> Result<(), GpuError> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let ptr = self.mapped()?;
        assert!(
            offset_bytes
                .checked_add(bytes.len() as u64)
                .is_some_and(|end| end <= self.size),
            "write of {} bytes at offset {offset_bytes} overflows buffer '{}' ({} bytes)",
            bytes.len(),
            self.name,
            self.size
        );
        // SAFETY: the mapping covers `size` bytes and the range was checked above; raw copies
        // avoid creating `&mut [u8]` over memory the GPU may also access.
        unsafe { std::ptr::copy_nonoverlapping(bytes.as_ptr(), ptr.add(offset_bytes as usize), bytes.len()) };
        Ok(())
    }

    /// Reads the whole buffer as `size / size_of::<T>()` elements. Host-visible buffers only.
    pub fn read<T: bytemuck::Pod>(&self) -> Result<Vec<T>, GpuError> {
        let ptr = self.mapped()?;
        let n = self.size as usize / std::mem::size_of::<T>().max(1);
        let mut out = vec![T::zeroed(); n];
        let dst: &mut [u8] = bytemuck::cast_slice_mut(&mut out);
        // SAFETY: `dst.len() <= size`, inside the mapping.
        unsafe { std::ptr::copy_nonoverlapping(ptr as *const u8, dst.as_mut_ptr(), dst.len()) };
        Ok(out)
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        // Hazard: the GPU must be done with the buffer. Recorder::submit_and_wait and the
        // one-off transfers wait for completion, so this holds unless a submission timed out.
        if let Some(v) = self.texel_view.take() {
            unsafe { self.ctx.device.destroy_buffer_view(v, None) };
        }
        if let Some(a) = self.allocation.take() {
            let _ = self.ctx.allocator().free(a);
        }
        unsafe { self.ctx.device.destroy_buffer(self.raw, None) };
    }
}

impl std::fmt::Debug for Buffer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Buffer")
            .field("name", &self.name)
            .field("size", &self.size)
            .field("loc", &self.loc)
            .finish()
    }
}
