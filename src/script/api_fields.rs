//! Script API: derived fields and subsets of volumes (log10, abs, magnitude of components, a box
//! of voxels, a shell resampled onto a regular box) and transfer-function presets. Derived
//! volumes are new volumes; the originals stay.

use super::api_render::ScriptVolume;
use super::convert::{err, int, to_rhai, RResult};
use super::options::{opt, Kind, OptionTable};
use crate::model::volume::MAX_DIM;
use crate::model::{LutTransfer, Scale, TransferFunction, Volume};
use rhai::{Array, Engine, Map};
use std::sync::Arc;

fn derived(v: &Volume, name: &str, f: impl Fn(f32) -> f32 + Sync) -> RResult<ScriptVolume> {
    use rayon::prelude::*;
    let data: Vec<f32> = v.data.par_iter().map(|&x| f(x)).collect();
    let mut out = Volume::new(
        format!("{name}({})", v.name),
        v.dims,
        v.spacing,
        v.origin,
        data,
    )
    .map_err(to_rhai)?
    .with_geometry(v.geometry.clone())
    .map_err(to_rhai)?;
    out.units = v.units.clone();
    Ok(Arc::new(out))
}

/// Transfer-function presets by name, for quick looks at HDR data.
pub(crate) const TF_PRESETS: &[&str] = &[
    "log-inferno",
    "log-viridis",
    "symlog-diverging",
    "linear-grey",
];

pub(crate) fn tf_preset(name: &str) -> crate::Result<TransferFunction> {
    let lut = |scale, colormap: &str, emission: Vec<[f64; 2]>, opacity: Vec<[f64; 2]>| {
        TransferFunction::Lut(LutTransfer {
            scale,
            colormap: colormap.into(),
            emission,
            opacity,
            ..Default::default()
        })
    };
    Ok(match name {
        "log-inferno" => lut(
            Scale::Log10,
            "inferno",
            vec![[0.0, -2.0], [1.0, 1.0]],
            vec![[0.0, -4.0], [1.0, -1.0]],
        ),
        "log-viridis" => lut(
            Scale::Log10,
            "viridis",
            vec![[0.0, -2.0], [1.0, 0.5]],
            vec![[0.0, -4.0], [0.3, -3.5], [1.0, -0.5]],
        ),
        "symlog-diverging" => lut(
            Scale::Symlog { linthresh: 0.0 },
            "spectral",
            vec![[0.0, -1.0], [0.45, -3.0], [0.55, -3.0], [1.0, -1.0]],
            vec![[0.0, -1.5], [0.45, -3.5], [0.55, -3.5], [1.0, -1.5]],
        ),
        "linear-grey" => lut(
            Scale::Linear,
            "white",
            vec![[0.0, -2.0], [1.0, 0.0]],
            vec![[0.0, -3.0], [1.0, -1.0]],
        ),
        _ => {
            return Err(crate::Error::invalid(
                "tf_preset",
                format!("unknown preset {name:?}; known: {}", TF_PRESETS.join(", ")),
            ))
        }
    })
}

pub(crate) fn register(engine: &mut Engine) {
    engine.register_fn("volume_log10", |v: &mut ScriptVolume| {
        // Zeros and negatives have no logarithm: they become missing values (NaN).
        derived(v, "log10", |x| if x > 0.0 { x.log10() } else { f32::NAN })
    });
    engine.register_fn("volume_abs", |v: &mut ScriptVolume| {
        derived(v, "abs", f32::abs)
    });
    engine.register_fn("volume_magnitude", volume_magnitude);
    engine.register_fn("volume_subset", volume_subset);
    engine.register_fn("resample", resample);
    engine.register_fn("tf_preset", |name: &str| tf_preset(name).map_err(to_rhai));
}

/// `volume_magnitude([a, b, ...])`: the voxelwise Euclidean norm of same-shaped components.
fn volume_magnitude(parts: Array) -> RResult<ScriptVolume> {
    let vols: Vec<ScriptVolume> = parts
        .into_iter()
        .map(|p| {
            p.try_cast::<ScriptVolume>().ok_or_else(|| {
                to_rhai(crate::Error::invalid(
                    "volume_magnitude",
                    "expected an array of Volumes",
                ))
            })
        })
        .collect::<RResult<_>>()?;
    let Some(first) = vols.first() else {
        return err("volume_magnitude", "expected at least one Volume");
    };
    if let Some(bad) = vols.iter().find(|v| v.geometry != first.geometry) {
        return err(
            "volume_magnitude",
            format!(
                "components lie on different grids: {} and {}",
                first.geometry.name(),
                bad.geometry.name()
            ),
        );
    }
    if let Some(bad) = vols.iter().find(|v| v.dims != first.dims) {
        return err(
            "volume_magnitude",
            format!(
                "components differ in shape: {:?} and {:?}",
                first.dims, bad.dims
            ),
        );
    }
    let data: Vec<f32> = (0..first.data.len())
        .map(|i| {
            vols.iter()
                .map(|v| (v.data[i] as f64).powi(2))
                .sum::<f64>()
                .sqrt() as f32
        })
        .collect();
    let name = format!(
        "|{}|",
        vols.iter()
            .map(|v| v.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(Arc::new(
        Volume::new(name, first.dims, first.spacing, first.origin, data)
            .and_then(|v| v.with_geometry(first.geometry.clone()))
            .map_err(to_rhai)?,
    ))
}

pub(crate) const RESAMPLE: OptionTable = OptionTable {
    function: "resample",
    options: &[opt(
        "n",
        Kind::Int(2, MAX_DIM as i64),
        "required",
        "voxels along the longest side of the box",
    )],
    call: "resample(load_volume(generate(\"mantle\", #{ n: 4, native: true })), OPTS)",
    base: "#{}",
};

/// `resample(v, #{ n: N })`: the volume on a regular box over its bounding box, N cubic voxels
/// along the longest side, missing outside a shell's domain (the paper's preparation of
/// spherical data).
fn resample(v: &mut ScriptVolume, opts: Map) -> RResult<ScriptVolume> {
    let Some(n) = RESAMPLE.read(&opts)?.count("n")? else {
        return err("resample", "expected #{ n: voxels along the longest side }");
    };
    Ok(Arc::new(
        crate::model::resample_to_box(v, n).map_err(to_rhai)?,
    ))
}

/// `volume_subset(v, [i, j, k], [i, j, k])`: the box of voxels from lo (inclusive) to hi
/// (exclusive), corners clamped to the volume.
fn volume_subset(v: &mut ScriptVolume, lo: Array, hi: Array) -> RResult<ScriptVolume> {
    let corner = |a: &Array, what: &str| -> RResult<[usize; 3]> {
        if a.len() != 3 {
            return err(what, "expected [i, j, k]");
        }
        let mut out = [0usize; 3];
        for (axis, x) in a.iter().enumerate() {
            out[axis] = int(x, what)?.clamp(0, v.dims[axis] as i64) as usize;
        }
        Ok(out)
    };
    let (lo, hi) = (
        corner(&lo, "volume_subset lo")?,
        corner(&hi, "volume_subset hi")?,
    );
    if (0..3).any(|a| hi[a] <= lo[a]) {
        return err(
            "volume_subset",
            format!(
                "expected lo < hi on every axis within {:?}, got {lo:?} .. {hi:?}",
                v.dims
            ),
        );
    }
    if !v.is_regular() {
        return err(
            "volume_subset",
            format!(
                "{} is a {} volume placed by coordinate axes; subsets are for regular boxes",
                v.name,
                v.geometry.name()
            ),
        );
    }
    let dims = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    let mut data = Vec::with_capacity(dims[0] * dims[1] * dims[2]);
    for k in lo[2]..hi[2] {
        for j in lo[1]..hi[1] {
            let start = v.index(lo[0], j, k);
            data.extend_from_slice(&v.data[start..start + dims[0]]);
        }
    }
    let origin = [0, 1, 2].map(|a| v.origin[a] + lo[a] as f64 * v.spacing[a]);
    let mut out = Volume::new(
        format!("{}[{lo:?}..{hi:?}]", v.name),
        dims,
        v.spacing,
        origin,
        data,
    )
    .map_err(to_rhai)?;
    out.units = v.units.clone();
    Ok(Arc::new(out))
}
