//! Where tone mapping runs, decided once for every front end (`hdrvis tonemap`, scripts): the
//! f64 operators of [`super::cpu`] on the CPU's cores, or the GPU passes of [`super::gpu`].
//!
//! On a CPU rasterizer (lavapipe, llvmpipe) the "GPU" is the same cores running the shaders
//! through a JIT, with f32 arithmetic, fresh buffers and the pipelines' compilation on every
//! run. There the f64 operators are the better tool on both counts: they are the references the
//! GPU passes are tested against, and a whole `hdrvis tonemap` of a 1024² image took 0.53–0.58 s
//! against 0.99–1.05 s for Reinhard's local operator on the 2-core benchmark machine
//! (docs/performance.md). A real GPU keeps the GPU passes.

use std::sync::Arc;

use super::cpu::{false_colour_log10, tonemap_cpu};
use super::gpu::GpuToneMapper;
use super::{ToneMapSettings, DISPLAY_REFERRED};
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::model::HdrImage;

/// Which tone mapper a caller asks for (`hdrvis tonemap --mapper`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MapperChoice {
    /// The CPU's f64 operators where the adapter is a CPU rasterizer, else the GPU.
    #[default]
    Auto,
    /// The f64 operators on the CPU's cores, whatever the adapter.
    Cpu,
    /// The GPU passes, on whatever adapter was opened (a CPU rasterizer included).
    Gpu,
}

impl MapperChoice {
    pub fn parse(name: &str) -> Result<MapperChoice> {
        match name {
            "auto" => Ok(MapperChoice::Auto),
            "cpu" => Ok(MapperChoice::Cpu),
            "gpu" => Ok(MapperChoice::Gpu),
            other => Err(Error::invalid(
                "mapper",
                format!("unknown tone mapper {other:?}: expected auto, cpu or gpu"),
            )),
        }
    }
}

/// A tone mapper: the f64 operators on the CPU, or the GPU passes on an opened adapter.
pub enum ToneMapper {
    Cpu,
    Gpu(Box<GpuToneMapper>),
}

impl ToneMapper {
    /// The mapper `choice` asks for on `ctx`: the one place the CPU/GPU decision is made.
    pub fn new(ctx: Arc<GpuContext>, choice: MapperChoice) -> ToneMapper {
        let on_cpu = match choice {
            MapperChoice::Auto => ctx.info.device_type == wgpu::DeviceType::Cpu,
            MapperChoice::Cpu => true,
            MapperChoice::Gpu => false,
        };
        if on_cpu {
            ToneMapper::Cpu
        } else {
            ToneMapper::Gpu(Box::new(GpuToneMapper::new(ctx)))
        }
    }

    /// Makes ready what a call with `settings` (or the false-colour view) will use: the GPU's
    /// pipelines; nothing on the CPU. Meant to run while the caller reads the image.
    pub fn prepare(&self, settings: &ToneMapSettings, false_colour: bool) -> Result<()> {
        match self {
            ToneMapper::Cpu => Ok(()),
            ToneMapper::Gpu(gpu) => gpu.prepare(settings, false_colour),
        }
    }

    /// Tone-maps `img`: display-referred linear RGBA in [0, 1], missing pixels (0, 0, 0, 0),
    /// with the metadata of [`GpuToneMapper::tonemap`] whichever mapper ran.
    pub fn tonemap(&self, img: &HdrImage, settings: &ToneMapSettings) -> Result<HdrImage> {
        match self {
            ToneMapper::Cpu => {
                settings.validate()?;
                let mut out = tonemap_cpu(img, settings)?;
                out.set_meta("tonemap.exposure_ev", format!("{}", settings.exposure_ev));
                out.set_meta(DISPLAY_REFERRED, "1");
                Ok(out)
            }
            ToneMapper::Gpu(gpu) => gpu.tonemap(img, settings),
        }
    }

    /// The false-colour view of log10 luminance (see [`false_colour_log10`]).
    pub fn false_colour(
        &self,
        img: &HdrImage,
        exposure_ev: f64,
        decades: Option<(f64, f64)>,
    ) -> Result<HdrImage> {
        match self {
            ToneMapper::Cpu => {
                super::check_ev("exposure_ev", exposure_ev)?;
                let mut out = false_colour_log10(img, exposure_ev, decades)?;
                out.set_meta(DISPLAY_REFERRED, "1");
                Ok(out)
            }
            ToneMapper::Gpu(gpu) => gpu.false_colour(img, exposure_ev, decades),
        }
    }

    /// What maps, for reports: the adapter, or the CPU and its threads.
    pub fn describe(&self) -> String {
        match self {
            ToneMapper::Cpu => format!("f64 on the CPU, {} threads", rayon::current_num_threads()),
            ToneMapper::Gpu(gpu) => gpu.context().describe(),
        }
    }
}
