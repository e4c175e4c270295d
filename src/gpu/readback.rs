//! Copying GPU results back to host memory: textures with wgpu's 256-byte row alignment
//! removed, and plain buffers.

use super::GpuContext;
use crate::error::{Error, Result};

/// Reads an Rgba32Float texture back as row-major pixels.
pub(crate) fn read_rgba32f_texture(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
) -> Result<Vec<[f32; 4]>> {
    let (w, h) = (texture.width(), texture.height());
    let row = w as u64 * 16;
    let padded = row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as u64)
        * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as u64;
    let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: padded * h as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    enc.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded as u32),
                rows_per_image: Some(h),
            },
        },
        wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
    );
    ctx.queue.submit([enc.finish()]);
    let bytes = map_read(ctx, &buffer)?;
    let mut out = Vec::with_capacity(w as usize * h as usize);
    for y in 0..h as usize {
        let start = y * padded as usize;
        let line: &[[f32; 4]] = bytemuck::cast_slice(&bytes[start..start + row as usize]);
        out.extend_from_slice(line);
    }
    Ok(out)
}

/// Maps a MAP_READ buffer and copies its contents out.
pub(crate) fn map_read(ctx: &GpuContext, buffer: &wgpu::Buffer) -> Result<Vec<u8>> {
    read_mapped(ctx, buffer, buffer.size())
}

/// Maps a MAP_READ buffer the GPU has filled and copies its first `bytes` out as `T`s: the one
/// readback path of the renderers and the tone mapper.
pub(crate) fn read_mapped<T: bytemuck::Pod>(
    ctx: &GpuContext,
    buffer: &wgpu::Buffer,
    bytes: u64,
) -> Result<Vec<T>> {
    let slice = buffer.slice(..bytes.max(16).min(buffer.size()));
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    ctx.wait()?;
    rx.recv()
        .map_err(|_| Error::Gpu("readback was never answered".into()))?
        .map_err(|e| Error::Gpu(format!("readback failed: {e}")))?;
    let out = {
        let view = slice
            .get_mapped_range()
            .map_err(|e| Error::Gpu(format!("readback mapping failed: {e}")))?;
        bytemuck::pod_collect_to_vec(&view[..bytes.min(view.len() as u64) as usize])
    };
    buffer.unmap();
    Ok(out)
}
