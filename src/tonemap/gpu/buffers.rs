//! The buffers a [`GpuToneMapper`](super::GpuToneMapper) keeps between calls: the uploaded
//! image, the display image read back, and scratch storage by label.

use crate::gpu::transfer::{ReadbackBuffer, UploadBuffer};
use crate::gpu::GpuContext;
use std::collections::HashMap;

/// The buffers of the last call, reused while the sizes stay the same.
#[derive(Default)]
pub(super) struct BufferCache {
    image: Option<UploadBuffer>,
    output: Option<ReadbackBuffer>,
    scratch: HashMap<&'static str, wgpu::Buffer>,
    textures: HashMap<&'static str, wgpu::Texture>,
}

impl BufferCache {
    pub(super) fn image(&mut self, ctx: &GpuContext, bytes: u64) -> &UploadBuffer {
        let size = bytes.max(16).next_multiple_of(16);
        if self.image.as_ref().map(|b| b.buffer.size()) != Some(size) {
            self.image = Some(UploadBuffer::new(
                ctx,
                "hdr image",
                size,
                wgpu::BufferUsages::empty(),
            ));
        }
        self.image.as_ref().expect("just made")
    }

    pub(super) fn output(&mut self, ctx: &GpuContext, bytes: u64) -> &ReadbackBuffer {
        let size = bytes.max(16).next_multiple_of(16);
        if self.output.as_ref().map(|b| b.buffer.size()) != Some(size) {
            self.output = Some(ReadbackBuffer::new(
                ctx,
                "display image",
                size,
                wgpu::BufferUsages::empty(),
            ));
        }
        self.output.as_ref().expect("just made")
    }

    /// A scratch storage buffer of exactly `bytes` (rounded up to 16) under `label`: shaders
    /// take lengths from `arrayLength`, so a larger cached buffer would not do.
    pub(super) fn scratch(
        &mut self,
        ctx: &GpuContext,
        label: &'static str,
        bytes: u64,
    ) -> wgpu::Buffer {
        let size = bytes.max(16).next_multiple_of(16);
        self.scratch
            .entry(label)
            .and_modify(|b| {
                if b.size() != size {
                    *b = new_storage(ctx, label, size);
                }
            })
            .or_insert_with(|| new_storage(ctx, label, size))
            .clone()
    }
}

impl BufferCache {
    /// A 2-D texture of exactly `width` x `height` texels of `format` under `label`, sampled
    /// and filled by copies.
    pub(super) fn texture(
        &mut self,
        ctx: &GpuContext,
        label: &'static str,
        format: wgpu::TextureFormat,
        (width, height): (u32, u32),
    ) -> wgpu::Texture {
        let size = wgpu::Extent3d {
            width: width.max(1),
            height: height.max(1),
            depth_or_array_layers: 1,
        };
        let make = || {
            ctx.device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            })
        };
        self.textures
            .entry(label)
            .and_modify(|t| {
                if t.size() != size || t.format() != format {
                    *t = make();
                }
            })
            .or_insert_with(make)
            .clone()
    }
}

fn new_storage(ctx: &GpuContext, label: &str, size: u64) -> wgpu::Buffer {
    ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}
