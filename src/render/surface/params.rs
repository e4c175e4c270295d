//! What the two GPU passes are given: the host mirrors of their uniform structs, the node
//! inputs of the data pass (values split about d_ref), the fringe pass's parameters and its
//! colour table.

use super::geometry::SurfaceGeometry;
use super::LUT_SIZE;
use super::{LIGHT_AMBIENT, LIGHT_DIRECTION};
use crate::model::colormap::Colormap;
use crate::model::Grid;

/// Host mirror of `Params` in shaders/surface_data.wgsl — keep in sync.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct DataParams {
    eye: [f32; 4],
    forward: [f32; 4],
    right: [f32; 4],
    up: [f32; 4],
    proj: [f32; 4],
    cell: [f32; 4],
    light: [f32; 4],
    box_size: [f32; 4],
    globe: [f32; 4],
    dims: [u32; 4],
    counts: [u32; 4],
    globe_rotation: [[f32; 4]; 3],
}

/// Host mirror of `Params` in shaders/surface_fringe.wgsl — keep in sync.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct FringeParams {
    pub(super) nu: [f32; 4],
    pub(super) refs: [f32; 4],
    pub(super) shade: [f32; 4],
    pub(super) mode: [u32; 4],
    pub(super) dims: [u32; 4],
    pub(super) footprint: [f32; 4],
}

/// Name, units, d_ref, finite range and long name (empty: none) of a rendered property.
pub(super) type PropMeta = (String, String, f64, Option<(f64, f64)>, String);

/// The node inputs of step 1: per node and property slot, the value less the property's
/// reference d_ref split into an f32 head and the f32 rest (together ~f64 precision), and 1
/// where the value is finite; with what step 2 needs to know of each property.
pub(super) struct NodeValues {
    pub(super) hi: Vec<[f32; 4]>,
    pub(super) rest: Vec<[f32; 4]>,
    pub(super) valid: Vec<[f32; 4]>,
    pub(super) meta: Vec<PropMeta>,
}

impl NodeValues {
    pub(super) fn of(grid: &Grid, props: &[usize]) -> NodeValues {
        let n = grid.nx() * grid.ny();
        let mut hi = vec![[0f32; 4]; n];
        let mut rest = vec![[0f32; 4]; n];
        let mut valid = vec![[0f32; 4]; n];
        let mut meta = Vec::new();
        for (slot, &p) in props.iter().enumerate() {
            let (name, values) = grid.property_at(p);
            let range = grid.range(p);
            let d_ref = range.map(|(a, b)| 0.5 * (a + b)).unwrap_or(0.0);
            for k in 0..n {
                let d = values[k];
                if d.is_finite() {
                    let off = d - d_ref;
                    let h = off as f32;
                    hi[k][slot] = h;
                    rest[k][slot] = (off - h as f64) as f32;
                    valid[k][slot] = 1.0;
                }
            }
            meta.push((
                name.to_string(),
                grid.units(p).to_string(),
                d_ref,
                range,
                grid.long_name(p).to_string(),
            ));
        }
        NodeValues {
            hi,
            rest,
            valid,
            meta,
        }
    }
}

/// The data pass's parameters: the camera (left zero for the map view), cell size,
/// exaggeration, light and sizes.
pub(super) fn data_params(
    geo: &SurfaceGeometry,
    grid: &Grid,
    properties: usize,
    width: u32,
    height: u32,
) -> DataParams {
    let (nx, ny) = (grid.nx(), grid.ny());
    let v4 = |v: [f64; 3], w: f64| [v[0] as f32, v[1] as f32, v[2] as f32, w as f32];
    let mut params = DataParams {
        eye: [0.0; 4],
        forward: [0.0; 4],
        right: [0.0; 4],
        up: [0.0; 4],
        proj: [0.0; 4],
        cell: [
            geo.spacing[0] as f32,
            geo.spacing[1] as f32,
            geo.exaggeration as f32,
            geo.height_at_floor() as f32,
        ],
        light: v4(LIGHT_DIRECTION, LIGHT_AMBIENT),
        box_size: v4(geo.box_size, 0.0),
        globe: [0.0; 4],
        dims: [nx as u32, ny as u32, width, height],
        counts: [properties as u32, 0, geo.y_down as u32, 0],
        globe_rotation: [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ],
    };
    if let Some(g) = &geo.globe {
        params.globe = [g.lon0 as f32, g.dlon as f32, g.lat0 as f32, g.dlat as f32];
        params.counts[1] = g.wrap as u32;
        params.globe_rotation = g.rotation_rows().map(|row| v4(row, 0.0));
    }
    if let Some(cam) = &geo.camera {
        params.eye = v4(cam.eye, 0.0);
        params.forward = v4(cam.forward, 0.0);
        params.right = v4(cam.right, 0.0);
        params.up = v4(cam.up, 0.0);
        params.proj = cam.shader_projection(width, height).map(|v| v as f32);
    }
    params
}

/// The colour map sampled at LUT_SIZE points, as the fringe shader's table.
pub(super) fn colormap_table(colormap: &Colormap) -> Vec<[f32; 4]> {
    (0..LUT_SIZE)
        .map(|i| {
            let c = colormap.linear_rgb(i as f64 / (LUT_SIZE - 1) as f64);
            [c[0] as f32, c[1] as f32, c[2] as f32, 1.0]
        })
        .collect()
}
