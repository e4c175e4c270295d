//! `hdrvis bench meshes --volume`: why a (depth, cells) variable renders through a spherical
//! grid rather than natively through the mesh's prisms. A mantle-like field on ICON's triangles
//! of the icosahedron (written as ICON writes them: centres and corners in radians, a depth
//! coordinate) is loaded with `load_volume(…, #{ resolution })` and rendered by the mapped ray
//! caster; beside it, the frame's own samples (each ray through the shell at the render's step)
//! are located on the mesh through its spatial index, which is the work a native march through
//! the prisms would do at every sample of every frame before compositing anything.

use super::meshes::icosphere;
use super::{median, time_renders, timing_session};
use crate::datasets::{conventions::select::Selection, LoadOptions};
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::model::{Camera, Geometry, LutTransfer, TransferFunction};
use crate::render::{VolumeRenderOptions, VolumeSource};
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

/// Depths of the benchmark's levels in km: 16 from 50 to 2850 (a mantle).
fn depths() -> Vec<f64> {
    (0..16).map(|k| 50.0 + 2800.0 * k as f64 / 15.0).collect()
}

/// Writes the (depth, cells) file of `level` at `path`; returns its cells.
pub(crate) fn write_icon_volume(path: &Path, level: u32) -> Result<usize> {
    use netcdf_reader::NcAttrValue;
    use netcdf_writer::NcFileBuilder;
    let (nodes, tris) = icosphere(level);
    let lon_lat = |p: [f64; 3]| (p[1].atan2(p[0]), p[2].clamp(-1.0, 1.0).asin());
    let n = tris.len();
    let (mut clon, mut clat) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let (mut blon, mut blat) = (Vec::with_capacity(3 * n), Vec::with_capacity(3 * n));
    for t in &tris {
        let [a, b, c] = t.map(|i| nodes[i as usize]);
        let (lo, la) = lon_lat(crate::model::vec3::normalize([
            a[0] + b[0] + c[0],
            a[1] + b[1] + c[1],
            a[2] + b[2] + c[2],
        ]));
        clon.push(lo);
        clat.push(la);
        for p in [a, b, c] {
            let (lo, la) = lon_lat(p);
            blon.push(lo);
            blat.push(la);
        }
    }
    let depth = depths();
    let field: Vec<f32> = depth
        .iter()
        .flat_map(|d| {
            let s = d / 2900.0;
            clon.iter().zip(&clat).map(move |(lo, la)| {
                (1600.0 + 1200.0 * s + 150.0 * (5.0 * lo + 9.0 * s).sin() * (4.0 * la).cos()) as f32
            })
        })
        .collect();
    let bad = |e: netcdf_writer::Error| Error::invalid("bench meshes --volume", e.to_string());
    let text = |s: &str| NcAttrValue::Chars(s.into());
    let mut b = NcFileBuilder::new();
    let cells = b.add_dimension("ncells", n as u64).map_err(bad)?;
    let vertices = b.add_dimension("vertices", 3).map_err(bad)?;
    let levels = b.add_dimension("depth", depth.len() as u64).map_err(bad)?;
    for (name, standard, values, bounds) in [
        ("clon", "longitude", &clon, "clon_bnds"),
        ("clat", "latitude", &clat, "clat_bnds"),
    ] {
        let v = b.add_variable::<f64>(name, &[cells]).map_err(bad)?;
        for (key, value) in [
            ("standard_name", standard),
            ("units", "radian"),
            ("bounds", bounds),
        ] {
            b.add_variable_attribute(v, key, text(value)).map_err(bad)?;
        }
        b.write_variable(v, values).map_err(bad)?;
    }
    for (name, values) in [("clon_bnds", &blon), ("clat_bnds", &blat)] {
        let v = b
            .add_variable::<f64>(name, &[cells, vertices])
            .map_err(bad)?;
        b.add_variable_attribute(v, "units", text("radian"))
            .map_err(bad)?;
        b.write_variable(v, values).map_err(bad)?;
    }
    let v = b.add_variable::<f64>("depth", &[levels]).map_err(bad)?;
    for (key, value) in [
        ("standard_name", "depth"),
        ("units", "km"),
        ("positive", "down"),
        ("axis", "Z"),
    ] {
        b.add_variable_attribute(v, key, text(value)).map_err(bad)?;
    }
    b.write_variable(v, &depth).map_err(bad)?;
    let v = b.add_variable::<f32>("T", &[levels, cells]).map_err(bad)?;
    for (key, value) in [("units", "K"), ("coordinates", "clat clon")] {
        b.add_variable_attribute(v, key, text(value)).map_err(bad)?;
    }
    b.write_variable(v, &field).map_err(bad)?;
    crate::datasets::readers::netcdf::write_built(path, &b)?;
    Ok(n)
}

/// One mesh's (depth, cells) volume: the grid route's times and the native route's floor.
#[derive(Clone, Debug)]
pub struct MeshVolumeRow {
    pub level: u32,
    pub cells: usize,
    pub levels: usize,
    /// `load_volume`'s resolution in degrees and the voxels it made.
    pub resolution: f64,
    pub voxels: usize,
    /// `load_volume` (read, mesh, every level sampled onto latitude and longitude).
    pub load_ms: Vec<f64>,
    /// A render of the spherical volume, to the image in host memory.
    pub render_ms: Vec<f64>,
    /// The frame's samples inside the shell, and locating each on the mesh (in parallel).
    pub samples: usize,
    pub locate_ms: Vec<f64>,
}

/// Times `level`'s volume both ways at `width`², `runs` times each after one warm-up.
pub fn bench_mesh_volume(
    ctx: Arc<GpuContext>,
    level: u32,
    (width, resolution): (u32, f64),
    runs: usize,
    progress: &mut dyn FnMut(&str),
) -> Result<MeshVolumeRow> {
    let dir = tempfile::tempdir().map_err(|e| Error::invalid("bench meshes", e.to_string()))?;
    let path = dir.path().join(format!("icon_volume_level{level}.nc"));
    progress(&format!(
        "meshes: writing the (depth, cells) volume of level {level}"
    ));
    let cells = write_icon_volume(&path, level)?;
    let opts = LoadOptions {
        variable: Some("T".into()),
        resolution: Some(resolution),
        ..LoadOptions::default()
    };
    let mut load_ms = Vec::new();
    let mut volume = None;
    for run in 0..=runs.max(1) {
        progress(&format!(
            "meshes: volume of level {level}, load_volume, run {run}"
        ));
        let t = Instant::now();
        volume = Some(Arc::new(crate::datasets::load_volume_with(&path, &opts)?));
        if run > 0 {
            load_ms.push(t.elapsed().as_secs_f64() * 1e3);
        }
    }
    let volume = volume.expect("at least one run");
    progress(&format!("meshes: volume of level {level}, rendering"));
    let source = VolumeSource::Memory(volume.clone());
    let session = timing_session(ctx);
    let render = render_options(&volume, width)?;
    let (rendered, _) = time_renders(&session, &source, &render, runs)?;
    let points = frame_samples(&volume, &render.camera, width)?;
    let field = crate::datasets::load_mesh(
        &path,
        &LoadOptions {
            variable: Some("T".into()),
            select: Selection {
                index: vec![("depth".into(), 0)],
                at: Vec::new(),
            },
            ..LoadOptions::default()
        },
    )?;
    let mut locate_ms = Vec::new();
    for run in 0..=runs.max(1) {
        progress(&format!(
            "meshes: volume of level {level}, locating the frame's samples, run {run}"
        ));
        let t = Instant::now();
        std::hint::black_box(field.values_at(&points));
        if run > 0 {
            locate_ms.push(t.elapsed().as_secs_f64() * 1e3);
        }
    }
    Ok(MeshVolumeRow {
        level,
        cells,
        levels: depths().len(),
        resolution,
        voxels: volume.data.len(),
        load_ms,
        render_ms: rendered.ms,
        samples: points.len(),
        locate_ms,
    })
}

/// The render both routes make: an orbit view of the whole globe, one sample per step of the
/// smallest radial spacing.
fn render_options(volume: &crate::model::Volume, width: u32) -> Result<VolumeRenderOptions> {
    let camera = Camera::orbit(&volume.bounds(), 30.0, 20.0, 30.0)?;
    let mut o = VolumeRenderOptions::new(camera, TransferFunction::Lut(LutTransfer::default()));
    (o.width, o.height, o.step) = (width, width, 1.0);
    Ok(o)
}

/// Longitude and latitude (degrees) of every sample a render of `volume` through `camera` takes: each pixel's
/// ray cut to the shell between the outer and the inner sphere, sampled at the middle of each
/// step of the smallest radial spacing (the mapped ray caster's segments, without jitter).
fn frame_samples(
    volume: &crate::model::Volume,
    camera: &Camera,
    width: u32,
) -> Result<Vec<[f64; 2]>> {
    let Geometry::Spherical(g) = &volume.geometry else {
        return Err(Error::invalid(
            "bench meshes --volume",
            "expected a spherical volume",
        ));
    };
    let (inner, outer) = (g.radius.lo, g.radius.hi);
    let step = g.length_scale();
    let mut points = Vec::new();
    for py in 0..width {
        for px in 0..width {
            let (o, d) = camera.ray(px, py, width, width);
            let Some((t0, t1)) = sphere_span(o, d, outer) else {
                continue;
            };
            let core = sphere_span(o, d, inner);
            let mut t = t0.max(0.0) + 0.5 * step;
            while t < t1 {
                if !core.is_some_and(|(a, b)| t > a && t < b) {
                    let p = [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]];
                    let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                    points.push([
                        p[1].atan2(p[0]).to_degrees(),
                        (p[2] / r).asin().to_degrees(),
                    ]);
                }
                t += step;
            }
        }
    }
    Ok(points)
}

/// Where the ray o + t d (d a unit vector) lies inside the sphere of `radius` about the origin.
fn sphere_span(o: [f64; 3], d: [f64; 3], radius: f64) -> Option<(f64, f64)> {
    let b = o[0] * d[0] + o[1] * d[1] + o[2] * d[2];
    let c = o[0] * o[0] + o[1] * o[1] + o[2] * o[2] - radius * radius;
    let disc = b * b - c;
    (disc > 0.0).then(|| (-b - disc.sqrt(), -b + disc.sqrt()))
}

/// The `hdrvis bench meshes --volume` table.
pub fn format_mesh_volume_table(width: u32, rows: &[MeshVolumeRow]) -> String {
    let mut s = format!(
        "(depth, cells) volumes on ICON's triangles of the icosahedron, 16 levels, rendered {width}x{width} (orbit view, one sample per smallest radial spacing); grid route: load_volume at the resolution (read, mesh, each level sampled onto lat/lon) then the mapped ray caster; native floor: locating each of the frame's samples on the mesh through its spatial index (2 threads), per frame, before any compositing; medians\n"
    );
    s.push_str(&format!(
        "{:>5} {:>9} {:>6} {:>12} {:>12} {:>9} {:>10} {:>11} {:>12}\n",
        "level",
        "cells",
        "deg",
        "voxels",
        "samples",
        "load ms",
        "render ms",
        "locate ms",
        "locate/render"
    ));
    for r in rows {
        let (load, render, locate) = (
            median(&r.load_ms),
            median(&r.render_ms),
            median(&r.locate_ms),
        );
        s.push_str(&format!(
            "{:>5} {:>9} {:>6} {:>12} {:>12} {:>9.0} {:>10.1} {:>11.0} {:>11.1}x\n",
            r.level,
            r.cells,
            r.resolution,
            r.voxels,
            r.samples,
            load,
            render,
            locate,
            locate / render
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_benchmark_volume_loads_on_the_sphere_and_its_samples_lie_in_the_shell() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.nc");
        assert_eq!(write_icon_volume(&path, 1).unwrap(), 80);
        let opts = LoadOptions {
            variable: Some("T".into()),
            resolution: Some(10.0),
            ..LoadOptions::default()
        };
        let v = crate::datasets::load_volume_with(&path, &opts).unwrap();
        let Geometry::Spherical(g) = &v.geometry else {
            panic!("not spherical: {:?}", v.geometry)
        };
        // 16 levels 2800 km apart end to end, below the planet's surface.
        assert_eq!(g.radius.len(), 16);
        let span = g.radius.centres[15] - g.radius.centres[0];
        let km = if g.length_unit == "m" { 1e3 } else { 1.0 };
        assert!(
            (span.abs() - 2800.0 * km).abs() < 1e-6 * km,
            "{span} {}",
            g.length_unit
        );
        // Every sample of the frame lies between the spheres, none in the core.
        let camera = render_options(&v, 24).unwrap().camera;
        let points = frame_samples(&v, &camera, 24).unwrap();
        assert!(points.len() > 24 * 24);
        assert!(points
            .iter()
            .all(|p| p[1].abs() <= 90.0 && p[0].abs() <= 180.0));
        // The ray's span in a sphere, against the closed form.
        assert_eq!(
            sphere_span([0.0, 0.0, -10.0], [0.0, 0.0, 1.0], 2.0),
            Some((8.0, 12.0))
        );
        assert_eq!(sphere_span([3.0, 0.0, -10.0], [0.0, 0.0, 1.0], 2.0), None);
    }
}
