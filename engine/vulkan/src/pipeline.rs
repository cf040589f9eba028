//! [`ComputePipeline`]: one compute shader with the engine's fixed binding convention:
//! set 0, bindings `0..num_buffers` storage buffers, then texel buffers (the views of
//! [`super::Buffer::new_texel`] and [`super::Buffer::new_u32_texel`]; none unless built with
//! [`ComputePipeline::with_texels`]), each
//! read (a uniform texel buffer, `samplerBuffer`) or written (a storage texel buffer,
//! `imageBuffer`); plus one push-constant range of `push_constant_bytes` at offset 0. The shader must declare exactly that interface
//! (validation reports a mismatch, naming the pipeline).
use std::sync::Arc;

use ash::vk;

use super::{
    device::Context,
    error::{vk_err, GpuError},
    shader::ShaderCompiler,
};

/// Texel-buffer bindings a pipeline may have (the shading kernels have four); the recorder's
/// descriptor pools are sized for it.
pub const MAX_TEXEL_BINDINGS: usize = 4;

/// A texel-buffer binding of a [`ComputePipeline`] (after its storage buffers).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Texel {
    /// Read with `texelFetch` (`uniform samplerBuffer`): a uniform texel buffer.
    Read,
    /// Written with `imageStore` (`uniform imageBuffer`, rgba32f): a storage texel buffer.
    Write,
}

impl Texel {
    pub fn descriptor_type(self) -> vk::DescriptorType {
        match self {
            Texel::Read => vk::DescriptorType::UNIFORM_TEXEL_BUFFER,
            Texel::Write => vk::DescriptorType::STORAGE_TEXEL_BUFFER,
        }
    }
}

pub struct ComputePipeline {
    ctx: Arc<Context>,
    pipeline: vk::Pipeline,
    layout: vk::PipelineLayout,
    set_layout: vk::DescriptorSetLayout,
    num_buffers: u32,
    texels: Vec<Texel>,
    push_bytes: u32,
    name: String,
}

impl ComputePipeline {
    /// Compiles `path` (see [`ShaderCompiler::compile`]) and builds the pipeline, named `path`.
    pub fn new(
        ctx: &Arc<Context>,
        compiler: &ShaderCompiler,
        path: &str,
        defines: &[(&str, &str)],
        num_buffers: u32,
        push_constant_bytes: u32,
    ) -> Result<ComputePipeline, GpuError> {
        let spirv = compiler.compile(path, defines)?;
        Self::from_spirv(ctx, path, &spirv, num_buffers, push_constant_bytes)
    }

    pub fn from_spirv(
        ctx: &Arc<Context>,
        name: &str,
        spirv: &[u32],
        num_buffers: u32,
        push_constant_bytes: u32,
    ) -> Result<ComputePipeline, GpuError> {
        Self::with_texels(ctx, name, spirv, num_buffers, &[], push_constant_bytes)
    }

    /// As [`from_spirv`](Self::from_spirv), with the texel buffers `texels` bound after the
    /// storage buffers (bindings `num_buffers..num_buffers + texels.len()`).
    pub fn with_texels(
        ctx: &Arc<Context>,
        name: &str,
        spirv: &[u32],
        num_buffers: u32,
        texels: &[Texel],
        push_constant_bytes: u32,
    ) -> Result<ComputePipeline, GpuError> {
        assert!(
            push_constant_bytes & 3 == 0 && push_constant_bytes <= ctx.info().max_push_constants_size,
            "pipeline '{name}': push constants must be a multiple of 4 bytes and at most {} (got {push_constant_bytes})",
            ctx.info().max_push_constants_size
        );
        assert!(
            texels.len() <= MAX_TEXEL_BINDINGS,
            "pipeline '{name}': {} texel bindings, at most MAX_TEXEL_BINDINGS = {MAX_TEXEL_BINDINGS}",
            texels.len()
        );
        let d = &ctx.device;
        let bindings: Vec<_> = (0..num_buffers + texels.len() as u32)
            .map(|i| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i)
                    .descriptor_type(if i < num_buffers {
                        vk::DescriptorType::STORAGE_BUFFER
                    } else {
                        texels[(i - num_buffers) as usize].descriptor_type()
                    })
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        let set_layout = unsafe {
            d.create_descriptor_set_layout(&vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings), None)
        }
        .map_err(vk_err("vkCreateDescriptorSetLayout"))?;
        // Name each object as soon as it exists, so creation errors already name them.
        ctx.set_object_name(set_layout, &format!("{name} (set layout)"));

        // Build the rest; on failure destroy what exists so far (nothing may leak: validation
        // reports leaked objects at vkDestroyDevice).
        let mut layout = vk::PipelineLayout::null();
        let result = (|| {
            let set_layouts = [set_layout];
            let ranges = [vk::PushConstantRange::default()
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
                .offset(0)
                .size(push_constant_bytes)];
            let lci = vk::PipelineLayoutCreateInfo::default()
                .set_layouts(&set_layouts)
                .push_constant_ranges(if push_constant_bytes > 0 { &ranges[..] } else { &[] });
            layout = unsafe { d.create_pipeline_layout(&lci, None) }.map_err(vk_err("vkCreatePipelineLayout"))?;
            ctx.set_object_name(layout, &format!("{name} (layout)"));

            let module = unsafe { d.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(spirv), None) }
                .map_err(vk_err("vkCreateShaderModule"))?;
            ctx.set_object_name(module, name);
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module)
                .name(c"main");
            let ci = [vk::ComputePipelineCreateInfo::default().stage(stage).layout(layout)];
            let r = unsafe { d.create_compute_pipelines(ctx.pipeline_cache(), &ci, None) };
            // The module is only needed during pipeline creation.
            unsafe { d.destroy_shader_module(module, None) };
            r.map(|p| p[0]).map_err(|(_, e)| vk_err("vkCreateComputePipelines")(e))
        })();
        let pipeline = match result {
            Ok(p) => p,
            Err(e) => {
                unsafe {
                    if layout != vk::PipelineLayout::null() {
                        d.destroy_pipeline_layout(layout, None);
                    }
                    d.destroy_descriptor_set_layout(set_layout, None);
                }
                return Err(e);
            }
        };
        ctx.set_object_name(pipeline, name);
        Ok(ComputePipeline {
            ctx: ctx.clone(),
            pipeline,
            layout,
            set_layout,
            num_buffers,
            texels: texels.to_vec(),
            push_bytes: push_constant_bytes,
            name: name.into(),
        })
    }

    pub fn name(&self) -> &str {
        &self.name
    }
    /// Storage-buffer bindings (the first ones).
    pub fn num_buffers(&self) -> u32 {
        self.num_buffers
    }
    /// Texel-buffer bindings (after the storage buffers).
    pub fn texels(&self) -> &[Texel] {
        &self.texels
    }
    pub fn push_constant_bytes(&self) -> u32 {
        self.push_bytes
    }
    pub fn raw(&self) -> vk::Pipeline {
        self.pipeline
    }
    pub fn layout(&self) -> vk::PipelineLayout {
        self.layout
    }
    pub fn set_layout(&self) -> vk::DescriptorSetLayout {
        self.set_layout
    }
}

impl Drop for ComputePipeline {
    fn drop(&mut self) {
        // Hazard: must not be in use by pending GPU work (recorders wait before returning).
        unsafe {
            let d = &self.ctx.device;
            d.destroy_pipeline(self.pipeline, None);
            d.destroy_pipeline_layout(self.layout, None);
            d.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}
