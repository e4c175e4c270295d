//! Large storage buffers the host fills or reads without a staging copy where the adapter
//! allows it. On CPU adapters the context enables MAPPABLE_PRIMARY_BUFFERS
//! ([`super::Capabilities::mappable_primary_buffers`]): the storage buffer itself is mapped, so
//! an upload is one copy from host memory and a readback one copy into it. Elsewhere the same
//! calls fall back to `Queue::write_buffer_with` (written straight into wgpu's staging memory)
//! and to a copy into a MAP_READ staging buffer. Buffers are meant to be kept and reused: a
//! fresh buffer costs an allocation, page faults and wgpu's zero-initialisation.

use super::GpuContext;
use crate::error::{Error, Result};

/// A storage buffer the host uploads into (binding it read-only or read-write).
pub(crate) struct UploadBuffer {
    pub buffer: wgpu::Buffer,
    direct: bool,
}

impl UploadBuffer {
    /// A buffer of `bytes` (rounded up to 16) with STORAGE usage plus `extra`.
    pub(crate) fn new(
        ctx: &GpuContext,
        label: &str,
        bytes: u64,
        extra: wgpu::BufferUsages,
    ) -> Self {
        let direct = ctx.caps.mappable_primary_buffers;
        let mut usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | extra;
        if direct {
            usage |= wgpu::BufferUsages::MAP_WRITE;
        }
        let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(16).next_multiple_of(16),
            usage,
            mapped_at_creation: false,
        });
        UploadBuffer { buffer, direct }
    }

    /// Writes `data` at the start of the buffer. The GPU must not be using the buffer (every
    /// caller waits for its submission before the next upload). Without direct mapping the
    /// bytes land in wgpu's staging memory and are copied at the next submit.
    pub(crate) fn write(&self, ctx: &GpuContext, data: &[u8]) -> Result<()> {
        self.write_with(ctx, data.len() as u64, |mut dst| dst.copy_from_slice(data))
    }

    /// Hands the first `size` bytes of the buffer's host-visible memory (the mapped buffer, or
    /// wgpu's staging memory; write-only, as it may be write-combining) to `fill`, so a caller
    /// can produce its data in place — in parallel, and scanning it on the way — rather than
    /// copy a finished array.
    pub(crate) fn write_with(
        &self,
        ctx: &GpuContext,
        size: u64,
        fill: impl FnOnce(wgpu::WriteOnly<'_, [u8]>),
    ) -> Result<()> {
        if size == 0 {
            return Ok(());
        }
        if size > self.buffer.size() {
            return Err(Error::Gpu(format!(
                "upload of {size} bytes into a {}-byte buffer",
                self.buffer.size()
            )));
        }
        if self.direct {
            let slice = self.buffer.slice(..size);
            let (tx, rx) = std::sync::mpsc::channel();
            slice.map_async(wgpu::MapMode::Write, move |r| {
                let _ = tx.send(r);
            });
            ctx.wait()?;
            rx.recv()
                .map_err(|_| Error::Gpu("upload mapping was never answered".into()))?
                .map_err(|e| Error::Gpu(format!("upload mapping failed: {e}")))?;
            {
                let mut view = slice
                    .get_mapped_range_mut()
                    .map_err(|e| Error::Gpu(format!("upload mapping failed: {e}")))?;
                fill(view.slice(..));
            }
            self.buffer.unmap();
        } else {
            let len = wgpu::BufferSize::new(size).expect("non-empty upload");
            let mut view = ctx
                .queue
                .write_buffer_with(&self.buffer, 0, len)
                .ok_or_else(|| Error::Gpu("upload staging allocation failed".into()))?;
            fill(view.slice(..));
        }
        Ok(())
    }
}

/// A storage buffer the GPU writes and the host reads back.
pub(crate) struct ReadbackBuffer {
    pub buffer: wgpu::Buffer,
    /// The MAP_READ copy target when the storage buffer itself cannot be mapped.
    staging: Option<wgpu::Buffer>,
}

impl ReadbackBuffer {
    /// A buffer of `bytes` (rounded up to 16) with STORAGE usage plus `extra`.
    pub(crate) fn new(
        ctx: &GpuContext,
        label: &str,
        bytes: u64,
        extra: wgpu::BufferUsages,
    ) -> Self {
        let size = bytes.max(16).next_multiple_of(16);
        let direct = ctx.caps.mappable_primary_buffers;
        let mut usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | extra;
        if direct {
            usage |= wgpu::BufferUsages::MAP_READ;
        }
        let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage,
            mapped_at_creation: false,
        });
        let staging = (!direct).then(|| {
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        });
        ReadbackBuffer { buffer, staging }
    }

    /// Records the copy of the first `bytes` into the staging buffer, when there is one; call
    /// after the passes that write the buffer, before submitting.
    pub(crate) fn record_copy(&self, encoder: &mut wgpu::CommandEncoder, bytes: u64) {
        if let Some(staging) = &self.staging {
            let size = bytes.max(16).next_multiple_of(4).min(staging.size());
            encoder.copy_buffer_to_buffer(&self.buffer, 0, staging, 0, size);
        }
    }

    /// Waits for the submitted work and copies the first `bytes` out as `T`s.
    pub(crate) fn read<T: bytemuck::Pod>(&self, ctx: &GpuContext, bytes: u64) -> Result<Vec<T>> {
        let mapped = self.staging.as_ref().unwrap_or(&self.buffer);
        super::readback::read_mapped(ctx, mapped, bytes)
    }
}
