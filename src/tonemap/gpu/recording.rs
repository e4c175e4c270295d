//! One tone-mapping call being recorded: bind groups with windows of large buffers, the
//! dispatch shapes (per pixel, per item, one workgroup), the single submission with its error
//! scopes and readback, and the optional stage profile.

use super::bands::{Band, Window};
use super::{pixel_groups, GpuToneMapper, Specialisation};
use crate::error::{Error, Result};
use crate::gpu::transfer::ReadbackBuffer;
use crate::tonemap::StageClock;

/// One tone-mapping call being recorded: the context, its encoder and the uploaded image.
pub(super) struct Recording<'a> {
    pub(super) mapper: &'a GpuToneMapper,
    pub(super) spec: Specialisation,
    pub(super) encoder: wgpu::CommandEncoder,
    pub(super) width: u32,
    pub(super) height: u32,
    /// Windows (byte ranges) for the next dispatch's bindings; the rest are bound whole.
    pub(super) windows: Vec<(u32, Window)>,
    /// Textures for the next dispatch's bindings, beside its buffers.
    pub(super) textures: Vec<(u32, wgpu::TextureView)>,
}

impl Recording<'_> {
    pub(super) fn dispatch(
        &mut self,
        file: &'static str,
        entry: &'static str,
        bindings: &[(u32, &wgpu::Buffer)],
        groups: (u32, u32),
    ) -> Result<()> {
        let pipeline = self.mapper.pipeline(file, entry, self.spec)?;
        let windows = std::mem::take(&mut self.windows);
        let textures = std::mem::take(&mut self.textures);
        let mut entries: Vec<wgpu::BindGroupEntry> = bindings
            .iter()
            .map(|(binding, buffer)| wgpu::BindGroupEntry {
                binding: *binding,
                resource: match windows.iter().find(|(b, _)| b == binding) {
                    Some((_, w)) => wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer,
                        offset: w.offset,
                        size: wgpu::BufferSize::new(w.size),
                    }),
                    None => buffer.as_entire_binding(),
                },
            })
            .collect();
        entries.extend(textures.iter().map(|(binding, view)| wgpu::BindGroupEntry {
            binding: *binding,
            resource: wgpu::BindingResource::TextureView(view),
        }));
        let bind_group = self
            .mapper
            .ctx
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(entry),
                layout: &pipeline.get_bind_group_layout(0),
                entries: &entries,
            });
        let mut pass = self
            .encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(entry),
                timestamp_writes: None,
            });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups(groups.0, groups.1, 1);
        Ok(())
    }

    /// Binds `texture` at `binding` in the next dispatch.
    pub(super) fn texture(&mut self, binding: u32, texture: &wgpu::Texture) -> &mut Self {
        self.textures
            .push((binding, texture.create_view(&Default::default())));
        self
    }

    /// Binds `window` of the buffer at `binding` in the next dispatch.
    pub(super) fn window(&mut self, binding: u32, window: Window) -> &mut Self {
        self.windows.push((binding, window));
        self
    }

    /// One invocation per pixel of `band`.
    pub(super) fn pixels(
        &mut self,
        band: Band,
        file: &'static str,
        entry: &'static str,
        bindings: &[(u32, &wgpu::Buffer)],
    ) -> Result<()> {
        let groups = pixel_groups(self.width * band.rows);
        self.dispatch(file, entry, bindings, groups)
    }

    /// One invocation per item (grid cells, pyramid cells, cells x levels).
    pub(super) fn items(
        &mut self,
        count: u32,
        file: &'static str,
        entry: &'static str,
        bindings: &[(u32, &wgpu::Buffer)],
    ) -> Result<()> {
        self.dispatch(file, entry, bindings, pixel_groups(count))
    }

    /// One workgroup (combining partial results).
    pub(super) fn single(
        &mut self,
        file: &'static str,
        entry: &'static str,
        bindings: &[(u32, &wgpu::Buffer)],
    ) -> Result<()> {
        self.dispatch(file, entry, bindings, (1, 1))
    }

    /// Submits everything once, waits, checks the error scopes and reads `output` back.
    pub(super) fn finish(
        self,
        output: &ReadbackBuffer,
        validation: wgpu::ErrorScopeGuard,
        oom: wgpu::ErrorScopeGuard,
        profile: &StageClock,
    ) -> Result<Vec<[f32; 4]>> {
        let ctx = &self.mapper.ctx;
        let bytes = self.width as u64 * self.height as u64 * 16;
        let mut encoder = self.encoder;
        output.record_copy(&mut encoder, bytes);
        ctx.queue.submit([encoder.finish()]);
        if profile.on() {
            ctx.wait()?;
            profile.mark("passes");
        }
        let invalid = pollster::block_on(validation.pop());
        let out_of_memory = pollster::block_on(oom.pop());
        if let Some(e) = out_of_memory {
            return Err(Error::Gpu(format!(
                "out of GPU memory while tone mapping: {e}"
            )));
        }
        if let Some(e) = invalid {
            return Err(Error::Gpu(format!("tone-mapping pass failed: {e}")));
        }
        let pixels = output.read(ctx, bytes);
        profile.mark("readback");
        pixels
    }
}
