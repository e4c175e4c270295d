//! The GPU ray caster for volumes placed by coordinate axes (`shaders/volume_mapped.wgsl`):
//! spherical shells and wedges, and rectilinear boxes with uneven axes. It shares the in-core
//! ray caster's texture, transfer tables, parameters and pipeline cache, and adds the axes: an
//! even axis as its first centre and step, an uneven one as its centres in a storage buffer
//! that the shader bisects.

use super::mapped_skipping::cell_size;
use super::skipping::SkipGrid;
use super::volume::{
    Geometry as FrameGeometry, GpuVolume, RenderTiming, VolumeRenderer, CF_AXES, RECTILINEAR,
    RENORMALISE, SEAM, SHELL, SPHERICAL, UNEVEN,
};
use super::VolumeRenderOptions;
use crate::error::Result;
use crate::model::{CoordAxis, Cut, Geometry, HdrImage, Volume, MAX_CUT_PLANES};

/// Host mirror of `Mapped` in shaders/volume_mapped.wgsl — keep in sync.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct MappedParams {
    domain_lo: [f32; 4],
    domain_hi: [f32; 4],
    axis_of: [u32; 4],
    row_x: [f32; 4],
    row_y: [f32; 4],
    row_z: [f32; 4],
    count: [u32; 4],
    offset: [u32; 4],
    first: [f32; 4],
    inv_step: [f32; 4],
    dir: [f32; 4],
    seam: [f32; 4],
    inv_dims: [f32; 4],
    cut: [f32; 4],
    cut_r: [f32; 4],
    cut_on: [u32; 4],
    box_cut_lo: [f32; 4],
    box_cut_hi: [f32; 4],
    box_cut_planes: [[f32; 4]; MAX_CUT_PLANES],
    skip_lo: [f32; 4],
    skip_cells: [f32; 4],
    faces: [f32; 4],
    rings: [f32; 4],
}

impl MappedParams {
    /// Coordinate `c` from `axis`: an even axis by its first centre and step, an uneven one by
    /// its centres appended to `coords`, stored rising.
    fn set_axis(&mut self, c: usize, axis: &CoordAxis, texture_axis: usize, coords: &mut Vec<f32>) {
        self.axis_of[c] = texture_axis as u32;
        let mut row = [0.0; 4];
        row[texture_axis] = 1.0;
        match c {
            0 => self.row_x = row,
            1 => self.row_y = row,
            _ => self.row_z = row,
        }
        let n = axis.len();
        self.count[c] = n as u32;
        let rising = n < 2 || axis.centres[1] > axis.centres[0];
        self.dir[c] = if rising { 1.0 } else { -1.0 };
        match axis.uniform_step() {
            Some(step) if n >= 2 => {
                self.first[c] = axis.centres[0] as f32;
                self.inv_step[c] = (1.0 / step) as f32;
            }
            _ if n < 2 => {
                self.first[c] = axis.centres[0] as f32;
                self.inv_step[c] = 1.0;
            }
            _ => {
                self.offset[c] = coords.len() as u32;
                coords.extend(
                    axis.centres
                        .iter()
                        .map(|&x| (x * self.dir[c] as f64) as f32),
                );
            }
        }
    }

    /// The cut-away `cut` of a shell of planet radius `planet`.
    fn set_cut(&mut self, cut: &Cut, planet: f64) {
        let on = |b: bool| u32::from(b);
        let [la, lb] = cut.lat.unwrap_or([-90.0, 90.0]);
        let [oa, ob] = cut.lon.unwrap_or([0.0, 360.0]);
        let [ra, rb] = cut.radii(planet).unwrap_or([0.0, 0.0]);
        self.cut = [la as f32, lb as f32, oa as f32, (ob - oa) as f32];
        self.cut_r = [ra as f32, rb as f32, 0.0, 0.0];
        self.cut_on = [
            on(cut.lat.is_some()),
            on(cut.lon.is_some()),
            on(cut.depth.is_some()),
            1,
        ];
    }

    /// The cut-away `cut` of a box whose lower corner is `corner` (the shader's frame).
    fn set_box_cut(&mut self, cut: &Cut, corner: [f64; 3]) {
        let [lo, hi] = cut.box_in_frame(corner);
        for a in 0..3 {
            (self.box_cut_lo[a], self.box_cut_hi[a]) = (lo[a] as f32, hi[a] as f32);
        }
        self.box_cut_lo[3] = 1.0;
        self.box_cut_planes = cut.planes_in_frame(corner).map(|row| row.map(|c| c as f32));
    }
}

/// The shader's view of `volume`'s geometry: the pipeline variant (bits above), the uniform
/// block, the uneven axes' centres, and the frame geometry the
/// shared parameters are built from (the eye relative to the box's corner, or to the planet's
/// centre for a shell). A shell's cut-away takes the general spherical variant, which clips to
/// it; a box's is clipped by the box variant, which is how a regular box with a cut renders.
fn mapped_params(
    volume: &Volume,
    cut: Option<&Cut>,
) -> Result<(u32, MappedParams, Vec<f32>, [f64; 3])> {
    let mut p = MappedParams {
        inv_dims: [0, 1, 2, 2].map(|a| 1.0 / volume.dims[a] as f32),
        ..Default::default()
    };
    let mut coords = Vec::new();
    let bounds = volume.bounds();
    match &volume.geometry {
        Geometry::Regular | Geometry::Rectilinear(_) => {
            // A regular box comes here only with a cut-away or missing: "renormalise": its axes
            // are even, the shader's fast case.
            let regular;
            let axes: &[CoordAxis; 3] = match &volume.geometry {
                Geometry::Rectilinear(axes) => axes,
                _ => {
                    regular = [0, 1, 2].map(|a| {
                        CoordAxis::uniform_cells(
                            volume.origin[a],
                            volume.spacing[a],
                            volume.dims[a],
                        )
                    });
                    &regular
                }
            };
            p.domain_lo = [
                bounds.lo[0] as f32,
                bounds.lo[1] as f32,
                bounds.lo[2] as f32,
                0.0,
            ];
            p.domain_hi = [
                bounds.hi[0] as f32,
                bounds.hi[1] as f32,
                bounds.hi[2] as f32,
                0.0,
            ];
            for (a, axis) in axes.iter().enumerate() {
                p.set_axis(a, axis, a, &mut coords);
            }
            if let Some(c) = cut {
                p.set_box_cut(c, bounds.lo);
            }
            let uneven = if coords.is_empty() { 0 } else { UNEVEN };
            coords.resize(coords.len().max(4), 0.0);
            Ok((RECTILINEAR | uneven, p, coords, bounds.lo))
        }
        Geometry::Spherical(g) => {
            let f = |x: f64| x as f32;
            p.domain_lo = [
                f(g.radius.lo),
                f(g.radius.hi),
                f(g.latitude.lo),
                f(g.latitude.hi),
            ];
            // The whole turns between the domain's first longitude and [-180°, 180°), where
            // atan2 lands: the shader wraps by one comparison and these turns.
            let turns = 360.0 * ((g.longitude.lo + 180.0) / 360.0).floor();
            p.domain_hi = [
                f(g.longitude.lo),
                f(g.longitude.hi),
                if g.lon_wraps { 1.0 } else { 0.0 },
                f(turns),
            ];
            for (c, axis) in [&g.radius, &g.latitude, &g.longitude]
                .into_iter()
                .enumerate()
            {
                p.set_axis(c, axis, g.axis_of[c], &mut coords);
            }
            let lon = &g.longitude.centres;
            let turn = if p.dir[2] > 0.0 { 360.0 } else { -360.0 };
            p.seam = [f(lon[0]), f(lon[lon.len() - 1]), f(lon[0] + turn), 0.0];
            // An even circle whose last centre is one step from the first a turn later needs
            // no seam code: its index runs on across the seam.
            let even_seam = g.longitude.uniform_step().is_some_and(|step| {
                lon.len() >= 2
                    && ((lon[lon.len() - 1] + step) - (lon[0] + turn)).abs() <= 1e-9 * 360.0
            });
            let seam = if g.lon_wraps && !even_seam { SEAM } else { 0 };
            let uneven = if coords.is_empty() { 0 } else { UNEVEN };
            coords.resize(coords.len().max(4), 0.0);
            let cf_axes = if g.axis_of == [2, 1, 0] { CF_AXES } else { 0 };
            if let Some(c) = cut {
                p.set_cut(c, g.planet_radius);
            }
            let whole =
                g.lon_wraps && g.latitude.lo <= -90.0 && g.latitude.hi >= 90.0 && cut.is_none();
            let shell = if whole { SHELL } else { 0 };
            Ok((
                SPHERICAL | uneven | seam | cf_axes | shell,
                p,
                coords,
                [0.0; 3],
            ))
        }
    }
}

impl VolumeRenderer {
    /// Renders `volume` (uploaded as `gpu`) through its coordinate axes.
    pub(crate) fn render_mapped(
        &self,
        volume: &Volume,
        gpu: &GpuVolume,
        opts: &VolumeRenderOptions,
        skip: Option<&SkipGrid>,
    ) -> Result<(HdrImage, RenderTiming)> {
        let (kind, mut params, coords, origin) = mapped_params(volume, opts.cut.as_ref())?;
        if let Some(f) = &opts.cut_faces {
            // On; fringes per unit of the value (0: none); the probe before a part's start;
            // the rings' half width and radii (0: none).
            let probe = crate::model::cut::FACE_PROBE * volume.voxel_length();
            let (radii, half) = f.rings(volume, &opts.camera, opts.height)?;
            params.faces = [1.0, f.nu.unwrap_or(0.0) as f32, probe as f32, half as f32];
            for (slot, r) in params.rings.iter_mut().zip(&radii) {
                *slot = *r as f32;
            }
        }
        if let Some(g) = skip {
            // The world cells' corner in the shader's frame, and cells per unit length.
            let size = cell_size(volume, g.grid);
            let lo = volume.bounds().lo;
            for a in 0..3 {
                params.skip_lo[a] = (lo[a] - origin[a]) as f32;
                params.skip_cells[a] = (1.0 / size[a]) as f32;
            }
        }
        let size = volume.bounds().size();
        let geometry = FrameGeometry {
            name: &gpu.name,
            dims: volume.dims,
            spacing: [0, 1, 2].map(|a| size[a] / volume.dims[a] as f64),
            origin,
            stats: &gpu.stats,
            voxel: volume.voxel_length(),
        };
        let frame = {
            let mut f = self.frame(&geometry, opts, false)?;
            f.key.mapped = kind;
            f.key.skipping = skip.is_some();
            if opts.missing == crate::model::Missing::Renormalise {
                // Which texels are missing is the shader's to see: no texture-unit filter.
                f.key.mapped |= RENORMALISE;
                f.key.hw_filter = false;
            }
            f
        };
        let (pipeline, compiled) = self.pipeline(frame.key)?;
        let (pipeline, layout) = (&pipeline.0, &pipeline.1);
        use wgpu::util::DeviceExt;
        let device = &self.context().device;
        let buffer = |label: &str, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let params_buf = buffer(
            "volume params",
            bytemuck::bytes_of(&frame.params),
            wgpu::BufferUsages::UNIFORM,
        );
        let mapped_buf = buffer(
            "mapped geometry",
            bytemuck::bytes_of(&params),
            wgpu::BufferUsages::UNIFORM,
        );
        let coords_buf = buffer(
            "axis centres",
            bytemuck::cast_slice(&coords),
            wgpu::BufferUsages::STORAGE,
        );
        let lut_view = self.lut_view(&frame.tf, frame.key.preintegrated);
        let out = self.output_texture(opts);
        let out_view = out.create_view(&Default::default());
        let mut entries =
            self.common_entries(&frame.key, &params_buf, gpu.view(), &lut_view, &out_view);
        // The texture unit filters in index space too (the shader hands it the fractional
        // index); a longitude that closes the circle repeats, so its last and first texels
        // are neighbours, as the exact path's wrap makes them.
        let wraps = matches!(&volume.geometry, Geometry::Spherical(g) if g.lon_wraps);
        if frame.key.hw_filter && wraps {
            let repeating = self.sampler_repeating(params.axis_of[2] as usize);
            for e in entries.iter_mut().filter(|e| e.binding == 4) {
                e.resource = wgpu::BindingResource::Sampler(repeating);
            }
        }
        entries.push(wgpu::BindGroupEntry {
            binding: 5,
            resource: mapped_buf.as_entire_binding(),
        });
        entries.push(wgpu::BindGroupEntry {
            binding: 6,
            resource: coords_buf.as_entire_binding(),
        });
        if let Some(grid) = skip {
            entries.push(wgpu::BindGroupEntry {
                binding: 7,
                resource: wgpu::BindingResource::TextureView(grid.view()),
            });
            entries.push(wgpu::BindGroupEntry {
                binding: 8,
                resource: wgpu::BindingResource::Sampler(self.nearest_sampler()),
            });
        }
        let (pixels, mut timing) = self.dispatch(pipeline, layout, &entries, &out, opts)?;
        let mut image = self.finish_image(&geometry, opts, frame.key.hw_filter, pixels);
        image.set_meta("geometry", volume.geometry.name());
        if let Geometry::Spherical(g) = &volume.geometry {
            image.set_meta("domain", g.to_string());
        }
        timing.compiled_pipeline = compiled;
        Ok((image, timing))
    }
}
