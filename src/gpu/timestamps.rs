//! The device's own clock around one compute pass, where the adapter has timestamp queries: the
//! time the GPU spent on the work, apart from submission, readback and the host, which on a
//! real GPU can take longer than the work itself.

use super::readback::read_mapped;
use super::GpuContext;
use crate::error::Result;

/// A begin and an end timestamp for one pass, and the buffers to read them back.
pub(crate) struct PassTimestamps {
    set: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    staging: wgpu::Buffer,
}

const BYTES: u64 = 2 * 8;

impl PassTimestamps {
    /// `None` where the adapter has no timestamp queries.
    pub(crate) fn new(ctx: &GpuContext) -> Option<PassTimestamps> {
        if !ctx.caps.timestamp_query {
            return None;
        }
        let device = &ctx.device;
        let buffer = |label, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: BYTES,
                usage,
                mapped_at_creation: false,
            })
        };
        Some(PassTimestamps {
            set: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            }),
            resolved: buffer(
                "pass timestamps resolved",
                wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            ),
            staging: buffer(
                "pass timestamps staging",
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            ),
        })
    }

    /// What the pass descriptor names: the first query at its beginning, the second at its end.
    pub(crate) fn writes(&self) -> wgpu::ComputePassTimestampWrites<'_> {
        wgpu::ComputePassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: Some(0),
            end_of_pass_write_index: Some(1),
        }
    }

    /// Records the copy of both timestamps to host-readable memory (after the pass).
    pub(crate) fn resolve(&self, enc: &mut wgpu::CommandEncoder) {
        enc.resolve_query_set(&self.set, 0..2, &self.resolved, 0);
        enc.copy_buffer_to_buffer(&self.resolved, 0, &self.staging, 0, BYTES);
    }

    /// Seconds between the two timestamps (after the submission that resolved them).
    pub(crate) fn seconds(&self, ctx: &GpuContext) -> Result<f64> {
        let ticks: Vec<u64> = read_mapped(ctx, &self.staging, BYTES)?;
        let period_ns = f64::from(ctx.queue.get_timestamp_period());
        Ok(ticks[1].saturating_sub(ticks[0]) as f64 * period_ns * 1e-9)
    }
}
