//! Upscaling by the copy engine: while moving (and no target is shown) the present pass writes
//! only the internal-resolution image, which is copied into a small [`StagingImage`] and blitted,
//! filtered, onto the swapchain image. On lavapipe a full-size compute present pass costs ~15 ms
//! at 1280x720 (one gather per sample); the blit runs through the driver's optimised copy path.
//! Used only when the swapchain format supports BLIT_DST and the staging format BLIT_SRC with
//! linear filtering; otherwise the present pass upsamples (see `frame.rs`).
//!
//! The blit filters display-encoded values (the present pass filters L): a preview-only
//! difference, gone in the still full-resolution frame, which never takes this path.
use std::sync::Arc;

use ash::vk;
use scratchart_vulkan::{Context, GpuError};

fn vk_fail(call: &'static str) -> impl Fn(vk::Result) -> GpuError {
    move |result| match result {
        vk::Result::ERROR_DEVICE_LOST => GpuError::DeviceLost,
        result => GpuError::Vk { call, result },
    }
}

/// Whether `format` (optimal tiling) can be a transfer destination, a blit source with linear
/// filtering and a blit destination.
pub fn blit_supported(ctx: &Context, format: vk::Format) -> bool {
    let props = unsafe {
        ctx.instance
            .get_physical_device_format_properties(ctx.physical_device, format)
    };
    props.optimal_tiling_features.contains(
        vk::FormatFeatureFlags::BLIT_SRC
            | vk::FormatFeatureFlags::BLIT_DST
            | vk::FormatFeatureFlags::SAMPLED_IMAGE_FILTER_LINEAR
            | vk::FormatFeatureFlags::TRANSFER_DST,
    )
}

/// A device-local 2D image with its own memory, the blit source.
pub struct StagingImage {
    ctx: Arc<Context>,
    pub image: vk::Image,
    memory: vk::DeviceMemory,
    pub size: (u32, u32),
    pub format: vk::Format,
}

impl StagingImage {
    pub fn new(ctx: &Arc<Context>, format: vk::Format, size: (u32, u32)) -> Result<StagingImage, GpuError> {
        let d = &ctx.device;
        let ci = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width: size.0,
                height: size.1,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::TRANSFER_SRC)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        let image = unsafe { d.create_image(&ci, None) }.map_err(vk_fail("vkCreateImage"))?;
        ctx.set_object_name(image, "upscale staging image");
        let req = unsafe { d.get_image_memory_requirements(image) };
        let mem_props = unsafe { ctx.instance.get_physical_device_memory_properties(ctx.physical_device) };
        let pick = |want: vk::MemoryPropertyFlags| {
            (0..mem_props.memory_type_count).find(|&i| {
                req.memory_type_bits & (1 << i) != 0 && mem_props.memory_types[i as usize].property_flags.contains(want)
            })
        };
        let Some(type_index) =
            pick(vk::MemoryPropertyFlags::DEVICE_LOCAL).or_else(|| pick(vk::MemoryPropertyFlags::empty()))
        else {
            unsafe { d.destroy_image(image, None) };
            return Err(GpuError::Allocation {
                name: "upscale staging image".into(),
                msg: "no memory type fits the image".into(),
            });
        };
        let ai = vk::MemoryAllocateInfo::default()
            .allocation_size(req.size)
            .memory_type_index(type_index);
        let memory = match unsafe { d.allocate_memory(&ai, None) } {
            Ok(m) => m,
            Err(e) => {
                unsafe { d.destroy_image(image, None) };
                return Err(vk_fail("vkAllocateMemory")(e));
            }
        };
        if let Err(e) = unsafe { d.bind_image_memory(image, memory, 0) } {
            unsafe {
                d.destroy_image(image, None);
                d.free_memory(memory, None);
            }
            return Err(vk_fail("vkBindImageMemory")(e));
        }
        Ok(StagingImage {
            ctx: ctx.clone(),
            image,
            memory,
            size,
            format,
        })
    }
}

impl Drop for StagingImage {
    fn drop(&mut self) {
        // Hazard: frames are host-waited, so no submitted work still uses the image.
        unsafe {
            self.ctx.device.destroy_image(self.image, None);
            self.ctx.device.free_memory(self.memory, None);
        }
    }
}

fn barrier(
    image: vk::Image,
    old: vk::ImageLayout,
    new: vk::ImageLayout,
    src: vk::AccessFlags,
    dst: vk::AccessFlags,
) -> vk::ImageMemoryBarrier<'static> {
    vk::ImageMemoryBarrier::default()
        .src_access_mask(src)
        .dst_access_mask(dst)
        .old_layout(old)
        .new_layout(new)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(
            vk::ImageSubresourceRange::default()
                .aspect_mask(vk::ImageAspectFlags::COLOR)
                .level_count(1)
                .layer_count(1),
        )
}

fn layers() -> vk::ImageSubresourceLayers {
    vk::ImageSubresourceLayers::default()
        .aspect_mask(vk::ImageAspectFlags::COLOR)
        .layer_count(1)
}

/// Records: output buffer -> `small` (its full size), then a filtered blit of `small` onto the
/// whole swapchain image of `extent`, left in PRESENT_SRC. The present pass's writes to `out`
/// must already be made TRANSFER_READ-visible (the recorder's barrier does that).
pub fn record_blit(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    out: vk::Buffer,
    small: &StagingImage,
    swap: vk::Image,
    extent: (u32, u32),
    nearest: bool,
) {
    use vk::{AccessFlags as A, ImageLayout as L, PipelineStageFlags as S};
    let d = &ctx.device;
    let (sw, sh) = small.size;
    let copy = [vk::BufferImageCopy::default()
        .image_subresource(layers())
        .image_extent(vk::Extent3D {
            width: sw,
            height: sh,
            depth: 1,
        })];
    let corner = |w: u32, h: u32| {
        [
            vk::Offset3D::default(),
            vk::Offset3D {
                x: w as i32,
                y: h as i32,
                z: 1,
            },
        ]
    };
    let blit = [vk::ImageBlit::default()
        .src_subresource(layers())
        .src_offsets(corner(sw, sh))
        .dst_subresource(layers())
        .dst_offsets(corner(extent.0, extent.1))];
    unsafe {
        d.cmd_pipeline_barrier(
            cmd,
            S::TOP_OF_PIPE,
            S::TRANSFER,
            vk::DependencyFlags::empty(),
            &[],
            &[],
            &[
                barrier(
                    small.image,
                    L::UNDEFINED,
                    L::TRANSFER_DST_OPTIMAL,
                    A::empty(),
                    A::TRANSFER_WRITE,
                ),
                barrier(
                    swap,
                    L::UNDEFINED,
                    L::TRANSFER_DST_OPTIMAL,
                    A::empty(),
                    A::TRANSFER_WRITE,
                ),
            ],
        );
        d.cmd_copy_buffer_to_image(cmd, out, small.image, L::TRANSFER_DST_OPTIMAL, &copy);
        d.cmd_pipeline_barrier(
            cmd,
            S::TRANSFER,
            S::TRANSFER,
            vk::DependencyFlags::empty(),
            &[],
            &[],
            &[barrier(
                small.image,
                L::TRANSFER_DST_OPTIMAL,
                L::TRANSFER_SRC_OPTIMAL,
                A::TRANSFER_WRITE,
                A::TRANSFER_READ,
            )],
        );
        d.cmd_blit_image(
            cmd,
            small.image,
            L::TRANSFER_SRC_OPTIMAL,
            swap,
            L::TRANSFER_DST_OPTIMAL,
            &blit,
            if nearest {
                vk::Filter::NEAREST
            } else {
                vk::Filter::LINEAR
            },
        );
        d.cmd_pipeline_barrier(
            cmd,
            S::TRANSFER,
            S::BOTTOM_OF_PIPE,
            vk::DependencyFlags::empty(),
            &[],
            &[],
            &[barrier(
                swap,
                L::TRANSFER_DST_OPTIMAL,
                L::PRESENT_SRC_KHR,
                A::TRANSFER_WRITE,
                A::empty(),
            )],
        );
    }
}
