//! Script API: dataset generation through the cache. `generate(kind, options)` returns the path
//! of the cached NetCDF file (generated on a miss), which `load_grid` / `load_volume` then read;
//! the cache folder is readable by every script.

use super::convert::{check_keys, int, num, string, to_rhai, RResult};
use crate::datasets::generate::{
    BathymetrySource, Job, MantleJob, OkadaJob, OutputFormat, TsunamiJob,
};
use crate::datasets::mantle::{MantleField, MantleFields, MantleOptions};
use crate::datasets::okada::DepthRef;
use crate::datasets::tsunami::Boundary;
use rhai::{Engine, Map};

const OKADA_KEYS: &[&str] = &[
    "strike",
    "dip",
    "rake",
    "slip",
    "length",
    "width",
    "depth",
    "depth_ref",
    "extent",
    "n",
];
const TSUNAMI_KEYS: &[&str] = &["n", "extent", "duration", "boundary"];
const MANTLE_KEYS: &[&str] = &["n", "seed", "field", "plumes", "slabs"];

/// The mantle options of `generate("mantle", #{…})` and `generate_mantle(#{…})`: `n`, `seed`,
/// `plumes`, `slabs` and the one `field` to generate (fluctuation by default), which is returned
/// beside the options. `what` names the function in the error for an unknown key.
pub(super) fn mantle_options(opts: &Map, what: &str) -> RResult<(MantleOptions, MantleField)> {
    check_keys(opts, MANTLE_KEYS, what)?;
    let mut o = MantleOptions::default();
    let mut field = MantleField::Fluctuation;
    for (k, v) in opts {
        match k.as_str() {
            "n" => o.n = int(v, "n")?.clamp(0, 4096) as usize,
            "seed" => o.seed = int(v, "seed")? as u64,
            "plumes" => o.plumes = int(v, "plumes")?.clamp(0, 10_000) as usize,
            "slabs" => o.slabs = int(v, "slabs")?.clamp(0, 10_000) as usize,
            "field" => field = MantleField::parse(&string(v, "field")?).map_err(to_rhai)?,
            _ => unreachable!("checked keys"),
        }
    }
    o.fields = MantleFields::only(field);
    Ok((o, field))
}

fn job_of(kind: &str, opts: &Map) -> RResult<Job> {
    match kind {
        "okada" => {
            check_keys(opts, OKADA_KEYS, "generate okada")?;
            let mut job = OkadaJob::default();
            let seg = &mut job.segments[0];
            for (k, v) in opts {
                match k.as_str() {
                    "strike" => seg.strike_deg = num(v, "strike")?,
                    "dip" => seg.dip_deg = num(v, "dip")?,
                    "rake" => seg.rake_deg = num(v, "rake")?,
                    "slip" => seg.slip_m = num(v, "slip")?,
                    "length" => seg.length_m = num(v, "length")?,
                    "width" => seg.width_m = num(v, "width")?,
                    "depth" => seg.depth_m = num(v, "depth")?,
                    "depth_ref" => {
                        seg.depth_ref =
                            DepthRef::parse(&string(v, "depth_ref")?).map_err(to_rhai)?
                    }
                    "extent" => job.extent_m = num(v, "extent")?,
                    "n" => job.n = int(v, "n")?.clamp(0, 100_000) as usize,
                    _ => unreachable!("checked keys"),
                }
            }
            Ok(Job::Okada(job))
        }
        "tsunami" => {
            check_keys(opts, TSUNAMI_KEYS, "generate tsunami")?;
            let mut job = TsunamiJob::default();
            let (mut n, mut extent) = match job.bathymetry {
                BathymetrySource::Synthetic { n, extent_m } => (n, extent_m),
                _ => unreachable!("the default is synthetic"),
            };
            for (k, v) in opts {
                match k.as_str() {
                    "n" => n = int(v, "n")?.clamp(0, 100_000) as usize,
                    "extent" => extent = num(v, "extent")?,
                    "duration" => job.options.duration_s = num(v, "duration")?,
                    "boundary" => {
                        job.options.boundary = match string(v, "boundary")?.as_str() {
                            "open" => Boundary::Open,
                            "reflective" => Boundary::Reflective,
                            other => {
                                return super::convert::err(
                                    "boundary",
                                    format!("expected open or reflective, got {other:?}"),
                                )
                            }
                        }
                    }
                    _ => unreachable!("checked keys"),
                }
            }
            job.bathymetry = BathymetrySource::Synthetic {
                n,
                extent_m: extent,
            };
            Ok(Job::Tsunami(job))
        }
        "mantle" => {
            // `native` chooses the file's grid; the other keys are the generator's.
            let mut opts = opts.clone();
            let native = match opts.remove("native") {
                Some(v) => v.as_bool().or_else(|_| {
                    super::convert::err(
                        "native",
                        format!("expected true or false, got {}", v.type_name()),
                    )
                })?,
                None => false,
            };
            let (options, _) = mantle_options(&opts, "generate mantle")?;
            Ok(Job::Mantle(MantleJob { options, native }))
        }
        other => super::convert::err(
            "generate",
            format!("unknown dataset {other:?}; known: okada, tsunami, mantle"),
        ),
    }
}

pub(crate) fn register(engine: &mut Engine) {
    engine.register_fn("generate", |kind: &str, opts: Map| -> RResult<String> {
        let job = job_of(kind, &opts)?;
        let path = job
            .run_cached(OutputFormat::NetCdf, &mut |_| {})
            .map_err(to_rhai)?;
        Ok(path.display().to_string())
    });
}
