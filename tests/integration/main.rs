//! Integration tests, one binary with a module per area. GPU tests run on the default adapter
//! (lavapipe in CI) and, where marked, on the GL fallback too.

// CI holds non-test functions to 100 lines; a test that drives a real terminal step by step
// reads best as one function.
#![allow(clippy::too_many_lines)]

mod archives;
mod arithmetic;
mod bricks;
mod cache;
mod cf_data;
mod cli;
mod cluster;
mod coastlines;
mod common;
mod conformance;
mod contours;
mod datasets;
mod distributed;
mod doc_examples;
mod figures;
mod fuzz_corpus;
mod gallery;
mod georaster;
mod grib;
mod meshes;
mod mpi;
mod passes;
mod projections;
mod readers;
mod scripts;
mod sections;
mod skipping;
mod spherical;
mod stability;
mod surface;
mod tonemap;
mod tui;
mod vertical;
mod volume_render;
mod zarr;
