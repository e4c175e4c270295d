//! hdrvis renders high-dynamic-range geoscience data headlessly: HDR volume ray casting with
//! float compositing (Yuan et al., "Visualization of high dynamic range data in geosciences"),
//! on any wgpu adapter including Mesa's CPU rasterizers, driven from the command line and Rhai
//! scripts. The library holds everything; the `hdrvis` binary is a thin client.
//!
//! Dependency direction: `model` and `datasets` know nothing of the GPU; `gpu` and `render` are
//! the only users of wgpu; `script` is the only user of Rhai.

pub mod bench;
pub mod datasets;
pub mod error;
pub mod gpu;
pub mod io;
pub mod model;
pub mod render;
pub mod script;
pub mod tonemap;

pub use error::{Error, Result};
