//! Bind-group layout entries for compute shaders, so every pipeline states its bindings in one
//! line each.

/// A storage buffer at `binding`.
pub(crate) fn storage_buffer(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    entry(
        binding,
        wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
    )
}

/// A uniform buffer at binding 0, then `inputs` read-only and `outputs` read-write storage
/// buffers at the bindings after it, in that order.
pub(crate) fn uniform_then_storage(inputs: u32, outputs: u32) -> Vec<wgpu::BindGroupLayoutEntry> {
    std::iter::once(uniform_buffer(0))
        .chain((1..=inputs).map(|b| storage_buffer(b, true)))
        .chain((inputs + 1..=inputs + outputs).map(|b| storage_buffer(b, false)))
        .collect()
}

/// A uniform buffer at `binding`.
pub(crate) fn uniform_buffer(binding: u32) -> wgpu::BindGroupLayoutEntry {
    entry(
        binding,
        wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
    )
}

/// A sampled float texture at `binding`.
pub(crate) fn texture(
    binding: u32,
    dimension: wgpu::TextureViewDimension,
    filterable: bool,
) -> wgpu::BindGroupLayoutEntry {
    entry(
        binding,
        wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable },
            view_dimension: dimension,
            multisampled: false,
        },
    )
}

/// A write-only Rgba32Float 2-D storage texture at `binding`.
pub(crate) fn storage_texture_rgba32f(binding: u32) -> wgpu::BindGroupLayoutEntry {
    entry(
        binding,
        wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::WriteOnly,
            format: wgpu::TextureFormat::Rgba32Float,
            view_dimension: wgpu::TextureViewDimension::D2,
        },
    )
}

/// A filtering sampler at `binding`.
pub(crate) fn filtering_sampler(binding: u32) -> wgpu::BindGroupLayoutEntry {
    entry(
        binding,
        wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
    )
}

/// A non-filtering (nearest) sampler at `binding`.
pub(crate) fn nearest_sampler(binding: u32) -> wgpu::BindGroupLayoutEntry {
    entry(
        binding,
        wgpu::BindingType::Sampler(wgpu::SamplerBindingType::NonFiltering),
    )
}

fn entry(binding: u32, ty: wgpu::BindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty,
        count: None,
    }
}
