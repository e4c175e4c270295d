//! Bricked rendering (`shaders/volume_bricked.wgsl`): a [`BrickedVolume`]'s bricks live in a GPU
//! atlas of fixed size (the brick cache) and a page table tells each sample where its brick is.
//!
//! * **Empty-space skipping**: bricks whose whole value range the transfer function maps to zero
//!   emission and extinction are marked EMPTY; rays jump across them. Re-evaluated from the
//!   per-brick ranges on every render, so a transfer-function change re-reads no data. Skipped
//!   samples would have added exactly nothing, so the image is the one without skipping (for the
//!   f32 and f16 compositing variants; u8 and f32c composite every sample).
//! * **Out-of-core**: when the bricks a render needs exceed the cache (sized by a memory budget),
//!   they stream through it in front-to-back visibility order, one pass per cache-full; rays keep
//!   their state in a buffer between passes and every sample is composited once, in ray order.
//!   A ray that finds its brick missing asks for it; the rare ray the visibility order does not
//!   serve (one starting within rounding of a brick face) is completed by extra passes.

use super::volume::{Geometry, VolumeRenderer};
use super::{Precision, VolumeRenderOptions};
use crate::error::{Error, Result};
use crate::gpu::{readback, GpuContext};
use crate::model::bricks::{visibility_order, BrickedVolume};
use crate::model::{HdrImage, Projection};
use std::sync::Arc;

/// Host mirror of `Bricks` in shaders/volume_bricked.wgsl — keep in sync.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct BrickParams {
    dims: [u32; 4],
    grid: [u32; 4],
    slots: [u32; 4],
    inv_atlas: [f32; 4],
}

const EMPTY: u32 = 0xffff_fffe;
const ABSENT: u32 = 0xffff_ffff;
const FIRST_PASS: u32 = 1;
const LAST_PASS: u32 = 2;
const KEEP_STATE: u32 = 4;
/// Ray state bytes per pixel: three vec4<f32> and one u32 of progress.
const STATE_BYTES_PER_PIXEL: u64 = 3 * 16 + 4;
/// Extra passes allowed for rays the visibility order did not serve.
const MAX_REPAIR_PASSES: usize = 64;

/// Where a brick is: in an atlas slot, or nowhere.
const NO_SLOT: u32 = u32::MAX;

/// The GPU brick cache of one bricked volume: a 3-D atlas of slots of (B + 2)³ voxels.
pub(crate) struct BrickCache {
    pub volume: Arc<BrickedVolume>,
    atlas: wgpu::Texture,
    atlas_view: wgpu::TextureView,
    slots: [u32; 3],
    capacity: usize,
    slot_of: Vec<u32>,
    owner: Vec<u32>,
    budget: Option<u64>,
}

/// What a bricked render did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BrickedStats {
    /// Seconds from the first upload to the image in host memory.
    pub seconds: f64,
    /// Compute passes (1 when every needed brick fits the cache).
    pub passes: usize,
    /// Passes added for rays the visibility order did not serve.
    pub repair_passes: usize,
    /// Bricks the render needed (not empty under its transfer function).
    pub needed: usize,
    /// Bricks the transfer function made empty.
    pub skipped: usize,
    /// Bricks read from the source and uploaded during this render.
    pub uploaded: usize,
    /// Slots in the cache.
    pub capacity: usize,
    /// GPU memory this render used: atlas, tables, image and ray state.
    pub gpu_bytes: u64,
}

impl BrickCache {
    /// A cache for `volume` within `budget` bytes of GPU memory (atlas plus the per-render
    /// buffers of a `width` x `height` image), or holding every brick when `budget` is `None`
    /// (still limited by the adapter's 3-D texture size).
    pub(crate) fn new(
        ctx: &GpuContext,
        volume: Arc<BrickedVolume>,
        budget: Option<u64>,
        width: u32,
        height: u32,
    ) -> Result<BrickCache> {
        let layout = volume.layout;
        let slot_bytes = layout.stored_bytes();
        let per_axis = (ctx.caps.max_texture_3d as usize / layout.stored_edge()).max(1);
        let mut capacity = layout.count().min(per_axis.pow(3));
        if let Some(b) = budget {
            let fixed = fixed_bytes(layout.count(), width, height, true);
            let avail = b.saturating_sub(fixed);
            let fit = (avail / slot_bytes) as usize;
            if fit == 0 {
                return Err(Error::invalid(
                    "memory_budget",
                    format!(
                        "{} MiB is too small: a {width}x{height} image and one {}³ brick need {:.1} MiB",
                        b >> 20,
                        layout.stored_edge(),
                        (fixed + slot_bytes) as f64 / (1u64 << 20) as f64
                    ),
                ));
            }
            capacity = capacity.min(fit);
        }
        let [sx, sy, sz] = atlas_shape(capacity, per_axis);
        let capacity = sx * sy * sz;
        let e = layout.stored_edge() as u32;
        let atlas =
            ctx.r32f_texture_3d("brick atlas", [sx as u32 * e, sy as u32 * e, sz as u32 * e]);
        let atlas_view = atlas.create_view(&Default::default());
        Ok(BrickCache {
            slot_of: vec![NO_SLOT; layout.count()],
            owner: vec![NO_SLOT; sx * sy * sz],
            volume,
            atlas,
            atlas_view,
            slots: [sx as u32, sy as u32, sz as u32],
            capacity,
            budget,
        })
    }

    /// Slots in the atlas.
    pub(crate) fn capacity(&self) -> usize {
        self.capacity
    }

    /// Whether this cache was made for this budget and can serve an image of this size.
    pub(crate) fn serves(&self, budget: Option<u64>, width: u32, height: u32) -> bool {
        self.budget == budget
            && budget.is_none_or(|b| {
                self.atlas_bytes() + fixed_bytes(self.volume.layout.count(), width, height, true)
                    <= b
            })
    }

    pub(crate) fn atlas_bytes(&self) -> u64 {
        self.slots.iter().map(|&s| s as u64).product::<u64>() * self.volume.layout.stored_bytes()
    }

    /// Makes `bricks` resident (at most `capacity`), evicting bricks not in the list. Returns
    /// how many were read and uploaded.
    fn load(&mut self, ctx: &GpuContext, bricks: &[u32]) -> Result<usize> {
        use rayon::prelude::*;
        debug_assert!(bricks.len() <= self.capacity);
        let mut wanted = vec![false; self.slot_of.len()];
        for &b in bricks {
            wanted[b as usize] = true;
        }
        let mut free: Vec<u32> = (0..self.capacity as u32)
            .filter(|&s| {
                let o = self.owner[s as usize];
                o == NO_SLOT || !wanted[o as usize]
            })
            .collect();
        free.reverse();
        let mut missing: Vec<u32> = bricks
            .iter()
            .copied()
            .filter(|&b| self.slot_of[b as usize] == NO_SLOT)
            .collect();
        // File order (z, then y, then x) reads each part of a file once per brick layer.
        missing.sort_unstable();
        let layout = self.volume.layout;
        let e = layout.stored_edge() as u32;
        for chunk in missing.chunks(32) {
            let data: Vec<Result<Vec<f32>>> = chunk
                .par_iter()
                .map(|&b| {
                    let mut out = Vec::new();
                    self.volume.read_brick(b as usize, &mut out).map(|_| out)
                })
                .collect();
            for (&b, d) in chunk.iter().zip(data) {
                let d = d?;
                let slot = free.pop().expect("enough free slots for the batch");
                let old = self.owner[slot as usize];
                if old != NO_SLOT {
                    self.slot_of[old as usize] = NO_SLOT;
                }
                self.owner[slot as usize] = b;
                self.slot_of[b as usize] = slot;
                let sc = [
                    slot % self.slots[0],
                    (slot / self.slots[0]) % self.slots[1],
                    slot / (self.slots[0] * self.slots[1]),
                ];
                ctx.queue.write_texture(
                    wgpu::TexelCopyTextureInfo {
                        texture: &self.atlas,
                        mip_level: 0,
                        origin: wgpu::Origin3d {
                            x: sc[0] * e,
                            y: sc[1] * e,
                            z: sc[2] * e,
                        },
                        aspect: wgpu::TextureAspect::All,
                    },
                    bytemuck::cast_slice(&d),
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(e * 4),
                        rows_per_image: Some(e),
                    },
                    wgpu::Extent3d {
                        width: e,
                        height: e,
                        depth_or_array_layers: e,
                    },
                );
            }
            // Hand the staged copies to the queue so staging memory stays one chunk.
            ctx.queue.submit([]);
        }
        Ok(missing.len())
    }
}

/// Slots per axis of an atlas holding as many of `capacity` slots as fit a box of at most
/// `per_axis` slots a side (the texture holds exactly that many, so none of the budget idles).
fn atlas_shape(capacity: usize, per_axis: usize) -> [usize; 3] {
    let mut best = [1, 1, 1];
    for sx in 1..=per_axis.min(capacity) {
        for sy in 1..=per_axis.min(capacity / sx) {
            let sz = per_axis.min(capacity / (sx * sy));
            if sx * sy * sz > best.iter().product() {
                best = [sx, sy, sz];
            }
        }
    }
    best
}

/// GPU bytes a render needs besides the atlas: page table and requests, output image and its
/// readback copy, the transfer table, and (for several passes) the ray state.
fn fixed_bytes(bricks: usize, width: u32, height: u32, multi_pass: bool) -> u64 {
    let pixels = width as u64 * height as u64;
    let state = if multi_pass {
        pixels * STATE_BYTES_PER_PIXEL
    } else {
        0
    };
    8 * bricks as u64 + 2 * pixels * 16 + state + (1 << 16) * 2
}

/// The per-render GPU buffers of the bricked ray caster (bindings 5–9 of volume_bricked.wgsl).
struct BrickedBuffers {
    bricks: wgpu::Buffer,
    pages: wgpu::Buffer,
    requests: wgpu::Buffer,
    state: wgpu::Buffer,
    progress: wgpu::Buffer,
}

impl BrickedBuffers {
    /// Buffers for `count` bricks and a `width` x `height` image; ray state only when the
    /// render takes several passes (`single` is false).
    fn new(ctx: &GpuContext, count: u64, opts: &VolumeRenderOptions, single: bool) -> Result<Self> {
        let device = &ctx.device;
        let buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        use wgpu::BufferUsages as U;
        let pixels = opts.width as u64 * opts.height as u64;
        let limit = ctx.caps.max_storage_buffer_binding_size;
        if !single && pixels * 48 > limit {
            return Err(Error::invalid(
                "width",
                format!(
                    "an out-of-core render keeps 48 bytes of ray state a pixel; {}x{} needs {} MiB but this adapter binds at most {} MiB",
                    opts.width,
                    opts.height,
                    (pixels * 48) >> 20,
                    limit >> 20
                ),
            ));
        }
        let (state_size, progress_size) = if single {
            (16, 16)
        } else {
            (pixels * 48, pixels * 4)
        };
        Ok(BrickedBuffers {
            bricks: buffer(
                "brick params",
                std::mem::size_of::<BrickParams>() as u64,
                U::UNIFORM | U::COPY_DST,
            ),
            pages: buffer("brick pages", 4 * count, U::STORAGE | U::COPY_DST),
            requests: buffer(
                "brick requests",
                4 * count,
                U::STORAGE | U::COPY_DST | U::COPY_SRC,
            ),
            state: buffer("ray state", state_size, U::STORAGE),
            progress: buffer("ray progress", progress_size, U::STORAGE),
        })
    }

    fn entries(&self) -> [wgpu::BindGroupEntry<'_>; 5] {
        [
            (5, &self.bricks),
            (6, &self.pages),
            (7, &self.state),
            (8, &self.progress),
            (9, &self.requests),
        ]
        .map(|(binding, buf)| wgpu::BindGroupEntry {
            binding,
            resource: buf.as_entire_binding(),
        })
    }
}

/// One bricked render in flight: what every compute pass of it needs.
struct BrickedPass<'a> {
    ctx: &'a GpuContext,
    pipeline: &'a wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    buffers: BrickedBuffers,
    volume: &'a BrickedVolume,
    empty: Vec<bool>,
    width: u32,
    height: u32,
}

impl BrickedPass<'_> {
    /// Runs one compute pass over the image with the cache's current page table.
    fn run(&self, cache: &BrickCache, flags: u32) -> Result<()> {
        let layout = self.volume.layout;
        let pages: Vec<u32> = (0..layout.count())
            .map(|b| {
                if self.empty[b] {
                    EMPTY
                } else {
                    match cache.slot_of[b] {
                        NO_SLOT => ABSENT,
                        s => s,
                    }
                }
            })
            .collect();
        let slots = cache.slots;
        let params = BrickParams {
            dims: [
                self.volume.dims[0] as u32,
                self.volume.dims[1] as u32,
                self.volume.dims[2] as u32,
                layout.brick as u32,
            ],
            grid: [
                layout.grid[0] as u32,
                layout.grid[1] as u32,
                layout.grid[2] as u32,
                layout.stored_edge() as u32,
            ],
            slots: [slots[0], slots[1], slots[2], flags],
            inv_atlas: [0, 1, 2, 0].map(|a| 1.0 / (slots[a] * layout.stored_edge() as u32) as f32),
        };
        let queue = &self.ctx.queue;
        queue.write_buffer(&self.buffers.pages, 0, bytemuck::cast_slice(&pages));
        queue.write_buffer(&self.buffers.bricks, 0, bytemuck::bytes_of(&params));
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(self.pipeline);
            pass.set_bind_group(0, &self.bind_group, &[]);
            pass.dispatch_workgroups(self.width.div_ceil(8), self.height.div_ceil(8), 1);
        }
        queue.submit([enc.finish()]);
        self.ctx.wait()
    }

    /// Streams the needed bricks, in visibility order, through the cache one cache-full a pass,
    /// then serves the rays still waiting for a brick until none asks.
    fn run_out_of_core(
        &self,
        cache: &mut BrickCache,
        order: Vec<u32>,
        stats: &mut BrickedStats,
    ) -> Result<()> {
        let count = self.volume.layout.count() as u64;
        let needed: Vec<u32> = order
            .into_iter()
            .filter(|&b| !self.empty[b as usize])
            .collect();
        let batches: Vec<&[u32]> = needed.chunks(cache.capacity).collect();
        let zeros = vec![0u8; 4 * count as usize];
        for (i, batch) in batches.iter().enumerate() {
            stats.uploaded += cache.load(self.ctx, batch)?;
            // Only the last pass's requests matter: earlier ones name later batches.
            self.ctx
                .queue
                .write_buffer(&self.buffers.requests, 0, &zeros);
            let mut flags = KEEP_STATE;
            if i == 0 {
                flags |= FIRST_PASS;
            }
            if i + 1 == batches.len() {
                flags |= LAST_PASS;
            }
            self.run(cache, flags)?;
            stats.passes += 1;
        }
        loop {
            let requested = read_requests(self.ctx, &self.buffers.requests, count)?;
            let wanted: Vec<u32> = needed
                .iter()
                .copied()
                .filter(|&b| requested[b as usize] != 0)
                .collect();
            if wanted.is_empty() {
                return Ok(());
            }
            if stats.repair_passes >= MAX_REPAIR_PASSES {
                return Err(Error::Gpu(format!(
                    "bricked render: rays still wait for {} bricks after {MAX_REPAIR_PASSES} extra passes",
                    wanted.len()
                )));
            }
            self.ctx
                .queue
                .write_buffer(&self.buffers.requests, 0, &zeros);
            let batch = &wanted[..wanted.len().min(cache.capacity)];
            stats.uploaded += cache.load(self.ctx, batch)?;
            self.run(cache, KEEP_STATE | LAST_PASS)?;
            stats.passes += 1;
            stats.repair_passes += 1;
        }
    }
}

impl VolumeRenderer {
    /// Renders a bricked volume through `cache`: in one pass when the bricks the transfer
    /// function needs fit, else streamed front to back through the cache. `skip` enables
    /// empty-space skipping (ignored for the u8 and f32c variants, which composite every sample).
    /// Point-sampled transfer functions only (checked by `route::choose_path`).
    pub(crate) fn render_bricked(
        &self,
        cache: &mut BrickCache,
        opts: &VolumeRenderOptions,
        skip: bool,
    ) -> Result<(HdrImage, BrickedStats)> {
        let ctx = self.context().clone();
        let volume = cache.volume.clone();
        let layout = volume.layout;
        let geometry = Geometry {
            name: &volume.name,
            dims: volume.dims,
            spacing: volume.spacing,
            origin: volume.origin,
            stats: &volume.stats,
            voxel: super::volume::min_spacing(volume.spacing),
        };
        // `auto` filters exactly here. The texture unit would see atlas coordinates, whose f32
        // rounding depends on where a brick landed in the cache (differences up to 1e-3 of the
        // peak after a steep transfer function, on lavapipe), and on CPU rasterizers it buys no
        // speed in the atlas; the exact path reads the plain render's texels with its weights.
        let mut exact = opts.clone();
        if exact.filter == super::FilterMode::Auto {
            exact.filter = super::FilterMode::Exact;
        }
        let opts = &exact;
        let frame = self.frame(&geometry, opts, true)?;
        let skip = skip && matches!(opts.precision, Precision::F32 | Precision::F16);
        let empty = if skip {
            volume.empty_bricks(&frame.tf)
        } else {
            vec![false; layout.count()]
        };
        let needed_count = empty.iter().filter(|&&e| !e).count();
        let single = needed_count <= cache.capacity;
        let (pipeline, _) = self.pipeline(frame.key)?;
        let start = std::time::Instant::now();
        use wgpu::util::DeviceExt;
        let params_buf = ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("volume params"),
                contents: bytemuck::bytes_of(&frame.params),
                usage: wgpu::BufferUsages::UNIFORM,
            });
        let buffers = BrickedBuffers::new(&ctx, layout.count() as u64, opts, single)?;
        let lut_view = self.lut_view(&frame.tf, false);
        let out = self.output_texture(opts);
        let out_view = out.create_view(&Default::default());
        let mut entries = self.common_entries(
            &frame.key,
            &params_buf,
            &cache.atlas_view,
            &lut_view,
            &out_view,
        );
        entries.extend(buffers.entries());
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("volume bricked"),
            layout: &pipeline.1,
            entries: &entries,
        });
        drop(entries);
        let mut stats = BrickedStats {
            needed: needed_count,
            skipped: layout.count() - needed_count,
            capacity: cache.capacity,
            gpu_bytes: cache.atlas_bytes()
                + fixed_bytes(layout.count(), opts.width, opts.height, !single),
            ..Default::default()
        };
        let pass = BrickedPass {
            ctx: &ctx,
            pipeline: &pipeline.0,
            bind_group,
            buffers,
            volume: &volume,
            empty,
            width: opts.width,
            height: opts.height,
        };
        if single {
            // When the cache holds every brick, load them all: a later transfer function that
            // needs other bricks then re-reads nothing.
            let all = cache.capacity >= layout.count();
            let needed: Vec<u32> = (0..layout.count() as u32)
                .filter(|&b| all || !pass.empty[b as usize])
                .collect();
            stats.uploaded += cache.load(&ctx, &needed)?;
            pass.run(cache, FIRST_PASS | LAST_PASS)?;
            stats.passes = 1;
        } else {
            pass.run_out_of_core(cache, self.visibility(&volume, opts), &mut stats)?;
        }
        let pixels = readback::read_rgba32f_texture(&ctx, &out)?;
        stats.seconds = start.elapsed().as_secs_f64();
        let mut image = self.finish_image(&geometry, opts, frame.key.hw_filter, pixels);
        image.set_meta(
            "bricks",
            format!(
                "{}^3 bricks: {} needed, {} skipped, {} passes, cache of {} slots",
                layout.brick, stats.needed, stats.skipped, stats.passes, stats.capacity
            ),
        );
        Ok((image, stats))
    }

    /// Front-to-back brick order for the render's camera (see `bricks::visibility_order`).
    fn visibility(&self, volume: &BrickedVolume, opts: &VolumeRenderOptions) -> Vec<u32> {
        let cam = &opts.camera;
        let to_voxels = |a: usize, p: f64| (p - volume.origin[a]) / volume.spacing[a];
        match cam.projection {
            Projection::Perspective { .. } => visibility_order(
                &volume.layout,
                Some([0, 1, 2].map(|a| to_voxels(a, cam.eye[a]))),
                [0.0; 3],
            ),
            Projection::Orthographic { .. } => visibility_order(
                &volume.layout,
                None,
                [0, 1, 2].map(|a| cam.forward[a] as f32 as f64),
            ),
        }
    }
}

fn read_requests(ctx: &GpuContext, requests: &wgpu::Buffer, count: u64) -> Result<Vec<u32>> {
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("requests readback"),
        size: 4 * count,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    enc.copy_buffer_to_buffer(requests, 0, &staging, 0, 4 * count);
    ctx.queue.submit([enc.finish()]);
    readback::read_mapped(ctx, &staging, 4 * count)
}

#[cfg(test)]
mod tests {
    use super::atlas_shape;

    #[test]
    fn atlas_uses_nearly_all_of_its_budget() {
        for (cap, per_axis) in [(7, 60), (4913, 60), (5960, 60), (100_000, 30), (1, 5)] {
            let s = atlas_shape(cap, per_axis);
            let n: usize = s.iter().product();
            assert!(n <= cap && s.iter().all(|&a| a <= per_axis), "{cap}: {s:?}");
            assert!(
                n as f64 >= 0.98 * cap.min(per_axis.pow(3)) as f64,
                "{cap}: {s:?}"
            );
        }
    }
}
