//! Compute pipelines: the one way a WGSL shader becomes a module and a module a pipeline. Each
//! build runs in a validation error scope, so a shader that does not compile is an error naming
//! the pipeline rather than a panic, and every pipeline goes through the context's on-disk
//! pipeline cache.

use super::GpuContext;
use crate::error::{Error, Result};

/// Whether wgpu injects runtime checks (buffer index clamps, loop bounds) into a shader.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RuntimeChecks(wgpu::ShaderRuntimeChecks);

impl RuntimeChecks {
    /// wgpu's checks stay in: the safe default.
    pub(crate) fn checked() -> RuntimeChecks {
        RuntimeChecks(wgpu::ShaderRuntimeChecks::checked())
    }

    /// No injected checks, for kernels whose checks cost a large share of their time.
    ///
    /// # Safety
    ///
    /// The shader must never index a buffer or array out of bounds and every loop must end;
    /// the caller states why at the call.
    pub(crate) unsafe fn unchecked() -> RuntimeChecks {
        RuntimeChecks(wgpu::ShaderRuntimeChecks::unchecked())
    }
}

/// Where a pipeline's shader comes from.
pub(crate) enum Shader<'a> {
    /// WGSL source (as [`super::shader::load`] returns it), compiled for this pipeline.
    Wgsl {
        /// The module's label, usually the shader's file name.
        label: &'a str,
        source: String,
        checks: RuntimeChecks,
    },
    /// A module compiled before, shared by several entry points (see [`compile`]).
    Module(&'a wgpu::ShaderModule),
}

/// What to build.
pub(crate) struct ComputeSpec<'a> {
    /// Debug label of the pipeline and of its layouts.
    pub(crate) label: &'a str,
    /// How a build failure names the pipeline: "`what` failed to build: wgpu's message".
    pub(crate) what: &'a str,
    pub(crate) shader: Shader<'a>,
    pub(crate) entry: &'a str,
    /// Values of the shader's `override` constants.
    pub(crate) constants: &'a [(&'a str, f64)],
}

/// Compiles WGSL into a module on its own; a compile error is "`label` failed to compile: …".
pub(crate) fn compile(
    ctx: &GpuContext,
    label: &str,
    source: String,
    checks: RuntimeChecks,
) -> Result<wgpu::ShaderModule> {
    let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let module = module(ctx, label, source, checks);
    match pollster::block_on(scope.pop()) {
        Some(e) => Err(Error::Gpu(format!("{label} failed to compile: {e}"))),
        None => Ok(module),
    }
}

/// A compute pipeline with one bind group (group 0) laid out as `entries`; returns the pipeline
/// and that group's layout, for making bind groups.
pub(crate) fn compute_with_layout(
    ctx: &GpuContext,
    spec: ComputeSpec<'_>,
    entries: &[wgpu::BindGroupLayoutEntry],
) -> Result<(wgpu::ComputePipeline, wgpu::BindGroupLayout)> {
    let (pipeline, layout) = build(ctx, spec, Some(entries))?;
    Ok((pipeline, layout.expect("an explicit layout was asked for")))
}

/// A compute pipeline with the layout wgpu derives from the shader (each entry point binds only
/// what it uses; fetch it with `get_bind_group_layout`).
pub(crate) fn compute(ctx: &GpuContext, spec: ComputeSpec<'_>) -> Result<wgpu::ComputePipeline> {
    Ok(build(ctx, spec, None)?.0)
}

fn build(
    ctx: &GpuContext,
    spec: ComputeSpec<'_>,
    entries: Option<&[wgpu::BindGroupLayoutEntry]>,
) -> Result<(wgpu::ComputePipeline, Option<wgpu::BindGroupLayout>)> {
    let device = &ctx.device;
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let compiled;
    let module = match spec.shader {
        Shader::Wgsl {
            label,
            source,
            checks,
        } => {
            compiled = module(ctx, label, source, checks);
            &compiled
        }
        Shader::Module(m) => m,
    };
    let bind_group_layout = entries.map(|entries| {
        device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(spec.label),
            entries,
        })
    });
    let pipeline_layout = bind_group_layout.as_ref().map(|layout| {
        device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(spec.label),
            bind_group_layouts: &[Some(layout)],
            immediate_size: 0,
        })
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(spec.label),
        layout: pipeline_layout.as_ref(),
        module,
        entry_point: Some(spec.entry),
        compilation_options: wgpu::PipelineCompilationOptions {
            constants: spec.constants,
            // Every hdrvis shader writes its workgroup memory before reading it (the ray casters
            // and surface passes have none), so wgpu's zeroing would be wasted work.
            zero_initialize_workgroup_memory: false,
        },
        cache: ctx.pipeline_cache(),
    });
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(Error::Gpu(format!("{} failed to build: {e}", spec.what)));
    }
    Ok((pipeline, bind_group_layout))
}

fn module(
    ctx: &GpuContext,
    label: &str,
    source: String,
    checks: RuntimeChecks,
) -> wgpu::ShaderModule {
    let descriptor = wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    };
    // SAFETY: with checked runtime checks this is `create_shader_module`; unchecked ones can only
    // be had through the unsafe `RuntimeChecks::unchecked`, whose caller vouches for the shader.
    unsafe {
        ctx.device
            .create_shader_module_trusted(descriptor, checks.0)
    }
}
