//! The conventions that give a file's arrays their meaning, applied once for every reader: CF's
//! decoding of stored values (`cf_decode`: signedness, fills, valid ranges, packing), its
//! coordinate roles, vertical axes, grid mappings and placement on the sphere (`cf`), its
//! calendars and time units (`cf_time`), selection by dimension as xarray's `isel`/`sel`/`interp`
//! (`select`), and curvilinear grids regridded onto latitude and longitude (`curvilinear`).

pub(crate) mod atmosphere;
pub(crate) mod cf;
pub(crate) mod cf_decode;
pub(crate) mod cf_time;
pub(crate) mod curvilinear;
pub(crate) mod mesh;
pub mod select;
pub(crate) mod vertical;
