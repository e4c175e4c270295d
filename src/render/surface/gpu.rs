//! The two-step GPU renderer ([`SurfaceRenderer`]): its pipelines, the step-1 cache of data
//! targets, the data pass, the fringe pass and the readback of its outputs.

use super::geometry::SurfaceGeometry;
use super::legend::{colour_domain, surface_colour_bar};
use super::options::{
    check_nu, default_size, property_indices, MissingColour, PhaseMethod, SurfaceOptions,
    SurfaceView,
};
use super::overlay::Overlay;
use super::params::{colormap_table, data_params, FringeParams, NodeValues, PropMeta};
use super::phase::{split_nu, FOOTPRINT_SIGMA};
use super::LUT_SIZE;
use crate::error::{Error, Result};
use crate::gpu::transfer::ReadbackBuffer;
use crate::gpu::{pipeline, shader, GpuContext};
use crate::model::colormap::Colormap;
use crate::model::{Grid, HdrImage};
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// Step-1 results kept per renderer.
const CACHE_ENTRIES: usize = 4;

/// Step-1 results on the GPU, with what step 2 needs to know about them.
pub(super) struct DataTargets {
    pub(super) hi: wgpu::Buffer,
    pub(super) rest: wgpu::Buffer,
    pub(super) mask: wgpu::Buffer,
    pub(super) width: u32,
    pub(super) height: u32,
    /// Per rendered property: name, units, d_ref, finite range.
    pub(super) props: Vec<PropMeta>,
    pub(super) view: String,
    /// The map's coordinate axes (map view of a grid with evenly spaced coordinates).
    pub(super) axes: Option<crate::model::map_frame::MapAxes>,
    /// Fringe-pass outputs and their staging copies, reused by every step-2 run on these targets.
    pub(super) outputs: Mutex<Option<FringeOutputs>>,
    /// Per property slot, the value channel as returned (missing pixels NaN): it depends on the
    /// data pass only, so step 2 reads it back once and a ν or mode change reuses it.
    pub(super) values: Mutex<HashMap<usize, Vec<f32>>>,
}

/// Step-2 outputs, mapped directly on CPU adapters (no staging copy of the 16 MiB colour
/// buffer at 1024²; see [`crate::gpu::transfer`]).
pub(super) struct FringeOutputs {
    color: ReadbackBuffer,
    value: ReadbackBuffer,
    filtered: ReadbackBuffer,
}

/// What a fringe pipeline is specialised on (pipeline constants of surface_fringe.wgsl).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct FringeVariant {
    slot: usize,
    mode: u32,
    absolute: bool,
    log_color: bool,
    write_value: bool,
    naive_phase: bool,
    antialias: bool,
}

#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub(super) struct DataKey {
    pub(super) grid: u64,
    pub(super) view: Vec<u64>,
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) properties: Vec<String>,
    pub(super) relief: Option<String>,
    pub(super) exaggeration: u64,
    /// Samples per pixel of a mesh's host data pass (0 for a grid's).
    pub(super) samples: u32,
}

/// Counters for tests and benchmarks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SurfaceCounters {
    pub data_passes: u64,
    pub fringe_passes: u64,
}

/// Wall time of the two steps of one render.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct SurfaceTiming {
    /// The data pass, or `None` when its targets came from the cache.
    pub data_ms: Option<f64>,
    pub fringe_ms: f64,
}

/// The two-step surface renderer with its pipelines and step-1 cache; one per GPU context.
pub struct SurfaceRenderer {
    ctx: Arc<GpuContext>,
    data_pipelines: Mutex<HashMap<u32, Arc<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>>>,
    fringe_pipelines:
        Mutex<HashMap<FringeVariant, Arc<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>>>,
    cache: Mutex<Vec<(DataKey, Arc<DataTargets>)>>,
    /// Evenly spaced stand-ins of grids on uneven axes (3-D views), by the source grid's
    /// identity, so views of one grid share one stand-in and its cached data pass.
    stand_ins: Mutex<Vec<(u64, Arc<Grid>)>>,
    pub(super) data_passes: AtomicU64,
    fringe_passes: AtomicU64,
}

impl SurfaceRenderer {
    pub fn new(ctx: Arc<GpuContext>) -> Self {
        SurfaceRenderer {
            ctx,
            data_pipelines: Mutex::new(HashMap::new()),
            fringe_pipelines: Mutex::new(HashMap::new()),
            cache: Mutex::new(Vec::new()),
            stand_ins: Mutex::new(Vec::new()),
            data_passes: AtomicU64::new(0),
            fringe_passes: AtomicU64::new(0),
        }
    }

    /// How many data and fringe passes this renderer has run.
    pub fn counters(&self) -> SurfaceCounters {
        SurfaceCounters {
            data_passes: self.data_passes.load(Ordering::Relaxed),
            fringe_passes: self.fringe_passes.load(Ordering::Relaxed),
        }
    }

    fn build(
        &self,
        name: &str,
        label: &str,
        entries: &[wgpu::BindGroupLayoutEntry],
        constants: &[(&str, f64)],
    ) -> Result<Arc<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>> {
        // SAFETY: wgpu's injected bounds checks cost a large share of these small kernels on
        // lavapipe, and neither shader needs them: every invocation returns early outside the
        // image, pixel buffers hold exactly width × height entries, node indices are clamped to
        // the grid, and the lookup-table index is clamped to [0, LUT_SIZE − 2].
        let checks = unsafe { pipeline::RuntimeChecks::unchecked() };
        let spec = pipeline::ComputeSpec {
            label,
            what: &format!("{label} pipeline"),
            shader: pipeline::Shader::Wgsl {
                label: name,
                source: shader::load(name, &[])?,
                checks,
            },
            entry: "main",
            constants,
        };
        Ok(Arc::new(pipeline::compute_with_layout(
            &self.ctx, spec, entries,
        )?))
    }

    /// The data pass specialised for a view ([`SurfaceView::code`]).
    fn data_pipeline(
        &self,
        view: u32,
    ) -> Result<Arc<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>> {
        let mut cache = self.data_pipelines.lock().expect("pipeline cache poisoned");
        if let Some(p) = cache.get(&view) {
            return Ok(p.clone());
        }
        let entries = crate::gpu::layout::uniform_then_storage(4, 3);
        let p = self.build(
            "surface_data.wgsl",
            "surface data pass",
            &entries,
            &[("VIEW", view as f64)],
        )?;
        cache.insert(view, p.clone());
        Ok(p)
    }

    fn fringe_pipeline(
        &self,
        variant: FringeVariant,
    ) -> Result<Arc<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>> {
        let mut cache = self
            .fringe_pipelines
            .lock()
            .expect("pipeline cache poisoned");
        if let Some(p) = cache.get(&variant) {
            return Ok(p.clone());
        }
        let entries = crate::gpu::layout::uniform_then_storage(4, 3);
        let p = self.build(
            "surface_fringe.wgsl",
            "surface fringe pass",
            &entries,
            &[
                ("SLOT", variant.slot as f64),
                ("MODE", variant.mode as f64),
                ("ABSOLUTE", variant.absolute as u8 as f64),
                ("LOG_COLOR", variant.log_color as u8 as f64),
                ("WRITE_VALUE", variant.write_value as u8 as f64),
                ("NAIVE_PHASE", variant.naive_phase as u8 as f64),
                ("ANTIALIAS", variant.antialias as u8 as f64),
            ],
        )?;
        cache.insert(variant, p.clone());
        Ok(p)
    }

    pub(super) fn input_buffer(&self, label: &str, bytes: &[u8]) -> wgpu::Buffer {
        use wgpu::util::DeviceExt;
        self.ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage: wgpu::BufferUsages::STORAGE,
            })
    }

    fn output_buffer(&self, label: &str, bytes: u64) -> wgpu::Buffer {
        self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(16),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        })
    }

    fn bind(
        &self,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        uniform: &wgpu::Buffer,
        buffers: &[&wgpu::Buffer],
    ) -> wgpu::BindGroup {
        let mut entries = vec![wgpu::BindGroupEntry {
            binding: 0,
            resource: uniform.as_entire_binding(),
        }];
        for (i, b) in buffers.iter().enumerate() {
            entries.push(wgpu::BindGroupEntry {
                binding: i as u32 + 1,
                resource: b.as_entire_binding(),
            });
        }
        self.ctx
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout,
                entries: &entries,
            })
    }

    fn resolve_size(&self, grid: &Grid, opts: &SurfaceOptions) -> Result<(u32, u32)> {
        let (w, h) = default_size(grid, opts);
        let what = format!("a {}x{} grid", grid.nx(), grid.ny());
        self.check_binding(w, h, (grid.nx() * grid.ny()) as u64, &what)?;
        Ok((w, h))
    }

    /// That `w × h` pixels and `nodes` input nodes (of `what`) fit the adapter's buffer bindings.
    pub(super) fn check_binding(&self, w: u32, h: u32, nodes: u64, what: &str) -> Result<()> {
        let limit = self.ctx.caps.max_storage_buffer_binding_size;
        let largest = (w as u64 * h as u64).max(nodes) * 16;
        if largest > limit {
            return Err(Error::invalid(
                "width",
                format!(
                    "{w}x{h} pixels of {what} need {} MiB buffers; this adapter binds at most {} MiB",
                    largest >> 20,
                    limit >> 20
                ),
            ));
        }
        Ok(())
    }

    /// Step 1, cached: the data targets for these options.
    fn data_pass(
        &self,
        grid: &Grid,
        opts: &SurfaceOptions,
        props: &[usize],
    ) -> Result<Arc<DataTargets>> {
        let (width, height) = self.resolve_size(grid, opts)?;
        let key = DataKey::new(grid, opts, props, width, height);
        if let Some(t) = self.cached_targets(&key) {
            return Ok(t);
        }
        let nodes = NodeValues::of(grid, props);
        let geo = SurfaceGeometry::new(grid, opts)?;
        let heights: Vec<f32> = geo.heights.iter().map(|&h| h as f32).collect();
        let t_hi = self.input_buffer("surface nodes hi", bytemuck::cast_slice(&nodes.hi));
        let t_rest = self.input_buffer("surface nodes rest", bytemuck::cast_slice(&nodes.rest));
        let t_valid = self.input_buffer("surface nodes valid", bytemuck::cast_slice(&nodes.valid));
        let t_height = self.input_buffer("surface nodes height", bytemuck::cast_slice(&heights));
        let map = opts.view == SurfaceView::Map;
        let params = data_params(&geo, grid, props.len(), width, height);
        let pipeline = self.data_pipeline(opts.view.code())?;
        let device = &self.ctx.device;
        use wgpu::util::DeviceExt;
        let ubuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("surface data params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let px = width as u64 * height as u64;
        let planes = px * 4 * props.len() as u64;
        let o_hi = self.output_buffer("surface data hi", planes);
        let o_rest = self.output_buffer("surface data rest", planes);
        let o_mask = self.output_buffer("surface data mask", px * 8);
        let bind = self.bind(
            "surface data",
            &pipeline.1,
            &ubuf,
            &[&t_hi, &t_rest, &t_valid, &t_height, &o_hi, &o_rest, &o_mask],
        );
        let mut enc = device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline.0);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
        }
        self.ctx.queue.submit([enc.finish()]);
        self.data_passes.fetch_add(1, Ordering::Relaxed);
        let targets = Arc::new(DataTargets {
            hi: o_hi,
            rest: o_rest,
            mask: o_mask,
            width,
            height,
            props: nodes.meta,
            view: opts.view.describe(),
            axes: map
                .then(|| crate::model::map_frame::MapAxes::of_grid(grid))
                .flatten(),
            outputs: Mutex::new(None),
            values: Mutex::new(HashMap::new()),
        });
        self.remember(key, targets.clone());
        Ok(targets)
    }

    /// The cached step-1 targets for `key`, if any.
    pub(super) fn cached_targets(&self, key: &DataKey) -> Option<Arc<DataTargets>> {
        let cache = self.cache.lock().expect("surface cache poisoned");
        cache.iter().find(|(k, _)| k == key).map(|(_, t)| t.clone())
    }

    /// Caches `targets` under `key`, dropping the oldest entry when the cache is full.
    pub(super) fn remember(&self, key: DataKey, targets: Arc<DataTargets>) {
        let mut cache = self.cache.lock().expect("surface cache poisoned");
        cache.retain(|(k, _)| *k != key);
        if cache.len() >= CACHE_ENTRIES {
            cache.remove(0);
        }
        cache.push((key, targets));
    }

    /// Renders every requested property from one (cached) data pass; one image per property.
    pub fn render(&self, grid: &Grid, opts: &SurfaceOptions) -> Result<Vec<HdrImage>> {
        Ok(self.render_timed(grid, opts)?.0)
    }

    /// As [`Self::render`], also saying how long each step took (no data time on a cache hit).
    pub(crate) fn render_timed(
        &self,
        grid: &Grid,
        opts: &SurfaceOptions,
    ) -> Result<(Vec<HdrImage>, SurfaceTiming)> {
        opts.validate()?;
        if opts.cell_edges.is_some() {
            return Err(Error::invalid(
                "cell_edges",
                format!(
                    "cells are drawn on meshes (load_mesh); {:?} is a grid",
                    grid.name()
                ),
            ));
        }
        let props = property_indices(grid, opts)?;
        // The route is chosen here alone: pixels placed on the host (projected maps, maps and
        // globes of uneven axes), an uneven grid's evenly spaced stand-in (3-D views), or the
        // data pass.
        if opts.host_placed(grid) {
            return self.render_placed(grid, opts, &props);
        }
        if !crate::model::grid_sampler::evenly_spaced(grid) {
            let even = self.stand_in(grid)?;
            return self.render_timed(&even, opts);
        }
        let colormap = Colormap::by_name(opts.colormap_name())?;
        let overlay = Overlay::plan(grid, opts)?;
        let t0 = std::time::Instant::now();
        let passes_before = self.data_passes.load(Ordering::Relaxed);
        let data = self.data_pass(grid, opts, &props)?;
        let data_ms = (self.data_passes.load(Ordering::Relaxed) > passes_before)
            .then(|| t0.elapsed().as_secs_f64() * 1e3);
        self.fringe_and_overlay(
            &data,
            props.len(),
            opts,
            &colormap,
            overlay.as_ref(),
            data_ms,
        )
    }

    /// The evenly spaced stand-in of `grid` (on uneven axes) at its finest spacing, made once
    /// per grid (the last few kept).
    fn stand_in(&self, grid: &Grid) -> Result<Arc<Grid>> {
        let mut kept = self.stand_ins.lock().expect("stand-in cache poisoned");
        if let Some((_, g)) = kept.iter().find(|(id, _)| *id == grid.id()) {
            return Ok(g.clone());
        }
        let even =
            Arc::new(crate::model::GridSampler::new(grid).evenly_spaced(super::MAX_EVEN_NODES)?);
        if kept.len() >= 4 {
            kept.remove(0);
        }
        kept.push((grid.id(), even.clone()));
        Ok(even)
    }

    /// Step 2 for each of `slots` properties of `data`, with `overlay` drawn over each image.
    pub(super) fn fringe_and_overlay(
        &self,
        data: &DataTargets,
        slots: usize,
        opts: &SurfaceOptions,
        colormap: &Colormap,
        overlay: Option<&Overlay>,
        data_ms: Option<f64>,
    ) -> Result<(Vec<HdrImage>, SurfaceTiming)> {
        let t1 = std::time::Instant::now();
        let mut images = (0..slots)
            .map(|slot| self.fringe_pass(data, slot, opts.nu_for(slot), opts, colormap))
            .collect::<Result<Vec<_>>>()?;
        if let Some(overlay) = overlay {
            images.iter_mut().for_each(|img| overlay.draw(img));
        }
        let timing = SurfaceTiming {
            data_ms,
            fringe_ms: t1.elapsed().as_secs_f64() * 1e3,
        };
        Ok((images, timing))
    }

    /// Step 2 for one property slot of a data pass.
    fn fringe_pass(
        &self,
        data: &DataTargets,
        slot: usize,
        nu: f64,
        opts: &SurfaceOptions,
        colormap: &Colormap,
    ) -> Result<HdrImage> {
        check_nu(nu)?;
        let (name, units, _, range, long_name) = data.props[slot].clone();
        let lut = colormap_table(colormap);
        let params = fringe_params(data, slot, nu, opts, &lut)?;
        let FringeReadback {
            pixels,
            values,
            fringe,
            filtered,
        } = self.run_fringe(data, slot, opts, &params, &lut)?;
        let mut image = HdrImage::from_pixels(data.width, data.height, pixels);
        let channel = if name.is_empty() {
            "value".to_string()
        } else {
            name.clone()
        };
        let channel = if channel == "fringe" {
            "value".to_string()
        } else {
            channel
        };
        image.extra_channels.push((channel, values));
        image.extra_channels.push(("fringe".to_string(), fringe));
        image
            .extra_channels
            .push(("fringe_filtered".to_string(), filtered));
        let units_for_bar = units.clone();
        let property = name.clone();
        let u = if units.is_empty() {
            "data units".to_string()
        } else {
            units
        };
        image.set_meta("property", name);
        image.set_meta("nu", format!("{nu}"));
        image.set_meta("resolution", format!("{} {u} per fringe (1/nu)", 1.0 / nu));
        image.set_meta("mode", opts.mode.name());
        image.set_meta("colormap", colormap.name());
        image.set_meta("modulation", format!("{}", opts.modulation));
        image.set_meta(
            "data_range",
            match range {
                Some((a, b)) => format!("{a} {b}"),
                None => "all missing".to_string(),
            },
        );
        image.set_meta("view", data.view.clone());
        if let Some(axes) = &data.axes {
            axes.record(&mut image);
        }
        image.set_meta("phase", opts.phase.describe());
        image.set_meta(
            "antialias",
            if opts.antialias {
                "colours from the fringe averaged over a Gaussian footprint of sigma 0.5 pixel"
            } else {
                "off: colours from the point fringe"
            },
        );
        image.set_meta("missing", opts.missing.describe());
        let d_ref = data.props[slot].2;
        surface_colour_bar(
            opts,
            nu,
            colormap.name(),
            (&units_for_bar, &long_name),
            (&property, d_ref, range),
        )?
        .record(&mut image);
        image.set_meta("adapter", self.ctx.describe());
        Ok(image)
    }

    /// Runs the fringe pass for `slot` and reads back its colours (alpha 1), the value channel
    /// (missing pixels NaN; read once per slot, then reused) and the fringe taken from alpha.
    fn run_fringe(
        &self,
        data: &DataTargets,
        slot: usize,
        opts: &SurfaceOptions,
        params: &FringeParams,
        lut: &[[f32; 4]],
    ) -> Result<FringeReadback> {
        let cached_values = data
            .values
            .lock()
            .expect("surface values poisoned")
            .get(&slot)
            .cloned();
        let pipeline = self.fringe_pipeline(FringeVariant {
            slot,
            mode: opts.mode.code(),
            absolute: opts.absolute,
            log_color: opts.log_color,
            write_value: cached_values.is_none(),
            naive_phase: opts.phase == PhaseMethod::Naive,
            antialias: opts.antialias,
        })?;
        let n = data.width as u64 * data.height as u64;
        let mut outputs = data.outputs.lock().expect("surface outputs poisoned");
        let none = wgpu::BufferUsages::empty();
        let outs = outputs.get_or_insert_with(|| FringeOutputs {
            color: ReadbackBuffer::new(&self.ctx, "surface image", n * 16, none),
            value: ReadbackBuffer::new(&self.ctx, "surface value", n * 4, none),
            filtered: ReadbackBuffer::new(&self.ctx, "surface fringe filtered", n * 4, none),
        });
        let enc = self.encode_fringe(&pipeline, params, lut, data, outs, cached_values.is_none());
        let profile = FringeProfile::start();
        self.ctx.queue.submit([enc.finish()]);
        if profile.on {
            self.ctx.wait()?;
        }
        profile.mark("fringe compute");
        self.fringe_passes.fetch_add(1, Ordering::Relaxed);
        let mut pixels: Vec<[f32; 4]> = outs.color.read(&self.ctx, n * 16)?;
        let mut filtered: Vec<f32> = outs.filtered.read(&self.ctx, n * 4)?;
        for (f, p) in filtered.iter_mut().zip(&pixels) {
            if p[3] < 0.0 {
                *f = f32::NAN;
            }
        }
        profile.mark("+ rgba readback");
        let values: Vec<f32> = match cached_values {
            Some(v) => v,
            None => {
                let mut v: Vec<f32> = outs.value.read(&self.ctx, n * 4)?;
                for (value, p) in v.iter_mut().zip(&pixels) {
                    if p[3] < 0.0 {
                        *value = f32::NAN;
                    }
                }
                data.values
                    .lock()
                    .expect("surface values poisoned")
                    .insert(slot, v.clone());
                v
            }
        };
        drop(outputs);
        profile.mark("+ value readback");
        let fringe = take_fringe(&mut pixels, &opts.missing);
        profile.mark("+ host");
        Ok(FringeReadback {
            pixels,
            values,
            fringe,
            filtered,
        })
    }

    /// Records the fringe pass and the copies of its outputs (the value channel only when it
    /// is written, `write_value`).
    fn encode_fringe(
        &self,
        pipeline: &(wgpu::ComputePipeline, wgpu::BindGroupLayout),
        params: &FringeParams,
        lut: &[[f32; 4]],
        data: &DataTargets,
        outs: &FringeOutputs,
        write_value: bool,
    ) -> wgpu::CommandEncoder {
        let device = &self.ctx.device;
        use wgpu::util::DeviceExt;
        let ubuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("surface fringe params"),
            contents: bytemuck::bytes_of(params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let lut_buf = self.input_buffer("surface lut", bytemuck::cast_slice(lut));
        let (w, h) = (data.width, data.height);
        let n = w as u64 * h as u64;
        let (out, out_value) = (&outs.color.buffer, &outs.value.buffer);
        let out_filtered = &outs.filtered.buffer;
        let bind = self.bind(
            "surface fringe",
            &pipeline.1,
            &ubuf,
            &[
                &data.hi,
                &data.rest,
                &data.mask,
                &lut_buf,
                out,
                out_value,
                out_filtered,
            ],
        );
        let mut enc = device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline.0);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
        }
        outs.color.record_copy(&mut enc, n * 16);
        outs.filtered.record_copy(&mut enc, n * 4);
        if write_value {
            outs.value.record_copy(&mut enc, n * 4);
        }
        enc
    }
}

impl DataKey {
    /// What step 1's result depends on (the relief and its exaggeration only off the map view).
    fn new(grid: &Grid, opts: &SurfaceOptions, props: &[usize], width: u32, height: u32) -> Self {
        DataKey {
            grid: grid.id(),
            view: opts.view.key(),
            width,
            height,
            properties: props
                .iter()
                .map(|&i| grid.property_at(i).0.to_string())
                .collect(),
            relief: if opts.view == SurfaceView::Map {
                None
            } else {
                opts.relief.clone()
            },
            exaggeration: if opts.view == SurfaceView::Map {
                0
            } else {
                opts.exaggeration.to_bits()
            },
            samples: 0,
        }
    }
}

/// The fringe pass's parameters for `slot` at `nu`: ν split for exact phases, the reference
/// phase, the colour domain, shading and mode, and the footprint (with the mean of the colour
/// table `lut`, what cyclic colours fade to).
fn fringe_params(
    data: &DataTargets,
    slot: usize,
    nu: f64,
    opts: &SurfaceOptions,
    lut: &[[f32; 4]],
) -> Result<FringeParams> {
    // The table's mean by the trapezoid rule (its entries are samples at both ends of [0, 1]).
    let mut mean = [0f32; 3];
    let last = lut.len() - 1;
    for (i, c) in lut.iter().enumerate() {
        let w = if i == 0 || i == last { 0.5 } else { 1.0 } / last as f32;
        for k in 0..3 {
            mean[k] += c[k] * w;
        }
    }
    let (name, _, d_ref, range, _) = &data.props[slot];
    let d_ref = *d_ref;
    let colours = opts.colour_range(*range, name)?;
    let (c_lo, c_inv, floor) = colour_domain(opts, colours.unwrap_or((d_ref, d_ref)), d_ref);
    let [na, nb, nc] = split_nu(nu);
    Ok(FringeParams {
        nu: [na, nb, nc, nu as f32],
        refs: [
            (nu * d_ref).rem_euclid(1.0) as f32,
            d_ref as f32,
            c_lo as f32,
            c_inv as f32,
        ],
        shade: [opts.modulation as f32, floor as f32, 0.0, 0.0],
        mode: [
            slot as u32,
            opts.mode.code(),
            opts.absolute as u32,
            opts.log_color as u32,
        ],
        dims: [data.width, data.height, LUT_SIZE as u32, 0],
        footprint: [mean[0], mean[1], mean[2], (nu * FOOTPRINT_SIGMA) as f32],
    })
}

/// Takes the fringe out of alpha, where the pass leaves it: every alpha ≥ 0 becomes 1. A
/// negative alpha marks a missing pixel (fringe NaN), whose red holds the surface's shading
/// there: a hole in the surface (shading ≥ 0) is painted in the missing colour times that
/// shading, so holes read as a shaded flat surface in 3-D; the background (shading −1) and,
/// with `missing: "transparent"`, every missing pixel become (0, 0, 0, 0).
fn take_fringe(pixels: &mut [[f32; 4]], missing: &MissingColour) -> Vec<f32> {
    use rayon::prelude::*;
    let paint = missing.linear();
    pixels
        .par_iter_mut()
        .map(|p| {
            if p[3] < 0.0 {
                let shade = p[0];
                *p = match paint {
                    Some(c) if shade >= 0.0 => [c[0] * shade, c[1] * shade, c[2] * shade, 1.0],
                    _ => [0.0; 4],
                };
                f32::NAN
            } else {
                let f = p[3];
                p[3] = 1.0;
                f
            }
        })
        .collect()
}

/// What the fringe pass of one slot hands back: colours with alpha 1 (missing pixels all 0),
/// the value channel, the fringe and the footprint-filtered fringe (NaN where missing).
struct FringeReadback {
    pixels: Vec<[f32; 4]>,
    values: Vec<f32>,
    fringe: Vec<f32>,
    filtered: Vec<f32>,
}

/// Step-2 stage times on stderr when `HDRVIS_SURFACE_PROFILE` is set, counted from the submit.
struct FringeProfile {
    on: bool,
    start: std::time::Instant,
}

impl FringeProfile {
    fn start() -> FringeProfile {
        FringeProfile {
            on: std::env::var_os("HDRVIS_SURFACE_PROFILE").is_some(),
            start: std::time::Instant::now(),
        }
    }

    fn mark(&self, stage: &str) {
        if self.on {
            eprintln!("{stage} {:.2} ms", self.start.elapsed().as_secs_f64() * 1e3);
        }
    }
}
