//! Integration tests, one binary with a module per area. GPU tests run on the default adapter
//! (lavapipe in CI) and, where marked, on the GL fallback too.

mod bricks;
mod cli;
mod common;
mod datasets;
mod passes;
mod scripts;
mod stability;
mod surface;
mod tonemap;
mod tui;
mod volume_render;
