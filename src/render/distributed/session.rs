//! One rank's part of a distributed render on a [`RenderSession`]: its slab read once per
//! session, ray-cast with the whole volume's rays, the partial images composited in visibility
//! order and the finished image handed to every rank (the module above says how).

use super::{composite, exchange, read_slab, Exchange, Placement, Scheme, Slab, GHOST};
use crate::error::{Error, Result};
use crate::model::bricks::MemorySource;
use crate::model::{HdrImage, Volume};
use crate::render::cache::KeyBuilder;
use crate::render::route::VolumeSource;
use crate::render::session::RenderSession;
use crate::render::volume::Geometry;
use crate::render::VolumeRenderOptions;
use std::sync::Arc;
use std::time::Instant;

/// One rank's share of a distributed render.
pub(crate) struct DistributedRender {
    pub image: HdrImage,
    /// Seconds of the slab's ray cast, of compositing (with the hand-out of the image).
    pub render_seconds: f64,
    pub composite_seconds: f64,
    pub compiled_pipeline: bool,
}

impl RenderSession {
    /// This rank's slab of `source` rendered, the partial images composited and the finished
    /// image handed to every rank (see the module documentation).
    pub(crate) fn render_distributed(
        &self,
        world: &dyn Exchange,
        source: &VolumeSource,
        opts: &VolumeRenderOptions,
    ) -> Result<DistributedRender> {
        let (rank, n) = (world.rank(), world.size());
        let dims = match source {
            VolumeSource::Memory(v) => v.dims,
            VolumeSource::Bricked(b) => b.dims,
        };
        let slab = Slab::new(dims[2], rank, n, source.name())?;
        let (spacing, origin, stats) = match source {
            VolumeSource::Memory(v) => (v.spacing, v.origin, v.stats()),
            VolumeSource::Bricked(b) => (b.spacing, b.origin, b.stats),
        };
        let part = self.slab_volume(source, &slab)?;
        let gpu_part = self.upload(&part)?;
        let whole = Geometry {
            name: source.name(),
            dims,
            spacing,
            origin,
            stats: &stats,
            voxel: crate::render::volume::min_spacing(spacing),
        };
        let t = Instant::now();
        let (partial, timing) = self.volume_renderer()?.render_slab(
            &gpu_part,
            &whole,
            opts,
            slab.shader_params(dims[2], spacing[2]),
        )?;
        let render_seconds = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let scheme = Scheme::for_ranks(n);
        let mut image = partial;
        let composited = composite::composite(world, std::mem::take(&mut image.pixels), scheme)?;
        let finished: Vec<[f32; 4]> = composited
            .map(|px| {
                px.into_iter()
                    .map(|p| composite::finish(p, opts.background))
                    .collect()
            })
            .unwrap_or_default();
        let bytes = exchange::broadcast(world, 0, bytemuck::cast_slice(&finished).to_vec())?;
        image.pixels = bytemuck::pod_collect_to_vec(&bytes);
        if image.pixels.len() != (opts.width * opts.height) as usize {
            return Err(Error::invalid(
                "distributed",
                "rank 0 handed out an image of the wrong size",
            ));
        }
        image.set_meta(
            "distributed",
            format!(
                "{n} ranks over {}, slabs along z, {} compositing",
                world.transport(),
                scheme.name()
            ),
        );
        Ok(DistributedRender {
            image,
            render_seconds,
            composite_seconds: t.elapsed().as_secs_f64(),
            compiled_pipeline: timing.compiled_pipeline,
        })
    }

    /// A rank's slab of `source`, read once per session (the `slab` stage).
    fn slab_volume(&self, source: &VolumeSource, slab: &Slab) -> Result<Arc<Volume>> {
        let key = KeyBuilder::new("slab")
            .u64(self.source_key(source))
            .debug(slab)
            .finish();
        self.stage_with(
            "slab",
            key,
            false,
            |v: &Volume| v.data.len() as u64 * 4,
            |_, _| {},
            || {
                let v = match source {
                    VolumeSource::Memory(v) => {
                        let place = Placement {
                            name: &v.name,
                            spacing: v.spacing,
                            origin: v.origin,
                        };
                        read_slab(&MemorySource(v.clone()), &place, slab)?
                    }
                    VolumeSource::Bricked(b) => {
                        let place = Placement {
                            name: &b.name,
                            spacing: b.spacing,
                            origin: b.origin,
                        };
                        read_slab(b.source().as_ref(), &place, slab)?
                    }
                };
                let detail = format!(
                    "rank {} of {}: z {}..{} (+{} ghost slices)",
                    slab.rank, slab.count, slab.z0, slab.z1, GHOST
                );
                Ok((v, detail))
            },
        )
    }
}
