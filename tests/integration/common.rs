//! Shared helpers: one GPU context per backend for the whole test binary.

use hdrvis::gpu::{BackendChoice, GpuContext};
use hdrvis::render::volume::VolumeRenderer;
use std::sync::{Arc, OnceLock};

pub fn renderer(backend: BackendChoice) -> Arc<VolumeRenderer> {
    static VK: OnceLock<Arc<VolumeRenderer>> = OnceLock::new();
    static GL: OnceLock<Arc<VolumeRenderer>> = OnceLock::new();
    let cell = match backend {
        BackendChoice::Gl => &GL,
        _ => &VK,
    };
    cell.get_or_init(|| {
        let ctx = GpuContext::new(backend).unwrap_or_else(|e| panic!("{e}"));
        Arc::new(VolumeRenderer::new(ctx))
    })
    .clone()
}

/// Largest relative difference, measured against `floor` where values are tiny.
pub fn max_rel(a: &[f64], b: &[f64], floor: f64) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() / y.abs().max(floor))
        .fold(0.0, f64::max)
}
