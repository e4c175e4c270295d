//! Where tone mapping runs, decided once for every front end (`hdrvis tonemap`, scripts): the
//! f64 operators of [`super::cpu`] on the CPU's cores, or the GPU passes of [`super::gpu`].
//!
//! On a CPU rasterizer (lavapipe, llvmpipe) the "GPU" is the same cores running the shaders
//! through a JIT, with f32 arithmetic, fresh buffers and the pipelines' compilation on every
//! run. There the f64 operators are the better tool on both counts: they are the references the
//! GPU passes are tested against, and a whole `hdrvis tonemap` of a 1024² image took 0.53–0.58 s
//! against 0.99–1.05 s for Reinhard's local operator on the 2-core benchmark machine
//! (docs/performance.md). A real GPU keeps the GPU passes, and so does an image too large for
//! the f64 operators' planes in the memory available.

use std::sync::Arc;

use super::cpu::{false_colour_log10, tonemap_cpu};
use super::gpu::GpuToneMapper;
use super::{Operator, ToneMapSettings};
use crate::error::{Error, Result};
use crate::gpu::{BackendChoice, GpuContext};
use crate::model::volume::available_memory_bytes;
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

/// Peak bytes a pixel of the f64 operators (whole-process peaks measured at 1024² and 4096²,
/// rounded up): the luminance plane, the operator's planes and the f32 result; an upper bound
/// for the global operators, which write only the result. Reinhard's local operator also holds
/// its pyramid, its coarse scales' two blur buffers and each pixel's scan up the scales.
const CPU_BYTES_PER_PIXEL: u64 = 100;
const CPU_BYTES_PER_PIXEL_REINHARD_LOCAL: u64 = 180;

/// Whether the f64 operators' planes for a `width` x `height` image fit in half of `available`
/// bytes (unknown: they are taken to fit).
fn f64_planes_fit(width: u32, height: u32, op: Option<&Operator>, available: Option<u64>) -> bool {
    let per_pixel = match op {
        Some(Operator::ReinhardLocal { .. }) => CPU_BYTES_PER_PIXEL_REINHARD_LOCAL,
        _ => CPU_BYTES_PER_PIXEL,
    };
    let bytes = (width as u64 * height as u64).saturating_mul(per_pixel);
    available.is_none_or(|avail| bytes <= avail / 2)
}

/// A tone mapper: the f64 operators on the CPU or the GPU passes on an opened adapter, chosen
/// per image.
pub struct ToneMapper {
    /// The GPU's mapper; `None` when the CPU was asked for, which needs no adapter.
    gpu: Option<GpuToneMapper>,
    choice: MapperChoice,
}

impl ToneMapper {
    /// The mapper `choice` asks for on `ctx`.
    pub fn new(ctx: Arc<GpuContext>, choice: MapperChoice) -> ToneMapper {
        ToneMapper {
            gpu: Some(GpuToneMapper::new(ctx)),
            choice,
        }
    }

    /// The mapper `choice` asks for, opening an adapter of `backend` unless it asks for the CPU.
    /// The CPU, asked for or chosen by `Auto` where no adapter opens, needs no GPU driver at all.
    pub fn open(backend: BackendChoice, choice: MapperChoice) -> Result<ToneMapper> {
        let cpu_only = ToneMapper { gpu: None, choice };
        if choice == MapperChoice::Cpu {
            return Ok(cpu_only);
        }
        match GpuContext::new(backend) {
            Ok(ctx) => Ok(ToneMapper::new(ctx, choice)),
            Err(_) if choice == MapperChoice::Auto => Ok(cpu_only),
            Err(e) => Err(e),
        }
    }

    /// The one place the CPU/GPU decision is made: the GPU's mapper where it maps `img`, `None`
    /// where the f64 operators do. `Auto` maps on the CPU where the adapter is a CPU rasterizer
    /// and the f64 operators' planes for `img` fit in half the memory available; a larger image
    /// goes to the GPU passes, which work in bands. `op` is `None` for the false-colour view.
    fn gpu_for(&self, img: &HdrImage, op: Option<&Operator>) -> Option<&GpuToneMapper> {
        let gpu = self.gpu.as_ref()?;
        let on_cpu = match self.choice {
            MapperChoice::Cpu => true,
            MapperChoice::Gpu => false,
            MapperChoice::Auto => {
                let available = available_memory_bytes();
                cpu_adapter(gpu) && f64_planes_fit(img.width, img.height, op, available)
            }
        };
        (!on_cpu).then_some(gpu)
    }

    /// Builds the GPU's pipelines for a call with `settings` (or the false-colour view) where
    /// the GPU is the likely mapper; on a CPU rasterizer under `Auto` only images too large for
    /// the f64 planes use it, and they build their pipelines when they come. Meant to run while
    /// the caller reads the image.
    pub fn prepare(&self, settings: &ToneMapSettings, false_colour: bool) -> Result<()> {
        match (&self.gpu, self.choice) {
            (Some(gpu), MapperChoice::Gpu) => gpu.prepare(settings, false_colour),
            (Some(gpu), MapperChoice::Auto) if !cpu_adapter(gpu) => {
                gpu.prepare(settings, false_colour)
            }
            _ => Ok(()),
        }
    }

    /// Tone-maps `img`: display-referred linear RGBA in [0, 1], missing pixels (0, 0, 0, 0),
    /// with the same metadata whichever mapper ran.
    pub fn tonemap(&self, img: &HdrImage, settings: &ToneMapSettings) -> Result<HdrImage> {
        match self.gpu_for(img, Some(&settings.op)) {
            Some(gpu) => gpu.tonemap(img, settings),
            None => tonemap_cpu(img, settings),
        }
    }

    /// The false-colour view of log10 luminance (see [`false_colour_log10`]).
    pub fn false_colour(
        &self,
        img: &HdrImage,
        exposure_ev: f64,
        decades: Option<(f64, f64)>,
    ) -> Result<HdrImage> {
        match self.gpu_for(img, None) {
            Some(gpu) => gpu.false_colour(img, exposure_ev, decades),
            None => false_colour_log10(img, exposure_ev, decades),
        }
    }

    /// What maps `img`, for reports: "f64 on the CPU, N threads", or the adapter.
    pub fn describe(&self, img: &HdrImage, op: Option<&Operator>) -> String {
        match self.gpu_for(img, op) {
            Some(gpu) => gpu.context().describe(),
            None => format!("f64 on the CPU, {} threads", rayon::current_num_threads()),
        }
    }
}

fn cpu_adapter(gpu: &GpuToneMapper) -> bool {
    gpu.context().info.device_type == wgpu::DeviceType::Cpu
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn images_too_large_for_the_f64_planes_go_to_the_gpu() {
        let local = Operator::REINHARD_LOCAL;
        let gib = 1u64 << 30;
        // 4096²: 1.6 GiB of planes for a global operator, 2.8 GiB for Reinhard local.
        assert!(f64_planes_fit(
            4096,
            4096,
            Some(&Operator::REINHARD),
            Some(4 * gib)
        ));
        assert!(!f64_planes_fit(4096, 4096, Some(&local), Some(4 * gib)));
        assert!(f64_planes_fit(4096, 4096, Some(&local), Some(6 * gib)));
        assert!(f64_planes_fit(4096, 4096, None, Some(4 * gib)));
        // Sides whose product overflows 32 bits, and a machine that does not say.
        assert!(!f64_planes_fit(65536, 65536, None, Some(64 * gib)));
        assert!(f64_planes_fit(1024, 1024, Some(&local), None));
    }
}
