//! Exposure and tone mapping of HDR images: operator parameters (names and defaults from the
//! papers) and their f64 CPU references. The GPU passes for the same operators live in
//! `shaders/tonemap/`; their host code lands with the tone-mapping work.

pub mod cpu;
pub mod params;
