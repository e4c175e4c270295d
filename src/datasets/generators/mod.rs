//! The generators of the paper's three case studies, each written to NetCDF or `.npy` through
//! the dataset cache: Okada's fault displacement (`okada`: kernel, segment, table), a tsunami
//! (`tsunami`: solver, bathymetry, scenario) and mantle convection (`mantle`: options, spherical,
//! temperature), and the jobs that run them from the CLI and scripts (`generate`).

pub mod generate;
pub mod mantle;
pub mod okada;
pub mod tsunami;
