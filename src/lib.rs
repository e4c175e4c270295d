//! hdrvis renders high-dynamic-range geoscience data headlessly: HDR volume ray casting with
//! float compositing (Yuan et al., "Visualization of high dynamic range data in geosciences"),
//! on any wgpu adapter including Mesa's CPU rasterizers, driven from the command line and Rhai
//! scripts. The library holds everything; the `hdrvis` binary is a thin client.
//!
//! Dependency direction: `model` and `datasets` know nothing of the GPU; `gpu`, `render` and
//! `tonemap` are the only users of wgpu; `script` is the only user of Rhai; `tui` the only user
//! of ratatui (`tools/modcycles.py --check` holds these).
//!
//! The optical model in one example — the f64 CPU reference renders a homogeneous slab, whose
//! closed form is I = (e/a)(1 − exp(−a·L)):
//!
//! ```
//! use hdrvis::model::{Axis, Camera, TransferFunction, Volume};
//! use hdrvis::render::{cpu_reference::render_volume_f64, VolumeRenderOptions};
//!
//! let slab = Volume::from_fn("slab", [4, 4, 8], |_, _, _| 1.0)?;
//! let tf = TransferFunction::emission_absorption(2.0, 0.25)?;
//! let mut opts = VolumeRenderOptions::new(Camera::axis(Axis::Z, &slab.bounds()), tf);
//! (opts.width, opts.height, opts.early_exit) = (4, 4, 0.0);
//! let image = render_volume_f64(&slab, &opts)?;
//! let expected = 2.0 / 0.25 * (1.0 - (-0.25f64 * 8.0).exp());
//! assert!((image[0][0] - expected).abs() < 1e-12);
//! # Ok::<(), hdrvis::Error>(())
//! ```

pub mod bench;
pub mod datasets;
pub mod error;
pub mod gpu;
pub mod io;
pub mod model;
pub mod render;
pub mod script;
pub mod tonemap;
pub mod tui;

pub use error::{Error, Result};
