//! `hdrvis tonemap IN.exr -o OUT.png|OUT.exr`: tone-maps any RGB(A) OpenEXR (float or half, from
//! any producer) with a chosen operator, on the GPU or with the f64 operators on the CPU
//! ([`hdrvis::tonemap::mapper`] chooses), or draws its false-colour view, and writes a
//! display image: PNG in sRGB (8-bit, or 16-bit on request) or EXR holding display-referred
//! linear values in [0, 1]. Every option is checked before the input is read, and outputs are
//! written atomically, so bad input leaves no file behind.

use hdrvis::gpu::BackendChoice;
use hdrvis::io::exr::ExrWrite;
use hdrvis::io::png::PngCompression;
use hdrvis::tonemap::cpu::{auto_exposure_key, auto_exposure_percentile};
use hdrvis::tonemap::{
    check_ev, Gamut, MapperChoice, Operator, StageClock, ToneMapSettings, ToneMapper,
};
use hdrvis::{Error, Result};
use std::path::PathBuf;

/// Percentile of luminance that `--auto-exposure percentile` maps to display white.
const AUTO_PERCENTILE: f64 = 99.0;

#[derive(clap::Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct ToneMapArgs {
    /// Input OpenEXR (RGB or RGBA, float or half; a luminance-only Y file is shown grey).
    pub input: PathBuf,
    /// Output: .png (sRGB) or .exr (display-referred linear, [0, 1]).
    #[arg(long, short)]
    pub output: PathBuf,
    /// Operator: linear, drago, reinhard, ward, aces, reinhard-local, durand.
    #[arg(long, default_value = "reinhard")]
    pub op: String,
    /// Exposure in stops applied before the operator (added to --auto-exposure's).
    #[arg(long, default_value_t = 0.0)]
    pub exposure: f64,
    /// Key a of reinhard and reinhard-local (> 0; paper: 0.18).
    #[arg(long)]
    pub key: Option<f64>,
    /// L_white of reinhard in scaled luminance (> 0; default: the largest, so it maps to 1).
    #[arg(long)]
    pub white: Option<f64>,
    /// Bias of drago, in (0, 1] (paper: 0.85).
    #[arg(long)]
    pub bias: Option<f64>,
    /// Colour saturation s in C_d = (C / L_w)^s L_d, in [0, 10].
    #[arg(long, default_value_t = 1.0)]
    pub saturation: f64,
    /// Display gamma, applied as v^(1/gamma) before the sRGB curve, in [0.1, 10].
    #[arg(long, default_value_t = 1.0)]
    pub gamma: f64,
    /// Offset added to display values before clamping, in [-1, 1].
    #[arg(long, default_value_t = 0.0)]
    pub offset: f64,
    /// Colours with a channel above 1 after the operator: `scale` by 1 / max (keeps the hue) or
    /// `clip` each channel.
    #[arg(long, value_name = "scale|clip", default_value = "scale")]
    pub gamut: String,
    /// Any other operator parameter by its paper name, e.g. `--param contrast=8`; repeatable.
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// Write a 16-bit PNG.
    #[arg(long)]
    pub sixteen_bit: bool,
    /// Write EXR output as 32-bit float instead of half (display values need no more than
    /// half's 11 bits; EXR output only).
    #[arg(long)]
    pub float32: bool,
    /// Compression of the output. EXR: none, rle, zips, zip, piz (lossless) or pxr24, b44,
    /// b44a (lossy); default zip. PNG: fast (the default), default or best.
    #[arg(long)]
    pub compression: Option<String>,
    /// Choose the exposure from the image: `key` (log-average to 0.18, or --key) or
    /// `percentile` (the 99th percentile of luminance to 1).
    #[arg(long, value_name = "key|percentile")]
    pub auto_exposure: Option<String>,
    /// Write the false-colour view of log10 luminance (with a legend) instead of tone mapping.
    #[arg(long)]
    pub false_colour: bool,
    /// Where to map: `cpu` (the f64 operators on every core), `gpu`, or `auto`: the CPU when
    /// the only adapter is a CPU rasterizer (lavapipe, llvmpipe), else the GPU.
    #[arg(long, value_name = "auto|cpu|gpu", default_value = "auto")]
    pub mapper: String,
}

enum Format {
    Png,
    Exr,
}

/// How the output is stored, from `--compression`, `--float32` and `--sixteen-bit`.
enum Store {
    Png(PngCompression),
    Exr(ExrWrite),
}

/// The output's storage, checked against its format before anything is read.
fn output_store(args: &ToneMapArgs, format: &Format) -> Result<Store> {
    let named = args.compression.as_deref();
    match format {
        Format::Png => {
            if args.float32 {
                return Err(Error::invalid(
                    "--float32",
                    "applies to EXR output only (PNG is 8- or 16-bit)",
                ));
            }
            let compression = match named {
                Some(n) => PngCompression::parse(n).map_err(as_compression_flag)?,
                None => PngCompression::Fast,
            };
            Ok(Store::Png(compression))
        }
        Format::Exr => {
            if args.sixteen_bit {
                return Err(Error::invalid(
                    "--sixteen-bit",
                    "applies to PNG output only (EXR output is half or, with --float32, float)",
                ));
            }
            let compression = match named {
                Some(n) => ExrWrite::compression_named(n).map_err(as_compression_flag)?,
                None => ExrWrite::default().compression,
            };
            Ok(Store::Exr(ExrWrite {
                compression,
                half: !args.float32,
                keep_opaque_alpha: false,
            }))
        }
    }
}

/// Checks the options, reads the input, tone-maps it on `backend` and writes the output.
pub fn run_tonemap(args: &ToneMapArgs, backend: BackendChoice) -> Result<()> {
    let input = args.input.display().to_string();
    let format = output_format(args)?;
    let store = output_store(args, &format)?;
    check_ev("--exposure", args.exposure)?;
    let pairs = operator_params(args)?;
    let borrowed: Vec<(&str, f64)> = pairs.iter().map(|(k, v)| (k.as_str(), *v)).collect();
    let op = Operator::parse(&args.op, &borrowed).map_err(|e| with_flag(e, "--op"))?;
    let mut settings = ToneMapSettings {
        exposure_ev: args.exposure,
        offset: args.offset,
        gamma: args.gamma,
        saturation: args.saturation,
        gamut: Gamut::parse(&args.gamut).map_err(|e| with_flag(e, "--gamut"))?,
        op,
    };
    settings.validate()?;
    let auto = auto_exposure_mode(args)?;
    let choice = mapper_flag(&args.mapper)?;

    let clock = StageClock::start();
    // Opening the adapter (which decides the mapper) and the GPU's pipelines do not need the
    // image: they are made while the file is read.
    let (img, mapper) = std::thread::scope(|scope| {
        let gpu = scope.spawn(|| -> Result<ToneMapper> {
            let mapper = ToneMapper::open(backend, choice)?;
            mapper.prepare(&settings, args.false_colour)?;
            Ok(mapper)
        });
        let img = hdrvis::io::exr::read_exr(&args.input).map_err(one_line);
        clock.mark("read (whole file)");
        let mapper = gpu.join().expect("GPU set-up thread panicked");
        clock.mark("GPU set-up and pipelines, after the read");
        (img, mapper)
    });
    let img = img?;
    let mapper = mapper?;
    if let Some(mode) = auto {
        let key = args.key.unwrap_or(0.18);
        let ev = match mode {
            "key" => auto_exposure_key(&img, key)?,
            _ => auto_exposure_percentile(&img, AUTO_PERCENTILE, 1.0)?,
        };
        settings.exposure_ev = (settings.exposure_ev + ev).clamp(-200.0, 200.0);
        eprintln!("{input}: auto exposure ({mode}) {ev:+.2} EV");
    }
    let adapter = mapper.describe(&img, (!args.false_colour).then_some(&settings.op));
    let out = if args.false_colour {
        mapper.false_colour(&img, settings.exposure_ev, None)?
    } else {
        mapper.tonemap(&img, &settings)?
    };
    clock.mark("map");
    match store {
        Store::Png(compression) => hdrvis::io::png::write_display_png_with(
            &out,
            &args.output,
            args.sixteen_bit,
            compression,
        )?,
        Store::Exr(how) => hdrvis::io::exr::write_exr_with(&out, &args.output, &how)?,
    }
    clock.mark("write (whole file)");
    let view = if args.false_colour {
        "false colour".to_string()
    } else {
        format!("{} at {:+.2} EV", op.name(), settings.exposure_ev)
    };
    println!(
        "wrote {} ({}x{}, {view}, {adapter})",
        args.output.display(),
        out.width,
        out.height
    );
    Ok(())
}

/// `--mapper NAME` (of `hdrvis tonemap` and `hdrvis bench tonemap --peer`).
pub(super) fn mapper_flag(name: &str) -> Result<MapperChoice> {
    MapperChoice::parse(name).map_err(|e| match e {
        Error::Invalid { msg, .. } => Error::invalid("--mapper", msg),
        other => other,
    })
}

/// The output's format, from its file name's extension.
fn output_format(args: &ToneMapArgs) -> Result<Format> {
    match args
        .output
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .as_deref()
    {
        Some("png") => Ok(Format::Png),
        Some("exr") => Ok(Format::Exr),
        _ => Err(Error::invalid(
            "--output",
            format!(
                "{}: expected a .png or .exr file name",
                args.output.display()
            ),
        )),
    }
}

/// The operator's parameters: `--key`, `--white` and `--bias` where given, then every
/// `--param NAME=NUMBER`.
fn operator_params(args: &ToneMapArgs) -> Result<Vec<(String, f64)>> {
    let mut pairs: Vec<(String, f64)> = Vec::new();
    for (name, value) in [
        ("key", args.key),
        ("white", args.white),
        ("bias", args.bias),
    ] {
        if let Some(v) = value {
            pairs.push((name.to_string(), v));
        }
    }
    for p in &args.params {
        let parsed = p
            .split_once('=')
            .and_then(|(k, v)| Some((k.trim().to_string(), v.trim().parse::<f64>().ok()?)));
        match parsed {
            Some(kv) if !kv.0.is_empty() => pairs.push(kv),
            _ => {
                return Err(Error::invalid(
                    "--param",
                    format!("expected NAME=NUMBER, got {p:?}"),
                ))
            }
        }
    }
    Ok(pairs)
}

/// The `--auto-exposure` mode, checked: none, `key` or `percentile`.
fn auto_exposure_mode(args: &ToneMapArgs) -> Result<Option<&str>> {
    match args.auto_exposure.as_deref() {
        None => Ok(None),
        Some(m @ ("key" | "percentile")) => Ok(Some(m)),
        Some(other) => Err(Error::invalid(
            "--auto-exposure",
            format!("unknown mode {other:?}; known: key, percentile"),
        )),
    }
}

/// A compression name's error, said of the flag that carried it.
fn as_compression_flag(e: Error) -> Error {
    match e {
        Error::Invalid { msg, .. } => Error::invalid("--compression", msg),
        other => other,
    }
}

/// Prefixes an operator error with the flag that carried it, so the line names the input.
fn with_flag(e: Error, flag: &str) -> Error {
    match e {
        Error::Invalid { field, msg } if field == "operator" => Error::invalid(flag, msg),
        Error::Invalid { field, msg } => {
            Error::invalid(format!("{field} (--{})", last(&field)), msg)
        }
        other => other,
    }
}

fn last(field: &str) -> &str {
    field.rsplit('.').next().unwrap_or(field)
}

/// Readers' messages can span lines; the CLI prints exactly one.
fn one_line(e: Error) -> Error {
    match e {
        Error::Format { path, msg } => Error::Format {
            path,
            msg: msg.split_whitespace().collect::<Vec<_>>().join(" "),
        },
        other => other,
    }
}
